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
axis seen from the carriage (``alpha2``, ``theta2``); ``theta1``, ``d1``, ``a2`` and ``d2`` (where the
carriage frame sits on the track) are confounded with the base frame and dropped, which the result
reports. The calibrated cell is written as that chain (a model file
with ``type: prismatic`` on joint 1), which every command reads.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, short_repr
from robocal.kinematics.convert import PARALLEL_TOL, default_parallel
from robocal.kinematics.joint_errors import JointErrorModel
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.model_file import MAX_DESCRIPTION, MAX_NAME, _frame, _mapping, _numbers, _text, _units
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z

CELL_KEYS = {"format", "name", "description", "units", "robot", "track", "mount"}
# What a calibration of a cell reports about the track's direction and the mount (module docstring).
TRACK_IDENTIFIABILITY = (
    "track: its direction and the mount's rotation describe one freedom (only their relation to the "
    "arm is identifiable): the track axis is the base frame's z (base.*), the arm's first axis seen "
    "from the carriage is alpha2/theta2, the encoder scale is scale1; where the carriage frame sits on "
    "the track (theta1, d1, a2, d2) is the base frame's own freedom")
DIRECTION_TOL = 1e-6  # |norm - 1| of the track direction: a unit vector written to 6 digits
TRACK_SCALE = "scale1"  # the track encoder's scale error (a joint-error term of joint 1)


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
    G[:3, :3] = P[:3, :3] @ rot_x(arm.alpha[0]) @ rot_y(arm.beta[0]) @ rot_z(arm.theta[0])
    gz = G[:3, 2]
    normal = np.cross(u, gz)
    if np.linalg.norm(normal) > PARALLEL_TOL:
        x1 = normal / np.linalg.norm(normal)
    else:  # the track is parallel to joint 1 (a lift): any normal; the arm's x keeps theta small
        x1 = G[:3, 0] - (G[:3, 0] @ u) * u
        x1 /= np.linalg.norm(x1)
    F1 = make_transform(np.column_stack([x1, np.cross(u, x1), u]), G[:3, 3])
    alpha2 = float(np.arctan2(np.cross(u, gz) @ x1, u @ gz))
    R = F1[:3, :3] @ rot_x(alpha2)
    theta2 = float(np.arctan2(np.cross(R[:, 0], G[:3, 0]) @ gz, R[:, 0] @ G[:3, 0]))
    links = {"alpha": np.r_[0.0, alpha2, arm.alpha[1:]], "a": np.r_[0.0, 0.0, arm.a[1:]],
             "beta": np.r_[0.0, 0.0, arm.beta[1:]], "theta": np.r_[0.0, theta2, arm.theta[1:]],
             "d": np.r_[0.0, arm.d[0], arm.d[1:]]}
    parallel = np.r_[False, default_parallel([0.0, alpha2])[1], arm.parallel[1:]]
    return {**links, "base": F1, "tool": arm.tool, "parallel": parallel, "smr": arm.smr}


def cell_from_data(data: dict, path: Path | None = None) -> Robot:
    """The chain of a cell mapping (the module docstring's file); ``robot:`` is a catalog name or
    a model file relative to ``path``'s folder. ModelError names the key."""
    _mapping(data, "the cell", CELL_KEYS, {"units", "robot", "track"})
    length_unit, angle_unit = _units(data)
    length = LENGTH_UNITS[length_unit]
    angle = ANGLE_UNITS[angle_unit]
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


def is_track_cell(robot: Robot) -> bool:
    """Whether ``robot`` is an arm on a track: a prismatic joint 1 carrying revolute joints 2..n."""
    return robot.n_joints >= 2 and bool(robot.prismatic[0]) and not robot.prismatic[1:].any()


def _check_cell(robot: Robot) -> None:
    if not is_track_cell(robot):
        raise ModelError(f"{robot.name} is not an arm on a track (joint 1 prismatic, the others revolute)")


def track_scale(robot: Robot) -> float:
    """The track encoder's scale error ``scale1`` of a cell (0 when not declared)."""
    names = robot.joint_error_names
    return float(robot.joint_errors.values[names.index(TRACK_SCALE)]) if TRACK_SCALE in names else 0.0


def _link_fixed(alpha: float, a: float, beta: float, theta: float) -> np.ndarray:
    """Rx(alpha) Tx(a) Ry(beta) Rz(theta): the constant part of a link before its joint."""
    return make_transform(rot_x(alpha) @ rot_y(beta) @ rot_z(theta), rot_x(alpha) @ np.array([a, 0.0, 0.0]))


def _arm_link1(robot: Robot) -> tuple[float, float, float, float]:
    """The arm's own link 1 constants (alpha, a, beta, theta): its OPW form's (so that the arm model
    keeps its closed form), else those of a link that starts on joint 1's axis (0, 0, 0, the chain's
    link-2 theta)."""
    if robot.opw is not None:
        from robocal.kinematics.convert import opw_chain

        chain = opw_chain(robot.opw)
        return tuple(float(chain[f][0]) for f in ("alpha", "a", "beta", "theta"))
    return 0.0, 0.0, 0.0, float(robot.theta[1])


def carriage_frames(robot: Robot, e1) -> np.ndarray:
    """World poses ``(N, 4, 4)`` of the arm's base (the frame :func:`arm_model` is built on) with the
    carriage at ``e1`` ``(N,)`` m (the track's scale error applied, as the cell's forward kinematics
    does)."""
    _check_cell(robot)
    e1 = np.atleast_1d(np.asarray(e1, float))
    q = np.zeros((e1.size, robot.n_joints))
    q[:, 0] = e1
    frames = robot.fk(q, frames=True)[1]  # frames {0}..{n}; {1} is the carriage
    chain_link = _link_fixed(robot.alpha[1], robot.a[1], robot.beta[1], robot.theta[1])
    return frames[:, 1] @ chain_link @ np.linalg.inv(_link_fixed(*_arm_link1(robot)))


def arm_model(robot: Robot) -> Robot:
    """The arm of a track cell as a 6-joint robot whose base frame is the identity: placed at
    :func:`carriage_frames` it is the cell with the carriage at that e1 (its tool, SMRs and the
    cell's OPW form kept; a nominal catalog arm keeps its closed-form IK)."""
    _check_cell(robot)
    links = {f: np.array(getattr(robot, f)[1:]) for f in ("alpha", "a", "beta", "theta", "d")}
    for f, v in zip(("alpha", "a", "beta", "theta"), _arm_link1(robot), strict=True):
        links[f][0] = v
    return Robot(**links, base=np.eye(4), tool=robot.tool, limits=robot.limits[1:],
                 parallel=np.r_[False, robot.parallel[2:]], smr=robot.smr, opw=robot.opw,
                 name=f"{robot.name} (arm)", description=robot.description)
