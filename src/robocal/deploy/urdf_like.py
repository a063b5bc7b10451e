"""A calibrated model written into the vendor's own URDF: the same document (robot name, links,
joints, meshes, limits, inertials, materials, extra frames such as ``base``, ``flange``, ``tool0``,
comments), with only the origins of its moving joints changed, so that its forward kinematics is the
calibrated model's and every link frame (where its mesh hangs) stays where the calibration put it.

The map between the vendor's frames and robocal's is found from the nominal models and checked:

1. The vendor's joint values are the controller's (as the ROS drivers send them) and robocal's
   nominal model is the controller's, so the n joint axes of the two at q = 0 are the same lines;
   the rigid transform ``B`` (robocal's world in the vendor's root link) that carries robocal's
   axes onto the vendor's is fitted (directions: Kabsch; points: the lines' normal distances),
   and every axis must then lie on the vendor's. UR's base_link, the controller's base turned by
   pi, comes out of the fit as such.
2. Every link of the vendor's chain rides on one of robocal's frames {f} (f: the moving joints
   before it); its pose in that frame, ``M = (B F_f(q))^-1 T_link(q)``, must be the same for every
   joint vector: checked on `CHECK_POSES` random ones (`MAP_TOL_M`, `MAP_TOL_RAD`), else the vendor
   file is refused as another robot.
3. The calibrated link frames are ``B F_f(q) M`` with the calibrated chain F (its frame {0} the
   controller's base, `robocal.deploy.compensation.controller_model`): the origin of moving joint k
   becomes ``M_parent^-1 F_{k-1}(0)^-1 F_k(0) M_child``. Its axis stays the vendor's exactly (M's
   origin is on the joint's line, so the calibrated rotation about frame {k}'s z is the vendor's
   joint turning about its own axis) and no fixed joint is added.

The document is edited as text (the values of those ``<origin>`` elements only, floats written with
``repr``), and an XML comment says per joint how far its origin and its link's frame moved from the
vendor's (mm, deg). The written text is read back and its forward kinematics compared with the
calibrated model's (`FK_POSES` joint vectors).
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError, ModelError, RobocalError
from robocal.core.io import check_outputs, read_text, write_all
from robocal.deploy.compensation import controller_model
from robocal.deploy.models import controller_for
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.transforms import invert_transform
from robocal.kinematics.urdf import not_carried
from robocal.kinematics.urdf_read import joint_axis, joint_origin, matrix_to_rpy, parse_urdf, urdf_chain

MAP_TOL_M = 1e-6  # m: a vendor link's pose in robocal's frame may vary this much over joint vectors
MAP_TOL_RAD = 1e-6  # rad: the same for its orientation (the vendor files round pi/2 to 1e-10)
CHECK_POSES = 256  # random joint vectors the map is checked on
FK_POSES = 1000  # random joint vectors the written file's FK is compared on
FK_TOL_M = 1e-9  # m: the written file's FK off the calibrated model's beyond this is an internal error
FK_TOL_RAD = 1e-9  # rad: the same for the orientation
DROPPED_TERMS_MM = 0.05  # mm: joint-error terms moving the TCP by more (mean) make a URDF another robot
KEPT_BELOW = 1e-12  # m, rad: a new origin's number this close to the vendor's is written as the vendor's
GOAL_MM = 1.0  # a joint origin moved further than this from the vendor's is said (meshes move with it)
GOAL_DEG = 0.1  # the same, deg
_MOVING = ("revolute", "continuous", "prismatic")
FLANGE_LINKS = ("tool0", "flange")  # links at the controller's flange (ROS-Industrial, REP 199)
_WHY_NOT = ("(another robot, joints that are not the controller's, or a controller's model that is not what "
            "the file draws: give that as --vendor-model)")


# ----------------------------------------------------------------- the vendor's chain
@dataclass(frozen=True)
class _Chain:
    """A URDF's chain from its root link to ``tip``: ``links`` (root first, then each joint's child),
    ``joints`` (elements), ``origins`` ``(m, 4, 4)``, ``axes`` ``(m, 3)``, ``kinds``, and ``frame``
    ``(m + 1,)``: the moving joints up to each link (robocal's frame it rides on)."""

    links: list[str]
    joints: list[ET.Element]
    origins: np.ndarray
    axes: np.ndarray
    kinds: list[str]
    frame: np.ndarray

    @classmethod
    def read(cls, root: ET.Element, tip: str | None) -> _Chain:
        joints = urdf_chain(root, tip)
        if not joints:
            raise ModelError("the vendor URDF has no chain of joints from its root link")
        kinds = [j.get("type") for j in joints]
        for j, kind in zip(joints, kinds, strict=True):
            if kind != "fixed" and kind not in _MOVING:
                raise ModelError(f"URDF joint {j.get('name')!r} is {kind!r}: only revolute, continuous, "
                                 "prismatic and fixed joints are supported")
        origins = np.array([joint_origin(j, f"joint {j.get('name')!r}") for j in joints])
        axes = np.array([joint_axis(j) if k in _MOVING else np.zeros(3) for j, k in zip(joints, kinds,
                                                                                        strict=True)])
        frame = np.concatenate([[0], np.cumsum([k in _MOVING for k in kinds])])
        links = [joints[0].find("parent").get("link"), *(j.find("child").get("link") for j in joints)]
        return cls(links, joints, origins, axes, kinds, frame)

    @property
    def n_moving(self) -> int:
        return int(self.frame[-1])

    @property
    def moving(self) -> list[int]:
        """Indices (in ``joints``) of the moving joints."""
        return [i for i, k in enumerate(self.kinds) if k in _MOVING]

    def poses(self, q: np.ndarray, origins: np.ndarray | None = None) -> np.ndarray:
        """Poses ``(N, m + 1, 4, 4)`` of the chain's links in its root link for joints ``q``
        ``(N, n)`` (rad, m), with ``origins`` (default the file's)."""
        origins = self.origins if origins is None else origins
        N = q.shape[0]
        out = np.empty((N, len(self.links), 4, 4))
        out[:, 0] = np.eye(4)
        T = np.broadcast_to(np.eye(4), (N, 4, 4))
        for i, kind in enumerate(self.kinds):
            T = T @ origins[i]
            if kind in _MOVING:
                T = T @ _joint_motion(self.axes[i], q[:, self.frame[i + 1] - 1], kind == "prismatic")
            out[:, i + 1] = T
        return out


def _joint_motion(axis: np.ndarray, q: np.ndarray, prismatic: bool) -> np.ndarray:
    """``(N, 4, 4)``: a turn by ``q`` (rad) about ``axis`` (Rodrigues), or a slide by ``q`` (m)."""
    T = np.tile(np.eye(4), (q.size, 1, 1))
    if prismatic:
        T[:, :3, 3] = q[:, None] * axis
        return T
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    T[:, :3, :3] += np.sin(q)[:, None, None] * K + (1 - np.cos(q))[:, None, None] * (K @ K)
    return T


def _pose_gap(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (m) and rotation angle (rad) between poses ``A`` and ``B`` ``(..., 4, 4)``."""
    dist = np.linalg.norm(A[..., :3, 3] - B[..., :3, 3], axis=-1)
    R = np.swapaxes(A[..., :3, :3], -1, -2) @ B[..., :3, :3]
    cos = (np.trace(R, axis1=-2, axis2=-1) - 1) / 2
    sin = np.linalg.norm(np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                                   R[..., 1, 0] - R[..., 0, 1]], -1), axis=-1) / 2
    return dist, np.arctan2(sin, cos)


def _fit_lines(robot_P, robot_Z, vendor_P, vendor_Z, revolute) -> np.ndarray:
    """The rigid transform ``(4, 4)`` carrying robocal's joint lines (points, unit directions
    ``(n, 3)``) onto the vendor's: rotation by Kabsch on the directions, translation by least squares
    of the distances to the vendor's lines (revolute joints: a slide's line has no position)."""
    U, _, Vt = np.linalg.svd(robot_Z.T @ vendor_Z)
    R = Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
    normal = np.eye(3) - vendor_Z[revolute, :, None] * vendor_Z[revolute, None, :]  # (k, 3, 3)
    rhs = normal @ (vendor_P[revolute] - robot_P[revolute] @ R.T)[..., None]
    t = np.linalg.lstsq(normal.reshape(-1, 3), rhs.reshape(-1), rcond=None)[0]
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = R, t
    return out


def _random_joints(robot: Robot, count: int, seed: int = 0) -> np.ndarray:
    """``(count, n)`` joint vectors within ``robot``'s limits (rad, m), q = 0 first."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    q = np.random.default_rng(seed).uniform(lo, hi, (count, robot.n_joints))
    q[0] = 0.0
    return q


def _link_maps(chain: _Chain, nominal: Robot,
               vendor_file: str) -> tuple[np.ndarray, np.ndarray, float, float]:
    """``B`` (robocal's world in the vendor's root link), the links' poses ``M`` ``(m + 1, 4, 4)`` in
    the robocal frame each rides on, and the check's largest variation (m, rad); DataError when the
    vendor's chain is not ``nominal``'s robot."""
    n = nominal.n_joints
    kinds = [chain.kinds[i] for i in chain.moving]
    if chain.n_moving != n or [k == "prismatic" for k in kinds] != list(nominal.prismatic):
        raise DataError(f"{vendor_file} is not {nominal.name}: its chain to {chain.links[-1]} has "
                        f"{chain.n_moving} moving joints ({', '.join(kinds)}), the model {n}")
    q = _random_joints(nominal, CHECK_POSES)
    vendor = chain.poses(q)
    _, frames = chain_frames(nominal.links, nominal.base, nominal.tool, q, frames=True,
                             prismatic=nominal.prismatic)
    child = [i + 1 for i in chain.moving]
    axes_v = np.einsum("kij,kj->ki", vendor[0, child, :3, :3], chain.axes[chain.moving])
    B = _fit_lines(frames[0, 1:, :3, 3], frames[0, 1:, :3, 2], vendor[0, child, :3, 3], axes_v,
                   ~np.asarray(nominal.prismatic))
    _check_axes(B, frames[0, 1:], vendor[0, child, :3, 3], axes_v, nominal, chain, vendor_file)
    M = invert_transform(B @ frames[:, chain.frame]) @ vendor  # (N, m + 1, 4, 4)
    dist, angle = _pose_gap(M, M[:1])
    off = np.flatnonzero((dist.max(0) > MAP_TOL_M) | (angle.max(0) > MAP_TOL_RAD))
    if off.size:
        worst = int(off[0])  # the first link along the chain that does not follow robocal's frame
        raise DataError(f"{vendor_file} is not {nominal.name}: its link {chain.links[worst]} moves "
                        f"{dist[:, worst].max() * 1e3:.3g} mm / {np.rad2deg(angle[:, worst].max()):.3g} deg "
                        f"against robocal's frame {{{chain.frame[worst]}}} over {CHECK_POSES} joint vectors "
                        f"{_WHY_NOT}")
    _check_flange(chain, M[0], nominal, vendor_file)
    return B, _on_axes(chain, M[0]), float(dist.max()), float(angle.max())


def _check_flange(chain: _Chain, M: np.ndarray, nominal: Robot, vendor_file: str) -> None:
    """DataError when a link of the chain named as the flange (`FLANGE_LINKS`: ROS-Industrial's
    ``tool0`` is the controller's flange) has its origin off robocal's flange frame {n} (``M``: the
    links' poses in the frames they ride on): a vendor file whose tool0 was 1 m beyond the flange
    was written, exit 0, with its base_link-to-tool0 FK 1 m off the calibrated model's."""
    for i, link in enumerate(chain.links):
        if link in FLANGE_LINKS and chain.frame[i] == chain.n_moving:
            off = float(np.linalg.norm(M[i, :3, 3]))
            if off > MAP_TOL_M:
                raise DataError(f"{vendor_file} is not {nominal.name}: its {link} is {off * 1e3:.4g} mm "
                                f"from the model's flange (ROS-Industrial's {link} is the controller's "
                                f"flange) {_WHY_NOT}")


def _check_axes(B: np.ndarray, frames: np.ndarray, points: np.ndarray, axes: np.ndarray, nominal: Robot,
                chain: _Chain, vendor_file: str) -> None:
    """DataError naming the joint whose axis (robocal's frames {1..n} ``(n, 4, 4)`` moved by ``B``)
    is furthest from the vendor's line (``points``, unit ``axes`` ``(n, 3)``) beyond the map's
    tolerance: the vendor's file is another robot (or another joint convention)."""
    mapped = B @ frames
    angle = np.arccos(np.clip(np.einsum("ki,ki->k", mapped[:, :3, 2], axes), -1.0, 1.0))
    gap = mapped[:, :3, 3] - points
    dist = np.linalg.norm(gap - np.einsum("ki,ki->k", gap, axes)[:, None] * axes, axis=1)
    dist[np.asarray(nominal.prismatic)] = 0.0  # a slide's line has no position
    k = int(np.argmax(np.maximum(dist / MAP_TOL_M, angle / MAP_TOL_RAD)))
    if dist[k] > MAP_TOL_M or angle[k] > MAP_TOL_RAD:
        name = chain.joints[chain.moving[k]].get("name")
        raise DataError(f"{vendor_file} is not {nominal.name}: the axis of its joint {name} is "
                        f"{dist[k] * 1e3:.3g} mm / {np.rad2deg(angle[k]):.3g} deg off the model's joint "
                        f"{k + 1} after the best rigid fit of all the axes {_WHY_NOT}")


def _on_axes(chain: _Chain, M: np.ndarray) -> np.ndarray:
    """The links' poses ``M`` ``(m + 1, 4, 4)`` made exact where the map holds to rounding only: each
    moving joint's child carries the vendor's axis exactly onto robocal's z (the smallest turn) with
    its origin on that z (a revolute joint), and every link after a fixed joint sits at the vendor's
    origin from its parent; so the written joints turn about the vendor's axes and the file's FK is
    the calibrated model's to rounding, not to the vendor file's rounding of pi/2 (UR: 1e-10)."""
    M = M.copy()
    for i, kind in enumerate(chain.kinds):
        if kind == "fixed":
            M[i + 1] = M[i] @ chain.origins[i]
            continue
        v = M[i + 1, :3, :3] @ chain.axes[i]
        w = np.cross(v, [0.0, 0.0, 1.0])
        turn = np.arctan2(np.linalg.norm(w), v[2])
        if np.linalg.norm(w) > 0:
            M[i + 1, :3, :3] = _joint_motion(w / np.linalg.norm(w), np.array([turn]), False)[0, :3, :3] \
                @ M[i + 1, :3, :3]
        if kind != "prismatic":
            M[i + 1, :2, 3] = 0.0
    return M


# ----------------------------------------------------------------- the document as text
_COMMENT = re.compile(r"<!--.*?-->", re.S)


def _masked(text: str) -> str:
    """``text`` with its comments blanked (same length), so that searches skip them."""
    return _COMMENT.sub(lambda m: " " * len(m.group()), text)


def _number_list(values) -> str:
    return " ".join(repr(float(v) + 0.0) for v in values)


def _kept(old: str, candidates: list[np.ndarray], angles: bool) -> str:
    """The text of an origin attribute: of the ``candidates`` ``(3,)`` (the same pose: an rpy has
    two), the one nearest the vendor's ``old`` numbers, each number written as the vendor's where it
    is within `KEPT_BELOW` of it (``angles``: modulo 2 pi), so that what the calibration did not move
    reads as the vendor wrote it; ``old`` itself when every number is kept."""
    tokens = old.split()
    try:
        given = np.array([float(t) for t in tokens])
    except ValueError:
        given = np.zeros(0)
    if given.size != 3:
        return _number_list(candidates[0])

    def gap(values):
        d = given - values
        return np.abs(np.remainder(d + np.pi, 2 * np.pi) - np.pi) if angles else np.abs(d)

    values = min(candidates, key=lambda c: gap(c).max())
    out = [t if g <= KEPT_BELOW else repr(float(v) + 0.0) for t, g, v in zip(tokens, gap(values), values,
                                                                             strict=True)]
    return old if out == tokens else " ".join(out)


def _rpy_pair(R: np.ndarray) -> list[np.ndarray]:
    """The two roll-pitch-yaw triples of rotation ``R`` (rad)."""
    r, p, y = matrix_to_rpy(R)
    wrap = np.remainder(np.array([r + np.pi, np.pi - p, y + np.pi]) + np.pi, 2 * np.pi) - np.pi
    return [np.array([r, p, y]), wrap]


def _with_origins(text: str, origins: dict[str, np.ndarray], what: str = "") -> str:
    """``text`` with the ``xyz`` and ``rpy`` of each named joint's ``<origin>`` set to
    ``origins[name]`` (4x4, m), everything else as it was (an ``<origin>`` added where none is).
    ``what`` names a xacro macro file: its joints' names may start with a property (``${prefix}``);
    ModelError when a joint is not in it."""
    masked = _masked(text)
    edits = []
    prefix = r"(?:\$\{[^}\"']*\})?" if what else ""
    for name, T in origins.items():
        values = {"xyz": [T[:3, 3]], "rpy": _rpy_pair(T[:3, :3])}
        pattern = r"<joint\b[^>]*\bname\s*=\s*([\"'])" + prefix + re.escape(name) + r"\1[^>]*>"
        # a joint with a type: not a <transmission>'s or <ros2_control>'s reference to it
        found = [m for m in re.finditer(pattern, masked) if re.search(r"\btype\s*=", m.group())]
        start = found[0] if len(found) == 1 else None
        if start is None:
            raise ModelError(f"{what or 'the URDF text'} has {len(found) or 'no'} joint(s) {name!r}: give "
                             "the vendor's macro of this robot (the xacro file the URDF was expanded from)")
        end = masked.find("</joint>", start.end())
        tag = re.compile(r"<origin\b[^>]*>").search(masked, start.end(), end)
        if tag is None:
            xyz, rpy = (_number_list(values[k][0]) for k in ("xyz", "rpy"))
            edits.append((start.end(), start.end(), f'<origin xyz="{xyz}" rpy="{rpy}"/>'))
            continue
        new = text[tag.start():tag.end()]
        for attr, value in values.items():
            pattern = re.compile(r"(\b" + attr + r"\s*=\s*)([\"'])([^\"']*)\2")
            found = pattern.search(new)
            if found:
                value = _kept(found.group(3), value, attr == "rpy")
                new = pattern.sub(lambda m, v=value: f"{m.group(1)}{m.group(2)}{v}{m.group(2)}", new, count=1)
            else:
                close = len(new) - (2 if new.endswith("/>") else 1)
                new = f'{new[:close].rstrip()} {attr}="{_number_list(value[0])}"{new[close:]}'
        edits.append((tag.start(), tag.end(), new))
    for a, b, new in sorted(edits, reverse=True):
        text = text[:a] + new + text[b:]
    return text


def _with_comment(text: str, comment: str) -> str:
    """``text`` with the XML comment ``comment`` after its XML declaration (or first)."""
    body = comment
    while "--" in body:
        body = body.replace("--", "- -")
    block = f"<!-- {body.rstrip('-')} -->\n"
    declaration = re.match(r"\s*<\?xml[^>]*\?>\s*\n?", text)
    at = declaration.end() if declaration else 0
    return text[:at] + block + text[at:]


# ----------------------------------------------------------------- the result
def _pose_text(T: np.ndarray) -> str:
    return (f"xyz {' '.join(f'{v:.4f}' for v in T[:3, 3] * 1e3)} mm, rpy "
            f"{' '.join(f'{v:.6f}' for v in np.rad2deg(matrix_to_rpy(T[:3, :3])))} deg")


@dataclass(frozen=True)
class JointShift:
    """How far a moving joint's origin (its child link's frame in its parent's, mm and deg) and its
    child link's frame at q = 0 (in base_link) moved from the vendor's."""

    joint: str
    link: str
    origin_mm: float
    origin_deg: float
    frame_mm: float
    frame_deg: float


@dataclass
class UrdfLikeExport:
    """The vendor's URDF with the calibrated kinematics (`export_urdf_like`): ``text``, the map
    (``base`` robocal's base frame in base_link, ``tool`` tool0 in robocal's flange, both 4x4 m, and
    the check's largest variation ``map_check`` (m, rad)), the ``shifts`` per moving joint, the
    comparison of the written file's FK with the calibrated model's ``fk_check`` (m, rad, joint
    vectors) and the ``warnings``.

    Parameters
    ----------
    robot : Robot
        The calibrated model written into the vendor's file.
    nominal : Robot
        The nominal model the vendor's file was mapped against.
    vendor : str
        The vendor's URDF (path).
    robot_name : str
        The ``<robot name>`` of the vendor's file (kept).
    text : str
        The written URDF.
    base, tool : ndarray, shape (4, 4)
        robocal's base frame in base_link; tool0 in robocal's flange (m).
    map_check : tuple of float
        The map's largest variation over the check's joint vectors (m, rad).
    shifts : list of JointShift
        Per moving joint: how far its origin and its link frame at q = 0 moved (mm, deg).
    fk_check : tuple
        The written file's FK against the calibrated model's: largest gap (m, rad), joint vectors.
    output : str, optional
        Where `write` writes the URDF by default.
    warnings : list of str
        What the user should know (joint-error terms a URDF cannot hold...).
    xacro, xacro_text, xacro_output : str, optional
        The vendor's macro, the calibrated macro and where it is written.
    fk_frames : str
        The frames the FK check compares.

    See Also
    --------
    rc.export_urdf_like : Makes it.
    rc.Robot : The calibrated model.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.kinematics.urdf import to_urdf
    >>> nominal = rc.Robot.from_catalog("ur5e")
    >>> _ = open("ur5e.urdf", "w").write(to_urdf(nominal, frames="robot"))
    >>> out = rc.export_urdf_like(nominal.with_values({"d4": nominal.get("d4") + 3e-4}), "ur5e.urdf")
    >>> round(out.shifts[3].origin_mm, 3), out.warnings
    (0.3, [])
    >>> print(out.summary().splitlines()[2])
    FK base_link -> tool0 = the calibrated model's within ... mm / ... rad (1000 joint vectors)
    >>> out.write("ur5e_calibrated.urdf")
    ['ur5e_calibrated.urdf']
    """

    robot: Robot
    nominal: Robot
    vendor: str
    robot_name: str
    text: str
    base: np.ndarray
    tool: np.ndarray
    map_check: tuple[float, float]
    shifts: list[JointShift]
    fk_check: tuple[float, float, int]
    output: str | None = None
    warnings: list[str] = field(default_factory=list)
    xacro: str | None = None
    xacro_text: str | None = None
    xacro_output: str | None = None
    fk_frames: str = "base_link -> tool0"

    def summary(self) -> str:
        """The map, the FK check and the per-joint shifts, one line each.

        Returns
        -------
        str
            The summary, several lines.
        """
        mm, rad, count = self.fk_check
        lines = [f"{self.vendor} ({self.robot_name}) with the kinematics of {self.robot.name} "
                 f"(nominal {self.nominal.name}): only the {len(self.shifts)} moving joints' origins changed",
                 f"map: robocal's base in base_link {_pose_text(self.base)}; tool0 in robocal's flange "
                 f"{_pose_text(self.tool)} (checked to {self.map_check[0] * 1e3:.2g} mm / "
                 f"{self.map_check[1]:.2g} rad on {CHECK_POSES} joint vectors)",
                 f"FK {self.fk_frames} = the calibrated model's within {mm * 1e3:.2g} mm / {rad:.2g} rad "
                 f"({count} joint vectors)",
                 "moved from the vendor's: joint origin (mm, deg), link frame at q = 0 (mm, deg)"]
        lines += [f"  {s.joint} ({s.link}): {s.origin_mm:.4f} mm {s.origin_deg:.5f} deg; "
                  f"{s.frame_mm:.4f} mm {s.frame_deg:.5f} deg" for s in self.shifts]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The map, the checks, the shifts, the warnings and the file.

        Returns
        -------
        dict
            JSON-ready (lengths in m, angles in rad; the shifts in mm and deg).
        """
        return {"vendor": self.vendor, "robot_name": self.robot_name, "model": self.robot.name,
                "nominal": self.nominal.name, "base_in_base_link": self.base.tolist(),
                "tool0_in_flange": self.tool.tolist(),
                "map_check": {"m": self.map_check[0], "rad": self.map_check[1], "joint_vectors": CHECK_POSES},
                "fk_check": {"m": self.fk_check[0], "rad": self.fk_check[1],
                             "joint_vectors": self.fk_check[2], "frames": self.fk_frames},
                "joints": [vars(s) for s in self.shifts], "warnings": list(self.warnings),
                "output": self.output, "urdf": self.text, "xacro": self.xacro,
                "xacro_output": self.xacro_output, "xacro_text": self.xacro_text}

    def write(self, path=None, xacro_path=None) -> list[str]:
        """Write the URDF to ``path`` (default ``output``) and, with a vendor macro, the calibrated
        macro to ``xacro_path`` (default ``xacro_output``), all or none; the paths written.

        Parameters
        ----------
        path : str, optional
            The URDF to write (default ``output``).
        xacro_path : str, optional
            The calibrated macro to write (default ``xacro_output``).

        Returns
        -------
        list of str
            The paths written.

        Raises
        ------
        DataError
            No path, or a path is one of the vendor's files (never overwritten).
        """
        path = path if path is not None else self.output
        xacro_path = xacro_path if xacro_path is not None else self.xacro_output
        if path is None or (self.xacro_text is not None and xacro_path is None):
            raise DataError("no output path: give write(path, xacro_path) or export_urdf_like(..., output=, "
                            "xacro_output=)")
        texts = {path: self.text} | ({} if self.xacro_text is None else {xacro_path: self.xacro_text})
        check_outputs(list(texts), [self.vendor, self.xacro])
        write_all(texts)
        return [str(p) for p in texts]


def _shift_comment(result: UrdfLikeExport) -> str:
    rows = "\n".join(f"       {s.joint} ({s.link}): origin {s.origin_mm:.4f} mm {s.origin_deg:.5f} deg, "
                     f"frame at q = 0 {s.frame_mm:.4f} mm {s.frame_deg:.5f} deg" for s in result.shifts)
    mm, rad, count = result.fk_check
    return (f"robocal: the kinematics of calibrated model {result.robot.name} (nominal "
            f"{result.nominal.name}) in {Path(result.vendor).name}.\n     Only the origins of the moving "
            "joints changed; names, axes, meshes, limits, inertials and the fixed frames are the "
            "vendor's.\n     robocal's base is "
            f"at {_pose_text(result.base)} in base_link; tool0 at {_pose_text(result.tool)} in robocal's "
            f"flange.\n     FK {result.fk_frames.replace('->', 'to')} = the calibrated model's within "
            f"{mm * 1e3:.2g} mm / {rad:.2g} rad ({count} joint vectors).\n     Moved from the vendor's "
            f"(joint origin; the link's frame in base_link at q = 0):\n{rows}\n")


# ----------------------------------------------------------------- the export
def export_urdf_like(calibrated: Robot | str, vendor_urdf, nominal: Robot | str | None = None,
                     output=None, tip: str | None = None, xacro=None, xacro_output=None,
                     geometry_only: bool = False, vendor_model: Robot | str | None = None) -> UrdfLikeExport:
    """The vendor's URDF (``vendor_urdf``: a path, as xacro expands it) with the kinematics of
    ``calibrated`` (a `Robot`, model file or catalog name).

    Parameters
    ----------
    calibrated : Robot or str
        The calibrated model; its frame {0} is taken as the controller's base and the flange as
        the nominal model's (`robocal.deploy.compensation.controller_model`).
    vendor_urdf : str or Path
        The vendor's expanded URDF (ROS-Industrial support package, ur_description); read only.
    nominal : Robot or str, optional
        The controller's model (catalog name or model file; default the catalog robot of the
        calibrated model's name), which the vendor's file must describe (checked).
    output : str or Path, optional
        Where `UrdfLikeExport.write` writes by default.
    tip : str, optional
        The vendor's tool link (default ``tool0`` when it has one, else its deepest leaf).
    xacro, xacro_output : str or Path, optional
        The vendor's xacro macro the URDF was expanded from (a ROS-Industrial
        ``*_macro.xacro``, joint names after ``${prefix}``), and where `UrdfLikeExport.write`
        writes the same macro with the calibrated joint origins (``xacro_text``), for launch files
        that include a macro.
    vendor_model : Robot or str, optional
        The nominal model the vendor's file draws, when the controller's is not (a UR's factory
        calibration as ``nominal``, the catalog ``ur5e`` here): the same parametrization as the
        calibrated model; its base and flange are base_link's and tool0's. Default: ``nominal``.
    geometry_only : bool, default False
        Write the geometry of a model whose joint-error terms (compliance, backlash, ...) move its
        TCP by more than `DROPPED_TERMS_MM` (refused otherwise: that URDF is not the calibrated
        robot; calibrate with ``nongeometric=None`` for ROS), with a warning saying how far.

    Returns
    -------
    UrdfLikeExport
        The text, the map, the checks and the per-joint shifts (mm, deg).

    Raises
    ------
    DataError
        The vendor file is another robot, there is no nominal model, or the model's joint-error
        terms matter and ``geometry_only`` is not set.
    ModelError
        The vendor file is not a readable URDF.

    See Also
    --------
    robocal.deploy.urdf_like.UrdfLikeExport : What it returns.
    rc.Robot : The calibrated model (``Robot.load`` of calibrate's output).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.kinematics.urdf import to_urdf
    >>> nominal = rc.Robot.from_catalog("kuka_kr16_2")
    >>> _ = open("kr16_2.urdf", "w").write(to_urdf(nominal, frames="robot"))  # stands for the vendor's
    >>> calibrated = nominal.with_values({"a2": nominal.get("a2") + 5e-4})  # 0.5 mm longer
    >>> out = rc.export_urdf_like(calibrated, "kr16_2.urdf", output="kr16_2_calibrated.urdf")
    >>> [f"{s.joint}: {s.origin_mm:.2f} mm" for s in out.shifts][:3]
    ['joint_1: 0.00 mm', 'joint_2: 0.50 mm', 'joint_3: 0.00 mm']
    >>> bool(out.fk_check[0] < 1e-9)  # m: the written file's FK against the calibrated model's
    True
    >>> out.write()
    ['kr16_2_calibrated.urdf']
    """
    robot = calibrated if isinstance(calibrated, Robot) else load_model(str(calibrated))
    controller = nominal if isinstance(nominal, Robot) else controller_for(robot, nominal)
    if controller is None:
        raise DataError(f"{robot.name} is not a catalog robot: give the controller's nominal model "
                        "(--nominal, a catalog name or model file), which the vendor's URDF must describe")
    dropped = _dropped_terms(robot, geometry_only)
    vendor_file = str(vendor_urdf)
    text = read_text(vendor_file, "vendor URDF")
    root = parse_urdf(text)
    names = {lk.get("name") for lk in root.findall("link")}
    chain = _Chain.read(root, tip if tip is not None else ("tool0" if "tool0" in names else None))
    drawn = controller if vendor_model is None else (
        vendor_model if isinstance(vendor_model, Robot) else load_model(str(vendor_model)))
    cal = controller_model(robot, drawn)  # DataError: the model the vendor draws is another robot's
    B, M, *check = _link_maps(chain, drawn.nominal_robot(), vendor_file)
    zero = np.zeros((1, robot.n_joints))
    _, F = chain_frames(cal.links, cal.base, cal.tool, zero, frames=True, prismatic=cal.prismatic)
    origins = chain.origins.copy()
    for i in chain.moving:
        f = chain.frame[i + 1]
        origins[i] = invert_transform(M[i]) @ invert_transform(F[0, f - 1]) @ F[0, f] @ M[i + 1]
    new_text = _with_origins(text, {chain.joints[i].get("name"): origins[i] for i in chain.moving})
    result = _result(robot, drawn, vendor_file, root.get("name") or "", chain, B, M, check, new_text, cal)
    result.output = None if output is None else str(output)
    result.warnings[:0] = dropped
    result.text = _with_comment(new_text, _shift_comment(result))
    if xacro is not None:
        macro = _with_origins(read_text(xacro, "vendor xacro macro"),
                              {chain.joints[i].get("name"): origins[i] for i in chain.moving}, str(xacro))
        result.xacro, result.xacro_text = str(xacro), _with_comment(macro, _shift_comment(result))
        result.xacro_output = None if xacro_output is None else str(xacro_output)
    return result


def _dropped_terms(robot: Robot, geometry_only: bool) -> list[str]:
    """What leaving ``robot``'s joint-error terms out of a URDF costs, as a warning (with
    ``geometry_only``), or DataError when they move the TCP by more than `DROPPED_TERMS_MM` on
    average over `FK_POSES` random joint vectors (their conditions unknown: no payload, the
    reference temperature)."""
    if robot.joint_errors is None:
        return []
    q = _random_joints(robot, FK_POSES, seed=2)
    rigid = replace(robot, joint_errors=None)
    gap = np.linalg.norm(robot.fk(q)[:, :3, 3] - rigid.fk(q)[:, :3, 3], axis=1) * 1e3
    said = (f"{robot.name}'s joint-error terms ({', '.join(robot.joint_errors.names)}) move its TCP by "
            f"{gap.mean():.3f} mm on average, {gap.max():.3f} mm at most, over {FK_POSES} joint vectors; a "
            "URDF has rigid links and exact joints, so it holds the geometry without them")
    if gap.mean() <= DROPPED_TERMS_MM:
        return []
    if not geometry_only:
        raise DataError(f"{said}, which is not the calibrated robot: calibrate with --nongeometric none "
                        "(nongeometric=None) for ROS, or give --geometry-only to write it anyway")
    return [f"{said}: this URDF is not the calibrated robot (calibrate with --nongeometric none for ROS)"]


def _result(robot, controller, vendor_file, robot_name, chain, B, M, check, new_text, cal):
    """The checks of an export: the written text read back, its FK against the calibrated model's
    (base_link to tool0, base_link wherever it rides: before a track or after it), the shifts per
    joint, the warnings."""
    written = _Chain.read(parse_urdf(new_text), chain.links[-1])
    q = _random_joints(controller, FK_POSES, seed=1)
    base_at = chain.links.index("base_link") if "base_link" in chain.links else 0
    poses = written.poses(q)
    _, frames = chain_frames(cal.links, cal.base, cal.tool, q, frames=True, prismatic=cal.prismatic)
    links = B @ frames[:, chain.frame[[base_at, -1]]] @ M[[base_at, -1]]  # base_link and the tip
    # the tip from base_link and, where they differ (a track before base_link), from the root link
    mine = np.stack([invert_transform(poses[:, base_at]) @ poses[:, -1], poses[:, -1]])
    theirs = np.stack([invert_transform(links[:, 0]) @ links[:, 1], links[:, 1]])
    dist, angle = _pose_gap(mine, theirs)
    if dist.max() > FK_TOL_M or angle.max() > FK_TOL_RAD:
        raise RobocalError(f"internal: the written URDF's FK is {dist.max() * 1e3:.3g} mm / "
                           f"{angle.max():.3g} rad off the calibrated model's")
    vendor0, new0 = chain.poses(q[:1])[0], written.poses(q[:1])[0]
    frame_mm, frame_rad = _pose_gap(invert_transform(vendor0[base_at]) @ vendor0,
                                    invert_transform(new0[base_at]) @ new0)
    origin_mm, origin_rad = _pose_gap(chain.origins, written.origins)  # as the file holds them
    shifts = [JointShift(chain.joints[i].get("name"), chain.links[i + 1], float(origin_mm[i] * 1e3),
                         float(np.rad2deg(origin_rad[i])), float(frame_mm[i + 1] * 1e3),
                         float(np.rad2deg(frame_rad[i + 1]))) for i in chain.moving]
    warnings = [] if not_carried(robot) is None else [not_carried(robot)]
    far = [s.joint for s in shifts if s.origin_mm > GOAL_MM or s.origin_deg > GOAL_DEG]
    if far:
        warnings.append(f"the origins of {', '.join(far)} moved more than {GOAL_MM:g} mm or {GOAL_DEG:g} deg "
                        "from the vendor's (more than a typical calibration): their meshes hang that far "
                        "from where the vendor drew them")
    base = invert_transform(vendor0[base_at]) @ B @ cal.base  # robocal's frame {0} in base_link at q = 0
    tool = invert_transform(controller.tool) @ M[-1]
    fk_frames = " and ".join(f"{chain.links[k]} -> {chain.links[-1]}" for k in dict.fromkeys((base_at, 0)))
    return UrdfLikeExport(robot, controller, vendor_file, robot_name, new_text, base, tool,
                          (check[0], check[1]), shifts, (float(dist.max()), float(angle.max()), FK_POSES),
                          warnings=warnings, fk_frames=fk_frames)
