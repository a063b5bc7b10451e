"""URDF export and import of serial robots (revolute and prismatic joints).

Export (:func:`to_urdf`): ``world`` -> fixed joint ``base_joint`` (the model's base frame) ->
``base_link`` (frame {0}) -> revolute ``joint_i`` -> ``link_i`` (frame {i}) -> fixed
``tool_joint`` (the tool frame) -> ``tool0``. With ``frames="robot"`` (what a ROS user drops in,
as ROS-Industrial's URDFs): the root is ``base_link`` at the robot's base (frame {0}) and ``tool0``
is the flange; the model's base frame (after a tracker calibration: the tracker's frame) and tool
(the measured SMR or probe) are given in comments only. Joint i's origin is Rx(alpha_i) Tx(a_i) Ry(beta_i)
Rz(theta_i) Tz(d_i) (Rz(q) and Tz(d) commute) and its axis is z, so URDF forward kinematics is
exactly the model's; a prismatic joint is a URDF ``prismatic`` joint along z (Tz(q) after Tz(d)),
its limits in m. Floats are written with ``repr`` (shortest exact round trip).

Import (:func:`from_urdf`): the joints' lines at the zero configuration converted to MDH + beta,
by `robocal.kinematics.urdf_read` (which the model's loader uses too: `load_model` reads a URDF).
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.escape import xml_comment_text, xml_text
from robocal.core.io import write_atomic
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z
from robocal.kinematics.urdf_read import matrix_to_rpy, urdf_kwargs

_ZERO = 1e-12


def _fmt(values) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def _origin(T: np.ndarray) -> str:
    return f'<origin xyz="{_fmt(T[:3, 3])}" rpy="{_fmt(matrix_to_rpy(T[:3, :3]))}"/>'


def _attr(text: str) -> str:
    return xml_text(text)


# ----------------------------------------------------------------- export
def not_carried(robot: Robot) -> str | None:
    """What a URDF cannot hold of ``robot`` (its joint-error terms and extra SMRs), as a sentence;
    None when it holds everything."""
    parts = []
    if robot.joint_errors is not None:
        parts.append(f"the non-geometric joint-error terms {', '.join(robot.joint_errors.names)} "
                     "(a URDF has rigid links and exact joints)")
    if len(robot.smr):
        parts.append(f"the {len(robot.smr)} extra SMR offset(s)")
    if not parts:
        return None
    return ("the URDF carries the geometry only, not " + " nor ".join(parts)
            + ": its forward kinematics is the model's without them")


def _comment(text: str) -> str:
    return f"<!-- {xml_comment_text(text)} -->"


def _frames_comment(robot: Robot, base: np.ndarray, flange: np.ndarray) -> str:
    """Where the model's world frame and tool are relative to base_link and tool0 (mm, deg), with
    ``base`` frame {0} in base_link and ``flange`` tool0 in frame {n}."""
    def pose(T):
        return (f"xyz {' '.join(f'{v:.4f}' for v in T[:3, 3] * 1e3)} mm, rpy "
                f"{' '.join(f'{v:.6f}' for v in np.rad2deg(matrix_to_rpy(T[:3, :3])))} deg")

    base_in_link = base @ np.linalg.inv(robot.base)
    return (f"base_link is the robot's base (the model's frame {{0}}) and tool0 its flange. The model's "
            f"world frame (e.g. the laser tracker's, where it was measured) is at {pose(base_in_link)} in "
            f"base_link; its tool (e.g. the measured SMR or probe) is at "
            f"{pose(np.linalg.inv(flange) @ robot.tool)} in tool0"
            + "".join(f"; SMR {k + 1} at xyz {' '.join(f'{v:.4f}' for v in s * 1e3)} mm in frame {{n}}"
                      for k, s in enumerate(robot.smr)))


def to_urdf(robot: Robot, name: str | None = None, frames: str = "model",
            nominal: Robot | None = None) -> str:
    """URDF text of ``robot`` (lengths m, angles rad); joint limits are the model's.

    ``frames="model"``: ``world`` -> ``tool0`` forward kinematics equals ``robot.fk`` without what
    :func:`not_carried` names (world: the model's world frame, tool0: its tool). ``"robot"``: the
    root is ``base_link``, the robot's base, and ``tool0`` is the flange (what ROS expects): as in
    ``nominal`` (the controller's model: its base and tool frames; default: base_link at frame {0},
    tool0 with the model's tool rotation at the flange's centre); the model's world frame and tool
    are written in a comment."""
    if frames not in ("model", "robot"):
        raise ModelError(f"frames must be 'model' or 'robot', got {frames!r}")
    name = robot.name if name is None else name
    missing = not_carried(robot)
    lines = ['<?xml version="1.0"?>',
             _comment(f"written by robocal from model {robot.name}: frames are the model's MDH+beta frames; "
                      "effort and velocity limits are not part of a kinematic model (0 here), set them "
                      "for your robot"),
             *([] if missing is None else [_comment(f"NOTE: {missing}")])]
    if frames == "robot":
        base = np.eye(4) if nominal is None else nominal.base
        flange = make_transform(robot.tool[:3, :3], np.zeros(3)) if nominal is None else nominal.tool
        lines += [_comment(_frames_comment(robot, base, flange)), f'<robot name="{_attr(name)}">',
                  '  <link name="base_link"/>']
        if not np.allclose(base, np.eye(4), rtol=0, atol=_ZERO):  # frame {0} off the robot's base
            lines += ['  <joint name="base_joint" type="fixed">', '    <parent link="base_link"/>',
                      '    <child link="link_0"/>', f"    {_origin(base)}", "  </joint>",
                      '  <link name="link_0"/>']
        robot = robot.with_frames(base=base, tool=flange)
    else:
        lines += [f'<robot name="{_attr(name)}">', '  <link name="world"/>',
                  '  <joint name="base_joint" type="fixed">', '    <parent link="world"/>',
                  '    <child link="base_link"/>', f"    {_origin(robot.base)}", "  </joint>",
                  '  <link name="base_link"/>']
    parent = "link_0" if lines[-1] == '  <link name="link_0"/>' else "base_link"
    for i in range(robot.n_joints):
        R = rot_x(robot.alpha[i]) @ rot_y(robot.beta[i]) @ rot_z(robot.theta[i])
        t = rot_x(robot.alpha[i]) @ np.array([robot.a[i], 0.0, 0.0]) + R @ np.array([0, 0, robot.d[i]])
        lo, hi = robot.limits[i]
        child = f"link_{i + 1}"
        kind = "prismatic" if robot.prismatic[i] else "revolute"
        lines += [f'  <joint name="joint_{i + 1}" type="{kind}">', f'    <parent link="{parent}"/>',
                  f'    <child link="{child}"/>', f"    {_origin(make_transform(R, t))}",
                  '    <axis xyz="0 0 1"/>',
                  f'    <limit lower="{float(lo)!r}" upper="{float(hi)!r}" effort="0" velocity="0"/>',
                  "  </joint>", f'  <link name="{child}"/>']
        parent = child
    lines += ['  <joint name="tool_joint" type="fixed">', f'    <parent link="{parent}"/>',
              '    <child link="tool0"/>', f"    {_origin(robot.tool)}", "  </joint>",
              '  <link name="tool0"/>', "</robot>", ""]
    return "\n".join(lines)


def write_urdf(robot: Robot, path, name: str | None = None, frames: str = "model") -> None:
    """Write :func:`to_urdf` to ``path`` atomically."""
    write_atomic(path, to_urdf(robot, name, frames))


# ----------------------------------------------------------------- import


def from_urdf(source, tip: str | None = None, name: str | None = None,
              parallel_tol_deg: float = 5.0) -> Robot:
    """A :class:`Robot` from a serial URDF (`robocal.kinematics.urdf_read.urdf_kwargs`: its arguments
    and their meaning)."""
    return Robot(**urdf_kwargs(source, tip, name, parallel_tol_deg))
