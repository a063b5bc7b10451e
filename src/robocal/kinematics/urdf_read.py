"""URDF import of serial robots (revolute and prismatic joints), and URDF's roll-pitch-yaw.

The joints' lines at the zero configuration (point and direction in
the root frame) are converted to MDH + beta: consecutive axes that are not (nearly) parallel get
the common normal (alpha, a, beta = 0); nearly parallel ones get Hayati's construction (x along
the perpendicular to the next axis in the plane normal to the current one; beta non-zero). The
root-to-frame-{0} transform becomes the base frame and the flange-to-tip transform the tool.
A prismatic joint (a mobile manipulator's torso lift, a gantry's axes, a linear track) slides along
its axis: where its line lies is free (a translation moves every point alike), so the same
construction places it, and the joint is flagged prismatic (its value, m, adds to its d).

`robocal.kinematics.model.load_model` and `robocal.kinematics.urdf.from_urdf` build the robot.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import read_text
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z

MAX_OFFSET_M = 100.0  # a joint origin farther than this from its parent is no robot's (URDF is in m)
MAX_ANGLE_RAD = 100.0  # origin angles and joint limits beyond (16 turns) are a unit or typing error
_MAX_AXIS = 1e6  # an axis vector is normalised; components beyond are refused
HAYATI_DEG = 5.0  # consecutive axes closer than this to parallel are modelled with beta (Hayati)
# m: between nearly parallel axes, an offset from one's frame origin to the other's foot below this is
# rounding (the next x then follows the previous one); a larger one, however small, is kept as a, so
# the chain's FK stays the joints' own to rounding (an offset of 1e-9 m dropped here was an error)
SAME_POINT_M = 1e-13


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


def parse_urdf(source) -> ET.Element:
    """The ``<robot>`` element of a URDF (text, or a path to a file); ModelError when it is not
    well-formed, has a DOCTYPE or entities (unsafe XML), or its root is another element."""
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


def joint_origin(joint: ET.Element, where: str) -> np.ndarray:
    """A joint's ``<origin>`` as a 4x4 transform (m), checked (``where`` names it in errors)."""
    origin = joint.find("origin")
    xyz = _floats(None if origin is None else origin.get("xyz"), [0, 0, 0], f"{where} origin xyz",
                  MAX_OFFSET_M, "m")
    rpy = _floats(None if origin is None else origin.get("rpy"), [0, 0, 0], f"{where} origin rpy",
                  MAX_ANGLE_RAD, "rad")
    return make_transform(rpy_to_matrix(rpy), xyz)


def joint_axis(joint: ET.Element) -> np.ndarray:
    """The unit axis ``(3,)`` of a moving joint in its child link's frame (URDF's default: x)."""
    axis_el = joint.find("axis")
    axis = _floats(None if axis_el is None else axis_el.get("xyz"), [1, 0, 0],
                   f"joint {joint.get('name')!r} axis", _MAX_AXIS, "(a direction)")
    if np.linalg.norm(axis) < 1e-12:
        raise ModelError(f"URDF joint {joint.get('name')!r} has a zero axis")
    return _unit(axis)


def urdf_chain(root: ET.Element, tip: str | None) -> list[ET.Element]:
    """Joints from the root link to ``tip`` (default: the leaf with most moving joints)."""
    joints = root.findall("joint")
    for kind, elements in (("link", root.findall("link")), ("joint", joints)):  # as ROS's parser does
        counts = Counter(e.get("name") for e in elements if e.get("name") is not None)
        twice = sorted(n for n, c in counts.items() if c > 1)
        if twice:
            raise ModelError(f"URDF {kind} name {twice[0]!r} is given {counts[twice[0]]} times: each "
                             f"{kind} needs its own name (ROS refuses such a file)")
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
        raise ModelError(f"cannot choose the URDF chain's tip link among {tips or leaves}: name the "
                         "chain's last link (--tip LINK on the command line, tip= in Python)")
    return path_to(tips[0])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _perpendicular(z: np.ndarray, hint: np.ndarray) -> np.ndarray:
    """Unit vector normal to ``z``, as close as possible to ``hint`` (else to world x or y); projected
    twice, so that it is normal to ``z`` to rounding even when ``hint`` is nearly along ``z``."""
    for h in (hint, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        v = h - (h @ z) * z
        if np.linalg.norm(v) > 1e-6:
            v = _unit(v)
            return _unit(v - (v @ z) * z)
    raise AssertionError("unreachable: x and y cannot both be parallel to a unit z")


def _angle_about(u: np.ndarray, v: np.ndarray, axis: np.ndarray) -> float:
    return float(np.arctan2(np.cross(u, v) @ axis, u @ v))


def urdf_kwargs(source, tip: str | None = None, name: str | None = None,
                parallel_tol_deg: float = HAYATI_DEG) -> dict:
    """The `robocal.kinematics.model.Robot` arguments of a serial URDF (revolute, continuous,
    prismatic and fixed joints; text, or a path to a file).

    ``tip`` is the end link (default: the leaf link reached through the most moving joints,
    e.g. ``tool0``); fixed joints along the chain are folded into the geometry. The chain's link
    names are kept with the frame each moves with (``link_frames``: the root's 0, a moving joint's
    child its number, a link fixed after it the same). Consecutive
    axes closer than ``parallel_tol_deg`` to parallel are modelled with beta (flagged
    ``parallel``). The result's FK from the URDF root link to ``tip`` equals the URDF's.
    """
    root = parse_urdf(source)
    chain = urdf_chain(root, tip)
    T = np.eye(4)
    points, dirs, limits, prismatic = [], [], [], []
    link_frames = {chain[0].find("parent").get("link"): 0} if chain else {}
    for j in chain:
        jname, jtype = j.get("name"), j.get("type")
        T = T @ joint_origin(j, f"joint {jname!r}")
        link_frames[j.find("child").get("link")] = len(dirs) + (jtype != "fixed")
        if jtype == "fixed":
            continue
        if jtype not in ("revolute", "continuous", "prismatic"):
            raise ModelError(f"URDF joint {jname!r} is {jtype!r}: only revolute, continuous, prismatic "
                             "and fixed joints are supported")
        if j.find("mimic") is not None:
            raise ModelError(f"URDF joint {jname!r} mimics another joint: not a serial robot joint")
        points.append(T[:3, 3].copy())
        dirs.append(T[:3, :3] @ joint_axis(j))
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
    kw = lines_to_chain(np.array(points), np.array(dirs), T, np.array(limits),
                         name or root.get("name") or "robot", np.sin(np.deg2rad(parallel_tol_deg)),
                         np.array(prismatic))
    return {**kw, "link_frames": link_frames}


def _closest_on_line(p: np.ndarray, z: np.ndarray, x: np.ndarray) -> np.ndarray:
    return p + ((x - p) @ z) * z


def lines_to_chain(P: np.ndarray, Z: np.ndarray, T_tip: np.ndarray, limits: np.ndarray, name: str,
                    sin_tol: float, prismatic: np.ndarray) -> dict:
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
                x = _unit(c) * (-1.0 if gap @ c < 0 else 1.0)  # the common normal's direction, exactly
                foot2 = o + (gap @ x) * x
            else:
                hayati[i + 1] = True
                o = feet[i] if i > 0 else _closest_on_line(P[0], z, np.zeros(3))
                if abs(z @ z2) < 1e-12:
                    raise ModelError("internal: nearly parallel axes with a perpendicular direction")
                # axis i+1 meets the plane through o normal to z here
                foot2 = p2 + ((o - p2) @ z) / (z2 @ z) * z2
                gap = foot2 - o
                gap -= (gap @ z) * z  # in the plane normal to z, to rounding
                hint = xs[i - 1] if i > 0 else np.array([1.0, 0, 0])
                x = _unit(gap) if np.linalg.norm(gap) > SAME_POINT_M else _perpendicular(z, hint)
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
    return {"alpha": alpha, "a": a, "beta": beta, "theta": theta, "d": d, "base": frames[0], "tool": tool,
            "limits": limits, "parallel": hayati, "name": name, "prismatic": prismatic,
            "description": "imported from URDF"}
