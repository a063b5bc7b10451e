"""A robot on a linear track seen as an arm on a carriage: which chains are cells, where the
carriage puts the arm, the arm alone (the cell file and its chain: `robocal.kinematics.cell_file`)."""

from __future__ import annotations

import numpy as np

from robocal.core.errors import ModelError
from robocal.kinematics.cell_file import TRACK_SCALE
from robocal.kinematics.convert import opw_chain
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z

# What a calibration of a cell reports about the track's direction and the mount (cell_file's docstring).
TRACK_IDENTIFIABILITY = (
    "track: its direction and the mount's rotation describe one freedom (only their relation to the "
    "arm is identifiable): the track axis is the base frame's z (base.*), the arm's first axis seen "
    "from the carriage is alpha2/theta2, the encoder scale is scale1; where the carriage frame sits on "
    "the track (theta1, d1, a2, d2) is the base frame's own freedom")
# The same freedoms for any other prismatic joint 1 (a lift, a gantry axis: no cell file declares a track)
PRISMATIC_FIRST_IDENTIFIABILITY = (
    "prismatic joint 1 (a track, a lift, a gantry axis): its direction is the base frame's z (base.*), "
    "the next joint's axis seen from what it carries is alpha2/theta2{scale}; where that frame sits "
    "along the axis (theta1, d1, a2, d2) is the base frame's own freedom")


def declares_track(robot: Robot) -> bool:
    """Whether ``robot`` is a track cell as a cell file builds it (:func:`is_track_cell` with the
    track encoder's scale term ``scale1`` declared), not any chain whose joint 1 slides."""
    return is_track_cell(robot) and TRACK_SCALE in robot.joint_error_names


def first_joint_identifiability(robot: Robot) -> str | None:
    """What a calibration of a robot whose joint 1 is prismatic (``robot``: the model it started
    from) identifies of that axis, in words: the track's sentence for a declared track
    (:func:`declares_track`), the general one for a lift or a gantry axis; None otherwise."""
    if declares_track(robot):
        return TRACK_IDENTIFIABILITY
    if not robot.prismatic[0]:
        return None
    return PRISMATIC_FIRST_IDENTIFIABILITY.format(
        scale=", its encoder scale scale1" if TRACK_SCALE in robot.joint_error_names else "")


def is_track_cell(robot: Robot) -> bool:
    """Whether ``robot`` is an arm on a track: a prismatic joint 1 carrying revolute joints 2..n."""
    return robot.external_axes == 1


def _check_cell(robot: Robot) -> None:
    if not is_track_cell(robot):
        raise ModelError(f"{robot.name} is not an arm on a track (joint 1 prismatic, the others revolute)")


def _link_fixed(alpha: float, a: float, beta: float, theta: float) -> np.ndarray:
    """Rx(alpha) Tx(a) Ry(beta) Rz(theta): the constant part of a link before its joint."""
    return make_transform(rot_x(alpha) @ rot_y(beta) @ rot_z(theta), rot_x(alpha) @ np.array([a, 0.0, 0.0]))


def _arm_link1(robot: Robot) -> tuple[float, float, float, float]:
    """The arm's own link 1 constants (alpha, a, beta, theta): its OPW form's (so that the arm model
    keeps its closed form), else those of a link that starts on joint 1's axis (0, 0, 0, the chain's
    link-2 theta)."""
    if robot.opw is not None:
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
