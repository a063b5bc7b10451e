"""A robot on a linear track (a 7th axis): the cell file and the chain it stands for.

The cell file is a model file next to a robot (docs/model-yaml.md)::

    units: {length: mm, angle: deg}
    name: kr210 on a 6 m track
    robot: kuka_kr210_r2700            # a catalog name or a model file (relative to this file)
    track: {direction: [1, 0, 0], limits: [0, 6000]}   # unit vector in the world frame; e1 range
    mount: {xyz: [0, 0, 0], rpy: [0, 0, 0]}            # carriage at e1 = 0 -> robot base

Its forward kinematics is ``world_T_tcp = [I, direction * e1] @ mount @ robot_fk(q)`` (robot_fk
with the robot's own base and tool frames). The cell is a chain like any other
(:class:`robocal.kinematics.model.Robot`, joints ``(e1, q1..q6)``): joint 1 is prismatic along
the track, so forward kinematics, the identification Jacobian, calibration and the files come
for free. The chain is built exactly:

- frame {0} (the model's base frame) has z along the track and its origin where the track line
  through the arm's first joint frame meets it (where a translation's line lies is free);
- link 1 is the prismatic joint with every constant zero (its d is the track's zero);
- link 2 is the arm's first joint re-expressed from frame {1}: alpha the angle from the track to
  the joint-1 axis about their common normal, theta the turn that puts the arm's frame {1} back,
  d the arm's own d1; links 3..7 are the arm's links 2..6 unchanged, and the tool is the arm's;
- a ``scale1`` joint-error term (the track encoder's scale, nominally 0) is declared.

Identifiability: the cell file's ``direction`` and ``mount`` rotation describe overlapping freedom
(turning the track direction and counter-turning the mount leaves the arm where it was), so a
calibration identifies the chain's parameters instead: the base frame (the track's direction and
position in the tracker frame), the track scale ``scale1``, and the mount as the arm's first
link seen from the carriage (``alpha2``, ``a2``, ``theta2``, ``d2``); ``theta1`` and ``d1`` (a turn
of the carriage frame about the track and a shift along it) are confounded with the base frame
and dropped, which the result reports. The calibrated cell is written as that chain (a model file
with ``type: prismatic`` on joint 1), which every command reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.errors import ModelError
from robocal.io import LENGTH_UNITS, short_repr
from robocal.kinematics.convert import PARALLEL_TOL, default_parallel
from robocal.kinematics.joint_errors import JointErrorModel
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.model_file import MAX_DESCRIPTION, MAX_NAME, _frame, _mapping, _numbers, _text, _units
from robocal.kinematics.transforms import make_transform

CELL_KEYS = {"format", "name", "description", "units", "robot", "track", "mount"}
DIRECTION_TOL = 1e-6  # |norm - 1| of the track direction: a unit vector written to 6 digits
TRACK_SCALE = "scale1"  # the track encoder's scale error (a joint-error term of joint 1)


def _rx(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def _ry(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def track_chain(arm: Robot, direction, mount: np.ndarray, limits, name: str | None = None,
                description: str = "") -> Robot:
    """The cell chain (module docstring) of ``arm`` (6 revolute joints, no joint-error terms) on a
    track along unit ``direction`` (world frame) with ``mount`` ``(4, 4)`` (carriage at e1 = 0 ->
    robot base, m) and e1 ``limits`` (lower, upper) in m."""
    if arm.has_prismatic or arm.joint_errors is not None:
        raise ModelError(f"{arm.name}: a robot on a track must be a revolute arm without joint-error "
                         "terms (give its geometry; the cell declares the track's own terms)")
    chain = _chain_arrays(arm, direction, mount)
    nominal = _chain_arrays(arm.nominal_robot(), direction, mount)
    kinds = np.r_[True, np.zeros(arm.n_joints, bool)]  # the track, then the arm's revolute joints
    nominal_robot = Robot(**nominal, prismatic=kinds)
    limits = np.vstack([np.asarray(limits, float).reshape(1, 2), arm.limits])
    return Robot(**chain, limits=limits, prismatic=kinds,
                 nominal=nominal_robot.nominal, opw=arm.opw,
                 name=arm.name if name is None else name, description=description,
                 joint_errors=JointErrorModel((TRACK_SCALE,), np.zeros(1)))


def _chain_arrays(arm: Robot, direction, mount: np.ndarray) -> dict:
    """Links, base, tool, parallel flags and SMR offsets of the chain (module docstring)."""
    u = np.asarray(direction, float)
    P = np.asarray(mount, float) @ arm.base
    G = P.copy()  # the arm's joint-1 frame before its joint: Rx(alpha1) Tx(a1) Ry(beta1) Rz(theta1)
    G[:3, 3] += arm.a[0] * P[:3, 0]
    G[:3, :3] = P[:3, :3] @ _rx(arm.alpha[0]) @ _ry(arm.beta[0]) @ _rz(arm.theta[0])
    gz = G[:3, 2]
    normal = np.cross(u, gz)
    if np.linalg.norm(normal) > PARALLEL_TOL:
        x1 = normal / np.linalg.norm(normal)
    else:  # the track is parallel to joint 1 (a lift): any normal; the arm's x keeps theta small
        x1 = G[:3, 0] - (G[:3, 0] @ u) * u
        x1 /= np.linalg.norm(x1)
    F1 = make_transform(np.column_stack([x1, np.cross(u, x1), u]), G[:3, 3])
    alpha2 = float(np.arctan2(np.cross(u, gz) @ x1, u @ gz))
    R = F1[:3, :3] @ _rx(alpha2)
    theta2 = float(np.arctan2(np.cross(R[:, 0], G[:3, 0]) @ gz, R[:, 0] @ G[:3, 0]))
    links = {"alpha": np.r_[0.0, alpha2, arm.alpha[1:]], "a": np.r_[0.0, 0.0, arm.a[1:]],
             "beta": np.r_[0.0, 0.0, arm.beta[1:]], "theta": np.r_[0.0, theta2, arm.theta[1:]],
             "d": np.r_[0.0, arm.d[0], arm.d[1:]]}
    parallel = np.r_[False, default_parallel([0.0, alpha2])[1], arm.parallel[1:]]
    return {**links, "base": F1, "tool": arm.tool, "parallel": parallel, "smr": arm.smr}


def _rz(t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def cell_from_data(data: dict, path: Path | None = None) -> Robot:
    """The chain of a cell mapping (the module docstring's file); ``robot:`` is a catalog name or
    a model file relative to ``path``'s folder. ModelError names the key."""
    _mapping(data, "the cell", CELL_KEYS, {"units", "robot", "track"})
    length_unit, angle_unit = _units(data)
    length = LENGTH_UNITS[length_unit]
    angle = np.pi / 180.0 if angle_unit == "deg" else 1.0
    spec = data["robot"]
    if not isinstance(spec, str) or not spec.strip():
        raise ModelError(f"robot: expected a catalog name or a model file, got {short_repr(spec)}")
    local = (path.parent if path is not None else Path(".")) / spec
    arm = load_model(str(local) if local.suffix or local.exists() else spec)
    track = _mapping(data["track"], "track", {"direction", "limits"}, {"direction", "limits"})
    direction = _numbers(track["direction"], "track.direction", 3)
    if abs(np.linalg.norm(direction) - 1.0) > DIRECTION_TOL:
        raise ModelError(f"track.direction {direction.tolist()} is not a unit vector (norm "
                         f"{np.linalg.norm(direction):.6g}): give the track's direction in the world frame "
                         "with norm 1")
    limits = _numbers(track["limits"], "track.limits", 2) * length
    if not limits[0] < limits[1]:
        raise ModelError(f"track.limits: lower {limits[0]:g} m is not below upper {limits[1]:g} m")
    mount = _frame(data.get("mount", {}), length, angle, "mount")
    return track_chain(arm, direction / np.linalg.norm(direction), mount, limits,
                       name=_text(data.get("name", f"{arm.name} on a track"), "name", MAX_NAME),
                       description=_text(data.get("description", ""), "description", MAX_DESCRIPTION))

