"""Plane contacts (seed 004): a probe tip touches flat plates; only the joints are recorded.

The probe tip is the tool translation (the seed's pt_x, pt_y, pt_z = ``tool.x/y/z``); the
world frame is the robot base frame, in which the planes are expressed. One residual per
contact: measured minus modelled signed distance of the tip to its plane, i.e. ``-h`` with
``h`` the orthogonal signed distance of the modelled tip.

Plane parametrisation. Plane ``k`` (the data's ``plane`` index) is ``p_d = a p_u + b p_v + c``
with nuisance parameters ``plane{k}.a``, ``plane{k}.b``, ``plane{k}.c`` (c in m). The seed writes
``z = a x + b y + c``; that cannot represent a plane whose normal is far from z, so each plane's
dependent coordinate ``d`` is the axis closest to its normal, chosen once from the tip points of
the model the observation is built with (principal axes of the points); ``(u, v)`` are the two
other axes in cyclic order (d = z: u = x, v = y; d = x: u = y, v = z; d = y: u = z, v = x).
:attr:`PlaneObservation.dependent_axis` records the choice.

Two formulations of the same cost:

- nuisance (``residuals`` / ``jacobian``): the plane coefficients are unknowns identified jointly
  with the robot, so ``lsq`` and ``robust`` work on plane data;
- variable projection (:meth:`PlaneObservation.profiled_residuals_batch`, the seed's): for each
  candidate robot the planes are fitted by (weighted) least squares of ``p_d`` on ``(p_u, p_v, 1)``
  to the modelled tip points, and the residuals are the distances to those planes. The
  metaheuristics (``swarm``, ``genetic``) use this, so they search the robot parameters only.

What plane contacts cannot see (so ``params='auto'`` leaves it out, see :func:`not_observable`):

- the base frame ``base.*``: the planes are expressed in it, and moving it moves the planes;
- the overall scale: scaling every length (links, tool, planes) about the base origin keeps every
  contact on its plane, and shrinking the model shrinks the residuals, so a free scale collapses.
  The longest nominal link length (:func:`scale_reference`) is held at its nominal value to fix it;
  its own error then scales the whole model (0.5 mm on an 800 mm link is 0.06 %).

The identifiability analysis reports the rest honestly: with three planes of independent normals
the first link's rigid motions (alpha1, a1, theta1, d1) are absorbed by the plane coefficients;
with one plane the in-plane translations and the rotation about its normal are not seen at all.
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.identify.observations.base import Observation

MIN_CONTACTS_PER_PLANE = 3
# |normal component| along a plane's dependent axis below which another data set's plane cannot be
# expressed in this set's parametrisation (it stands on edge): it is fitted instead
MIN_DEPENDENT_COMPONENT = 1e-6


def scale_reference(robot) -> str:
    """Name of the longest nominal link length (a_i or d_i): the one held fixed for the scale."""
    n = robot.n_joints
    lengths = np.abs(robot.nominal[: 5 * n].reshape(n, 5)[:, [1, 4]])
    i, j = np.unravel_index(np.argmax(lengths), lengths.shape)
    return f"{'ad'[j]}{i + 1}"


def not_observable(robot) -> list[str]:
    """Parameters plane contacts can never identify: ``base.*`` and the scale reference."""
    return [f"base.{f}" for f in ("x", "y", "z", "rx", "ry", "rz")] + [scale_reference(robot)]


def check_enough_contacts(n_contacts: int, n_unknowns: int) -> None:
    """Raise IdentificationError unless there are more contacts than unknowns."""
    if n_contacts <= n_unknowns:
        raise IdentificationError(
            f"{n_contacts} plane contacts cannot determine {n_unknowns} unknowns (robot parameters plus 3 "
            f"coefficients per plane): record more than {n_unknowns} contacts (3 times as many is "
            "better), spread over each plane and over the robot's orientations")


class PlaneObservation(Observation):
    kind = "plane"
    rows_per_item = 1
    blind_spot = "plane contacts carry no length reference and do not see the base frame"
    world_frame = False

    def not_observable(self, robot) -> list[str]:
        return not_observable(robot)

    def scale_reference(self, robot) -> str:
        return scale_reference(robot)

    def check_enough(self, n_unknowns: int) -> None:
        check_enough_contacts(self.n_items, n_unknowns)

    def __init__(self, data, robot) -> None:
        super().__init__(data, robot)
        self._index_planes(data, "plane contacts use the probe tip (the tool point)")
        self.dependent_axis = self._choose_axes(self.modelled_points(robot))
        d = self.dependent_axis
        self.perm = np.stack([(d + 1) % 3, (d + 2) % 3, d], axis=1)  # (K, 3): u, v, d per plane
        self.nuisance_names = [f"plane{pid}.{c}" for pid in self.plane_ids for c in "abc"]
        self.nuisance_start(robot)  # raises when a plane's contacts are collinear

    def _index_planes(self, data, tool_point: str) -> None:
        """The planes of the rows (``plane_ids``, ``plane_of``, ``onehot (N, K)`` and the
        least-squares ``fit_weights (N, K)``); IdentificationError for a row on an SMR (``tool_point``
        says why) or a plane with fewer than `MIN_CONTACTS_PER_PLANE` contacts."""
        if self.smr.any():
            raise IdentificationError(f"{tool_point}: the smr column must be 0 on every row")
        self.plane_ids, self.plane_of = np.unique(np.asarray(data.plane, dtype=int), return_inverse=True)
        counts = np.bincount(self.plane_of, minlength=self.plane_ids.size)
        few = counts < MIN_CONTACTS_PER_PLANE
        if few.any():
            raise IdentificationError(
                f"plane(s) {self.plane_ids[few].tolist()} have only {counts[few].tolist()} contact(s): each "
                f"plane needs at least {MIN_CONTACTS_PER_PLANE} (better 10 or more) contacts spread over its "
                "surface")
        self.onehot = np.zeros((self.n_items, self.plane_ids.size))
        self.onehot[np.arange(self.n_items), self.plane_of] = 1.0
        w = 1.0 if self.item_sigma is None else 1.0 / self.item_sigma**2
        self.fit_weights = self.onehot * np.broadcast_to(w, (self.n_items,))[:, None]  # (N, K)

    # ---------------------------------------------------------------- geometry
    def _choose_axes(self, points: np.ndarray) -> np.ndarray:
        """Per plane the coordinate axis closest to the normal of its tip points (smallest
        principal axis), ``(K,)`` ints."""
        K = self.plane_ids.size
        W = self.onehot / self.onehot.sum(axis=0)
        centre = W.T @ points  # (K, 3)
        dev = points - centre[self.plane_of]
        cov = np.einsum("nk,ni,nj->kij", self.onehot, dev, dev)
        _, vec = np.linalg.eigh(cov)
        return np.argmax(np.abs(vec[:, :, 0]), axis=1).reshape(K)

    def _local(self, points: np.ndarray) -> np.ndarray:
        """Points ``(..., N, 3)`` reordered per contact to ``(u, v, d)`` of its plane."""
        idx = self.perm[self.plane_of]  # (N, 3)
        return np.take_along_axis(points, np.broadcast_to(idx, points.shape), axis=-1)

    def fit_planes(self, points: np.ndarray) -> np.ndarray:
        """Least-squares planes ``p_d = a p_u + b p_v + c`` through tip points ``(..., N, 3)``:
        coefficients ``(..., 3K)`` in nuisance order (vectorised over the leading dims)."""
        loc = self._local(points)
        A = np.concatenate([loc[..., :2], np.ones(loc.shape[:-1] + (1,))], axis=-1)  # (..., N, 3)
        G = np.einsum("nk,...ni,...nj->...kij", self.fit_weights, A, A)
        rhs = np.einsum("nk,...ni,...n->...ki", self.fit_weights, A, loc[..., 2])
        cond = np.linalg.cond(G)
        if not np.all(np.isfinite(cond)) or cond.max() > 1e14:
            raise IdentificationError("the contacts of a plane lie on a line: touch each plane at points "
                                      "spread over its surface (not along one edge)")
        coef = np.linalg.solve(G, rhs[..., None])[..., 0]
        return coef.reshape(coef.shape[:-2] + (-1,))

    def signed_distance(self, points: np.ndarray, nuisance: np.ndarray) -> np.ndarray:
        """Orthogonal signed distance ``(..., N)`` of tip points ``(..., N, 3)`` to their planes
        ``nuisance (..., 3K)`` (positive on the +d side), m."""
        coef = np.asarray(nuisance, float).reshape(nuisance.shape[:-1] + (-1, 3))[..., self.plane_of, :]
        loc = self._local(points)
        a, b, c = coef[..., 0], coef[..., 1], coef[..., 2]
        return (loc[..., 2] - a * loc[..., 0] - b * loc[..., 1] - c) / np.sqrt(1.0 + a * a + b * b)

    def plane_normals(self, nuisance: np.ndarray) -> np.ndarray:
        """Unit normals ``(K, 3)`` (base frame) of the planes ``nuisance (3K,)``."""
        coef = np.asarray(nuisance, float).reshape(-1, 3)
        local = np.column_stack([-coef[:, 0], -coef[:, 1], np.ones(len(coef))])
        n = np.zeros_like(local)
        np.put_along_axis(n, self.perm, local, axis=1)
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    # ---------------------------------------------------------------- Observation API
    def nuisance_start(self, robot) -> np.ndarray:
        """The planes fitted to the tip points of ``robot`` (so the start is consistent)."""
        return self.fit_planes(self.modelled_points(robot))

    def export_nuisance(self, nuisance: np.ndarray) -> dict[str, np.ndarray]:
        """Each plane as ``{"plane<id>": [nx, ny, nz, c]}``: unit normal and offset, n . p = c (m)."""
        coef = np.asarray(nuisance, float).reshape(-1, 3)
        normals = self.plane_normals(nuisance)
        scale = normals[np.arange(len(coef)), self.dependent_axis]  # n_d = 1 / sqrt(1 + a^2 + b^2)
        return {f"plane{pid}": np.append(normals[k], coef[k, 2] * scale[k])
                for k, pid in enumerate(self.plane_ids)}

    def import_nuisance(self, robot, entities: dict[str, np.ndarray]) -> np.ndarray:
        """Coefficients of the shared planes (in this data set's own dependent axes), the other
        planes fitted to ``robot``'s tips."""
        coef = self.nuisance_start(robot).reshape(-1, 3)
        for k, pid in enumerate(self.plane_ids):
            plane = entities.get(f"plane{pid}")
            if plane is None:
                continue
            n_u, n_v, n_d = np.asarray(plane[:3])[self.perm[k]]
            if abs(n_d) < MIN_DEPENDENT_COMPONENT:
                continue
            coef[k] = (-n_u / n_d, -n_v / n_d, plane[3] / n_d)
        return coef.reshape(-1)

    def residuals(self, robot, nuisance) -> np.ndarray:
        return -self.signed_distance(self.modelled_points(robot), nuisance)

    def jacobian(self, robot, names, nuisance) -> np.ndarray:
        """``(N, k + 3K)``: robot columns n . dp/dx, then the plane coefficients."""
        nuisance = np.asarray(nuisance, float)
        p = self.modelled_points(robot)
        h = self.signed_distance(p, nuisance)
        normal = self.plane_normals(nuisance)[self.plane_of]  # (N, 3)
        J_tip = self._tcp_jacobian(robot, names)
        J_robot = np.einsum("ni,nik->nk", normal, J_tip) if len(names) else np.zeros((self.n_items, 0))
        coef = nuisance.reshape(-1, 3)[self.plane_of]
        a, b = coef[:, 0], coef[:, 1]
        s = np.sqrt(1.0 + a * a + b * b)
        loc = self._local(p)
        cols = np.stack([-loc[:, 0] / s - h * a / s**2, -loc[:, 1] / s - h * b / s**2, -1.0 / s], axis=1)
        J_plane = (self.onehot[:, :, None] * cols[:, None, :]).reshape(self.n_items, -1)
        return np.concatenate([J_robot, J_plane], axis=1)

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        """Residuals ``(P, N)`` of displaced robots ``X (P, k)`` against fixed planes ``nuisance``."""
        tips = self.batch_tcp(robot, names, X)[..., :3, 3]
        return -self.signed_distance(tips, np.asarray(nuisance, float))

    def profiled_residuals_batch(self, robot, names, X) -> tuple[np.ndarray, np.ndarray]:
        """The seed's cost: per displaced robot ``X (P, k)`` the planes fitted to its own tip
        points; returns residuals ``(P, N)`` and the fitted coefficients ``(P, 3K)``."""
        tips = self.batch_tcp(robot, names, X)[..., :3, 3]
        coef = self.fit_planes(tips)
        return -self.signed_distance(tips, coef), coef

    def position_errors(self, robot, nuisance) -> np.ndarray:
        """``(N,)`` absolute distance of each modelled tip from its plane, m."""
        return np.abs(self.residuals(robot, nuisance))
