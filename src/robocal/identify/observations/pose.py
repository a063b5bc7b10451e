"""6-DOF tracker poses: 3 position + 3 orientation residuals per item.

The orientation residual is the rotation vector of R_measured R_model^T (rad), multiplied by
``length_scale`` (m) so both parts count in one norm: with the default 0.1 m, 1 mrad of
orientation error weighs like 0.1 mm of position error; rows declared taken with an instrument that
documents both noises (a camera) start from their ratio (`robocal.data.instruments`).
"""

from __future__ import annotations

import numpy as np

from robocal.data.instruments import INSTRUMENTS
from robocal.identify.observations.base import Observation, SixDWeights
from robocal.kinematics.transforms import pose_error

DEFAULT_LENGTH_SCALE = 0.1


class PoseObservation(SixDWeights, Observation):
    kind = "pose"
    rows_per_item = 6

    def __init__(self, data, robot, length_scale: float | None = None) -> None:
        super().__init__(data, robot)
        self.measured = np.zeros((self.n_items, 4, 4))
        self.measured[:, :3, :3] = data.rotations
        self.measured[:, :3, 3] = data.points
        self.measured[:, 3, 3] = 1.0
        declared = INSTRUMENTS[data.instrument].length_scale if data.instrument else 0.0
        self.set_length_scale(length_scale or declared or DEFAULT_LENGTH_SCALE)

    def residuals(self, robot, nuisance=None) -> np.ndarray:
        return (pose_error(self.measured, self._fk(robot)) * self.scale).reshape(-1)

    def jacobian(self, robot, names, nuisance=None) -> np.ndarray:
        J = self._tcp_jacobian(robot, names, "pose")
        return (J * self.scale[None, :, None]).reshape(-1, len(names))

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        tcp = self.batch_tcp(robot, names, X)
        return (pose_error(self.measured[None], tcp) * self.scale).reshape(X.shape[0], -1)
