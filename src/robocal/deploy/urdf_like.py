"""A calibrated model written into the vendor's own URDF: the same document (robot name, links,
joints, meshes, limits, inertials, materials, extra frames such as ``base``, ``flange``, ``tool0``,
comments), with only the origins of its moving joints changed, so that its forward kinematics is the
calibrated model's and every link frame (where its mesh hangs) stays where the calibration put it.

The map between the vendor's frames and robocal's is found from the nominal models and checked:

1. The vendor's joint values are the controller's up to a sign and a zero per joint (`JointMap`,
   ``u = sign * q + offset``; the identity for the ROS-Industrial and UR files), so the n joint
   lines of the vendor's file at ``u = offset`` are robocal's nominal ones at q = 0 moved rigidly:
   the map and the rigid transform ``B`` (robocal's world in the vendor's root link) are fitted
   together (`_joint_map`: every sign and candidate zero at once, directions by Kabsch, points by
   the lines' normal distances), and every axis must then lie on the vendor's. UR's base_link, the
   controller's base turned by pi, comes out of the fit as such.
2. Every link of the vendor's chain rides on one of robocal's frames {f} (f: the moving joints
   before it); its pose in that frame, ``M = (B F_f(q))^-1 T_link(q)``, must be the same for every
   joint vector: checked on `CHECK_POSES` random ones (`MAP_TOL_REACHES`, `MAP_TOL_RAD`), else the vendor
   file is refused as another robot.
3. The calibrated link frames are ``B F_f(q) M`` with the calibrated chain F (its frame {0} the
   controller's base, `robocal.deploy.compensation.controller_model`): the origin of moving joint k
   becomes ``M_parent^-1 F_{k-1}(0)^-1 F_k(0) M_child Rot(axis, -offset_k)``. Its axis stays the
   vendor's exactly (M's origin is on the joint's line, so the calibrated rotation about frame
   {k}'s z is the vendor's joint turning about its own axis by ``sign``) and no fixed joint is
   added.
4. A work cell (`robocal.kinematics.workcell.Cell`, or its file): the arm as above, its ``B`` the
   cell's world for each positioner's branch (`_export_cell`).

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
from robocal.core.io import check_format, check_outputs, read_text, write_all
from robocal.core.magnitudes import CALIBRATED_TCP_MM, MODEL_MIN_REACH_M
from robocal.deploy.compensation import controller_model
from robocal.deploy.models import controller_for
from robocal.kinematics.cell_file import is_workcell
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.model import Robot, links_length, load_model
from robocal.kinematics.model_file import read_model_data
from robocal.kinematics.transforms import invert_transform
from robocal.kinematics.urdf import not_carried
from robocal.kinematics.urdf_read import joint_axis, joint_origin, matrix_to_rpy, parse_urdf, urdf_chain
from robocal.kinematics.workcell import Cell, load_cell

# a vendor link's pose in robocal's frame may vary this much over joint vectors, in reaches of the arm
# (`_tol_m`: 1 um on a KR 16's 2.5 m; the vendor files round pi/2 to 1e-10; looser, the refined
# offsets of `_refined` keep micro-radian residues that pass for a map with one more offset)
MAP_TOL_REACHES = 4e-7
MAP_TOL_RAD = 1e-6  # rad: the same for its orientation
CHECK_POSES = 256  # random joint vectors the map is checked on
FK_POSES = 1000  # random joint vectors the written file's FK is compared on
FK_TOL_REACHES = 1e-9  # the written file's FK off the calibrated model's beyond this: an internal error
FK_TOL_RAD = 1e-9  # rad: the same for the orientation
KEPT_BELOW = 1e-12  # m, rad: a new origin's number this close to the vendor's is written as the vendor's
OFFSET_CANDIDATES = (0.0, np.pi / 2, np.pi, -np.pi / 2)  # rad: a vendor joint's zero tried against the
# controller's (then refined: any value), for the revolute joints but the first and the last
SNAP_RAD = 1e-9  # rad: a refined offset this close to a candidate is the candidate
REFINED = 8  # best candidate maps refined by least squares when none holds as tried
GOAL_MM = 1.0  # a joint origin moved further than this from the vendor's is said (meshes move with it)
GOAL_DEG = 0.1  # the same, deg
_MOVING = ("revolute", "continuous", "prismatic")
FLANGE_LINKS = ("tool0", "flange")  # links at the controller's flange (ROS-Industrial, REP 199)
_WHY_NOT = ("(another robot, joints that differ from the controller's by more than a sign and a zero, or a "
            "controller's model that is not what the file draws: give that as --vendor-model)")


def parse_joint_map(items) -> dict[str, tuple[float, float]]:
    """``{joint: (sign, offset_rad)}`` from ``NAME=SIGN,OFFSET_DEG`` texts (``joint_a4=1,-90``;
    sign 1 or -1, the offset in degrees) for `export_urdf_like`'s ``joint_map``.

    Examples
    --------
    >>> parse_joint_map(["joint_a2=-1,0", "joint_a4=1,90"])["joint_a4"]
    (1.0, 1.5707963267948966)
    """
    out = {}
    for item in items or ():
        name, _, value = str(item).partition("=")
        parts = value.split(",")
        try:
            sign, offset = float(parts[0]), float(parts[1]) if len(parts) == 2 else None
        except ValueError:
            sign = offset = None
        if not name or sign not in (1.0, -1.0) or offset is None or not np.isfinite(offset) or name in out:
            raise DataError(f"--joint-map {item!r}: give NAME=SIGN,OFFSET_DEG once per joint, SIGN 1 or -1 "
                            "(the vendor's joint value = SIGN * the controller's + OFFSET)")
        out[name] = (sign, float(np.deg2rad(offset)))
    return out


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


def _tol_m(robot: Robot, reaches: float) -> float:
    """A length tolerance (m) of ``reaches`` times ``robot``'s reach (its link lengths, at least the
    smallest arm's, `MODEL_MIN_REACH_M`): a position compared over the arm is off by rounding in
    proportion to its size."""
    return reaches * max(links_length(robot), MODEL_MIN_REACH_M)


def _random_joints(robot: Robot, count: int, seed: int = 0) -> np.ndarray:
    """``(count, n)`` joint vectors within ``robot``'s limits (rad, m), q = 0 first."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    q = np.random.default_rng(seed).uniform(lo, hi, (count, robot.n_joints))
    q[0] = 0.0
    return q


@dataclass(frozen=True)
class JointMap:
    """The vendor's joint values from the controller's: ``u = signs * q + offsets`` per moving
    joint (``(n,)`` each; rad, or m for a slide, whose offset is 0)."""

    signs: np.ndarray
    offsets: np.ndarray
    alternative: JointMap | None = None  # another map as good among the candidates, when not the identity
    given: bool = False  # the user's (checked), not found

    @classmethod
    def identity(cls, n: int) -> JointMap:
        return cls(np.ones(n), np.zeros(n))

    def to_dict(self) -> dict:
        return {"signs": self.signs.tolist(), "offsets_rad": self.offsets.tolist()}

    def vendor(self, q: np.ndarray) -> np.ndarray:
        """The vendor's joint values ``(N, n)`` of the controller's ``q`` ``(N, n)``."""
        return q * self.signs + self.offsets

    @property
    def is_identity(self) -> bool:
        return bool(np.all(self.signs == 1) and np.all(self.offsets == 0))

    def text(self, names: list[str]) -> list[str]:
        """One line per joint the map changes: ``joint_3 = -q3 + 1.570796 rad``."""
        return [f"{name} = {'-' if s < 0 else ''}q{k + 1}"
                + (f" {'+-'[int(o < 0)]} {abs(o):.9g} rad" if o else "")
                for k, (name, s, o) in enumerate(zip(names, self.signs, self.offsets, strict=True))
                if s != 1 or o != 0]


def _lines(chain: _Chain, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vendor's joint lines at joint values ``u`` ``(C, n)``: points and unit directions
    ``(C, n, 3)`` in its root link."""
    poses = chain.poses(u)[:, [i + 1 for i in chain.moving]]
    return poses[..., :3, 3], np.einsum("ckij,kj->cki", poses[..., :3, :3], chain.axes[chain.moving])


def _fit_all(P: np.ndarray, Z: np.ndarray, vP: np.ndarray, vZ: np.ndarray, signs: np.ndarray,
             revolute: np.ndarray,
             fixed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rigid transforms ``(C, S, 4, 4)`` carrying robocal's joint lines (points ``P``, unit
    directions ``Z`` ``(n, 3)``) onto the vendor's (``vP``, ``vZ`` ``(C, n, 3)``: ``C`` candidate
    offsets) with the directions turned by ``S`` sign vectors ``(S, n)``: rotation by Kabsch on the
    directions, translation by least squares of the distances to the vendor's lines (``revolute``
    joints only: a slide's line has no position); and each joint line's distance (m) and angle
    (rad) ``(C, S, n)`` from the vendor's after the fit. ``fixed`` ``(4, 4)``: that transform
    instead of the fit (a positioner in the world its cell's arm fixed)."""
    vZs = vZ[:, None] * signs[None, :, :, None]  # (C, S, n, 3)
    if fixed is not None:
        R = np.broadcast_to(fixed[:3, :3], (*vZs.shape[:2], 3, 3))
        t = np.broadcast_to(fixed[:3, 3], (*vZs.shape[:2], 3))
    else:
        U, _, Vt = np.linalg.svd(np.einsum("ki,cskj->csij", Z, vZs))
        D = np.broadcast_to(np.eye(3), U.shape).copy()
        D[..., 2, 2] = np.sign(np.linalg.det(np.swapaxes(Vt, -1, -2) @ np.swapaxes(U, -1, -2)))
        R = np.swapaxes(Vt, -1, -2) @ D @ np.swapaxes(U, -1, -2)
        normal = np.eye(3) - vZ[..., :, None] * vZ[..., None, :]  # (C, n, 3, 3)
        normal = normal * revolute[None, :, None, None]
        rhs = np.einsum("ckij,cskj->cski", normal, vP[:, None] - np.einsum("csij,kj->cski", R, P))
        t = np.einsum("cij,csj->csi", np.linalg.pinv(normal.sum(1)), rhs.sum(2))
    mapped_Z = np.einsum("csij,kj->cski", R, Z)
    angle = np.arctan2(np.linalg.norm(np.cross(mapped_Z, vZs), axis=-1),
                       np.einsum("cski,cski->csk", mapped_Z, vZs))
    gap = np.einsum("csij,kj->cski", R, P) + t[:, :, None] - vP[:, None]
    along = np.einsum("cski,cki->csk", gap, vZ)[..., None] * vZ[:, None]
    dist = np.linalg.norm(gap - along, axis=-1) * revolute
    T = np.broadcast_to(np.eye(4), (*R.shape[:2], 4, 4)).copy()
    T[..., :3, :3], T[..., :3, 3] = R, t
    return T, dist, angle


def _joint_map(chain: _Chain, nominal: Robot, vendor_file: str, B: np.ndarray | None = None,
               given: dict | None = None) -> tuple[JointMap, np.ndarray]:
    """The map from the controller's joints to the vendor's (`JointMap`) and ``B`` (robocal's world
    in the vendor's root link) that make the vendor's joint lines robocal's nominal ones moved
    rigidly; DataError (naming the worst joint) when no such map exists.

    Every sign and, for the revolute joints but the first (its offset is the base map's turn about
    it) and the last (its offset is tool0's turn in the flange), every offset in
    `OFFSET_CANDIDATES` is tried at once; when none holds, the best few are refined by least
    squares over the offsets (any value). Among the maps that hold, the one with the fewest offsets,
    then the fewest signs turned, is taken: the vendor's joint values equal the controller's where
    the file allows it (a spherical wrist also fits joint 4 turned by pi with joint 5 reversed).
    ``B`` given (a positioner in its cell's world): no fit, and the first joint's offset is tried too.
    ``given`` (`parse_joint_map`; a joint not named: sign 1, offset 0): that map only, checked."""
    n = nominal.n_joints
    _, frames = chain_frames(nominal.links, nominal.base, nominal.tool, np.zeros((1, n)), frames=True,
                             prismatic=nominal.prismatic)
    P, Z = frames[0, 1:, :3, 3], frames[0, 1:, :3, 2]
    revolute = ~np.asarray(nominal.prismatic, bool)
    if given is None:
        free = [k for k in np.flatnonzero(revolute) if (k > 0 or B is not None) and k < n - 1]
        grid = np.zeros((1, 0))  # no offset to try (a one-axis positioner)
        if free:
            grid = np.array(np.meshgrid(*[OFFSET_CANDIDATES] * len(free), indexing="ij"))
            grid = grid.reshape(len(free), -1).T
        offsets = np.zeros((len(grid), n))
        offsets[:, free] = grid
        signs = np.array(np.meshgrid(*[[1.0, -1.0]] * n, indexing="ij")).reshape(n, -1).T
    else:
        free, pairs = [], [given.get(chain.joints[i].get("name"), (1.0, 0.0)) for i in chain.moving]
        signs, offsets = np.array([[p[0] for p in pairs]]), np.array([[p[1] for p in pairs]])
        if (offsets[0] != 0)[~revolute].any():
            raise DataError("--joint-map: a prismatic joint's zero is its origin: give it no offset")
    vP, vZ = _lines(chain, offsets)
    T, dist, angle = _fit_all(P, Z, vP, vZ, signs, revolute, B)
    tol_m = _tol_m(nominal, MAP_TOL_REACHES)
    score = np.maximum(dist / tol_m, angle / MAP_TOL_RAD).max(-1)  # (C, S)
    cost = (np.count_nonzero(offsets, axis=1)[:, None] * (n + 1) + (signs < 0).sum(1)[None, :]).astype(float)
    if not (score <= 1).any() and free:
        refined = _refined(chain, P, Z, signs, revolute, offsets, score, free, B, tol_m)
        if refined is not None:
            return refined
    cost = np.where(score <= 1, cost, np.inf)
    c, s = np.unravel_index(np.argmin(cost), score.shape)
    if score[c, s] > 1:
        c, s = np.unravel_index(np.argmin(score), score.shape)
        k = int(np.argmax(np.maximum(dist[c, s] / tol_m, angle[c, s] / MAP_TOL_RAD)))
        name = chain.joints[chain.moving[k]].get("name")
        how = "with the given joint map" if given is not None else "with any joint's sign and zero"
        raise DataError(f"{vendor_file} is not {nominal.name}: the axis of its joint {name} is "
                        f"{dist[c, s, k] * 1e3:.3g} mm / {np.rad2deg(angle[c, s, k]):.3g} deg off the "
                        f"model's joint {k + 1} after the best rigid fit of all the axes, {how} {_WHY_NOT}")
    alternative = None
    cost[c, s] = np.inf
    if ((signs[s] < 0).any() or offsets[c].any()) and np.isfinite(cost).any():
        a, b = np.unravel_index(np.argmin(cost), score.shape)
        alternative = JointMap(signs[b], offsets[a])
    return JointMap(signs[s], offsets[c], alternative, given is not None), T[c, s]


def _refined(chain, P, Z, signs, revolute, offsets, score, free, B,
             tol_m: float) -> tuple[JointMap, np.ndarray] | None:
    """The offsets (any value) of the `REFINED` best candidates of `_joint_map` refined by least
    squares of the joint lines' gaps: of the maps that then hold, the one with the fewest offsets
    (then reversed joints), another as its ``alternative``; None when none holds."""
    from scipy.optimize import least_squares

    found = {}
    for c, s in zip(*np.unravel_index(np.argsort(score, axis=None)[:REFINED], score.shape), strict=True):
        def gaps(x, c=c, s=s):
            u = offsets[c].copy()
            u[free] = x
            vP, vZ = _lines(chain, u[None])
            _, dist, angle = _fit_all(P, Z, vP, vZ, signs[s:s + 1], revolute, B)
            return np.concatenate([dist[0, 0] / tol_m, angle[0, 0] / MAP_TOL_RAD])

        fit = least_squares(gaps, offsets[c, free], jac="3-point", diff_step=1e-5, xtol=1e-15, ftol=1e-15,
                            gtol=1e-15)
        if np.abs(gaps(fit.x)).max() > 1:
            continue
        u = offsets[c].copy()
        u[free] = np.remainder(fit.x + np.pi, 2 * np.pi) - np.pi
        near = np.asarray(OFFSET_CANDIDATES)[np.argmin(np.abs(u[:, None] - OFFSET_CANDIDATES), axis=1)]
        u = np.where(np.abs(u - near) < SNAP_RAD, near, u)  # a candidate the refinement kept
        key = (np.count_nonzero(u), int((signs[s] < 0).sum()), tuple(np.round(u, 6)), tuple(signs[s]))
        found.setdefault(key, (u, s))
    if not found:
        return None
    ranked = [found[k] for k in sorted(found)]
    (u, s), other = ranked[0], ranked[1] if len(ranked) > 1 else None
    vP, vZ = _lines(chain, u[None])
    T, *_ = _fit_all(P, Z, vP, vZ, signs[s:s + 1], revolute, B)
    alternative = None if other is None else JointMap(signs[other[1]], other[0])
    return JointMap(signs[s], u, alternative), T[0, 0]


def _link_maps(chain: _Chain, nominal: Robot, vendor_file: str, B: np.ndarray | None = None,
               given: dict | None = None) -> tuple[np.ndarray, np.ndarray, float, float, JointMap]:
    """``B`` (robocal's world in the vendor's root link), the links' poses ``M`` ``(m + 1, 4, 4)`` in
    the robocal frame each rides on, the check's largest variation (m, rad) and the joint map
    (`_joint_map`; ``B`` given: that one); DataError when the vendor's chain is not ``nominal``'s
    robot."""
    n = nominal.n_joints
    kinds = [chain.kinds[i] for i in chain.moving]
    if chain.n_moving != n or [k == "prismatic" for k in kinds] != list(nominal.prismatic):
        raise DataError(f"{vendor_file} is not {nominal.name}: its chain to {chain.links[-1]} has "
                        f"{chain.n_moving} moving joints ({', '.join(kinds)}), the model {n}")
    joint_map, B = _joint_map(chain, nominal, vendor_file, B, given)
    q = _random_joints(nominal, CHECK_POSES)
    vendor = chain.poses(joint_map.vendor(q))
    _, frames = chain_frames(nominal.links, nominal.base, nominal.tool, q, frames=True,
                             prismatic=nominal.prismatic)
    M = invert_transform(B @ frames[:, chain.frame]) @ vendor  # (N, m + 1, 4, 4)
    dist, angle = _pose_gap(M, M[:1])
    off = np.flatnonzero((dist.max(0) > _tol_m(nominal, MAP_TOL_REACHES)) | (angle.max(0) > MAP_TOL_RAD))
    if off.size:
        worst = int(off[0])  # the first link along the chain that does not follow robocal's frame
        raise DataError(f"{vendor_file} is not {nominal.name}: its link {chain.links[worst]} moves "
                        f"{dist[:, worst].max() * 1e3:.3g} mm / {np.rad2deg(angle[:, worst].max()):.3g} deg "
                        f"against robocal's frame {{{chain.frame[worst]}}} over {CHECK_POSES} joint vectors "
                        f"{_WHY_NOT}")
    _check_flange(chain, M[0], nominal, vendor_file)
    return B, _on_axes(chain, M[0], joint_map.signs), float(dist.max()), float(angle.max()), joint_map


def _check_flange(chain: _Chain, M: np.ndarray, nominal: Robot, vendor_file: str) -> None:
    """DataError when a link of the chain named as the flange (`FLANGE_LINKS`: ROS-Industrial's
    ``tool0`` is the controller's flange) has its origin off robocal's flange frame {n} (``M``: the
    links' poses in the frames they ride on): a vendor file whose tool0 was 1 m beyond the flange
    was written, exit 0, with its base_link-to-tool0 FK 1 m off the calibrated model's."""
    for i, link in enumerate(chain.links):
        if link in FLANGE_LINKS and chain.frame[i] == chain.n_moving:
            off = float(np.linalg.norm(M[i, :3, 3]))
            if off > _tol_m(nominal, MAP_TOL_REACHES):
                raise DataError(f"{vendor_file} is not {nominal.name}: its {link} is {off * 1e3:.4g} mm "
                                f"from the model's flange (ROS-Industrial's {link} is the controller's "
                                f"flange) {_WHY_NOT}")


def _on_axes(chain: _Chain, M: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """The links' poses ``M`` ``(m + 1, 4, 4)`` made exact where the map holds to rounding only: each
    moving joint's child carries the vendor's axis exactly onto robocal's z turned by the joint's
    sign (``signs`` ``(n,)``; the smallest turn) with its origin on that z (a revolute joint), and
    every link after a fixed joint sits at the vendor's origin from its parent; so the written joints
    turn about the vendor's axes and the file's FK is the calibrated model's to rounding, not to the
    vendor file's rounding of pi/2 (UR: 1e-10)."""
    M = M.copy()
    for i, kind in enumerate(chain.kinds):
        if kind == "fixed":
            M[i + 1] = M[i] @ chain.origins[i]
            continue
        v = M[i + 1, :3, :3] @ chain.axes[i]
        w = np.cross(v, [0.0, 0.0, signs[chain.frame[i + 1] - 1]])
        turn = np.arctan2(np.linalg.norm(w), v[2] * signs[chain.frame[i + 1] - 1])
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
    vectors), the ``joint_map`` (`JointMap`: the vendor's joint values from the controller's),
    ``world`` (robocal's world in the vendor's root link, 4x4 m), a cell's other bodies in ``bodies``
    (per body: its unit, root and tip links, FK and map checks, joint map and joints) and the
    ``warnings``.

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
    joint_map : JointMap, optional
        The vendor's joint values from the controller's (``u = sign * q + offset``).
    world : ndarray, shape (4, 4), optional
        robocal's world in the vendor's root link (the map ``B``).
    bodies : dict
        A cell's other bodies: unit, root and tip links, FK and map checks, joint map, joints.
    inputs : list of str
        The model files read (given by path), which `write` never writes over.

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
    joint_map: JointMap | None = None
    world: np.ndarray | None = None  # (4, 4) robocal's world in the vendor's root link (the map B)
    bodies: dict = field(default_factory=dict)  # a cell's other bodies: tip, checks, joint map, joints
    inputs: list[str] = field(default_factory=list)  # the model files read: never written over

    def _map_lines(self) -> list[str]:
        """The joints whose values are not the controller's (``u = sign * q + offset``)."""
        if self.joint_map is None or self.joint_map.is_identity:
            return []
        return self.joint_map.text([s.joint for s in self.shifts[:len(self.joint_map.signs)]])

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
                 *([f"joint values: the vendor's from the controller's q: {'; '.join(self._map_lines())}"]
                   if self._map_lines() else []),
                 *(f"{name} ({b['unit']}): FK {b['root']} -> {b['tip']} = the calibrated body's within "
                   f"{b['fk_check'][0] * 1e3:.2g} mm / {b['fk_check'][1]:.2g} rad ({b['fk_check'][2]} joint "
                   "vectors), in the arm's map" for name, b in self.bodies.items()),
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
                "joint_map": None if self.joint_map is None else self.joint_map.to_dict(),
                "bodies": {name: {**b, "joint_map": b["joint_map"].to_dict()}
                           for name, b in self.bodies.items()},
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
            No path, a path named for another format than URDF, or a path that is one of the
            files read (the vendor's, the model files: never overwritten).
        """
        path = path if path is not None else self.output
        xacro_path = xacro_path if xacro_path is not None else self.xacro_output
        if path is None or (self.xacro_text is not None and xacro_path is None):
            raise DataError("no output path: give write(path, xacro_path) or export_urdf_like(..., output=, "
                            "xacro_output=)")
        texts = {path: self.text} | ({} if self.xacro_text is None else {xacro_path: self.xacro_text})
        check_format(path, "URDF", "path")  # as robocal export --urdf-like -o does
        check_outputs(list(texts), [self.vendor, self.xacro, *self.inputs])
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
            f"flange.\n{_map_comment(result)}     FK {result.fk_frames.replace('->', 'to')} = the "
            "calibrated model's within "
            f"{mm * 1e3:.2g} mm / {rad:.2g} rad ({count} joint vectors).\n     Moved from the vendor's "
            f"(joint origin; the link's frame in base_link at q = 0):\n{rows}\n{_bodies_comment(result)}")


def _bodies_comment(result: UrdfLikeExport) -> str:
    return "".join(f"     {name} ({b['unit']}, joints {', '.join(b['joints'])}; its link frames above in "
                   f"{b['root']}): FK {b['root']} to {b['tip']} = the calibrated body's within "
                   f"{b['fk_check'][0] * 1e3:.2g} mm / {b['fk_check'][1]:.2g} rad ({b['fk_check'][2]} joint "
                   "vectors)\n" + "".join(f"       {line}\n" for line in b["joint_map"].text(b["joints"]))
                   for name, b in result.bodies.items())


def _map_comment(result: UrdfLikeExport) -> str:
    lines = result._map_lines()
    if not lines:
        return ""
    return ("     Joint values: this file's are not the controller's q (robocal's model) for\n" +
            "".join(f"       {line}\n" for line in lines) +
            "     (the ROS driver must send these values: check it does before use).\n")


# ----------------------------------------------------------------- the export
def export_urdf_like(calibrated: Robot | str, vendor_urdf, nominal: Robot | str | None = None,
                     output=None, tip: str | None = None, xacro=None, xacro_output=None,
                     geometry_only: bool = False, vendor_model: Robot | str | None = None,
                     joint_map: dict[str, tuple[float, float]] | None = None) -> UrdfLikeExport:
    """The vendor's URDF (``vendor_urdf``: a path, as xacro expands it) with the kinematics of
    ``calibrated`` (a `Robot`, model file or catalog name).

    Parameters
    ----------
    calibrated : Robot, Cell or str
        The calibrated model; its frame {0} is taken as the controller's base and the flange as
        the nominal model's (`robocal.deploy.compensation.controller_model`). Or a calibrated work
        cell (`Cell`, or its file from ``robocal calibrate --model``): its arms and positioners,
        all in the one vendor file (the first arm's tip ``tip`` or tool0; each other body on the
        branch that fits it where the cell puts it; its joints' origins take its calibrated axes
        and base or mount); ``nominal``, ``vendor_model`` and ``xacro`` are then not taken.
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
    joint_map : dict, optional
        The vendor's joint values from the controller's, ``{joint: (sign, offset_rad)}`` (a joint
        not named: 1, 0; `parse_joint_map` reads ``NAME=SIGN,OFFSET_DEG``), checked instead of
        found: to take the other map a spherical wrist allows.
    geometry_only : bool, default False
        Write the geometry of a model whose joint-error terms (compliance, backlash, ...) move its
        TCP by more than `CALIBRATED_TCP_MM` (refused otherwise: that URDF is not the calibrated
        robot; calibrate with ``nongeometric=None`` for ROS), with a warning saying how far.

    Returns
    -------
    UrdfLikeExport
        The text, the map, the checks, the joint map (``u = sign * q + offset`` where the vendor's
        joints are not the controller's) and the per-joint shifts (mm, deg); a cell's other arms
        and positioners in ``bodies``.

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
    inputs = [str(p) for p in (calibrated, nominal, vendor_model) if isinstance(p, str | Path)]
    if output is not None or xacro_output is not None:  # before any work; write() checks again
        check_format(output, "URDF", "output")
        check_outputs([output, xacro_output], [str(vendor_urdf), xacro, *inputs])
    cell = _as_cell(calibrated)
    if cell is not None:
        if nominal is not None or vendor_model is not None:
            raise DataError("a calibrated cell carries its bodies' nominal models: no --nominal or "
                            "--vendor-model for a cell")
        result = _export_cell(cell, str(vendor_urdf), output, tip, geometry_only, xacro, joint_map)
        result.inputs = inputs
        return result
    result, chain, origins = _export_arm(calibrated, str(vendor_urdf), nominal, tip, geometry_only,
                                         vendor_model, joint_map)
    result.inputs = inputs
    result.output = None if output is None else str(output)
    result.text = _with_comment(result.text, _shift_comment(result))
    if xacro is not None:
        macro = _with_origins(read_text(xacro, "vendor xacro macro"),
                              {chain.joints[i].get("name"): origins[i] for i in chain.moving}, str(xacro))
        result.xacro, result.xacro_text = str(xacro), _with_comment(macro, _shift_comment(result))
        result.xacro_output = None if xacro_output is None else str(xacro_output)
    return result


def _new_origins(chain: _Chain, M: np.ndarray, joint_map: JointMap, cal: Robot,
                 base: np.ndarray) -> np.ndarray:
    """The joint origins ``(m, 4, 4)`` that put each vendor link ``M`` (`_link_maps`) on the
    calibrated chain ``cal``'s frame, the links before the first moving joint staying on ``base``
    (the nominal frame {0}: the file's fixed joints are kept)."""
    _, F = chain_frames(cal.links, cal.base, cal.tool, np.zeros((1, cal.n_joints)), frames=True,
                        prismatic=cal.prismatic)
    F = F[0].copy()
    F[0] = base
    origins = chain.origins.copy()
    for i in chain.moving:
        f = chain.frame[i + 1]  # the vendor's joint at u = offset is robocal's at q = 0: turn it back
        back = _joint_motion(chain.axes[i], -joint_map.offsets[f - 1:f], chain.kinds[i] == "prismatic")[0]
        origins[i] = invert_transform(M[i]) @ invert_transform(F[f - 1]) @ F[f] @ M[i + 1] @ back
    return origins


def _export_arm(calibrated, vendor_file: str, nominal, tip, geometry_only, vendor_model, given):
    """The arm's export (`export_urdf_like` without the comment and the macro), its chain and its
    new joint origins."""
    robot = calibrated if isinstance(calibrated, Robot) else load_model(str(calibrated))
    controller = nominal if isinstance(nominal, Robot) else controller_for(robot, nominal)
    if controller is None:
        raise DataError(f"{robot.name} is not a catalog robot: give the controller's nominal model "
                        "(--nominal, a catalog name or model file), which the vendor's URDF must describe")
    dropped = _dropped_terms(robot, geometry_only)
    text = read_text(vendor_file, "vendor URDF")
    root = parse_urdf(text)
    names = {lk.get("name") for lk in root.findall("link")}
    chain = _Chain.read(root, tip if tip is not None else ("tool0" if "tool0" in names else None))
    unknown = set(given or {}) - {j.get("name") for j in root.findall("joint") if j.get("type") in _MOVING}
    if unknown:
        raise DataError(f"--joint-map names no moving joint of {vendor_file}: {', '.join(sorted(unknown))}")
    drawn = controller if vendor_model is None else (
        vendor_model if isinstance(vendor_model, Robot) else load_model(str(vendor_model)))
    cal = controller_model(robot, drawn)  # DataError: the model the vendor draws is another robot's
    B, M, *check, joint_map = _link_maps(chain, drawn.nominal_robot(), vendor_file, given=given)
    origins = _new_origins(chain, M, joint_map, cal, cal.base)
    new_text = _with_origins(text, {chain.joints[i].get("name"): origins[i] for i in chain.moving})
    result = _result(robot, drawn, vendor_file, root.get("name") or "", chain, B, M, check, new_text, cal,
                     joint_map)
    result.warnings[:0] = dropped
    return result, chain, origins


# ----------------------------------------------------------------- cells: an arm and its positioners
def _as_cell(calibrated) -> Cell | None:
    """``calibrated`` as a work cell (a `Cell`, or a cell file: several bodies), else None."""
    if isinstance(calibrated, Cell):
        return calibrated
    path = Path(str(calibrated))
    if isinstance(calibrated, Robot) or path.suffix.lower() not in (".yaml", ".yml") or not path.is_file():
        return None
    return load_cell(path) if is_workcell(read_model_data(path)) else None


def _export_cell(cell: Cell, vendor_file: str, output, tip, geometry_only, xacro, given) -> UrdfLikeExport:
    """`export_urdf_like` of a calibrated cell's arms and positioners into one vendor file: the
    first arm (the cell's anchor; its tip ``tip`` or tool0) as one robot, its map ``B`` fixing the
    cell's world in the file's root link; then each other body (arm, positioner) on the branch of
    the file that fits it with that ``B`` (`_branch`), its joints' origins corrected for its
    calibrated axes and its calibrated base or mount."""
    if xacro is not None:
        raise DataError(f"cell {cell.name!r}: no xacro macro for a cell (the macros are per robot)")
    (anchor, arm), *arms = cell.arms.items()
    result, chain, _ = _export_arm(arm, vendor_file, arm.nominal_robot(), tip, geometry_only, None, given)
    B = result.world
    root = parse_urdf(result.text)
    taken = {chain.joints[i].get("name") for i in chain.moving}
    others = [(name, body, cell.unit_of(name)) for name, body in arms]
    others += [(name, p.chain, p.unit) for name, p in cell.positioners.items()]
    for name, body, unit in others:
        drawn = body.nominal_robot()
        pchain, M, check, joint_map = _branch(root, taken, drawn, vendor_file, B, given, name)
        taken |= {pchain.joints[i].get("name") for i in pchain.moving}
        origins = _new_origins(pchain, M, joint_map, body, drawn.base)
        result.text = _with_origins(result.text,
                                    {pchain.joints[i].get("name"): origins[i] for i in pchain.moving})
        shifts, fk = _body_check(result.text, pchain, body, drawn, B, M, joint_map)
        result.shifts += shifts
        result.bodies[name] = {"unit": unit, "root": pchain.links[0], "tip": pchain.links[-1],
                               "fk_check": fk, "map_check": check, "joint_map": joint_map,
                               "joints": [s.joint for s in shifts]}
        far = [s.joint for s in shifts if s.origin_mm > GOAL_MM or s.origin_deg > GOAL_DEG]
        if far:
            result.warnings.append(f"{name}: the origins of {', '.join(far)} moved more than {GOAL_MM:g} mm "
                                   f"or {GOAL_DEG:g} deg from the vendor's: the calibrated cell has {name} "
                                   f"there (its base against {anchor}'s), and its meshes with it")
        if not joint_map.is_identity:
            result.warnings.append(f"{name}: the vendor's joint values are not the controller's: "
                                   f"{'; '.join(joint_map.text([s.joint for s in shifts]))}")
    result.output = None if output is None else str(output)
    result.text = _with_comment(result.text, _shift_comment(result))
    return result


def _branch(root: ET.Element, taken: set[str], drawn: Robot, vendor_file: str, B: np.ndarray, given,
            name: str) -> tuple[_Chain, np.ndarray, tuple[float, float], JointMap]:
    """The chain of the vendor's tree (root to a leaf) whose moving joints, none ``taken`` (another
    body's), are body ``name``'s (``drawn``, its nominal model in the cell's world) with the map
    ``B``; its `_link_maps`. DataError unless exactly one set of joints fits."""
    parents = {j.find("parent").get("link") for j in root.findall("joint")}
    chains: dict[tuple, str] = {}
    for link in root.findall("link"):
        if link.get("name") in parents:
            continue
        moving = tuple(j.get("name") for j in urdf_chain(root, link.get("name")) if j.get("type") in _MOVING)
        if len(moving) == drawn.n_joints and not taken & set(moving):
            chains.setdefault(moving, link.get("name"))
    fits, refused = [], []
    for leaf in chains.values():
        chain = _Chain.read(root, leaf)
        try:
            _, M, *check, joint_map = _link_maps(chain, drawn, vendor_file, B, given)
        except DataError as exc:
            refused.append(str(exc))
            continue
        fits.append((chain, M, (check[0], check[1]), joint_map))
    if len(fits) != 1:
        leaves = ", ".join(chains.values()) or "none"
        raise DataError(f"{vendor_file}: {len(fits) or 'no'} branches fit {name} ({drawn.name}) where the "
                        f"cell puts it (chains of {drawn.n_joints} moving joints but the first arm's: "
                        f"{leaves})"
                        + (f"; {refused[0]}" if refused and not fits else ""))
    return fits[0]


def _body_check(text: str, chain: _Chain, body: Robot, drawn: Robot, B: np.ndarray, M: np.ndarray,
                joint_map: JointMap) -> tuple[list[JointShift], tuple[float, float, int]]:
    """A positioner's written chain read back: its tip's pose in the root link against the
    calibrated body's (in the cell's world, ``B``) on `FK_POSES` joint vectors (RobocalError beyond
    `FK_TOL_REACHES`, `FK_TOL_RAD`), and how far each joint's origin and link frame (at q = 0, in the
    root link) moved from the vendor's."""
    written = _Chain.read(parse_urdf(text), chain.links[-1])
    q = _random_joints(drawn, FK_POSES, seed=1)
    _, frames = chain_frames(body.links, body.base, body.tool, q, frames=True, prismatic=body.prismatic)
    dist, angle = _pose_gap(written.poses(joint_map.vendor(q))[:, -1], B @ frames[:, chain.frame[-1]] @ M[-1])
    if dist.max() > _tol_m(body, FK_TOL_REACHES) or angle.max() > FK_TOL_RAD:
        raise RobocalError(f"internal: the written URDF's FK of {body.name} is {dist.max() * 1e3:.3g} mm / "
                           f"{angle.max():.3g} rad off the calibrated model's")
    vendor0, new0 = (c.poses(joint_map.vendor(q[:1]))[0] for c in (chain, written))
    frame_mm, frame_rad = _pose_gap(vendor0, new0)
    origin_mm, origin_rad = _pose_gap(chain.origins, written.origins)
    shifts = [JointShift(chain.joints[i].get("name"), chain.links[i + 1], float(origin_mm[i] * 1e3),
                         float(np.rad2deg(origin_rad[i])), float(frame_mm[i + 1] * 1e3),
                         float(np.rad2deg(frame_rad[i + 1]))) for i in chain.moving]
    return shifts, (float(dist.max()), float(angle.max()), FK_POSES)


def _dropped_terms(robot: Robot, geometry_only: bool) -> list[str]:
    """What leaving ``robot``'s joint-error terms out of a URDF costs, as a warning (with
    ``geometry_only``), or DataError when they move the TCP by more than `CALIBRATED_TCP_MM` on
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
    if gap.mean() <= CALIBRATED_TCP_MM:  # joint-error terms moving the TCP more: another robot
        return []
    if not geometry_only:
        raise DataError(f"{said}, which is not the calibrated robot: calibrate with --nongeometric none "
                        "(nongeometric=None) for ROS, or give --geometry-only to write it anyway")
    return [f"{said}: this URDF is not the calibrated robot (calibrate with --nongeometric none for ROS)"]


def _result(robot, controller, vendor_file, robot_name, chain, B, M, check, new_text, cal, joint_map):
    """The checks of an export: the written text read back, its FK against the calibrated model's
    (base_link to tool0, base_link wherever it rides: before a track or after it), the shifts per
    joint, the warnings."""
    written = _Chain.read(parse_urdf(new_text), chain.links[-1])
    q = _random_joints(controller, FK_POSES, seed=1)
    base_at = chain.links.index("base_link") if "base_link" in chain.links else 0
    poses = written.poses(joint_map.vendor(q))
    _, frames = chain_frames(cal.links, cal.base, cal.tool, q, frames=True, prismatic=cal.prismatic)
    links = B @ frames[:, chain.frame[[base_at, -1]]] @ M[[base_at, -1]]  # base_link and the tip
    # the tip from base_link and, where they differ (a track before base_link), from the root link
    mine = np.stack([invert_transform(poses[:, base_at]) @ poses[:, -1], poses[:, -1]])
    theirs = np.stack([invert_transform(links[:, 0]) @ links[:, 1], links[:, 1]])
    dist, angle = _pose_gap(mine, theirs)
    if dist.max() > _tol_m(cal, FK_TOL_REACHES) or angle.max() > FK_TOL_RAD:
        raise RobocalError(f"internal: the written URDF's FK is {dist.max() * 1e3:.3g} mm / "
                           f"{angle.max():.3g} rad off the calibrated model's")
    vendor0, new0 = (c.poses(joint_map.vendor(q[:1]))[0] for c in (chain, written))
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
    if not joint_map.is_identity:
        names = [s.joint for s in shifts]
        other = joint_map.alternative
        also = "" if other is None else (
            f"; the axes fit as well {'; '.join(other.text(names))}, with other links' meshes turned: check "
            "the file's zero pose against the robot's")
        how = "as given, checked on the axes" if joint_map.given else (
            "found from the axes: the fewest zeros moved, then the fewest joints reversed")
        warnings.append("the vendor's joint values are not the controller's: "
                        f"{'; '.join(joint_map.text(names))} ({how}); the ROS driver must send these "
                        f"values{also}")
    base = invert_transform(vendor0[base_at]) @ B @ cal.base  # robocal's frame {0} in base_link at q = 0
    # the controller's base frame is the nominal model's world (not its frame {0}, which a model
    # imported from a URDF places at joint 1): B maps that world into the vendor's root link
    drawn_base = invert_transform(vendor0[base_at]) @ B
    shift_mm = float(np.linalg.norm(drawn_base[:3, 3]) * 1e3)
    tilt_deg = float(np.rad2deg(np.arccos(np.clip(drawn_base[2, 2], -1.0, 1.0))))
    if shift_mm > GOAL_MM or tilt_deg > GOAL_DEG:  # ROS-Industrial's base_link is the controller's base
        warnings.append(f"the vendor's {chain.links[base_at]} is not the controller's base frame: that "
                        f"frame sits {shift_mm:.4g} mm away and {tilt_deg:.4g} deg tilted in it, so poses "
                        f"from {chain.links[base_at]} are not the controller's base-frame targets (the "
                        "file's FK is still the calibrated robot's)")
    tool = invert_transform(controller.tool) @ M[-1]
    fk_frames = " and ".join(f"{chain.links[k]} -> {chain.links[-1]}" for k in dict.fromkeys((base_at, 0)))
    return UrdfLikeExport(robot, controller, vendor_file, robot_name, new_text, base, tool,
                          (check[0], check[1]), shifts, (float(dist.max()), float(angle.max()), FK_POSES),
                          warnings=warnings, fk_frames=fk_frames, joint_map=joint_map, world=B)
