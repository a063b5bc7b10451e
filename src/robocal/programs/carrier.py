"""Does an external axis carry the arm? Judged from a program's data when its text cannot say.

A RAPID robtarget's ``eax_a`` or a KRL E6POS's ``E1`` in a work object no mechanical unit moves is
either a positioner the work object does not follow (the value does not move the target relative
to the arm: an arm target) or a track or gantry carrying the arm (the arm's base moves with the
value: corrected at a fixed base, the target gets a correction computed at the wrong place, a wrong
answer that looks right). The program's text does not tell them apart; its data often do:

* the targets' positions in the fixed frame follow the axis linearly, about 1 mm per mm along one
  direction with a high correlation: the arm rides on the axis (a track or gantry);
* the axis varies over values no positioner turn reads (beyond ``ANGLE_MAX_DEG``: a linear axis, in
  mm) while the targets do not follow it: it may still carry the arm (the arm reaching back as the
  track moves): suspect;
* the axis varies over too few targets to judge: the safe side, the same as suspect;
* an axis whose values stay within a turn and that the targets do not follow reads as a positioner
  (its angles do not shift fixed-frame targets along a line), and an axis held at one value gives
  no evidence: arm targets, as before.

Which axes may carry the arm is the dialect's knowledge (:attr:`Dialect.arm_axes`); this module
only weighs the numbers (:func:`arm_carriers`).
"""

from __future__ import annotations

import numpy as np

CONSTANT_SPAN = 0.5  # mm or deg as written: an axis whose values span less is held still (no evidence)
MIN_TARGETS = 4  # targets with a value of a varying axis needed to judge it ...
MIN_DISTINCT = 3  # ... at this many distinct values (two points always lie on a line)
FOLLOW_CORRELATION = 0.9  # the targets' positions along their best direction vs the axis' values
# mm of target per mm of axis along that direction: 1 for a track under a fixed reach; the arm's own
# reach, correlated with the other axes of a gantry, bends it (a real 3-axis gantry's program: 0.78, 0.88)
FOLLOW_SLOPE = (0.5, 2.0)
ANGLE_MAX_DEG = 360.0  # values beyond cannot be a positioner's turn as programs write it: a linear axis (mm)

ADVICE = ("give the cell file with the track or gantry (--model CELL.yaml), or --fixed-base if no external "
          "axis carries the arm (then corrected as arm targets)")


def follows(values: np.ndarray, positions: np.ndarray) -> tuple[float, float, np.ndarray]:
    """The least-squares slope of target positions ``positions`` ``(N, 3)`` (mm) on an axis'
    ``values`` ``(N,)`` (not all equal): ``(|slope| mm per unit, correlation along the slope's
    direction, the direction (3,))``; correlation 0 when the positions do not move."""
    de = values - values.mean()
    dX = positions - positions.mean(axis=0)
    b = dX.T @ de / (de @ de)
    norm = float(np.linalg.norm(b))
    if norm == 0.0:
        return 0.0, 0.0, np.zeros(3)
    u = b / norm
    s = dX @ u
    return norm, float(s @ de / np.sqrt((s @ s) * (de @ de))), u


def arm_carriers(values: dict[str, np.ndarray], positions: np.ndarray) -> dict[str, str]:
    """The axes that carry (or may carry) the arm, each with why: ``values``: axis name -> its value
    at each target ``(N,)`` (NaN: the target has none), ``positions``: the targets' positions in the
    fixed frame ``(N, 3)`` (mm; NaN rows: not known, not used as evidence). Axes held at one value
    and axes that read as a positioner are left out (see the module docstring)."""
    out = {}
    known = np.isfinite(positions).all(axis=1)
    for axis, v in sorted(values.items()):
        has = np.isfinite(v)
        if not has.any() or np.ptp(v[has]) < CONSTANT_SPAN:
            continue
        span = f"{v[has].min():g} .. {v[has].max():g}"
        use = has & known
        n, distinct = int(use.sum()), len(np.unique(v[use]))
        if n < MIN_TARGETS or distinct < MIN_DISTINCT:
            out[axis] = (f"external axis {axis} varies ({span}) over {n} target(s) at {distinct} value(s) in "
                         "frames no unit moves: too few to tell a track or gantry carrying the arm from a "
                         f"positioner the work object does not follow; {ADVICE}")
            continue
        slope, r, u = follows(v[use], positions[use])
        if FOLLOW_SLOPE[0] <= slope <= FOLLOW_SLOPE[1] and abs(r) >= FOLLOW_CORRELATION:
            direction = ", ".join(f"{c:.2f}" for c in np.round(u, 2) + 0.0)  # no "-0.00"
            out[axis] = (f"external axis {axis} carries the arm (a track or gantry): the {n} targets' "
                         f"positions follow it, {slope:.2f} mm per mm along ({direction}), correlation "
                         f"{abs(r):.2f}; corrected at a fixed base they would be wrong; {ADVICE}")
        elif np.abs(v[has]).max() > ANGLE_MAX_DEG:
            out[axis] = (f"external axis {axis} varies ({span}) beyond any positioner turn (a linear axis, "
                         f"mm) while the targets do not follow it ({slope:.2f} mm per mm, correlation "
                         f"{abs(r):.2f}): it may carry the arm; {ADVICE}")
    return out
