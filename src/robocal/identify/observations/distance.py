"""Distances (a ball bar between two poses, or two tracker readings): one residual per pair.

The data's two rows sharing a ``pair`` id are the two ends; the residual is the measured
distance minus the modelled distance between the two TCP (SMR) positions. Its Jacobian is
``e . (J_1 - J_2)`` with ``e`` the unit vector from the second end to the first. Distances do
not depend on the base frame, so ``params='auto'`` leaves ``base.*`` out (:func:`not_observable`);
unlike plane contacts they carry a length reference, so the scale is identified.
"""

from __future__ import annotations

import numpy as np

from robocal.identify.observations.base import Observation


def not_observable(robot) -> list[str]:
    """Parameters distances can never identify: the base frame."""
    return [f"base.{f}" for f in ("x", "y", "z", "rx", "ry", "rz")]


class DistanceObservation(Observation):
    kind = "distance"
    rows_per_item = 1
    blind_spot = "distances do not see the base frame"
    world_frame = False

    def not_observable(self, robot) -> list[str]:
        return not_observable(robot)

    def __init__(self, data, robot) -> None:
        super().__init__(data, robot)
        order = np.argsort(data.pair, kind="stable")
        self.ends = order.reshape(-1, 2).T  # (2, pairs): row index of each end
        self.measured = np.asarray(data.distance, float)[self.ends[0]]
        if self.item_sigma is not None:
            self.item_sigma = self.item_sigma[self.ends[0]]

    @property
    def n_items(self) -> int:
        return self.ends.shape[1]

    def item_of_rows(self) -> np.ndarray:
        items = np.empty(self.q.shape[0], int)
        items[self.ends] = np.arange(self.n_items)
        return items

    def _vectors(self, p: np.ndarray) -> np.ndarray:
        """End-to-end vectors ``(..., pairs, 3)`` from positions ``(..., N, 3)``."""
        return p[..., self.ends[0], :] - p[..., self.ends[1], :]

    def residuals(self, robot, nuisance=None) -> np.ndarray:
        return self.measured - np.linalg.norm(self._vectors(self.modelled_points(robot, nuisance)), axis=-1)

    def jacobian(self, robot, names, nuisance=None) -> np.ndarray:
        v = self._vectors(self.modelled_points(robot, nuisance))
        e = v / np.linalg.norm(v, axis=1, keepdims=True)
        J = self._tcp_jacobian(robot, names)
        return np.einsum("pi,pik->pk", e, J[self.ends[0]] - J[self.ends[1]])

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        p = self.batch_tcp(robot, names, X)[..., :3, 3]
        return self.measured - np.linalg.norm(self._vectors(p), axis=-1)
