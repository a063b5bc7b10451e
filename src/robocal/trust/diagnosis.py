"""Why does a model miss the measurements? The next step after a plausibility refusal.

When the nominal model misses tracker data by far more than a robot's errors can explain
(:mod:`robocal.identify.plausibility`), the data often tell which mistake it is. Each hypothesis
is tested by fitting the tracker frame and SMR offsets (:func:`robocal.data.registration.register_frame`)
to the data as the hypothesis would correct them; one that fits within the plausible error
(:func:`robocal.identify.plausibility.error_limit_mm`) and at least ``GAIN`` times better than the
data as given is named:

- two joint columns exchanged (every pair) or the signs of up to three joints flipped together
  (every subset, screened at once by a rigid fit; a prismatic axis named as a reversed track or
  lift direction, by the joint's kind);
- an arm mounted turned on its track or gantry carriage (multiples of 90 deg, then a fitted angle);
- a mirrored tracker frame (a left-handed frame: one axis's sign flipped in the export);
- several files: the odd one (the others fit, it does not), or every file fitting alone but not
  together (a second tracker station, or the tracker moved between files);
- a model judged in another frame than the data's (a nominal model without ``--fit-frame``);
- a length unit: the points read as millimetres but written in metres or inches (or the other way);
- FANUC's J2/J3 coupling: a controller's joint log counts J3 from the horizontal (J3 + J2);
- priors too tight for this robot (:func:`priors_too_tight`): the evidence of the linearised fit
  rises when a prior group is widened (an industrial arm's priors on a humanoid).
"""

from __future__ import annotations

from dataclasses import replace
from itertools import combinations

import numpy as np

from robocal.core.magnitudes import LENGTH_SCALES_M, UNIT_WORDS
from robocal.data.joint_conventions import COUPLED_OPTION, fanuc_decoupled
from robocal.data.registration import refit_frame, rigid_fit_rms
from robocal.identify.plausibility import error_limit_mm
from robocal.kinematics.cell import carriage_frames, is_track_cell
from robocal.kinematics.prior_spec import MAX_SCALE

GAIN = 5.0  # a hypothesis must fit this many times better than the data as given
# wider priors explain the data when the linearised fit's residual RMS falls by at least this fraction
# (measured: 9 % on FIGAROH's TIAGo with the industrial priors fixed; 0.001 % for points in inches,
# whose evidence also rises: the huge corrections they need are made anyway, a prior does not stop them)
PRIORS_MIN_RMS_DROP = 0.05
MAX_FLIPPED = 3  # joints whose signs a hypothesis flips together at most (63 subsets of 7 joints)
SCREENED = 4  # the hypotheses that pass the rigid screen best get the full frame and SMR fit
# a hypothesis changing fewer joints is named when it fits within this factor of the best (a wrist flip
# the SMR's 0.7 mm lateral offset shows: 1.50 mm against 1.20 on a GP25 whose links are 1.2 mm off nominal)
SIMPLER_WITHIN = 1.1
SCREEN_ROWS = 400  # rows (evenly spaced) the screens use at most: 78 hypotheses x 400 rows of a 7-axis cell
MOUNT_STEP_DEG = 15.0  # the grid of mount rotations tried before the fitted one
MOUNT_RIGHT_ANGLE_DEG = 1.0  # a fitted mount rotation this close to a multiple of 90 deg is named as one


def fit_rms_mm(robot, data) -> float:
    """RMS (mm) left after fitting the tracker frame and SMR offsets of ``robot`` to ``data``
    (point or pose Measurements, `robocal.data.registration.refit_frame`); inf when the fit fails."""
    reg = refit_frame(robot, data)
    return float("inf") if reg is None else reg.rms * 1e3


def _columns(data, joints) -> object:
    """``data`` with other joint values (approach and travel re-derived from the row order)."""
    from robocal.data.measurements import approach_from_order, travel_from_order

    return replace(data, joints=joints, approach=approach_from_order(joints, data.pose_id),
                   travel=travel_from_order(joints, data.pose_id))


def _screen_rows(n: int) -> np.ndarray:
    """Indices of at most :data:`SCREEN_ROWS` rows of ``n``, evenly spaced (all when fewer)."""
    return np.unique(np.linspace(0, n - 1, min(n, SCREEN_ROWS)).round().astype(int))


def _flip_words(spec, flipped: tuple[int, ...]) -> str:
    """The sign flip of joints ``flipped`` in words, by the joints' kind: a prismatic axis (a
    track, a lift) is a direction counted the other way, a revolute joint a sign."""
    slides = [spec[i] for i in flipped if spec[i].prismatic]
    turns = [spec[i] for i in flipped if not spec[i].prismatic]
    parts = [f"the prismatic axis {j.name}'s direction looks reversed (a track or lift counted the other "
             "way: the cell file's track direction, or the controller's sign of that axis; to the data the "
             "same as the arm mounted turned 180 deg on it)" for j in slides]
    if turns:
        names = ", ".join(j.name for j in turns)
        parts.append(f"joint {names}'s sign looks flipped (the controller counts it the other way)"
                     if len(turns) == 1 else
                     f"joints {names} look counted the other way (their signs flipped)")
    return "; ".join(parts)


def _mixup_trials(spec, n: int) -> list[tuple[str, np.ndarray]]:
    """Every joint column exchange (two joints of one kind) and sign flip of up to
    :data:`MAX_FLIPPED` joints together, as (words, column map ``(n,)``, signs ``(n,)``)."""
    trials = []
    for i, j in combinations(range(n), 2):
        if spec[i].kind == spec[j].kind:
            order = np.arange(n)
            order[[i, j]] = [j, i]
            trials.append((f"joint columns {spec[i].name} and {spec[j].name} look exchanged", order,
                           np.ones(n)))
    for k in range(1, min(MAX_FLIPPED, n) + 1):
        for flipped in combinations(range(n), k):
            signs = np.ones(n)
            signs[list(flipped)] = -1.0
            trials.append((_flip_words(spec, flipped), np.arange(n), signs))
    return trials


def joint_mixup(robot, data, given_mm: float) -> str | None:
    """A joint column exchange (of two joints of one kind: two angles, two lengths) or the signs of
    up to :data:`MAX_FLIPPED` joints flipped together under which the model fits, as a sentence
    naming the joints as ``robot`` does (a prismatic axis as a reversed direction), or None.

    Every hypothesis is screened at once by a rigid fit of its forward kinematics to the points
    (:func:`rigid_fit_rms`); the :data:`SCREENED` best get the full frame and SMR fit. Of those that
    fit, the one with the fewest joints changed among those within :data:`SIMPLER_WITHIN` of the
    best is named (a flip the data cannot see, a wrist joint with the SMR on its axis, is not); a
    mirrored tracker frame that fits as well as several joints flipped is named instead (one
    mistake in the export, the same to the data: :func:`mirrored`)."""
    limit = error_limit_mm(data.points)
    spec = robot.joints
    trials = _mixup_trials(spec, len(spec))
    rows = _screen_rows(len(data))
    q = np.stack([data.joints[rows][:, order] * signs for _, order, signs in trials])  # (H, R, n)
    modelled = robot.fk(q.reshape(-1, len(spec)), smr=np.tile(data.smr[rows], len(trials)))[:, :3, 3]
    screen = rigid_fit_rms(modelled.reshape(len(trials), rows.size, 3), data.points[rows])
    refined = []
    for h in np.argsort(screen)[:SCREENED]:
        what, order, signs = trials[h]
        rms = fit_rms_mm(robot, _columns(data, data.joints[:, order] * signs))
        changed = int(np.count_nonzero(signs < 0) + np.count_nonzero(order != np.arange(len(spec))))
        refined.append((rms, changed, what))
    best = min(r[0] for r in refined)
    rms, changed, what = min((r for r in refined if r[0] <= SIMPLER_WITHIN * best),
                             key=lambda r: (r[1], r[0]))
    mirror = _mirror_rms(robot, data) if changed > 1 else np.inf
    if mirror <= SIMPLER_WITHIN * rms:  # one mistake in the export explains it as well: named first
        said = _mirror_sentence(mirror, data, given_mm)  # the mirror's fit done once
        return None if said is None else f"{said} (to these data the same as: {what})"
    if rms <= limit and rms * GAIN < given_mm:
        return (f"{what}: corrected so, the nominal model fits to {rms:.3g} mm RMS ({given_mm:.3g} "
                "mm as given); fix the file's joint columns")
    return None


def mount_turned(robot, data, given_mm: float) -> str | None:
    """For a chain whose first revolute joint is carried by prismatic axes (an arm on a track, a
    gantry): the arm's mount turned about its first axis (the base z of the arm) by a multiple of
    90 deg, or by a fitted angle, under which the model fits, as a sentence; None otherwise. (On a
    fixed base the tracker frame fit absorbs any mount rotation: nothing to test.)"""
    slides = np.array([j.prismatic for j in robot.joints])
    if not slides[0] or slides.all():
        return None
    first = int(np.argmin(slides))  # the arm's first revolute joint
    name = f"theta{first + 1}"
    zero = robot.get(name)

    def rms_at(turn: float) -> float:
        return fit_rms_mm(robot.with_values({name: zero + turn}), data)

    rows = _screen_rows(len(data))

    def rigid_mm(turns: np.ndarray) -> np.ndarray:  # the cheap screen: a rigid fit per angle
        q, smr = data.joints[rows], data.smr[rows]
        points = np.stack([robot.with_values({name: zero + t}).fk(q, smr=smr)[:, :3, 3]
                           for t in np.atleast_1d(turns)])
        return rigid_fit_rms(points, data.points[rows]) * 1e3

    # the grid and the fitted angle screened, the named angle judged by the full frame and SMR fit
    grid = np.deg2rad(np.arange(MOUNT_STEP_DEG, 360.0, MOUNT_STEP_DEG))
    best = grid[int(np.argmin(rigid_mm(grid)))]
    from scipy.optimize import minimize_scalar  # here: scipy.optimize costs start-up to every command

    step = np.deg2rad(MOUNT_STEP_DEG)
    found = minimize_scalar(lambda t: float(rigid_mm(t)[0]), bounds=(best - step, best + step),
                            method="bounded", options={"xatol": 1e-6})
    turn = float(found.x)
    deg = float(np.rad2deg(np.remainder(turn + np.pi, 2 * np.pi) - np.pi))
    rms = rms_at(turn)
    right = round(deg / 90.0) * 90.0
    at_right = rms_at(np.deg2rad(right)) if abs(deg - right) <= MOUNT_RIGHT_ANGLE_DEG else np.inf
    if at_right <= SIMPLER_WITHIN * rms:
        deg, rms = right, at_right
    if rms <= error_limit_mm(data.points) and rms * GAIN < given_mm:
        axis = f"its first axis ({robot.joints[first].name}, in that joint's sense)"
        if is_track_cell(robot):  # as a cell file's mount rpy z turns it: about the arm base's z
            z_arm = carriage_frames(robot, [0.0])[0, :3, 2]
            z_joint = robot.fk(np.zeros((1, robot.n_joints)), frames=True)[1][0, first + 1, :3, 2]
            deg *= 1.0 if z_arm @ z_joint >= 0 else -1.0
            axis = "the z axis of its base (a cell file's mount rpy z)"
        return (f"the arm looks mounted turned by {deg:+.4g} deg about {axis} on the {robot.joints[0].name} "
                f"carriage: turned so, the nominal model fits to {rms:.3g} mm RMS ({given_mm:.3g} mm as "
                "given); fix the mount's rotation")
    return None


def _mirror_rms(robot, data) -> float:
    """RMS (mm) of the frame and SMR fit to ``data``'s points with one axis's sign flipped."""
    flipped = data.points * np.array([1.0, 1.0, -1.0])
    return fit_rms_mm(robot, replace(data, points=flipped, rotations=None, kind="point"))


def mirrored(robot, data, given_mm: float) -> str | None:
    """The sentence naming a mirrored tracker frame when the model fits the mirrored points (a
    mirror is the same, to the data, as some joints counted the other way: :func:`joint_mixup`
    names it first when it fits as well)."""
    return _mirror_sentence(_mirror_rms(robot, data), data, given_mm)


def _mirror_sentence(rms: float, data, given_mm: float) -> str | None:
    """:func:`mirrored`'s sentence from the mirrored points' fit ``rms`` (mm, `_mirror_rms`)."""
    if rms <= error_limit_mm(data.points) and rms * GAIN < given_mm:
        return (f"the tracker frame looks mirrored (left-handed: one axis's sign flipped in the export): "
                f"with one axis flipped the nominal model fits to {rms:.3g} mm RMS ({given_mm:.3g} mm as "
                "given); export the points in a right-handed frame")
    return None


# factor the points as read must be multiplied by to be right, and the mistake it undoes: every other
# unit of `robocal.core.magnitudes.LENGTH_SCALES_M` read under each header unit a file has (_mm, _m)
UNIT_SCALES = tuple((LENGTH_SCALES_M[unit] / LENGTH_SCALES_M[header],
                     f"the points look like {UNIT_WORDS[unit]} under _{header} headers")
                    for header in ("mm", "m") for unit in LENGTH_SCALES_M if unit != header)


def length_unit(robot, data, given_mm: float) -> str | None:
    """A length unit under which the model fits ``data``'s points (:data:`UNIT_SCALES`), as a
    sentence, or None. Each scale's fit is judged in the file's own unit (its RMS over the
    scale): a target the model cannot move (a positioner's target where its axes meet, with the
    frame fitted) fits a scaled-down cloud as closely, relative to its size, as the given one."""
    best = min(((fit_rms_mm(robot, replace(data, points=data.points * f)) / f, f, what)
                for f, what in UNIT_SCALES), key=lambda t: t[0])
    relative, f, what = best
    rms = relative * f
    if rms <= error_limit_mm(data.points * f) and relative * GAIN < given_mm:
        return (f"{what}: scaled by {f:g} the nominal model fits to {rms:.3g} mm RMS ({given_mm:.3g} mm as "
                "given); fix the unit of the file's x, y, z columns (their header's _mm or _m)")
    return None


def fanuc_coupled(robot, data, given_mm: float) -> str | None:
    """The sentence naming FANUC's J2/J3 coupling (J3 counted from the horizontal, as a FANUC
    controller logs it) when the model fits with J3 decoupled, or None."""
    if data.n_joints < 3:
        return None
    rms = fit_rms_mm(robot, _columns(data, fanuc_decoupled(data.joints)))
    if rms <= error_limit_mm(data.points) and rms * GAIN < given_mm:
        return (f"J3 looks coupled to J2 (FANUC's convention: J3 counted from the horizontal, as a FANUC "
                f"controller logs it and robocal's --fanuc programs take it): with J3 - J2 the nominal model "
                f"fits to {rms:.3g} mm RMS ({given_mm:.3g} mm as given); read the file with "
                f"{COUPLED_OPTION}")
    return None


# The hypotheses a file the model misses is tested on, in order, each a function (robot, data, the RMS
# as given (mm)) -> its sentence or None: a new one is registered here. An odd file among others that
# fit is tried on what its poses' structure allows (its joints, its mount, its frame's handedness).
STRUCTURE_HYPOTHESES = (joint_mixup, mount_turned, mirrored)
HYPOTHESES = (*STRUCTURE_HYPOTHESES, length_unit, fanuc_coupled)


def first_reason(robot, data, given_mm: float, hypotheses=HYPOTHESES) -> str | None:
    """The sentence of the first of ``hypotheses`` (default `HYPOTHESES`) that explains why
    ``robot`` misses ``data`` (Measurements) by ``given_mm`` (mm RMS, frames fitted), or None."""
    return next((r for h in hypotheses if (r := h(robot, data, given_mm))), None)


def diagnose(robot, datasets, *, frame_fitted: bool = True) -> str | None:
    """The most likely mistake behind data that ``robot`` (nominal or calibrated links) misses,
    as one sentence, or None when the data do not tell. ``datasets``: Measurements (only point
    and pose sets are examined); ``frame_fitted=False``: the model was judged in its own frame
    (no registration), so a frame that fits is itself the diagnosis."""
    sets = [d for d in datasets if d.spec.sees_position and len(d) >= 6]
    if not sets:
        return None
    alone = [fit_rms_mm(robot, d) for d in sets]
    limits = [error_limit_mm(d.points) for d in sets]
    fits = [a <= lim for a, lim in zip(alone, limits, strict=True)]
    if not frame_fitted and all(fits):
        return (f"with the base frame and SMR offsets fitted the model fits to {max(alone):.3g} mm RMS: the "
                "model's frame is not the measurements' (a nominal model): judge it with --fit-frame or "
                "--frame-from")
    if len(sets) > 1 and all(fits):
        return ("each file fits the model with its own tracker frame (" + ", ".join(
            f"{d.label or k}: {a:.3g} mm" for k, (d, a) in enumerate(zip(sets, alone, strict=True)))
            + ") but not together: they were measured from different tracker positions (a second station, or "
            "the tracker moved); bring them into one frame, or calibrate with one station's files")
    if len(sets) > 1 and any(fits):
        odd = [d.label or str(k) for k, (d, ok) in enumerate(zip(sets, fits, strict=True)) if not ok]
        worst = max(a for a, ok in zip(alone, fits, strict=True) if not ok)
        reason = next((r for d, ok in zip(sets, fits, strict=True) if not ok
                       for r in [first_reason(robot, d, worst, STRUCTURE_HYPOTHESES)] if r), None)
        return (f"{', '.join(odd)} is the odd file: the others fit the model, it misses by {worst:.4g} mm RMS"
                + (f"; {reason}" if reason else " (another robot's data, another file, or a unit)"))
    for d, a in zip(sets, alone, strict=True):
        reason = first_reason(robot, d, a)
        if reason:
            return (f"{d.label}: " if len(sets) > 1 and d.label else "") + reason
    return None


def diagnosed(error: Exception, robot, datasets, frame_fitted: bool = True) -> Exception:
    """``error`` (a PlausibilityError) with the data's own diagnosis (:func:`diagnose`) put first
    when it tells more (a swapped or sign-flipped joint column, a mirrored frame, the odd file, a
    frame that needs fitting); ``error`` itself otherwise."""
    why = diagnose(robot, datasets, frame_fitted=frame_fitted)
    return error if why is None else type(error)(f"{why} (the check: {error})")


def priors_too_tight(scales) -> str | None:
    """The sentence naming prior groups too tight for the robot, with the ``--priors`` option that
    widens them, when widening them explains the data (``scales``: the fit's
    :class:`robocal.identify.priors.PriorScales`; its ``asked`` scales raise the evidence by at
    least :data:`robocal.identify.evidence.EVIDENCE_GAIN_NATS`, the linearised fit's residual RMS
    falls by :data:`PRIORS_MIN_RMS_DROP` and every scale is one a robot can have,
    :data:`robocal.kinematics.prior_spec.MAX_SCALE`: else the data hold another mistake); None
    otherwise."""
    if scales is None or not (option := scales.option()):
        return None
    drop = 1.0 - scales.rms_asked / scales.rms_used if scales.rms_used > 0 else 0.0
    if drop < PRIORS_MIN_RMS_DROP or any(v > MAX_SCALE[g] for g, v in scales.tighter_than_asked.items()):
        return None
    other = "" if scales.robot_class == "service" else \
        " (or --priors class=service for a humanoid, a mobile manipulator or a low-cost arm)"
    return (f"priors too tight for this robot ({scales.robot_class} class): widening them to "
            f"{option.replace(',', ', ')} explains the data (evidence +{scales.asked_gain:.1f} nats, the "
            f"linearised fit's residual RMS {drop:.0%} lower); calibrate with --priors {option}{other}")
