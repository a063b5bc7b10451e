"""The load statements of URScript programs (the reader interface: :mod:`robocal.programs.load_data`).

``set_payload(m, [x, y, z])`` / ``set_target_payload(m, [x, y, z], ...)`` (kg, m from the tool
flange, in its frame), ``set_payload(m)`` (the centre of gravity kept), ``set_payload_mass(m)``,
``set_payload_cog([x, y, z])``.
"""

from __future__ import annotations

import re

from robocal.programs.dialects.urscript.syntax import COMMENT_RE, STRING_RE
from robocal.programs.load_data.base import (
    NUM,
    LoadReader,
    setting,
    unread,
)

_UR_CALL = re.compile(r"\b(set_payload|set_target_payload|set_payload_mass|set_payload_cog)\s*\(([^()\n]*"
                      r"(?:\[[^\]\n]*\][^()\n]*)?)\)")
_UR_ARGS = re.compile(r"\s*" + NUM + r"\s*(?:,\s*\[\s*" + NUM + r"\s*,\s*" + NUM + r"\s*,\s*" + NUM
                      + r"\s*\]\s*)?(?:,.*)?")
_UR_COG = re.compile(r"\s*\[\s*" + NUM + r"\s*,\s*" + NUM + r"\s*,\s*" + NUM + r"\s*\]\s*")


class URScriptLoads(LoadReader):
    """URScript (module docstring)."""

    def settings(self, sources, references):
        out = []
        for src in sources:
            masked = src.masked([COMMENT_RE], [STRING_RE])
            for m in _UR_CALL.finditer(masked):
                fn, args, text = m.group(1), m.group(2), m.group(0)
                if fn == "set_payload_cog":
                    c = _UR_COG.fullmatch(args)
                    if c is None:
                        raise unread(src, m.start(), text, "the centre of gravity is not written as numbers")
                    out.append(setting(src, m.start(), text, None, [float(v) for v in c.groups()]))
                    continue
                a = _UR_ARGS.fullmatch(args)
                if a is None or (fn == "set_payload_mass" and a.group(2) is not None):
                    raise unread(src, m.start(), text, "the payload is not written as numbers")
                cog = None if a.group(2) is None else [float(v) for v in a.groups()[1:]]
                out.append(setting(src, m.start(), text, float(a.group(1)), cog))
        return out
