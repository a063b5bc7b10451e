"""FANUC user and tool frames from the controller's backup: SYSFRAME.VA (given with
``--references``), the ASCII dump of ``$MNUFRAME`` and ``$MNUTOOL``::

    [*SYSTEM*]$MNUFRAME  Storage: SHADOW  Access: RW  : ARRAY[1,9] OF POSITION
        [1,1] =
      Group: 1   Config: N D B, 0, 0, 0
      X:  1000.000   Y:     0.000   Z:   500.000
      W:     0.000   P:     0.000   R:    90.000

``[1,n]`` is group 1's user frame n (tool frame n): X, Y, Z mm and W, P, R deg as on the teach
pendant's frame screen, the position format of POSREG.VA
(:mod:`robocal.programs.dialects.fanuc.posreg`). These are the frames ``UF : n`` / ``UT : n``
and ``UFRAME_NUM=n`` / ``UTOOL_NUM=n`` name; ``--frame`` / ``--tool`` override them. A frame the
controller never set reads as zeros: the identity, as the controller uses it.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.dialects.fanuc.posreg import cartesian, group_entries
from robocal.programs.source import ProgramText

_FRAMES = re.compile(r"\[\*SYSTEM\*\]\$MNUFRAME\s[^\n]*$", re.MULTILINE)
_TOOLS = re.compile(r"\[\*SYSTEM\*\]\$MNUTOOL\s[^\n]*$", re.MULTILINE)


def is_sysframe(src: ProgramText) -> bool:
    """Whether ``src`` holds the user frames ``$MNUFRAME`` (a SYSFRAME.VA)."""
    return _FRAMES.search(src.text) is not None


def read_sysframe(src: ProgramText, to_pose) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """``(user frames, tool frames)`` of motion group 1 in the SYSFRAME.VA ``src``: number (as
    text) -> 4x4 (m); ``to_pose``: the dialect's pose numbers ``(N, 6)`` -> ``(N, 4, 4)``."""
    out = []
    for header, what in ((_FRAMES, "user frame"), (_TOOLS, "tool frame")):
        values = {}
        for n, at, a, b, _, rest in group_entries(src, header) or []:
            frame = cartesian(src, at, f"{what} {n}", a, b)
            if isinstance(frame, str) or "Uninitialized" in rest:
                raise DataError(f"{src.path.name}:{src.line_of(at)}: {what} {n} is not readable "
                                f"({frame if isinstance(frame, str) else 'Uninitialized'})")
            values[str(n)] = frame.values()
        keys = list(values)
        poses = to_pose(np.array([values[k] for k in keys])) if keys else []
        out.append(dict(zip(keys, poses, strict=True)))
    return out[0], out[1]
