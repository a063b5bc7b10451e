"""Tracker-to-base registration: the base frame and SMR offsets from measured points.

Model: a point of SMR s at pose i is ``p_i = B (R_i t_s + o_i)`` with ``(R_i, o_i)`` the nominal
flange pose in frame {0}, ``B`` the base frame (tracker -> frame {0}) and ``t_s`` the SMR offset in
flange coordinates. Rotations are never parameterised by Euler angles, so any tracker orientation
works:

1. alternate an Umeyama/Kabsch fit of ``B`` (SVD, no scaling) with a linear least-squares
   fit of every ``t_s`` (starting from the model's offsets, or zero);
2. finish with Gauss-Newton on (B translation, B rotation as a multiplicative rotation vector,
   all t_s) until the step is below 1e-13 m.

A robot whose joints all leave one flange axis pointing the same way (a SCARA) cannot show the
SMR offsets along that axis apart from the base frame's translation: that one freedom stays where
it started (`turns_about_one_axis`), as the calibration then reports for tool.z.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robocal.core.errors import DataError, IdentificationError, RobocalError
from robocal.kinematics.transforms import kabsch_rotation, make_transform, rotvec_to_matrix, skew

# Smallest singular value (relative to the largest) of the column-normalised registration Jacobian
# for which the poses still fix the frame and the SMR offsets (identical or collinear poses do not).
REGISTRATION_RCOND = 1e-6
# A flange axis whose world direction wobbles less than this (rad RMS over the joint range) counts as
# fixed: the SMR offsets along it then move the points apart from the frame's translation by under
# 1e-3 of the offsets' change (micrometres), below any tracker's noise -- the structure of a SCARA,
# calibrated (its axes microradians off parallel) or read from a file with rounded angles as well
FIXED_AXIS_RAD = 1e-3
_SPREAD_POSES = 8  # joint vectors spread over the limits on which the wobble is judged
REGISTRATION_DEGENERATE = "cannot fix the tracker frame and the SMR offsets"  # said when they cannot


@dataclass(frozen=True)
class Registration:
    """Result of :func:`register_frame`: ``base`` (4, 4) tracker -> frame {0}; ``offsets`` (k, 3) m,
    SMR s's offset on the flange (row 0: the tool); ``residuals`` (N, 3) m; ``rms`` m (3-D RMS);
    ``tool_rotation`` (3, 3) (pose data only, else None); ``iterations`` of Gauss-Newton."""

    base: np.ndarray
    offsets: np.ndarray
    residuals: np.ndarray
    rms: float
    tool_rotation: np.ndarray | None
    iterations: int


def umeyama(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Rigid transform (4, 4) minimising sum |dst - (R src + t)|^2 for points ``(N, 3)`` (SVD)."""
    w = np.full(len(src), 1.0 / len(src))
    cs, cd = w @ src, w @ dst
    H = (src - cs).T @ ((dst - cd) * w[:, None])
    R = kabsch_rotation(H)
    return make_transform(R, cd - R @ cs)


def rigid_fit_rms(points: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """RMS (m) left after the best rigid transform of each hypothesis' points ``(H, N, 3)`` onto
    ``measured`` ``(N, 3)`` (Kabsch, all hypotheses at once: :func:`umeyama`'s fit, batched, its
    residual in closed form): the cheap screen of many hypotheses (the diagnoses' flipped joints,
    turned mounts) before the full frame and SMR fit (:func:`refit_frame`) of the few best."""
    P = points - points.mean(axis=1, keepdims=True)
    Y = measured - measured.mean(axis=0)
    U, s, Vt = np.linalg.svd(np.einsum("hni,nj->hij", P, Y))
    s[:, -1] *= np.sign(np.linalg.det(U @ Vt))  # a rotation, not a reflection
    sse = np.sum(P**2, axis=(1, 2)) + np.sum(Y**2) - 2.0 * s.sum(axis=1)
    return np.sqrt(np.maximum(sse, 0.0) / len(measured))


def turns_about_one_axis(robot) -> bool:
    """Whether every joint of ``robot`` leaves one flange axis pointing the same way, within
    `FIXED_AXIS_RAD` (a SCARA: all its revolute axes parallel, or microradians off in a calibrated
    model): point data then cannot tell the SMR offsets along that axis from the base frame's
    translation (one freedom the registration leaves where it started)."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    phase = (np.arange(_SPREAD_POSES)[:, None] * 0.618 + np.arange(robot.n_joints) * 0.382) % 1.0
    R = replace(robot, base=np.eye(4), tool=np.eye(4), smr=np.zeros((0, 3)), nominal=None,
                joint_errors=None).fk(lo + (hi - lo) * phase)[:, :3, :3]
    D = R - R[0]
    # the least-moving flange direction v: sum_n |R_n v - R_0 v|^2, each term ~ its turn (rad) squared
    least = np.linalg.eigvalsh(np.einsum("nji,njk->ik", D, D))[0]
    return bool(np.sqrt(max(least, 0.0) / _SPREAD_POSES) <= FIXED_AXIS_RAD)


def smr_offsets_lsq(Rf: np.ndarray, of: np.ndarray, local: np.ndarray, smr: np.ndarray, k: int) -> np.ndarray:
    """Least-squares SMR offsets ``(k, 3)`` (m) on the last frame, given its rotations ``Rf (N, 3, 3)``
    and origins ``of (N, 3)`` and the measured points ``local (N, 3)`` in the same frame, row i on
    SMR ``smr[i]`` (0..k-1): ``local_i - o_i = R_i t_s`` -> ``t_s = mean_i R_i^T (local_i - o_i)``
    (exact least squares since every R_i is orthonormal)."""
    v = np.einsum("nji,nj->ni", Rf, local - of)
    sums = np.zeros((k, 3))
    np.add.at(sums, smr, v)
    return sums / np.bincount(smr, minlength=k)[:, None]


def _step(J: np.ndarray, r: np.ndarray, free: int) -> np.ndarray:
    """The Gauss-Newton step ``(p,)`` of residuals ``r (M,)`` on columns ``J (M, p)``, scaled to unit
    norm, without the ``free`` weakest directions (the structure's: a SCARA's height, its axes
    microradians off parallel, whose freedom then stays where it started instead of wandering
    metres to fit the noise) nor any below `REGISTRATION_RCOND` (the check after the loop names them)."""
    scale = np.maximum(np.linalg.norm(J, axis=0), 1e-300)
    U, s, Vt = np.linalg.svd(J / scale, full_matrices=False)
    keep = (np.arange(s.size) < s.size - free) & (s >= REGISTRATION_RCOND * s[0])
    return (Vt[keep].T @ ((U[:, keep].T @ r) / s[keep])) / scale


def register_frame(robot, data, *, alternations: int = 200, iterations: int = 30) -> Registration:
    """Fit the base frame and the SMR offsets of ``robot`` (its links, nominal or not) to point or
    pose measurements ``data`` (tracker frame). See the module docstring."""
    if not data.spec.sees_position:
        raise DataError(f"registration needs point or pose measurements, not {data.kind!r} (marker and "
                        "camera data fit their own frames whenever they are judged: no frame to register)")
    if data.n_joints != robot.n_joints:
        data.check_against(robot)
    smr = data.smr
    k = int(smr.max()) + 1
    missing = np.setdiff1d(np.arange(k), smr)
    if missing.size:
        raise DataError(f"SMR index(es) {missing.tolist()} have no measurement; renumber the SMRs 0..k-1")
    # the joints the robot really reached (a model with backlash or travel terms needs the
    # directions and moves of the measuring order, as calibration and evaluation judge it)
    flange = replace(robot, base=np.eye(4), tool=np.eye(4), smr=np.zeros((0, 3)), nominal=None).fk(
        data.joints, conditions=data.conditions)
    Rf, of = flange[:, :3, :3], flange[:, :3, 3]
    p = data.points
    start = np.vstack([robot.tool[:3, 3], robot.smr])
    t = np.zeros((k, 3))
    t[: min(k, len(start))] = start[: min(k, len(start))]
    # 1. alternation: Umeyama for B, linear least squares for the offsets
    B = umeyama(np.einsum("nij,nj->ni", Rf, t[smr]) + of, p)
    for _ in range(alternations):
        Binv_p = (p - B[:3, 3]) @ B[:3, :3]
        t_new = smr_offsets_lsq(Rf, of, Binv_p, smr, k)
        B = umeyama(np.einsum("nij,nj->ni", Rf, t_new[smr]) + of, p)
        step = np.abs(t_new - t).max()
        t = t_new
        if step < 1e-6:  # Gauss-Newton below polishes to machine precision
            break
    # 2. Gauss-Newton on (B translation, B rotation increment, offsets)
    free = 1 if turns_about_one_axis(robot) else 0  # the structural freedom (turns_about_one_axis)
    it = 0
    while it < iterations:
        it += 1
        local = np.einsum("nij,nj->ni", Rf, t[smr]) + of
        model = local @ B[:3, :3].T + B[:3, 3]
        r = (p - model).reshape(-1)
        J = np.zeros((len(p), 3, 6 + 3 * k))
        J[:, :, :3] = np.eye(3)
        J[:, :, 3:6] = -skew(model)
        RBRf = B[:3, :3] @ Rf
        for s in range(k):
            rows = smr == s
            J[rows, :, 6 + 3 * s : 9 + 3 * s] = RBRf[rows]
        dx = _step(J.reshape(-1, 6 + 3 * k), r, free)
        Rb = rotvec_to_matrix(dx[3:6])
        B = make_transform(Rb @ B[:3, :3], Rb @ B[:3, 3] + dx[:3])
        t = t + dx[6:].reshape(k, 3)
        if np.abs(dx).max() < 1e-13:
            break
    Jn = J.reshape(-1, 6 + 3 * k)
    sv = np.linalg.svd(Jn / np.maximum(np.linalg.norm(Jn, axis=0), 1e-300), compute_uv=False)
    if sv[-1 - free] < REGISTRATION_RCOND * sv[0]:
        raise IdentificationError(
            f"the pose set is degenerate: its {data.n_poses} poses {REGISTRATION_DEGENERATE} (they barely "
            "change the flange's orientation or position): measure poses spread "
            "over the workspace and over the wrist's orientations")
    local = np.einsum("nij,nj->ni", Rf, t[smr]) + of
    res = p - (local @ B[:3, :3].T + B[:3, 3])
    tool_R = None
    if data.spec.sees_orientation:
        # R_meas = R_B R_f R_tool  ->  R_tool = projection onto SO(3) of the mean of (R_B R_f)^T R_meas
        M = np.einsum("nji,njk->ik", B[:3, :3] @ Rf, data.rotations)
        U, _, Vt = np.linalg.svd(M)
        tool_R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    rms = float(np.sqrt(np.mean(np.sum(res**2, axis=1))))
    if not np.isfinite(rms):
        raise DataError("registration failed (non-finite residuals): check the data's units and joints")
    return Registration(base=B, offsets=t, residuals=res, rms=rms, tool_rotation=tool_R, iterations=it)


def register(robot, data, **kwargs):
    """A copy of ``robot`` with its base frame and tool/SMR offsets fitted to ``data``.

    The registration of a model to a tracker: the rigid transform from the tracker's frame to the
    robot's frame {0} and the reflector positions on the flange, fitted to the measurements with
    the model's links as they are (nominal or calibrated).

    Parameters
    ----------
    robot : Robot
        The model whose frames are fitted; its links are kept.
    data : Measurements
        Point or 6-DOF pose measurements in the tracker's frame.
    **kwargs
        ``alternations`` and ``iterations`` of the fit (see `register_frame`).

    Returns
    -------
    Robot
        The copy: its ``base`` is the fitted frame, SMR 0's offset is the tool translation (the
        tool keeps its rotation, or takes the fitted one from pose data), SMRs 1.. are ``smr``.

    Raises
    ------
    DataError
        The data are plane contacts or distances (no frame to fit), or an SMR index has no row.

    See Also
    --------
    rc.Measurements : The data registered.
    rc.evaluate : Evaluate a model on data (registering them first by default).
    rc.calibrate : Calibration, whose frames are registered the same way.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(robot, 30, seed=1)  # a robot with errors, seen from a tracker
    >>> fitted = rc.register(robot, sim.data)
    >>> errors = np.linalg.norm(fitted.fk(sim.data.joints)[:, :3, 3] - sim.data.points, axis=1)
    >>> bool(0.1e-3 < errors.mean() < 5e-3)  # the nominal links miss by about a millimetre
    True
    """
    return apply_registration(robot, register_frame(robot, data, **kwargs))


def apply_registration(robot, reg: Registration):
    """A copy of ``robot`` with the base frame and tool/SMR offsets of ``reg``."""
    rot = robot.tool[:3, :3] if reg.tool_rotation is None else reg.tool_rotation
    tool = make_transform(rot, reg.offsets[0])
    out = replace(robot, base=reg.base, tool=tool, smr=reg.offsets[1:].copy(), nominal=None)
    # nominal: the robot's nominal links with the registered frames (nominal + fitted base/SMR)
    nominal = out.nominal.copy()
    nominal[: 5 * robot.n_joints] = robot.nominal[: 5 * robot.n_joints]
    return replace(out, nominal=nominal)


def refit_frame(robot, data) -> Registration | None:
    """:func:`register_frame` of ``robot`` on ``data``, or None where it fails (poses that cannot
    fix the frame and the SMR offsets, a fit that breaks down numerically): the one refit the
    diagnoses and the held-out judgement test their hypotheses with."""
    try:
        return register_frame(robot, data)
    except (RobocalError, np.linalg.LinAlgError, FloatingPointError):
        return None
