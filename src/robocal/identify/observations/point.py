"""Laser-tracker points: 3 residuals per item, measured minus modelled SMR position."""

from __future__ import annotations

import numpy as np

from robocal.identify.observations.base import Observation


class PointObservation(Observation):
    kind = "point"
    rows_per_item = 3

    def __init__(self, data, robot) -> None:
        super().__init__(data, robot)
        self.measured = np.asarray(data.points, dtype=float)

    def residuals(self, robot, nuisance=None) -> np.ndarray:
        return (self.measured - self.modelled_points(robot, nuisance)).reshape(-1)

    def jacobian(self, robot, names, nuisance=None) -> np.ndarray:
        return self._tcp_jacobian(robot, names).reshape(-1, len(names))

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        tcp = self.batch_tcp(robot, names, X)
        return (self.measured[None] - tcp[..., :3, 3]).reshape(X.shape[0], -1)
