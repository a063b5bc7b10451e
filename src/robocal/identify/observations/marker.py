"""Motion-capture markers on any link: 3 residuals per row, measured minus modelled position.

Each row is one marker's position in the capture system's frame. The marker sits on the link
whose frame the row's ``link`` names (0 the robot's base frame {0}, i the frame after joint i, n the
flange; the CSV's ``link`` column; without it, every marker is on the flange) at an offset ``o_s``
in that frame, one per marker (the ``smr`` column numbers the markers, as it numbers a tracker's
SMRs). The model is

    p = W F_j(q) o_s

with ``F_j`` the pose of frame j in the robot's world (base frame included) and ``W`` the robot's
world in the capture frame. ``W`` (``capture.*``) and every marker's offset (``marker{s}.x/y/z``)
are nuisance parameters estimated with the robot (:mod:`robocal.identify.observations.rigid`),
started by alternating a rigid fit of W (Umeyama) with the offsets' linear least squares.

Only the parameters of the links up to j act on a marker on link j: the Jacobian's columns of
later links, of their joint-error terms and of the tool are zero on its rows. The robot's base and
tool frames and SMR offsets are not seen (``W`` and the offsets take their place).
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.data.registration import umeyama
from robocal.identify.observations.base import Observation
from robocal.identify.observations.rigid import (
    FRAME_FIELDS,
    frame_of,
    left_jacobian,
    nuisance_of,
    replaced_frames,
)
from robocal.kinematics.jacobian import jacobian_from_axes, robot_motion_axes
from robocal.kinematics.joint_errors import joint_error_basis
from robocal.kinematics.thermal import is_name as is_thermal
from robocal.kinematics.transforms import skew

START_ALTERNATIONS = 50  # rigid fit of W / offsets' least squares: the start of the joint estimate


class MarkerObservation(Observation):
    kind = "marker"
    frames_replace_base = True  # its frames take the robot base's place (trust.coverage)
    rows_per_item = 3
    blind_spot = "the capture frame and the markers' offsets replace the robot's base and tool frames"

    def __init__(self, data, robot) -> None:
        super().__init__(data, robot)
        n = robot.n_joints
        self.link = np.full(len(data), n) if data.link is None else robot.link_numbers(data.link)
        if self.link.max() > n:
            raise IdentificationError(f"link {int(self.link.max())} does not exist: {robot.name} has frames "
                                      f"0 (its base) to {n} (its flange)")
        if robot.joint_errors is not None and any(is_thermal(t) for t in robot.joint_errors.names):
            raise IdentificationError("markers on links take no thermal term: calibrate them with the "
                                      "geometric model or other joint-error terms")
        self.markers, self.marker_of = np.unique(self.smr, return_inverse=True)
        links = np.zeros(self.markers.size, int)
        links[self.marker_of] = self.link
        moved = np.flatnonzero(links[self.marker_of] != self.link)
        if moved.size:
            s = int(self.smr[moved[0]])
            on = sorted(set(self.link[self.smr == s].tolist()))
            raise IdentificationError(f"marker {s} is on two links ({on}): a marker stays on one link; "
                                      "number markers on other links apart")
        self.marker_link = links  # (K,) the link frame of each marker
        if (links == 0).all():
            raise IdentificationError("every marker is on the robot's base (link 0): markers on moving links "
                                      "are needed to see the robot")
        self.measured = np.asarray(data.points, float)
        self.W0 = self._alternate(robot)[0]  # the capture frame's reference (nuisance 0 at this robot)
        self.nuisance_names = [f"capture.{f}" for f in FRAME_FIELDS] + [
            f"marker{s}.{c}" for s in self.markers for c in "xyz"]

    def not_observable(self, robot) -> list[str]:
        return replaced_frames(robot)

    # ---------------------------------------------------------------- model
    def _link_frames(self, robot) -> np.ndarray:
        """``(N, 4, 4)`` world pose of each row's link frame."""
        _, frames = robot.fk(self.q, frames=True, conditions=self.conditions)
        return frames[np.arange(self.n_items), self.link]

    def _split(self, nuisance) -> tuple[np.ndarray, np.ndarray]:
        """(W ``(..., 4, 4)``, offsets ``(..., K, 3)``) of nuisance values ``(..., 6 + 3K)``."""
        nuisance = np.asarray(nuisance, float)
        return frame_of(self.W0, nuisance[..., :6]), nuisance[..., 6:].reshape(nuisance.shape[:-1] + (-1, 3))

    def _alternate(self, robot) -> tuple[np.ndarray, np.ndarray]:
        """W and the offsets ``(K, 3)`` fitted to ``robot`` by alternation (the start)."""
        F = self._link_frames(robot)
        offsets = np.zeros((self.markers.size, 3))
        count = np.bincount(self.marker_of, minlength=self.markers.size)[:, None]
        for _ in range(START_ALTERNATIONS):
            p = self._on_links(F, offsets)
            W = umeyama(p, self.measured)
            local = np.einsum("nji,nj->ni", F[:, :3, :3],
                              (self.measured - W[:3, 3]) @ W[:3, :3] - F[:, :3, 3])
            offsets = np.zeros_like(offsets)
            np.add.at(offsets, self.marker_of, local)
            offsets /= count
        return W, offsets

    def _on_links(self, F: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """``(..., N, 3)`` each row's marker in the robot's world, from its link frame ``F (..., N, 4,
        4)`` and the markers' offsets ``(K, 3)`` (m, in their links' frames)."""
        return np.einsum("...nij,nj->...ni", F[..., :3, :3], offsets[self.marker_of]) + F[..., :3, 3]

    def modelled_points(self, robot, nuisance=None) -> np.ndarray:
        nuisance = self.nuisance_start(robot) if nuisance is None else nuisance
        W, offsets = self._split(nuisance)
        p = self._on_links(self._link_frames(robot), offsets)
        return p @ W[:3, :3].T + W[:3, 3]

    def frames(self, nuisance) -> dict[str, np.ndarray]:
        """The estimated capture frame (the robot's world in it, 4 x 4, m) and each marker's offset
        on its link (``(3,)``, m, in the link's frame)."""
        W, offsets = self._split(nuisance)
        return {"robot_world_in_capture": W,
                **{f"marker{s}_on_link{int(self.marker_link[k])}": offsets[k]
                   for k, s in enumerate(self.markers)}}

    # ---------------------------------------------------------------- nuisance
    def nuisance_start(self, robot) -> np.ndarray:
        W, offsets = self._alternate(robot)
        return np.r_[nuisance_of(self.W0, W), offsets.reshape(-1)]

    def export_nuisance(self, nuisance) -> dict[str, np.ndarray]:
        W, offsets = self._split(nuisance)
        out = {"capture": W.reshape(-1)}
        out.update({f"marker{s}": np.r_[offsets[k], self.marker_link[k]]
                    for k, s in enumerate(self.markers)})
        return out

    def import_nuisance(self, robot, entities) -> np.ndarray:
        """The capture frame and the offsets of the markers ``entities`` share (on the same link),
        the rest fitted to ``robot``."""
        start = self.nuisance_start(robot)
        if "capture" in entities:
            start[:6] = nuisance_of(self.W0, np.reshape(entities["capture"], (4, 4)))
        for k, s in enumerate(self.markers):
            known = entities.get(f"marker{s}")
            if known is not None and int(known[3]) == self.marker_link[k]:
                start[6 + 3 * k: 9 + 3 * k] = known[:3]
        return start

    # ---------------------------------------------------------------- Observation API
    def residuals(self, robot, nuisance) -> np.ndarray:
        return (self.measured - self.modelled_points(robot, nuisance)).reshape(-1)

    def _acting_frame(self, robot) -> np.ndarray:
        """``(P,)`` per robot parameter the first frame it moves: link i's five parameters frame i,
        the base frame 0, a joint-error term its joint's frame, the tool and SMRs none (n + 1)."""
        n = robot.n_joints
        act = np.full(len(robot.parameter_names), n + 1)
        act[: 5 * n] = np.repeat(np.arange(1, n + 1), 5)
        act[5 * n: 5 * n + 6] = 0
        if robot.joint_errors is not None:
            _, joint = joint_error_basis(robot, self.q[:1], robot.joint_errors.names,
                                         self.conditions.rows(slice(0, 1)))
            act[len(robot.geometry_names):] = np.asarray(joint) + 1
        return act

    def jacobian(self, robot, names, nuisance) -> np.ndarray:
        """``(3N, k + 6 + 3K)``: robot columns (zero on rows of links before a parameter's link),
        then the capture frame and the offsets."""
        W, offsets = self._split(nuisance)
        idx = robot.indices(names)
        F = self._link_frames(robot)
        p = self._on_links(F, offsets)  # robot world
        _, u, o, rotation = robot_motion_axes(robot, self.q, None, self.conditions)
        at = np.zeros((self.n_items, 4, 4))
        at[:, :3, 3] = p
        J = jacobian_from_axes(at, u[:, idx], o[:, idx], rotation[idx])  # (N, 3, k)
        J *= (self._acting_frame(robot)[idx][None, :] <= self.link[:, None])[:, None, :]
        J = np.einsum("ij,njk->nik", W[:3, :3], J)
        N, K = self.n_items, self.markers.size
        frame = np.zeros((N, 3, 6))
        frame[:, :, :3] = np.eye(3)
        frame[:, :, 3:] = -skew(p @ W[:3, :3].T) @ left_jacobian(np.asarray(nuisance, float)[3:6])
        marks = np.zeros((N, 3, K, 3))
        marks[np.arange(N), :, self.marker_of, :] = W[:3, :3] @ F[:, :3, :3]
        return np.concatenate([J, frame, marks.reshape(N, 3, 3 * K)], axis=2).reshape(3 * N, -1)

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        """Residuals ``(P, 3N)`` of displaced robots ``X (P, k)`` with a fixed capture frame and offsets."""
        _, frames = self.batch_tcp(robot, names, X, frames=True)
        F = frames[:, np.arange(self.n_items), self.link]  # (P, N, 4, 4)
        W, offsets = self._split(np.asarray(nuisance, float))
        p = self._on_links(F, offsets)
        return (self.measured[None] - (p @ W[:3, :3].T + W[:3, 3])).reshape(X.shape[0], -1)

    def profiled_residuals_batch(self, robot, names, X):
        raise IdentificationError("marker data carry a capture frame and marker offsets estimated with the "
                                  "robot: calibrate them with method lsq or robust")
