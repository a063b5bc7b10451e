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

Import (:func:`from_urdf`): the joints' lines at the zero configuration (point and direction in
the root frame) are converted to MDH + beta: consecutive axes that are not (nearly) parallel get
the common normal (alpha, a, beta = 0); nearly parallel ones get Hayati's construction (x along
the perpendicular to the next axis in the plane normal to the current one; beta non-zero). The
root-to-frame-{0} transform becomes the base frame and the flange-to-tip transform the tool.
A prismatic joint (a mobile manipulator's torso lift, a gantry's axes, a linear track) slides along
its axis: where its line lies is free (a translation moves every point alike), so the same
construction places it, and the joint is flagged prismatic (its value, m, adds to its d).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import read_text, write_atomic
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z

_ZERO = 1e-12
MAX_OFFSET_M = 100.0  # a joint origin farther than this from its parent is no robot's (URDF is in m)
MAX_ANGLE_RAD = 100.0  # origin angles and joint limits beyond (16 turns) are a unit or typing error
_MAX_AXIS = 1e6  # an axis vector is normalised; components beyond are refused


def rpy_to_matrix(rpy) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes X, Y, Z; rad) -> rotation ``Rz(y) Ry(p) Rx(r)``."""
    r, p, y = (float(v) for v in rpy)
    return rot_z(y) @ rot_y(p) @ rot_x(r)


def matrix_to_rpy(R: np.ndarray) -> np.ndarray:
    """Rotation -> URDF (roll, pitch, yaw) in rad; stable at pitch = +-pi/2 (roll set to 0)."""
    pitch = np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0]))
    if np.hypot(R[0, 0], R[1, 0]) < 1e-10:
        return np.array([0.0, pitch, np.arctan2(-R[0, 1], R[1, 1])])
    return np.array([np.arctan2(R[2, 1], R[2, 2]), pitch, np.arctan2(R[1, 0], R[0, 0])])


def _fmt(values) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def _origin(T: np.ndarray) -> str:
    return f'<origin xyz="{_fmt(T[:3, 3])}" rpy="{_fmt(matrix_to_rpy(T[:3, :3]))}"/>'


def _attr(text: str) -> str:
    return (text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
            .replace(">", "&gt;"))


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
    return f"<!-- {_attr(text).replace('-', '&#45;')} -->"


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
def _parse(source) -> ET.Element:
    if isinstance(source, Path) or (isinstance(source, str) and "<" not in source):
        text = read_text(source, "URDF file", ModelError)
    else:
        text = source.decode("utf-8") if isinstance(source, bytes) else str(source)
    upper = text.upper()
    if "<!DOCTYPE" in upper or "<!ENTITY" in upper:
        raise ModelError("URDF with a DOCTYPE or entity declarations is refused (unsafe XML); "
                         "expand xacro/entities first")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelError(f"URDF is not well-formed XML: {exc}") from exc
    if root.tag != "robot":
        raise ModelError(f"URDF root element must be <robot>, got <{root.tag}>")
    return root


def _short(text: str) -> str:
    return repr(text) if len(text) <= 60 else repr(text[:57] + "...")


def _floats(text: str | None, default, what: str, bound: float, unit: str, count: int = 3) -> np.ndarray:
    """``count`` finite numbers of an attribute, each within +-``bound`` (``unit``)."""
    if text is None:
        return np.array(default, dtype=float)
    try:
        values = np.array([float(v) for v in text.split()])
    except ValueError:
        raise ModelError(f"{what}: {_short(text)} is not a list of numbers") from None
    if values.size != count or not np.isfinite(values).all():
        raise ModelError(f"{what}: expected {count} finite numbers, got {_short(text)}")
    if np.abs(values).max() > bound:
        raise ModelError(f"{what}: {_short(text)} is beyond +-{bound:g} {unit} (no real robot; "
                         "URDF lengths are in m and angles in rad)")
    return values


def _joint_origin(joint: ET.Element, where: str) -> np.ndarray:
    origin = joint.find("origin")
    xyz = _floats(None if origin is None else origin.get("xyz"), [0, 0, 0], f"{where} origin xyz",
                  MAX_OFFSET_M, "m")
    rpy = _floats(None if origin is None else origin.get("rpy"), [0, 0, 0], f"{where} origin rpy",
                  MAX_ANGLE_RAD, "rad")
    return make_transform(rpy_to_matrix(rpy), xyz)


def _chain(root: ET.Element, tip: str | None) -> list[ET.Element]:
    """Joints from the root link to ``tip`` (default: the leaf with most moving joints)."""
    joints = root.findall("joint")
    by_child: dict[str, ET.Element] = {}
    for j in joints:
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None or parent.get("link") is None or child.get("link") is None:
            raise ModelError(f"URDF joint {j.get('name')!r} lacks <parent link> or <child link>")
        if child.get("link") in by_child:
            raise ModelError(f"URDF link {child.get('link')!r} has two parent joints (not a tree)")
        by_child[child.get("link")] = j
    parents = {j.find("parent").get("link") for j in joints}
    if any(lk.get("name") is None for lk in root.findall("link")):
        raise ModelError("URDF has a <link> without a name")
    links = {lk.get("name") for lk in root.findall("link")} | parents | set(by_child)

    def path_to(link: str) -> list[ET.Element]:
        path, seen = [], set()
        while link in by_child:
            if link in seen:
                raise ModelError(f"URDF has a kinematic loop through link {link!r}")
            seen.add(link)
            path.append(by_child[link])
            link = by_child[link].find("parent").get("link")
        return path[::-1]

    if tip is not None:
        if tip not in links:
            raise ModelError(f"URDF has no link {tip!r}; links: {sorted(links)}")
        return path_to(tip)
    leaves = sorted(links - parents)
    moving = {leaf: sum(j.get("type") != "fixed" for j in path_to(leaf)) for leaf in leaves}
    best = max(moving.values(), default=0)
    tips = [leaf for leaf in leaves if moving[leaf] == best]
    if best == 0 or len(tips) > 1:
        raise ModelError(f"cannot choose the URDF chain's tip link among {tips or leaves}; pass tip=...")
    return path_to(tips[0])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _perpendicular(z: np.ndarray, hint: np.ndarray) -> np.ndarray:
    """Unit vector normal to ``z``, as close as possible to ``hint`` (else to world x or y)."""
    for h in (hint, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        v = h - (h @ z) * z
        if np.linalg.norm(v) > 1e-6:
            return _unit(v)
    raise AssertionError("unreachable: x and y cannot both be parallel to a unit z")


def _angle_about(u: np.ndarray, v: np.ndarray, axis: np.ndarray) -> float:
    return float(np.arctan2(np.cross(u, v) @ axis, u @ v))


def from_urdf(source, tip: str | None = None, name: str | None = None,
              parallel_tol_deg: float = 5.0) -> Robot:
    """A :class:`Robot` from a serial URDF (revolute, continuous, prismatic and fixed joints; text,
    or a path to a file).

    ``tip`` is the end link (default: the leaf link reached through the most moving joints,
    e.g. ``tool0``); fixed joints along the chain are folded into the geometry. Consecutive
    axes closer than ``parallel_tol_deg`` to parallel are modelled with beta (flagged
    ``parallel``). The result's FK from the URDF root link to ``tip`` equals the URDF's.
    """
    root = _parse(source)
    chain = _chain(root, tip)
    T = np.eye(4)
    points, dirs, limits, prismatic = [], [], [], []
    for j in chain:
        jname, jtype = j.get("name"), j.get("type")
        T = T @ _joint_origin(j, f"joint {jname!r}")
        if jtype == "fixed":
            continue
        if jtype not in ("revolute", "continuous", "prismatic"):
            raise ModelError(f"URDF joint {jname!r} is {jtype!r}: only revolute, continuous, prismatic "
                             "and fixed joints are supported")
        if j.find("mimic") is not None:
            raise ModelError(f"URDF joint {jname!r} mimics another joint: not a serial robot joint")
        axis_el = j.find("axis")
        axis = _floats(None if axis_el is None else axis_el.get("xyz"), [1, 0, 0],
                       f"joint {jname!r} axis", _MAX_AXIS, "(a direction)")
        if np.linalg.norm(axis) < 1e-12:
            raise ModelError(f"URDF joint {jname!r} has a zero axis")
        points.append(T[:3, 3].copy())
        dirs.append(T[:3, :3] @ _unit(axis))
        lim = j.find("limit")
        slides = jtype == "prismatic"
        prismatic.append(slides)
        if jtype != "continuous" and lim is not None and lim.get("lower") and lim.get("upper"):
            bound, unit = (MAX_OFFSET_M, "m") if slides else (MAX_ANGLE_RAD, "rad")
            lower, upper = _floats(f"{lim.get('lower')} {lim.get('upper')}", None, f"joint {jname!r} limit",
                                   bound, unit, count=2)
            if lower >= upper:
                raise ModelError(f"joint {jname!r} limit: lower {lower:g} is not below upper {upper:g}")
            limits.append([lower, upper])
        elif slides:
            raise ModelError(f"URDF prismatic joint {jname!r} has no <limit lower upper> (m): a slide's "
                             "travel must be given")
        else:
            limits.append([-2 * np.pi, 2 * np.pi])
    if not dirs:
        raise ModelError("URDF chain has no moving joint")
    return _lines_to_robot(np.array(points), np.array(dirs), T, np.array(limits),
                           name or root.get("name") or "robot", np.sin(np.deg2rad(parallel_tol_deg)),
                           np.array(prismatic))


def _closest_on_line(p: np.ndarray, z: np.ndarray, x: np.ndarray) -> np.ndarray:
    return p + ((x - p) @ z) * z


def _lines_to_robot(P: np.ndarray, Z: np.ndarray, T_tip: np.ndarray, limits: np.ndarray, name: str,
                    sin_tol: float, prismatic: np.ndarray) -> Robot:
    """MDH + beta from joint lines (points ``P`` (n, 3), unit directions ``Z`` (n, 3)) and the
    tip pose ``T_tip`` at q = 0, all in the root frame; ``prismatic`` ``(n,)`` flags slides."""
    n = len(Z)
    hayati = np.zeros(n, bool)  # hayati[i]: pair (i-1, i) modelled with beta
    origins, xs, feet = [], [], [None] * n  # feet[i]: where x_{i-1} meets axis i
    for i in range(n):
        z = Z[i]
        if i + 1 < n:
            z2, p2 = Z[i + 1], P[i + 1]
            c = np.cross(z, z2)
            if np.linalg.norm(c) > sin_tol:
                # common normal: feet on both lines
                w = P[i] - p2
                A = np.array([[z @ z, -(z @ z2)], [z @ z2, -(z2 @ z2)]])
                s, t = np.linalg.solve(A, [-(w @ z), -(w @ z2)])
                o, foot2 = P[i] + s * z, p2 + t * z2
                gap = foot2 - o
                x = _unit(gap) if np.linalg.norm(gap) > 1e-9 else _unit(c)
                foot2 = o + (gap @ x) * x
            else:
                hayati[i + 1] = True
                o = feet[i] if i > 0 else _closest_on_line(P[0], z, np.zeros(3))
                if abs(z @ z2) < 1e-12:
                    raise ModelError("internal: nearly parallel axes with a perpendicular direction")
                # axis i+1 meets the plane through o normal to z here
                foot2 = p2 + ((o - p2) @ z) / (z2 @ z) * z2
                gap = foot2 - o
                hint = xs[i - 1] if i > 0 else np.array([1.0, 0, 0])
                x = _unit(gap) if np.linalg.norm(gap) > 1e-9 else _perpendicular(z, hint)
            feet[i + 1] = foot2
        else:
            o = _closest_on_line(P[i], z, T_tip[:3, 3])
            hint = xs[i - 1] if i > 0 else T_tip[:3, 0]
            x = _perpendicular(z, hint)
        origins.append(o)
        xs.append(x)
    frames = [make_transform(np.column_stack([x, np.cross(z, x), z]), o)
              for x, z, o in zip(xs, Z, origins, strict=True)]
    alpha, a, beta, theta, d = (np.zeros(n) for _ in range(5))
    for i in range(1, n):
        Rp, op = frames[i - 1][:3, :3], frames[i - 1][:3, 3]
        zl = Rp.T @ Z[i]
        beta[i] = np.arcsin(np.clip(zl[0], -1.0, 1.0))
        alpha[i] = np.arctan2(-zl[1], zl[2])
        a[i] = (feet[i] - op) @ Rp[:, 0]
        R_int = Rp @ rot_x(alpha[i]) @ rot_y(beta[i])
        theta[i] = _angle_about(R_int[:, 0], xs[i], Z[i])
        d[i] = (origins[i] - feet[i]) @ Z[i]
    tool = np.linalg.solve(frames[-1], T_tip)
    tool[3] = [0.0, 0.0, 0.0, 1.0]
    return Robot(alpha=alpha, a=a, beta=beta, theta=theta, d=d, base=frames[0], tool=tool,
                 limits=limits, parallel=hayati, name=name, prismatic=prismatic,
                 description="imported from URDF")
