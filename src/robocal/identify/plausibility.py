"""Plausibility guards: data and model that disagree beyond what real robots do are a mistake
(a unit, the wrong robot, the wrong file), not a calibration to report.

What real robots' errors can be, and the limits derived from it (named once here):

- An industrial arm's nominal model misses absolute targets by 0.5-3 mm (10 mm after a crash or
  a bad remastering: a joint zero 0.5 deg off at 1 m). After the tracker frame and the SMR
  offsets are fitted, no geometric error leaves more than ``MAX_NOMINAL_ERROR_MM`` of RMS
  residual, nor more than ``MAX_NOMINAL_ERROR_FRACTION`` of the spread of the measured points (the
  RMS distance from their centroid: a big robot's errors grow with its size). The real data sets
  leave 0.19 mm (Meca500) and 0.90 mm (IRB 120); the mistakes this catches leave 49-340 mm on the
  Meca500 data (metres under _mm headers 49 mm, radians under _deg 89 mm, each of the 11 other
  6-axis catalog robots 60-340 mm: ``benchmarks/bench_calibrate.py plausibility``).
- A length unit error scales the measured points by 1000 (or 1/1000) against the model (1/880
  after the frame fit on the Meca500 data); the wrong robot changes the spread by factors of
  3.2-6.5 there, except the IRB 120 and the PUMA 560 (2.0 and 2.7: within the limit, the residual
  check catches them), and radians under _deg by 1.6; inches under _mm by 1/25.4 (named when the
  ratio is within ``INCH_RATIO_TOL`` of it). The measured spread must be within
  ``SPREAD_RATIO`` of the fitted model's at the same joints.
- Calibration corrects link lengths by fractions of a millimetre (a few mm at most on big
  robots) and angles by hundredths of a degree (a degree for a badly mastered joint zero). A
  correction of a link length beyond ``MAX_LENGTH_CORRECTION_MM`` or
  ``MAX_LENGTH_CORRECTION_FRACTION`` of the robot's reach, or of a joint or axis angle beyond
  ``MAX_ANGLE_CORRECTION_DEG``, that the data determine (beyond ``DETERMINED_SIGMAS`` of its
  1-sigma) is the solver absorbing a mistake (a unit, the wrong robot). One the data do not
  determine (within that many sigma of zero) is weak identifiability: the message names what to
  measure instead of blaming the input. A robot whose prior class (or the user) states wider
  priors (:mod:`robocal.kinematics.prior_spec`: a humanoid's zeros 3 deg, lengths 10 mm per metre)
  has correspondingly wider limits: ``PRIOR_SIGMAS`` times the stated prior where that is larger
  (the scales a calibration estimated from the data do not count: a mistake widens them too).

- A joint reading lies inside the robot's limits; a little beyond (``JOINT_LIMIT_TOL_DEG``: soft
  limits set inside the hard stops, encoder rounding) passes, further is warned with the rows and
  joints named, and beyond ``JOINT_LIMIT_MARGIN_DEG`` past a limit is not this robot's reading
  (radians under _deg, a shifted column, another robot's file): a 12 rad reading on a joint
  limited to +-180 deg degraded a fit 27x without a word. A prismatic joint has the same checks
  in mm (``JOINT_LIMIT_TOL_MM``, ``JOINT_LIMIT_MARGIN_MM``). Beyond ``MAX_JOINT_TURNS`` turns (or a
  revolute joint's own limits, when wider) no reading is real and ``force`` does not pass it.

Each check raises :class:`robocal.core.errors.PlausibilityError` naming what is probably wrong;
``force=True`` (``--force``) turns it into a warning for users who know better.
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import DataError, PlausibilityError
from robocal.data.joint_conventions import COUPLED_OPTION, fanuc_decoupled
from robocal.data.measurements import robot_reach
from robocal.identify.space import block_of

MAX_NOMINAL_ERROR_MM = 10.0
MAX_NOMINAL_ERROR_FRACTION = 0.05
GROSS_FRACTION = 0.1  # the share of the largest errors the misfit check leaves out (gross errors)
SPREAD_RATIO = 3.0
UNIT_RATIO = 300.0  # a spread ratio beyond this (either way) is a length unit (x1000)
INCH_MM = 25.4
INCH_RATIO_TOL = 0.2  # a spread ratio within 20 % of 1/25.4 (or 25.4) is inches (another robot: 1.6-6.5)
MAX_LENGTH_CORRECTION_MM = 5.0
MAX_LENGTH_CORRECTION_FRACTION = 0.01
MAX_ANGLE_CORRECTION_DEG = 5.0
DETERMINED_SIGMAS = 3.0  # a correction beyond this many sigma is what the data say
PRIOR_SIGMAS = 3.0  # a correction within this many stated prior sigmas is plausible whatever the limit
JOINT_LIMIT_TOL_DEG = 1.0
JOINT_LIMIT_MARGIN_DEG = 90.0
JOINT_LIMIT_TOL_MM = 1.0  # the same for a prismatic joint (a track's carriage, a SCARA's quill)
JOINT_LIMIT_MARGIN_MM = 100.0
UNIT_SPREAD_OF_RANGE = 0.1  # prismatic readings read in mm span this share of the axis' range at least
MAX_JOINT_TURNS = 2.0
_LISTED = 5  # rows named in a joint-limit message
FORCE_HINT = "if you are sure the data and the model are right, rerun with --force (force=True)"


def spread(points: np.ndarray) -> float:
    """RMS distance of points ``(N, 3)`` from their centroid (m)."""
    return float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))


def bulk_rms_mm(errors: np.ndarray) -> float:
    """RMS (mm) of the bulk of position errors ``errors`` (m; ``(N, 3)`` vectors or ``(N,)`` norms):
    the largest :data:`GROSS_FRACTION` of the items left out, so that a few gross errors (a
    mislabelled marker, a mistyped row) do not make a right model look like another robot's, while
    data that do belong to another robot or unit, wrong in every row, still do."""
    e = np.asarray(errors, dtype=float)
    e = np.linalg.norm(e, axis=1) if e.ndim == 2 else np.abs(e)
    kept = np.sort(e)[:max(1, int(np.ceil(len(e) * (1 - GROSS_FRACTION))))]
    return float(np.sqrt(np.mean(kept**2)) * 1e3)


def error_limit_mm(points: np.ndarray) -> float:
    """The largest RMS residual (mm) a robot's geometric errors can leave on these points."""
    return max(MAX_NOMINAL_ERROR_MM, MAX_NOMINAL_ERROR_FRACTION * spread(points) * 1e3)


def _fail(message: str, force: bool, warnings: list[str] | None) -> None:
    if not force:
        raise PlausibilityError(f"{message}; {FORCE_HINT}")
    if warnings is not None:
        warnings.append(f"FORCED past a plausibility check: {message}")


def check_spread(measured: np.ndarray, modelled: np.ndarray, what: str, *, force: bool = False,
                 warnings: list[str] | None = None) -> None:
    """The measured points ``(N, 3)`` must spread like the model's points at the same joints."""
    ratio = spread(measured) / max(spread(modelled), 1e-12)
    if 1 / SPREAD_RATIO <= ratio <= SPREAD_RATIO:
        return
    inch = min(abs(np.log(ratio * INCH_MM)), abs(np.log(ratio / INCH_MM)))
    if inch < np.log1p(INCH_RATIO_TOL):
        cause = (f"the length unit is probably wrong by the factor of an inch ({INCH_MM:g}): "
                 + ("a tracker export in inches under x_mm, y_mm, z_mm headers: export millimetres, or "
                    f"multiply x, y, z by {INCH_MM:g}" if ratio < 1 else "millimetres given as inches"))
    elif ratio > UNIT_RATIO or ratio < 1 / UNIT_RATIO:
        cause = ("the length unit is probably wrong (values in metres under x_mm, y_mm, z_mm headers, "
                 "or millimetres under _m)")
    elif ratio > SPREAD_RATIO and spread(modelled) < 0.1 * spread(measured):
        cause = ("the model hardly moves at these joints: the joint angles are probably radians "
                 "under q_deg headers (or the joints belong to another robot)")
    else:
        cause = "the data probably belong to another robot, or the model is the wrong one"
    _fail(f"{what}: the measured points spread {ratio:.3g} times as far as the model predicts at the "
          f"same joints (measured {spread(measured) * 1e3:.4g} mm, model {spread(modelled) * 1e3:.4g} mm "
          f"RMS from the centroid): {cause}", force, warnings)


def check_residual(rms_mm: float, points: np.ndarray, what: str, *, force: bool = False,
                   warnings: list[str] | None = None) -> None:
    """An RMS residual ``rms_mm`` of the nominal (or calibrated) model on data whose points are
    ``points (N, 3)`` must be within what geometric errors can leave (:func:`error_limit_mm`);
    ``rms_mm`` is best the bulk's (:func:`bulk_rms_mm`)."""
    limit = error_limit_mm(points)
    if rms_mm <= limit:
        return
    _fail(f"{what}: the model misses the measurements by {rms_mm:.4g} mm RMS, far beyond what a "
          f"robot's geometric errors can explain (at most ~{limit:.3g} mm here): the data probably "
          "belong to another robot or another file, a unit (length or joint angle) is wrong, or the "
          "model's tool is not the one measured (a probe's or a contact face's offset from the flange: "
          "give it as the model's tool)", force, warnings)


def check_corrections(start, final, names, *, sigma: dict[str, float] | None = None,
                      confounded: dict[str, list[str]] | None = None, force: bool = False,
                      warnings: list[str] | None = None, prior: dict[str, float] | None = None) -> None:
    """Corrections of the estimated link parameters ``names`` from ``start`` to ``final`` (robots)
    must be of the size real robots' errors have (module docstring). ``sigma`` (SI, by name): the
    corrections' 1-sigma, to tell a determined correction from one the data cannot pin down;
    ``confounded``: what each parameter is confounded with (for the message); ``prior`` (SI, by
    name): the stated prior sigma, which widens a limit to ``PRIOR_SIGMAS`` of it."""
    length_limit = max(MAX_LENGTH_CORRECTION_MM * 1e-3, MAX_LENGTH_CORRECTION_FRACTION * robot_reach(start))
    angle_limit = np.deg2rad(MAX_ANGLE_CORRECTION_DEG)
    units = dict(zip(start.parameter_names, start.parameter_units(), strict=True))
    sigma, confounded, prior = sigma or {}, confounded or {}, prior or {}
    determined, loose = [], []
    links = [name for name in names if block_of(name) == "links"]
    deltas = final.values_of(links) - start.values_of(links)
    for name, delta in zip(links, deltas.tolist(), strict=True):
        widened = PRIOR_SIGMAS * prior.get(name, 0.0)
        if units[name] == "m" and abs(delta) > max(length_limit, widened):
            text = f"{name} by {delta * 1e3:+.4g} mm"
            s = sigma.get(name, 0.0) * 1e3
        elif units[name] == "rad" and abs(delta) > max(angle_limit, widened):
            text = f"{name} by {np.rad2deg(delta):+.4g} deg"
            s = np.rad2deg(sigma.get(name, 0.0))
        else:
            continue
        if abs(delta) > DETERMINED_SIGMAS * sigma.get(name, 0.0):
            determined.append(text)
        else:
            partners = "/".join(confounded.get(name, [])) or "the other parameters"
            loose.append(f"{text} (+- {s:.3g}, confounded with {partners})")
    limits = f"link lengths {length_limit * 1e3:.3g} mm, angles {MAX_ANGLE_CORRECTION_DEG:g} deg" + (
        f", or {PRIOR_SIGMAS:g} times the priors of the robot's class" if prior else "")
    if determined:
        _fail(f"the calibration corrected {', '.join(determined)}: more than real robots' errors can be "
              f"({limits}) and determined by the data; the solver is absorbing a mistake: a unit (length "
              "or joint angle), the wrong robot or the wrong data", force, warnings)
    if loose:
        _fail(f"the calibration moved {', '.join(loose)}: beyond real robots' errors ({limits}) but within "
              f"{DETERMINED_SIGMAS:g} sigma of zero, so these data cannot pin them down (not a unit or robot "
              "mix-up): measure poses that move these parameters apart from their confounders (wider wrist "
              "and elbow angles, several SMRs spread on the tool), or leave them out with --params",
              force, warnings)


def _readings(data, robot, mask: np.ndarray) -> str:
    """The first readings where ``mask (N, n)`` holds: row, joint, value and the limits (deg, or mm
    for a prismatic joint)."""
    rows, joints = np.nonzero(mask)
    spec = robot.joints
    items = [f"row {int(data.source_row[r])} {spec[j].describe(data.joints[r, j])}"
             for r, j in zip(rows[:_LISTED], joints[:_LISTED], strict=True)]
    more = len(rows) - len(items)
    n_rows = len(np.unique(rows))
    return f"{n_rows} row(s): " + "; ".join(items) + (f"; and {more} more" if more > 0 else "")


def _prismatic_unit(robot, data, far: np.ndarray) -> str | None:
    """The cause of prismatic readings far outside the limits (``far (N, n)``) when, read in
    millimetres (the values / 1000), every reading of each such axis lies within its limits and
    they spread over `UNIT_SPREAD_OF_RANGE` of its range at least (a track counted the other way
    near its zero is not millimetres): a column named in metres holding millimetres; None
    otherwise."""
    axes = np.flatnonzero(robot.prismatic & far.any(axis=0))
    if not axes.size or axes.size != np.flatnonzero(far.any(axis=0)).size:
        return None
    q = data.joints[:, axes] * 1e-3
    lo, hi = robot.limits[axes, 0], robot.limits[axes, 1]
    spread = np.ptp(q, axis=0) >= UNIT_SPREAD_OF_RANGE * (hi - lo)  # readings over the range, not near 0
    if (np.maximum(lo - q, q - hi) > JOINT_LIMIT_TOL_MM * 1e-3).any() or not spread.all():
        return None
    names = ", ".join(data.joint_column(int(k), "_m") for k in axes)
    return (f"read in millimetres every reading of {names} lies inside the limits: the column holds "
            f"millimetres under a metres header; name it {names.replace('_m', '_mm')}")


def check_joint_limits(robot, data, what: str, *, force: bool = False,
                       warnings: list[str] | None = None) -> None:
    """The joint readings of ``data`` (Measurements) against ``robot``'s limits (module docstring):
    DataError beyond ``MAX_JOINT_TURNS`` turns, PlausibilityError beyond the margin, a warning
    appended to ``warnings`` beyond the tolerance."""
    q = data.joints
    revolute = ~robot.prismatic
    widest = np.where(np.isfinite(robot.limits), np.abs(robot.limits), 0.0).max(axis=1)  # (n,) rad or m
    turns = revolute & (np.abs(q) > np.maximum(MAX_JOINT_TURNS * 2 * np.pi, widest))  # within its range: real
    if turns.any():
        raise DataError(f"{what}: joint readings beyond {MAX_JOINT_TURNS:g} turns cannot be real (radians "
                        f"under _deg headers? a shifted column?): {_readings(data, robot, turns)}")
    past = np.maximum(robot.limits[:, 0] - q, q - robot.limits[:, 1])  # (N, n) rad past a limit
    far = past > np.where(revolute, np.deg2rad(JOINT_LIMIT_MARGIN_DEG), JOINT_LIMIT_MARGIN_MM * 1e-3)
    if far.any():
        cause = "another robot's data, radians under _deg headers, a shifted column?"
        if q.shape[1] >= 3:
            q_dec = fanuc_decoupled(q)
            if (np.maximum(robot.limits[:, 0] - q_dec, q_dec - robot.limits[:, 1])
                    <= np.deg2rad(JOINT_LIMIT_TOL_DEG)).all():
                cause = ("J3 looks coupled to J2: with J3 - J2 every reading is inside the limits (a FANUC "
                         "controller's joint log counts J3 from the horizontal): read it with "
                         f"{COUPLED_OPTION}")
        cause = _prismatic_unit(robot, data, far) or cause
        margin = f"{JOINT_LIMIT_MARGIN_DEG:g} deg" + (f" ({JOINT_LIMIT_MARGIN_MM:g} mm on a prismatic joint)"
                                                       if robot.has_prismatic else "")
        _fail(f"{what}: joint readings more than {margin} outside {robot.name}'s "
              f"joint limits ({cause}): {_readings(data, robot, far)}", force, warnings)
    near = (past > np.where(revolute, np.deg2rad(JOINT_LIMIT_TOL_DEG), JOINT_LIMIT_TOL_MM * 1e-3)) & ~far
    if near.any() and warnings is not None:
        warnings.append(f"{what}: joint readings outside {robot.name}'s joint limits (check the model's "
                        f"limits and the joint columns): {_readings(data, robot, near)}")
