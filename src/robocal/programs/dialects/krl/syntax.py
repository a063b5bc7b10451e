"""The lexical pieces of KUKA KRL text its reader and its load reader share: comments, strings,
motion statements."""

from __future__ import annotations

import re

COMMENT_RE = re.compile(r";[^\n]*")
STRING_RE = re.compile(r'"[^"\n]*"')
MOTION_RE = re.compile(r"^[ \t]*(PTP|LIN|CIRC|SPTP|SLIN|SCIRC|SPL)(_REL)?\s+(.+)$",
                     re.IGNORECASE | re.MULTILINE)
