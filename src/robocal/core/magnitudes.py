"""Magnitudes a user types or a file declares, checked against the robot's size: one place.

Every length and angle that comes in with a declared unit (a ``--tool`` or ``--frame`` on the
command line, a targets file under ``_mm`` / ``_m`` headers, a model file's ``units``) is a number
of some size. When that size, read in the declared unit, is one no robot of this reach has, but
read in another common unit (m, mm, inch) it is one a robot has, the value is refused naming that
unit. The plausible sizes are named here once, as fractions of the robot's reach where the size
scales with the robot:

* a tool's TCP offset from the flange: `TOOL_MIN_M` .. `TOOL_MAX_M` (a TCP nearer
  than 2 mm to the flange centre but not on it is metres typed as mm);
* a frame (work object, user frame, base) translation: 0 or `FRAME_MIN_M` ..
  `FRAME_MAX_REACHES` reaches;
* a cell's offsets (an arm's base or mount on a riser or carriage, a positioner's mount and axis
  origins: `check_cell_offset`): as a frame, against the arm's reach from its link lengths, the
  advice naming the cell file's unit;
* a set of Cartesian targets: the farthest from the robot's base lies `TARGETS_MIN_REACHES`
  .. `TARGETS_MAX_REACHES` reaches away (the robot reaches its targets);
* a robot model's reach (sum of its link lengths): `MODEL_MIN_REACH_M` ..
  `MODEL_MAX_REACH_M`;
* a robot model file's angles (`check_model_units`): fixed angles all within a turn of
  'degrees' (largest above `RADIAN_SET_MIN_DEG`), or joint limits all within a turn of
  'degrees', are radians;
* a payload's mass (a ``payload_kg`` column, ``--payload``): at most `PAYLOAD_MAX_RATED` times
  the robot's rated payload (`check_payload`); a larger one that fits in pounds or grams read
  as kg (`MASS_SCALES_KG`) is refused naming that unit;
* an arm's temperature (a ``temperature_c`` column): within `ARM_TEMPERATURE_C`; hotter values
  that read as degrees Fahrenheit fall inside it are said (`temperature_note`; a warning, not a
  refusal: a hot cell may be real);
* angles in degrees that are radians: multiples of pi/12 within `RADIAN_LIKE_TOL`
  (0.785 = pi/4 typed where 45 belongs) for a value typed once; a set of targets' angles that
  all lie within pi 'degrees' (`check_degree_set`); angles in radians beyond
  `MAX_RADIANS` are degrees.

See Also
--------
rc.UnitError : What a check raises.
rc.Measurements : Read with these checks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robocal.core.errors import UnitError

# metres per unit of the lengths a user may type; the order is the order of likelihood
LENGTH_SCALES_M = {"mm": 1e-3, "m": 1.0, "inch": 0.0254}
UNIT_WORDS = {"mm": "millimetres", "m": "metres", "inch": "inches"}

TOOL_MIN_M = 2e-3  # a TCP this close to the flange centre but not on it: another unit
TOOL_MAX_M = 5.0  # no tool reaches 5 m from the flange
FRAME_MIN_M = 2e-3  # a frame origin within 2 mm of the base but not on it: another unit
FRAME_MAX_REACHES = 10.0  # a work object or user frame lies within 10 reaches of the robot
TARGETS_MIN_REACHES = 0.05  # the farthest target of a set lies at least 5 % of the reach from the base
TARGETS_MAX_REACHES = 2.0  # ... and at most twice the reach (the robot must get there)
MODEL_MIN_REACH_M = 0.05  # no arm this tool handles reaches less than 50 mm
MODEL_MAX_REACH_M = 50.0  # nor more than 50 m
# mm: the accuracy a calibrated arm measured with a laser tracker reaches at its TCP (a few hundredths
# of a mm): a TCP difference below it is too small to matter, one above it is what a calibration
# corrects. One threshold for: a --tool/--frame differing from the program's own data
# (programs/overrides), joint-error terms a URDF leaves out (deploy/urdf_like), a run-time
# correction's last step still off (programs/runtime: the controller's warning)
CALIBRATED_TCP_MM = 0.05
RADIAN_LIKE_TOL = 5e-4  # rad: angles in degrees this close to a multiple of pi/12 are radians
MAX_RADIANS = 2 * math.pi + 1e-6  # an orientation angle in radians beyond a full turn: degrees
RADIAN_SET_MIN_DEG = 0.1  # deg: a set of angles whose largest lies between this and pi 'deg' is radians
# a payload heavier than this many times the rated one is no load the arm carries (controllers refuse
# well below; the rated figure is at the rated centre-of-mass distance, a load nearer may exceed it a little)
PAYLOAD_MAX_RATED = 1.5
# deg C an arm's structure works at: its ambient 0..45 deg C (robot data sheets), the motors warming the
# links some 15 K above it; a campaign hotter than this is read in another unit (Fahrenheit) or odd
ARM_TEMPERATURE_C = (-10.0, 60.0)
MASS_SCALES_KG = {"lb": 0.45359237, "g": 1e-3}  # kg per unit of the masses typed as kg by mistake
MASS_WORDS = {"lb": "pounds", "g": "grams"}


def _mm(v: float) -> str:
    return f"{v * 1e3:.4g} mm" if abs(v) < 1 else f"{v:.4g} m"


def likely_unit(raw: float, scales: dict[str, float], low: float, high: float,
                besides: str | None = None) -> str | None:
    """The unit a number was most likely typed in: the first of ``scales`` (unit -> SI factor, in
    order of likelihood: `LENGTH_SCALES_M`, `MASS_SCALES_KG`) other than ``besides`` in which
    ``raw`` (the number as typed) lands within ``low .. high`` (SI); None when it fits none. The
    one rule behind every "the values look like ..." of this module.

    Examples
    --------
    >>> from robocal.core.magnitudes import LENGTH_SCALES_M, MASS_SCALES_KG, likely_unit
    >>> likely_unit(250.0, LENGTH_SCALES_M, 2e-3, 5.0, besides="m")  # a 250 mm tool typed as metres
    'mm'
    >>> likely_unit(397.0, MASS_SCALES_KG, 0.0, 300.0)  # 397 'kg' on a 200 kg robot: pounds
    'lb'
    """
    return next(iter(fitting_units(raw, scales, low, high, besides)), None)


def fitting_units(raw: float, scales: dict[str, float], low: float, high: float,
                  besides: str | None = None) -> list[str]:
    """Every unit of ``scales`` (other than ``besides``) in which ``raw`` lands within
    ``low .. high`` (SI), in the order of ``scales``: where a bound alone cannot tell them apart
    (6000 typed as kg: 6 kg in grams, 2722 kg in pounds), a message names them all.

    Examples
    --------
    >>> from robocal.core.magnitudes import MASS_SCALES_KG, fitting_units
    >>> fitting_units(6000.0, MASS_SCALES_KG, 0.0, 5000.0)
    ['lb', 'g']
    """
    return [u for u, s in scales.items() if u != besides and low <= raw * s <= high]


def check_length(size_m: float, declared: str, low_m: float, high_m: float, what: str, kind: str,
                 zero_ok: bool = True, advice: str = "give {declared}", strict: bool = True) -> None:
    """Refuse ``size_m`` (m, a length read in the ``declared`` unit: 'mm', 'm' or 'inch') outside
    ``low_m .. high_m``, the plausible sizes of ``kind`` (e.g. "a tool's TCP offset"): UnitError
    naming the unit in which the same number would fit (`LENGTH_SCALES_M`), or saying it
    fits none. ``advice`` ends the message (``{unit}`` / ``{declared}``: the likely / declared unit's
    word); ``strict`` False: a size that fits no unit passes (left to a check that says more).

    Parameters
    ----------
    size_m : float
        The size, m, as read in the ``declared`` unit.
    declared : {'mm', 'm', 'inch'}
        The unit the number was read in.
    low_m, high_m : float
        The plausible sizes of ``kind``, m.
    what : str
        Where the number came from (file, field), the start of the message.
    kind : str
        What the size is, e.g. "a tool's TCP offset".
    zero_ok : bool, optional
        A size of exactly 0 passes.
    advice : str, optional
        The end of the message.
    strict : bool, optional
        False: a size that fits no unit passes.

    Raises
    ------
    UnitError
        The size is out of range: the message names the unit it fits, if any.

    Examples
    --------
    >>> from robocal.core.magnitudes import TOOL_MAX_M, TOOL_MIN_M, check_length
    >>> check_length(0.25, "m", TOOL_MIN_M, TOOL_MAX_M, "tool.yaml", "a tool's TCP offset")  # passes
    >>> check_length(250.0, "m", TOOL_MIN_M, TOOL_MAX_M, "tool.yaml", "a tool's TCP offset")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: tool.yaml: 250 m is too large ...; the values look like millimetres ...
    """
    if (zero_ok and size_m == 0.0) or low_m <= size_m <= high_m:
        return
    raw = size_m / LENGTH_SCALES_M[declared]
    u = likely_unit(raw, LENGTH_SCALES_M, low_m, high_m, besides=declared)
    where = "too small" if size_m < low_m else "too large"
    span = f"{_mm(low_m)} .. {_mm(high_m)}"
    if u is not None:
        as_mm = "" if u == "mm" else f" = {raw * LENGTH_SCALES_M[u] * 1e3:.4g} mm"
        raise UnitError(f"{what}: {raw:.4g} {declared} is {where} for {kind} ({span}); the values "
                        f"look like {UNIT_WORDS[u]} ({raw:.4g} {u}{as_mm}): "
                        + advice.format(unit=u, declared=UNIT_WORDS[declared]))
    if not strict:
        return
    raise UnitError(f"{what}: {raw:.4g} {declared} is {where} for {kind} ({span}) in any unit "
                    "(mm, m, inch): check the values")


def check_tool(xyz_m: Sequence[float], declared: str, what: str) -> None:
    """A tool's TCP offset from the flange ``(3,)`` (m, read in ``declared``), see the module.

    Refused (UnitError) when its largest coordinate lies outside ``TOOL_MIN_M`` .. ``TOOL_MAX_M``
    (a TCP on the flange, all zeros, passes); ``what`` names where it came from.

    Parameters
    ----------
    xyz_m : sequence of float
        The TCP offset (m).
    declared : str
        The unit the file declared (named in the message).
    what : str
        Where the values come from (a file, its columns), for the message.

    Raises
    ------
    UnitError
        An offset too large or too small for a tool.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_tool
    >>> check_tool([0.0, 0.0, 0.25], "m", "tool.yaml")  # a 250 mm tool: passes
    >>> check_tool([0.0, 0.0, 250.0], "m", "tool.yaml")  # millimetres declared as metres
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: tool.yaml: 250 m is too large for a tool's TCP offset ...: give metres
    """
    xyz = np.abs(np.asarray(xyz_m, dtype=float))
    check_length(float(xyz.max()), declared, TOOL_MIN_M, TOOL_MAX_M, what, "a tool's TCP offset")


def check_frame(xyz_m: Sequence[float], declared: str, reach_m: float, what: str) -> None:
    """A frame's translation ``(3,)`` (m, read in ``declared``) for a robot of ``reach_m``.

    Refused (UnitError) when its largest coordinate lies outside ``FRAME_MIN_M`` ..
    ``FRAME_MAX_REACHES`` times the reach (m; a frame at the origin passes).

    Parameters
    ----------
    xyz_m : sequence of float
        The translation (m).
    declared : str
        The unit the file declared (named in the message).
    reach_m : float
        The robot's reach (m).
    what : str
        Where the values come from (a file, its columns), for the message.

    Raises
    ------
    UnitError
        A translation too large or too small for the robot.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_frame
    >>> check_frame([1.2, 0.3, 0.0], "m", 1.6, "wobj1")  # 1.2 m from a 1.6 m robot's base
    >>> check_frame([1200.0, 300.0, 0.0], "m", 1.6, "wobj1")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: wobj1: 1200 m is too large for a frame of this robot ...: give metres
    """
    xyz = np.abs(np.asarray(xyz_m, dtype=float))
    check_length(float(xyz.max()), declared, FRAME_MIN_M, FRAME_MAX_REACHES * reach_m, what,
                 "a frame of this robot")


def check_cell_offset(xyz_m: Sequence[float], declared: str, reach_m: float, what: str) -> None:
    """A cell file's offset ``(3,)`` or ``(k, 3)`` (m, read in the file's unit ``declared``) for an
    arm whose link lengths add up to ``reach_m``: an arm's base or its mount on a riser or a track's
    carriage, a positioner's mount or its axes' origins. Its largest coordinate must lie within
    `FRAME_MIN_M` .. `FRAME_MAX_REACHES` reaches (all zeros pass), or UnitError naming the unit the
    number fits (a 500 mm riser written 0.5 in a file in mm lands the flange 0.5 m off); a number
    that fits no unit passes (a 1 mm shim in a file in metres).

    Examples
    --------
    >>> from robocal.core.magnitudes import check_cell_offset
    >>> check_cell_offset([0.0, 0.0, 0.5], "mm", 3.1, "mount")  # a 500 mm riser, 500 in mm: passes
    >>> check_cell_offset([0.0, 0.0, 0.0005], "mm", 3.1, "mount")  # written 0.5 in a file in mm
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: mount: 0.5 mm is too small ... look like metres (0.5 m = 500 mm): write ...
    """
    xyz = np.abs(np.asarray(xyz_m, dtype=float))
    check_length(float(xyz.max(initial=0.0)), declared, FRAME_MIN_M, FRAME_MAX_REACHES * reach_m, what,
                 "an offset in a cell of this arm",
                 advice="write it in {declared}, the cell file's length unit (units: {{length: ...}})",
                 strict=False)


def check_targets(points_m: np.ndarray, declared: str, reach_m: float, what: str,
                  origin_m: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
    """Target positions ``(N, 3)`` (m, read in ``declared``) for a robot of ``reach_m`` whose base
    is at ``origin_m``: the farthest must lie within the robot's range (see the module), or refused
    naming the unit it fits (one that fits no unit is left to inverse kinematics, which names the
    targets out of reach).

    Parameters
    ----------
    points_m : ndarray, shape (N, 3)
        Target positions, m, as read in ``declared``.
    declared : {'mm', 'm', 'inch'}
        The unit they were read in.
    reach_m : float
        The robot's reach, m.
    what : str
        Where the targets came from.
    origin_m : sequence of float, shape (3,), optional
        The robot's base in the targets' frame, m.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.core.magnitudes import check_targets
    >>> check_targets(np.array([[1.0, 0.0, 0.5]]), "m", 1.6, "targets.csv")  # within reach
    >>> check_targets(np.array([[1000.0, 0.0, 500.0]]), "m", 1.6, "targets.csv")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: targets.csv: the farthest target ...; the values look like millimetres ...
    """
    far = float(np.linalg.norm(np.asarray(points_m, float) - np.asarray(origin_m, float), axis=1).max())
    check_length(far, declared, TARGETS_MIN_REACHES * reach_m, TARGETS_MAX_REACHES * reach_m,
                 f"{what}: the farthest target from the robot's base", "targets of this robot", zero_ok=False,
                 strict=False)


def check_model_reach(reach_m: float, declared: str, what: str) -> None:
    """A robot model's reach (m, its lengths read in ``declared``): the model file's length unit,
    refused when another unit fits (absurd values are left to the model's own bounds).

    Examples
    --------
    >>> from robocal.core.magnitudes import check_model_reach
    >>> check_model_reach(3.1, "m", "irb2600.yaml")  # m: passes
    >>> check_model_reach(3100.0, "m", "irb2600.yaml")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: irb2600.yaml: 3100 m is too large for a robot's reach ...
    """
    check_length(reach_m, declared, MODEL_MIN_REACH_M, MODEL_MAX_REACH_M, what, "a robot's reach",
                 advice="make it length: {unit} (or convert them)", strict=False)


def radian_like(angles_deg: Sequence[float]) -> np.ndarray:
    """``(k,)`` bool: angles given in degrees that are radians (a multiple of pi/12 typed as a
    number of degrees between 0.1 and 2 pi).

    Parameters
    ----------
    angles_deg : sequence of float, shape (k,)
        Angles read as degrees.

    Returns
    -------
    ndarray of bool, shape (k,)
        True where the number is a multiple of pi/12 within ``RADIAN_LIKE_TOL``.

    Examples
    --------
    >>> from robocal.core.magnitudes import radian_like
    >>> radian_like([90.0, 1.5708, 0.7854, 45.0]).tolist()  # pi/2 and pi/4 typed as degrees
    [False, True, True, False]
    """
    a = np.asarray(angles_deg, dtype=float)
    steps = a / (np.pi / 12)
    return (np.abs(a) > 0.1) & (np.abs(a) <= MAX_RADIANS) & \
        (np.abs(steps - np.round(steps)) * np.pi / 12 < RADIAN_LIKE_TOL)


def check_degrees(angles_deg: Sequence[float], what: str) -> None:
    """Refuse angles given in degrees that are clearly radians (pi/4 = 0.785, pi/2 = 1.571).

    Parameters
    ----------
    angles_deg : sequence of float
        The angles, read as degrees.
    what : str
        Where the values come from (a file, its columns), for the message.

    Raises
    ------
    UnitError
        Some angle is `radian_like`; the message names it in both units.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_degrees
    >>> check_degrees([90.0, -45.0], "tool rx, ry")  # passes
    >>> check_degrees([90.0, 1.5708], "tool rx, ry")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: tool rx, ry: 1.5708 look like radians (1.5708 rad = 90.0002 deg); ...
    """
    a = np.asarray(angles_deg, dtype=float)
    bad = radian_like(a)
    if bad.any():
        raise UnitError(f"{what}: {', '.join(f'{v:g}' for v in a[bad])} look like radians "
                        f"({', '.join(f'{v:g} rad = {np.rad2deg(v):g} deg' for v in a[bad])}); the "
                        "angles are in degrees")


def check_degree_set(angles_deg: Sequence[float], what: str) -> None:
    """Refuse a set of orientation angles in degrees (targets' rx, ry, rz) that are all within
    [-pi, pi] 'degrees' while the largest is above `RADIAN_SET_MIN_DEG`: radians (a set of
    real orientations that all lie within 3.14 deg of the identity is not what a program holds).

    Parameters
    ----------
    angles_deg : sequence of float
        The angles, read as degrees.
    what : str
        Where the values come from (a file, its columns), for the message.

    Raises
    ------
    UnitError
        The angles look like radians.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_degree_set
    >>> check_degree_set([90.0, -45.0, 0.0], "targets.csv rx ry rz")  # passes
    >>> check_degree_set([0.5, -1.2, 3.1], "targets.csv rx ry rz")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: targets.csv rx ry rz: every angle lies within +-3.1 deg, as radians do ...
    """
    a = np.abs(np.asarray(angles_deg, dtype=float))
    if RADIAN_SET_MIN_DEG < a.max(initial=0.0) <= math.pi + 1e-6:
        raise UnitError(f"{what}: every angle lies within +-{a.max():.4g} deg, as radians do (pi = 3.1416): "
                        "the angles look like radians; give degrees (or name the columns _rad)")


def check_radians(angles_rad: Sequence[float], what: str) -> None:
    """Refuse orientation angles given in radians beyond a full turn: degrees.

    Parameters
    ----------
    angles_rad : sequence of float
        The angles, read as radians.
    what : str
        Where the values come from (a file, its columns), for the message.

    Raises
    ------
    UnitError
        An angle beyond a full turn.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_radians
    >>> check_radians([1.5708, -0.1], "tool rx, ry")  # passes
    >>> check_radians([90.0, -0.1], "tool rx, ry")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: tool rx, ry: 90 rad is more than a turn: ...
    """
    a = np.asarray(angles_rad, dtype=float)
    bad = np.abs(a) > MAX_RADIANS
    if bad.any():
        raise UnitError(f"{what}: {', '.join(f'{v:g}' for v in a[bad])} rad is more than a turn: the "
                        "angles look like degrees; give radians")


def check_model_units(lengths_m, angles_rad, limits_rad, length_unit: str, angle_unit: str) -> None:
    """A model file's declared ``units`` against its numbers (SI here, read in those units): the
    link lengths ``lengths_m`` (a_i, d_i) must add up to a reach an arm has; the fixed angles
    ``angles_rad`` (twists alpha_i, offsets theta_i, beta_i) of a file in degrees that are all
    within a turn of 'degrees' while some is not 0 are radians (a real arm's twists are 0 or tens of
    degrees), and so are joint limits ``limits_rad`` (the file's explicit ones, may be empty) that all
    lie within a turn of 'degrees'; a file in radians with a fixed angle beyond a turn is in degrees.
    UnitError saying the model file's units look wrong.

    Parameters
    ----------
    lengths_m : array_like, shape (k,)
        The link lengths (a_i, d_i), m.
    angles_rad : array_like, shape (m,)
        The fixed angles (alpha_i, theta_i, beta_i), rad.
    limits_rad : array_like
        The file's explicit joint limits, rad (may be empty).
    length_unit, angle_unit : str
        The file's declared units ('mm', 'm', 'inch'; 'deg', 'rad').

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.core.magnitudes import check_model_units
    >>> lengths = [0.445, 0.15, 0.7, 0.115, 0.795, 0.085]  # m
    >>> check_model_units(lengths, np.deg2rad([90.0, 0.0, -90.0]), [], "m", "deg")  # passes
    >>> check_model_units(lengths, np.deg2rad([1.5708, 0.0, -1.5708]), [], "m", "deg")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: the model file's units look wrong ...; the angles look like radians: ...
    """
    scale = math.pi / 180.0 if angle_unit == "deg" else 1.0
    head = f"the model file's units look wrong (units: {{length: {length_unit}, angle: {angle_unit}}})"
    reach = float(np.abs(np.asarray(lengths_m, float)).sum())
    check_model_reach(reach, length_unit, f"{head}: its link lengths add up to")
    raw = np.abs(np.asarray(angles_rad, float)) / scale
    limits = np.abs(np.asarray(limits_rad, float)) / scale
    limits = limits[np.isfinite(limits)]
    if angle_unit == "deg":
        twisted = RADIAN_SET_MIN_DEG < raw.max(initial=0.0) <= MAX_RADIANS
        narrow = limits.size > 0 and RADIAN_SET_MIN_DEG < limits.max() <= MAX_RADIANS
        if twisted or narrow:
            what = (f"its fixed angles are at most {raw.max():.4g} deg" if twisted else
                    f"every joint moves at most {limits.max():.4g} deg")
            raise UnitError(f"{head}: {what}, which no arm has; the angles look like radians: make it "
                            "angle: rad (or convert them to degrees)")
    elif raw.max(initial=0.0) > MAX_RADIANS:
        raise UnitError(f"{head}: a fixed angle of {raw.max():.4g} rad (more than a turn); the angles look "
                        "like degrees: make it angle: deg (or convert them to radians)")


def check_payload(masses_kg: Sequence[float], rated_kg: float | None, robot: str, what: str) -> None:
    """Refuse payload masses ``(N,)`` (kg as given) heavier than `PAYLOAD_MAX_RATED` times the
    rated payload ``rated_kg`` of ``robot`` (None: not known, nothing is checked): UnitError naming
    pounds or grams (`MASS_SCALES_KG`) when the heaviest, read in that unit, is a load the robot
    carries, else saying it fits none.

    Parameters
    ----------
    masses_kg : sequence of float, shape (N,)
        The payload masses as given, kg.
    rated_kg : float or None
        The robot's rated payload, kg (`robocal.kinematics.model.Robot.payload_kg`).
    robot : str
        The robot's name, for the message.
    what : str
        Where the masses came from (a file's column, an option).

    Raises
    ------
    UnitError
        A mass above `PAYLOAD_MAX_RATED` times the rated payload.

    Examples
    --------
    >>> from robocal.core.magnitudes import check_payload
    >>> check_payload([0.0, 150.0, 200.0], 200.0, "gp180", "data.csv payload_kg")  # passes
    >>> check_payload([0.0, 397.0], 200.0, "gp180", "data.csv payload_kg")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: data.csv payload_kg: 397 kg is ... pounds (397 lb = 180.1 kg): give ...
    >>> check_payload([4000.0], 7.0, "lrmate200id", "--payload")
    Traceback (most recent call last):
    ...
    robocal.core.errors.UnitError: --payload: 4000 kg is ... the masses look like grams (4000 g = 4 kg): ...
    """
    m = np.asarray(masses_kg, dtype=float)
    if rated_kg is None or m.size == 0:
        return
    heaviest, most = float(m.max()), PAYLOAD_MAX_RATED * rated_kg
    if heaviest <= most:
        return
    head = (f"{what}: {heaviest:.4g} kg is {heaviest / rated_kg:.3g} times the rated payload of {robot} "
            f"({rated_kg:.4g} kg; at most {PAYLOAD_MAX_RATED:g} times is a load it carries)")
    u = likely_unit(heaviest, MASS_SCALES_KG, 0.0, most)
    if u is not None:
        raise UnitError(f"{head}; the masses look like {MASS_WORDS[u]} ({heaviest:.4g} {u} = "
                        f"{heaviest * MASS_SCALES_KG[u]:.4g} kg): give them in kilograms "
                        f"(x {MASS_SCALES_KG[u]:.6g})")
    raise UnitError(f"{head} in any unit (kg, lb, g): check the payload or the robot model")


def fahrenheit_to_celsius(t_f):
    """Degrees Fahrenheit -> Celsius (scalar or array)."""
    return (np.asarray(t_f, dtype=float) - 32.0) / 1.8


def temperature_note(temperatures_c: Sequence[float], what: str) -> str | None:
    """A warning when the arm temperatures ``(N,)`` (deg C as given) run above `ARM_TEMPERATURE_C`:
    naming Fahrenheit when the values read in it lie inside that range, else the range; None when
    they lie inside it.

    Examples
    --------
    >>> from robocal.core.magnitudes import temperature_note
    >>> temperature_note([20.0, 35.0], "cal.csv") is None
    True
    >>> print(temperature_note([68.0, 95.0], "cal.csv"))  # doctest: +ELLIPSIS
    cal.csv: the temperature_c column runs from 68 to 95 deg C, ... Fahrenheit they are 20 to 35 deg C...
    """
    t = np.asarray(temperatures_c, dtype=float)
    lo, hi = ARM_TEMPERATURE_C
    if t.size == 0 or float(t.max()) <= hi:
        return None
    head = (f"{what}: the temperature_c column runs from {t.min():.4g} to {t.max():.4g} deg C, above an "
            f"arm's working temperature (at most {hi:g} deg C)")
    as_c = fahrenheit_to_celsius(t)
    if float(as_c.min()) >= lo and float(as_c.max()) <= hi:
        return (f"{head}; read as degrees Fahrenheit they are {as_c.min():.4g} to {as_c.max():.4g} deg C: if "
                "the column is in Fahrenheit, convert it (deg C = (deg F - 32) / 1.8), else a thermal term "
                "identifies a wrong expansion")
    return f"{head}: check the column is in degrees Celsius"

