"""Which parameters no pose set can identify: the rank test on poses spread over the joint limits.

The rank test of a calibration or an analysis drops the parameters whose effect on *these* poses is
exactly that of others. Some are confounded on every pose set (d1 beside the base height, d3 beside
d2 of two parallel axes, theta6 beside the tool: the model has more parameters than effects); others
only on these poses (a joint that never moved, poses that all share one arm posture), and other
poses would determine them. :func:`unidentifiable` repeats the rank test on
:data:`GENERIC_POSES` poses drawn uniformly within the joint limits (seeded), the same SMRs and the
same kind of measurement (on the chain's `structural_form`: a SCARA a little off parallel is judged
as the SCARA it is), and :func:`separate` moves a robot parameter dropped on the data but
identifiable there from ``dropped`` to ``undetermined`` (not determined by these data,
:mod:`robocal.identify.vocabulary`). Joint-error terms are not judged here (their effect needs the
rows' conditions and approach directions), nor plane or other kinds (the fixture decides what a
pose can see): their rank-dropped parameters stay not identifiable. Distances are judged on
consecutive generic poses taken as pairs (a bar can be put anywhere).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.data.kinds import OBSERVED
from robocal.data.measurements import Measurements
from robocal.data.registration import turns_about_one_axis
from robocal.identify.freedoms import structural_freedoms
from robocal.identify.identifiability import DEFAULT_RTOL, Identifiability, analyze
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import block_of

GENERIC_POSES = 60  # poses spread over the joint limits: beyond the parameters of any arm robocal models
GENERIC_SEED = 0
JUDGED_BLOCKS = ("links", "base", "tool", "smr")


def structural_form(robot):
    """The chain whose structure ``robot`` has, for the rank tests: a SCARA whose axes are within
    `robocal.data.registration.FIXED_AXIS_RAD` of parallel (a calibrated one, a file with rounded
    angles) with its axes 2.. made exactly parallel to axis 1 (alpha on 0 or pi, beta 0), so the
    freedoms of its structure are held as a SCARA's instead of estimated from microradian tilts;
    any other robot itself."""
    if robot.n_joints < 2 or not turns_about_one_axis(robot):
        return robot
    known = set(robot.parameter_names)
    later = range(2, robot.n_joints + 1)
    snapped = {f"alpha{i}": float(np.round(robot.alpha[i - 1] / np.pi) * np.pi) for i in later}
    snapped.update({f"beta{i}": 0.0 for i in later})
    snapped = {k: v for k, v in snapped.items() if k in known and robot.get(k) != v}
    return robot.with_values(snapped) if snapped else robot


def unidentifiable(robot, kind: str, names: list[str], n_smr: int = 1,
                   rtol: float = DEFAULT_RTOL) -> set[str]:
    """Of the parameters ``names``: those the rank test drops on generic poses (module docstring)
    of ``robot`` measured as ``kind`` with SMRs 0..``n_smr``-1, plus every one this test does not
    judge (another kind, a joint-error term or a nuisance parameter)."""
    judged = [nm for nm in names if block_of(nm) in JUDGED_BLOCKS]
    unjudged = set(names) - set(judged)
    spec = OBSERVED.get(kind)  # None: several kinds ("mixed")
    pairs = spec is not None and spec.group == "pair"  # distances: consecutive generic poses pair up
    if spec is None or not (spec.sees_position or pairs) or not judged:
        return set(names)
    robot = structural_form(robot)
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    q = np.random.default_rng(GENERIC_SEED).uniform(lo, hi, (GENERIC_POSES, robot.n_joints))
    smr = np.repeat(np.arange(n_smr), GENERIC_POSES)
    q = np.tile(q, (n_smr, 1))
    T = robot.fk(q, smr=smr)
    if pairs:
        p = T[:, :3, 3].reshape(-1, 2, 3)
        readings = {"pair": np.arange(len(q)) // 2,
                    "distance": np.repeat(np.linalg.norm(p[:, 0] - p[:, 1], axis=1), 2)}
    else:
        readings = spec.readings(T)
    data = Measurements.from_arrays(kind, q, smr=smr, pose_id=np.tile(np.arange(GENERIC_POSES), n_smr),
                                    **readings)
    problem = CalibrationProblem(robot, data)
    space = problem.space(robot, judged)
    J = problem.jacobian(problem.start(robot), space)
    dropped = set(analyze(J, space.names, GENERIC_POSES, rtol).dropped)
    return unjudged | (dropped & set(judged))


def separate(ident: Identifiability, structural: set[str], robot=None) -> Identifiability:
    """``ident`` with each dropped parameter not in ``structural`` (identifiable on other poses)
    moved to ``undetermined`` with a posterior / prior sigma ratio of 1 (the data say nothing of it
    beyond what its confounders take: it keeps its prior). With ``robot``, a SCARA's held
    parameters are named by their structural freedom (:mod:`robocal.identify.freedoms`)."""
    moved = [nm for nm in ident.dropped if nm not in structural]
    dropped = [nm for nm in ident.dropped if nm in structural]
    freedoms = [] if robot is None else structural_freedoms(robot, dropped, ident.kept)
    if not moved:
        return replace(ident, freedoms=freedoms)
    return replace(ident, dropped=dropped, undetermined=ident.undetermined + moved, freedoms=freedoms,
                   prior_ratio={**ident.prior_ratio, **dict.fromkeys(moved, 1.0)})
