"""A ``--tool`` / ``--frame`` the user gives, compared with the program's own data of the same name:
one comparison and one tolerance for every language.

Each dialect reports what its files (and their references: a KUKA $config.dat, an INFORM TOOL.CND
/ UFRAME.CND, a FANUC SYSFRAME.VA, a VAL3 .dtx, an ABB tooldata / wobjdata, a URScript
``set_tcp`` or feature pose) declare without the user's values: `Program.declared_tools` and
`Program.declared_frames` (name -> 4x4, m). The controller moves with those; a value given on the
command line that differs from them makes every corrected target land off by the difference,
while the correction looks right. The difference is judged by how far it moves a point the robot
works at: the translation plus the rotation times a lever (a tool: its TCP's distance from the
flange; a frame: its farthest target's distance, else the robot's reach), against
`robocal.core.magnitudes.CALIBRATED_TCP_MM`, the size of what a calibration corrects down to (a
laser tracker's and a calibrated arm's accuracy, a few hundredths of a mm): a larger difference is
said, naming both.
"""

from __future__ import annotations

import numpy as np

from robocal.core.magnitudes import CALIBRATED_TCP_MM
from robocal.kinematics.transforms import pose_error
from robocal.programs.dialects.base import Dialect
from robocal.programs.model import Program

_WORDS = {"tool": ("--tool", "tool data", "TCP at", "on the flange"),
          "frame": ("--frame", "frame", "origin at", "in the robot's base frame")}


def frame_levers(d: Dialect, program: Program) -> dict[str, float]:
    """Frame key -> the farthest distance (m) of the program's targets from that frame's origin
    (what a rotation of the frame moves them by, per radian); frames without targets are absent."""
    targets = [t for t in program.targets if len(t.numbers) == d.n_values]
    if not targets:
        return {}
    far = np.linalg.norm(d.to_pose(np.array([t.values() for t in targets]))[:, :3, 3], axis=1)
    keys, which = np.unique([t.frame for t in targets], return_inverse=True)
    most = np.full(len(keys), np.nan)
    np.fmax.at(most, which, far)  # NaN (a number the file leaves out) never wins
    return {str(k): float(m) for k, m in zip(keys, most, strict=True) if np.isfinite(m)}


def override_disagreements(d: Dialect, kind: str, declared: dict[str, np.ndarray], given,
                           lever_m: float, levers: dict[str, float] | None = None) -> list[str]:
    """One warning per ``given`` entry (name -> 4x4 m, or text in ``d``'s pose notation) that
    replaces ``kind`` data ('tool' or 'frame') the program holds differently, naming both.

    Parameters
    ----------
    d : Dialect
        The program's language (its names and pose notation).
    kind : {'tool', 'frame'}
        What is compared.
    declared : dict of str to ndarray, shape (4, 4)
        The program's own data without the user's (`Program.declared_tools` /
        `Program.declared_frames`), m, keyed by ``d.name_key``.
    given : dict of str to str or ndarray
        The user's ``--tool`` / ``--frame`` values.
    lever_m : float
        The distance (m) at which a rotation difference is judged for a frame without targets
        (the robot's reach); a tool's lever is its own TCP offset (the larger of the two TCPs').
    levers : dict of str to float, optional
        Frame key -> the distance of its farthest target (`frame_levers`), used instead.

    Returns
    -------
    list of str
        A warning per value moving a working point more than `CALIBRATED_TCP_MM`.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.programs.registry import dialect_named
    >>> own = {"1": np.eye(4)}
    >>> own["1"][:3, 3] = [0.0, 0.0, 0.25]  # a 250 mm tool
    >>> krl = dialect_named("krl")
    >>> override_disagreements(krl, "tool", own, {"1": "0,0,250.02,0,0,0"}, 1.6)  # 0.02 mm: rounding
    []
    >>> said = override_disagreements(krl, "tool", own, {"1": "0,0,250.2,0,0,0"}, 1.6)  # 0.2 mm
    >>> said[0].startswith("--tool 1=0,0,250.2,0,0,0 replaces the program's own tool data 1 (TCP at")
    True
    """
    if not given:
        return []
    option, noun, at, where = _WORDS[kind]
    out = []
    for name, value in given.items():
        key = d.name_key(str(name))
        own = declared.get(key)
        if own is None:
            continue
        T = d.frame_from_text(value) if isinstance(value, str) else np.asarray(value, float)
        own = np.asarray(own, float)
        err = pose_error(own[None], T[None])[0]
        lever = max(np.linalg.norm(own[:3, 3]), np.linalg.norm(T[:3, 3])) if kind == "tool" else \
            (levers or {}).get(key, lever_m)
        mm, rad = np.linalg.norm(err[:3]) * 1e3, np.linalg.norm(err[3:])
        moved = mm + rad * lever * 1e3
        if moved > CALIBRATED_TCP_MM:
            own_text = ", ".join(f"{v:.4g}" for v in own[:3, 3] * 1e3)
            shown = value if isinstance(value, str) else "(a 4x4)"
            out.append(f"{option} {name}={shown} replaces the program's own {noun} {name} ({at} {own_text} "
                       f"mm {where}) and differs from it by {mm:.3g} mm, {np.rad2deg(rad):.3g} deg (a point "
                       f"{lever * 1e3:.4g} mm away moves {moved:.3g} mm, above {CALIBRATED_TCP_MM:g} mm): "
                       f"the controller moves with the {noun} it holds; make sure {option} is what it holds")
    return out
