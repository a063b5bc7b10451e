"""The lexical pieces of URScript text its reader and its load reader share: comments, strings."""

from __future__ import annotations

import re

COMMENT_RE = re.compile(r"#[^\n]*")
STRING_RE = re.compile(r"\"[^\"\n]*\"|'[^'\n]*'")
