"""The OPW form of a chain recognised from its geometry (not from a model file's ``opw:`` key).

An ortho-parallel arm with a spherical wrist (Brandstoetter et al. 2014, :mod:`robocal.kinematics.opw`)
is a 6R chain whose joint lines at zero joints satisfy, within tolerances scaled to the arm:

* axis 2 perpendicular to axis 1, axis 3 parallel to axis 2 (the arm plane is normal to them);
* axis 4 perpendicular to axes 2 and 3 (it lies in a plane normal to them);
* axes 4, 5 and 6 meet in one point (the wrist centre), axis 5 perpendicular to axes 4 and 6.

Then :func:`opw_model` derives the OPW set (the seven lengths, offsets and signs) from the lines --
whatever the chain was written in (MDH, DH, URDF, a cell's frames) -- and returns the same arm as
an OPW-form robot (``opw=`` the derived set, base and tool absorbing the placement), accepted only
when its forward kinematics equals the chain's within `ROUND_TRIP_REL` of the arm's size (m) and
`ROUND_TRIP_RAD`. With ``seed=True`` looser tolerances give the OPW arm nearest a chain a little off
the form (a calibrated arm, a URDF with rounded angles): its closed form seeds numeric IK.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from robocal.kinematics.convert import PARALLEL_TOL, opw_kwargs
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.opw import OPWParameters, opw_fk


class SerialArm(Protocol):
    """What this module reads of a robot: `robocal.kinematics.model.Robot`, which imports this
    module (its ``opw_model``), so it is not imported here (no import circle)."""

    name: str
    description: str
    base: np.ndarray  # (4, 4) m
    tool: np.ndarray  # (4, 4) m
    smr: np.ndarray
    limits: np.ndarray  # (n, 2) rad
    joint_errors: object
    n_joints: int
    has_prismatic: bool
    links: tuple

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Flange or tool poses (..., 4, 4) m at joint vectors ``q`` (..., n) rad."""

# The exact form: |cos| of axes that must be perpendicular, |sin| of axes that must be parallel
# (robocal.kinematics.convert.PARALLEL_TOL, the tolerance every chain reader decides parallel axes by),
# and the distance between wrist axes that must meet, relative to the arm's size (its lines' span)
LENGTH_REL = 1e-9
# The derived OPW model is the chain's arm when their poses agree this well (relative to the arm's
# size; rad): far below the closed form's own check (robocal.ik.opw_ik.TOL, 1e-9 m / rad)
ROUND_TRIP_REL = 1e-11
ROUND_TRIP_RAD = 1e-11
ROUND_TRIP_POSES = 64
# A chain this near the form (angles in rad, lengths relative to the arm) is seeded by the nearest OPW arm
SEED_AXIS_TOL = 0.05
SEED_LENGTH_REL = 0.01


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _lines(robot: SerialArm) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint axes (unit ``(6, 3)``), a point on each ``(6, 3)`` and the TCP ``(4, 4)`` at zero
    joints, world frame (m)."""
    q0 = np.zeros((1, robot.n_joints))
    tcp, frames = chain_frames(robot.links, robot.base, robot.tool, q0, frames=True)
    return frames[0, 1:, :3, 2], frames[0, 1:, :3, 3], tcp[0]


def _size(p: np.ndarray, tcp: np.ndarray) -> float:
    """The arm's size (m): the length of the polyline through its axis points and the TCP."""
    pts = np.vstack([p, tcp[:3, 3]])
    return max(float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()), 1e-3)


def _sign(value: float) -> float:
    return -1.0 if value < 0 else 1.0


def _derive(robot: SerialArm, axis_tol: float, length_rel: float) -> SerialArm | None:
    """The OPW-form robot of ``robot``'s lines within the tolerances, unchecked; None off the form."""
    u, p, tcp = _lines(robot)
    scale = _size(p, tcp)
    tol = length_rel * scale
    y_arm = u[1]
    if (abs(u[0] @ u[1]) > axis_tol or np.linalg.norm(np.cross(u[1], u[2])) > axis_tol
            or abs(u[3] @ y_arm) > axis_tol or abs(u[3] @ u[4]) > axis_tol or abs(u[4] @ u[5]) > axis_tol):
        return None
    # wrist centre: the feet of the common normal of axes 4 and 5 (perpendicular, so never parallel)
    w = np.cross(u[3], u[4])
    r = p[4] - p[3]
    f4 = p[3] + (np.cross(r, u[4]) @ w) / (w @ w) * u[3]
    f5 = p[4] + (np.cross(r, u[3]) @ w) / (w @ w) * u[4]
    C = 0.5 * (f4 + f5)
    off6 = C - p[5] - ((C - p[5]) @ u[5]) * u[5]
    if np.linalg.norm(f4 - f5) > tol or np.linalg.norm(off6) > tol:
        return None
    # the OPW base frame: z along axis 1 (upwards in the model's base frame), x normal to axis 2
    s1 = _sign(u[0] @ robot.base[:3, 2])
    z = s1 * u[0]
    O = p[0] + ((robot.base[:3, 3] - p[0]) @ u[0]) * u[0]
    x = _unit(np.cross(y_arm - (y_arm @ z) * z, z))
    x = x * _sign(x @ (p[1] - O) if abs(x @ (p[1] - O)) > tol else x @ (C - O))
    y = np.cross(z, x)
    R = np.column_stack([x, y, z])
    a1, _, c1 = R.T @ (p[1] - O)
    x3, _, z3 = R.T @ (p[2] - O)
    xc, b, zc = R.T @ (C - O)
    c2 = float(np.hypot(x3 - a1, z3 - c1))
    if c2 <= tol:
        return None
    t2 = np.arctan2(x3 - a1, z3 - c1)
    d4 = R.T @ u[3]
    s4 = _sign((xc - x3) * d4[0] + (zc - z3) * d4[2])
    t23 = np.arctan2(s4 * d4[0], s4 * d4[2])
    a2 = (xc - x3) * np.cos(t23) - (zc - z3) * np.sin(t23)
    c3 = (xc - x3) * np.sin(t23) + (zc - z3) * np.cos(t23)
    if np.hypot(a2, c3) <= tol:
        return None
    # the wrist's paper angles at zero joints: Rz(t4) Ry(t5) after the forearm frame (x3, y, z3)
    fx = np.array([np.cos(t23), 0.0, -np.sin(t23)])
    fz = np.array([np.sin(t23), 0.0, np.cos(t23)])
    v5 = R.T @ u[4]
    s5 = _sign(v5[1])
    v5 = s5 * v5
    t4 = np.arctan2(-(v5 @ fx), v5[1])
    x4 = np.cos(t4) * fx + np.sin(t4) * np.array([0.0, 1.0, 0.0])
    v6 = R.T @ u[5]
    s6 = _sign(v6 @ fz)
    v6 = s6 * v6
    t5 = np.arctan2(v6 @ x4, v6 @ fz)
    c4 = float((tcp[:3, 3] - C) @ (s6 * u[5]))
    signs = (s1, _sign(u[1] @ y), _sign(u[2] @ y), s4, s5, s6)
    offsets = -np.array([0.0, t2, t23 - t2, t4, t5, 0.0])
    offsets = np.remainder(offsets + np.pi, 2 * np.pi) - np.pi
    params = OPWParameters(float(a1), float(a2), float(b), float(c1), c2, float(c3), c4,
                           tuple(offsets), tuple(int(s) for s in signs))
    W = np.eye(4)
    W[:3, :3], W[:3, 3] = R, O
    Z = np.linalg.solve(W @ opw_fk(params, np.zeros((1, 6)))[0], tcp)
    Z[3] = (0.0, 0.0, 0.0, 1.0)
    return type(robot)(**opw_kwargs(params, base=W, tool=Z, limits=robot.limits, name=robot.name,
                                    description=robot.description, smr=robot.smr))


def round_trip_gap(robot: SerialArm, model: SerialArm) -> tuple[float, float]:
    """The largest position (m) and rotation-matrix (rad) gap between the two models' TCP poses at
    `ROUND_TRIP_POSES` fixed joint vectors over a full turn of each joint."""
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (ROUND_TRIP_POSES, 6))
    A, B = robot.fk(q), model.fk(q)
    return (float(np.abs(A[:, :3, 3] - B[:, :3, 3]).max()), float(np.abs(A[:, :3, :3] - B[:, :3, :3]).max()))


def opw_model(robot: SerialArm, seed: bool = False) -> SerialArm | None:
    """``robot``'s arm as an OPW-form robot (``opw`` set derived from its joint lines, base and tool
    placing it; same joints, same name and limits), or None when its chain is not of the OPW form.

    ``seed=False``: the form within `robocal.kinematics.convert.PARALLEL_TOL` / `LENGTH_REL` and
    forward kinematics equal within `ROUND_TRIP_REL` x the arm's size (m) / `ROUND_TRIP_RAD` -- the
    closed form is then the chain's own. ``seed=True``: the nearest OPW arm of a chain within
    `SEED_AXIS_TOL` / `SEED_LENGTH_REL` of the form (not the chain's arm; its closed form seeds
    numeric IK).
    A 6R chain without joint-error terms only."""
    if robot.n_joints != 6 or robot.has_prismatic or robot.joint_errors is not None:
        return None
    model = _derive(robot, *((SEED_AXIS_TOL, SEED_LENGTH_REL) if seed else (PARALLEL_TOL, LENGTH_REL)))
    if model is None or seed:
        return model
    dp, dr = round_trip_gap(robot, model)
    return model if dp <= ROUND_TRIP_REL * _size(*_lines(robot)[1:]) and dr <= ROUND_TRIP_RAD else None
