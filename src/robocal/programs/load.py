"""The payload a program sets for itself, when it sets one load for all its motions.

Read: KRL ``$LOAD = {M m, CM {X x, Y y, Z z ...}}`` (kg, mm, the flange frame) and URScript
``set_payload(m, [x, y, z])`` / ``set_target_payload(m, [x, y, z], ...)`` (kg, m, the tool flange
frame). A program with one such load (every statement the same) is filtered with it. A program
that changes its load between motions, or sets it in a way not read here (KRL
``$LOAD = LOAD_DATA[n]`` or a variable, RAPID ``loaddata`` / ``tooldata`` tload, FANUC
``PAYLOAD[n]``, whose values live in the controller), is not: the caller says so and the user
gives ``--payload``. The per-motion load is not applied.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.programs.fanuc_ls import FanucDialect
from robocal.programs.krl import KRLDialect
from robocal.programs.model import Dialect
from robocal.programs.rapid import RapidDialect
from robocal.programs.urscript import URScriptDialect

_NUM = r"([-+]?\d+(?:\.\d*)?(?:[eE][-+]?\d+)?)"
_KRL = re.compile(r"\$LOAD\s*=\s*\{\s*M\s+" + _NUM + r"\s*,\s*CM\s*\{\s*X\s+" + _NUM + r"\s*,\s*Y\s+" + _NUM
                  + r"\s*,\s*Z\s+" + _NUM, re.IGNORECASE)
_KRL_ANY = re.compile(r"\$LOAD\s*=", re.IGNORECASE)
_UR = re.compile(r"\bset_(?:target_)?payload\s*\(\s*" + _NUM + r"\s*,\s*\[\s*" + _NUM + r"\s*,\s*" + _NUM
                 + r"\s*,\s*" + _NUM + r"\s*\]")
_UR_ANY = re.compile(r"\bset_(?:target_)?payload\s*\(")
_OTHER = {"rapid": re.compile(r"\bloaddata\b|\bGripLoad\b", re.IGNORECASE),
          "fanuc": re.compile(r"\bPAYLOAD\s*\[", re.IGNORECASE)}


def program_load(d: Dialect, sources) -> tuple[np.ndarray | None, str]:
    """``(payload (4,) kg and m, or None, explanation)`` of the program texts ``sources``
    (:class:`robocal.programs.source.ProgramText`) in dialect ``d``: the one load they set (module
    docstring) and where, else None with why (empty when they set none)."""
    dialect = {KRLDialect: "krl", URScriptDialect: "urscript", RapidDialect: "rapid",
               FanucDialect: "fanuc"}.get(type(d), "")
    found, unread = [], []
    for s in sources:
        if dialect == "krl":
            found += [(s, m, np.array([float(v) for v in m.groups()]) * [1, 1e-3, 1e-3, 1e-3])
                      for m in _KRL.finditer(s.text)]
            unread += [(s, m) for m in _KRL_ANY.finditer(s.text) if not _KRL.match(s.text, m.start())]
        elif dialect == "urscript":
            found += [(s, m, np.array([float(v) for v in m.groups()])) for m in _UR.finditer(s.text)]
            unread += [(s, m) for m in _UR_ANY.finditer(s.text) if not _UR.match(s.text, m.start())]
        elif dialect in _OTHER:
            unread += [(s, m) for m in _OTHER[dialect].finditer(s.text)]
    if unread:
        s, m = unread[0]
        return None, (f"{s.path.name}:{s.line_of(m.start())}: the program sets its load in a way not read "
                      f"here ({m.group(0).strip()}...)")
    if not found:
        return None, ""
    loads = np.unique(np.array([p for *_, p in found]), axis=0)
    s, m, first = found[0]
    if len(loads) > 1:
        return None, (f"the program sets {len(loads)} different loads (the first at {s.path.name}:"
                      f"{s.line_of(m.start())}); the load of each motion is not applied")
    return first, f"{s.path.name}:{s.line_of(m.start())}"
