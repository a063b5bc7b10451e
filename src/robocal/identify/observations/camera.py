"""A camera observing a target board (a checkerboard, ArUco/ChArUco board): 6 residuals per pose.

Each row is the board's pose in the camera frame as the camera's pose estimation gives it,
``C (4, 4)`` (``points`` the translation, ``rotations`` the rotation). With ``F(q)`` the flange pose
in the robot's world frame (the robot's base frame included, its tool not):

- eye-to-hand (kind ``eye_to_hand``: camera fixed in the cell, board on the flange):
  ``C = L F(q) R`` with ``L`` the robot's world in the camera frame (the camera frame plays the
  role of a tracker's frame) and ``R`` the board on the flange;
- eye-in-hand (kind ``eye_in_hand``: camera on the flange, board fixed in the cell):
  ``C = L F(q)^-1 R`` with ``L = X^-1``, X the camera on the flange (the hand-eye frame) and ``R``
  the board in the robot's world.

Both frames are estimated with the robot as 12 nuisance parameters (``camera.*`` for L, ``board.*``
for R; :mod:`robocal.identify.observations.rigid`), started by a hand-eye solution (Park & Martin
1994) on the model the observation is built with. So the robot's base and tool frames are not seen
by these kinds (``params='auto'`` leaves them out): the camera and the board take their place, and
:meth:`CameraObservation.frames` gives them as physical frames.

Residuals: measured minus modelled board position (m, camera frame), then the rotation vector of
``R_meas R_model^T`` (rad) times ``length_scale`` (m per rad) so both count in one norm. The
default length scale is the camera's documented noise ratio (`robocal.data.instruments`); a
calibration re-estimates it from the data as a variance component
(:mod:`robocal.identify.variance_components`).
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.data.instruments import INSTRUMENTS
from robocal.identify.observations.base import Observation, SixDWeights
from robocal.identify.observations.rigid import (
    FRAME_FIELDS,
    frame_of,
    hand_eye,
    left_jacobian,
    nuisance_of,
    replaced_frames,
)
from robocal.kinematics.jacobian import identification_jacobian
from robocal.kinematics.transforms import invert_transform, make_transform, pose_error, skew


class CameraObservation(SixDWeights, Observation):
    """Board poses seen by a camera (see the module); subclasses fix the mounting."""

    kind = "camera"
    frames_replace_base = True  # its frames take the robot base's place (trust.coverage)
    rows_per_item = 6
    inverted = False  # eye-in-hand: the chain is F(q)^-1
    blind_spot = "a camera's own frames replace the robot's base and tool frames"

    def __init__(self, data, robot, length_scale: float | None = None) -> None:
        super().__init__(data, robot)
        if self.smr.any():
            raise IdentificationError(f"{self.kind} rows see one board: the smr column must be 0 on "
                                      "every row")
        self.measured = make_transform(data.rotations, data.points)
        default = INSTRUMENTS["camera"].length_scale
        self.set_length_scale(default if length_scale is None else length_scale)
        try:
            self.L0, self.R0 = hand_eye(self._chain(robot), self.measured)
        except IdentificationError:  # too few poses for frames of their own: they can still be judged
            self.L0 = self.R0 = np.eye(4)  # with another set's frames (import_nuisance); a fit refuses
        self.nuisance_names = [f"camera.{f}" for f in FRAME_FIELDS] + [f"board.{f}" for f in FRAME_FIELDS]

    def not_observable(self, robot) -> list[str]:
        return replaced_frames(robot)

    # ---------------------------------------------------------------- model
    def _flange(self, robot) -> np.ndarray:
        """Flange poses ``(N, 4, 4)`` in the robot's world frame (the tool left out)."""
        return robot.with_frames(tool=np.eye(4)).fk(self.q, conditions=self.conditions)

    def _chain(self, robot, F: np.ndarray | None = None) -> np.ndarray:
        F = self._flange(robot) if F is None else F
        return invert_transform(F) if self.inverted else F

    def _frames(self, nuisance) -> tuple[np.ndarray, np.ndarray]:
        nuisance = np.asarray(nuisance, float)
        return frame_of(self.L0, nuisance[..., :6]), frame_of(self.R0, nuisance[..., 6:])

    def modelled(self, robot, nuisance) -> np.ndarray:
        """Modelled board poses ``(N, 4, 4)`` in the camera frame."""
        L, R = self._frames(nuisance)
        return L @ self._chain(robot) @ R

    def frames(self, nuisance) -> dict[str, np.ndarray]:
        """The two estimated frames as physical ones (4 x 4, m): the camera in the robot's world
        (eye-to-hand) or on the flange (eye-in-hand), and the board on the flange or in the world."""
        L, R = self._frames(nuisance)
        where = (("camera_on_flange", "board_in_world") if self.inverted
                 else ("camera_in_world", "board_on_flange"))
        return {where[0]: invert_transform(L), where[1]: R}

    def modelled_points(self, robot, nuisance=None) -> np.ndarray:
        return self.modelled(robot, self.nuisance_start(robot) if nuisance is None else nuisance)[:, :3, 3]

    # ---------------------------------------------------------------- nuisance
    def nuisance_start(self, robot) -> np.ndarray:
        """The hand-eye solution of ``robot``'s flange poses against the measured board poses."""
        L, R = hand_eye(self._chain(robot), self.measured)
        return np.r_[nuisance_of(self.L0, L), nuisance_of(self.R0, R)]

    def export_nuisance(self, nuisance) -> dict[str, np.ndarray]:
        L, R = self._frames(nuisance)
        return {f"{self.kind}.camera": L.reshape(-1), f"{self.kind}.board": R.reshape(-1)}

    def import_nuisance(self, robot, entities) -> np.ndarray:
        """The shared camera and board frames where ``entities`` has them, the rest fitted to ``robot``
        (a set of fewer than 3 poses can only be judged with both frames shared)."""
        shared = [entities.get(f"{self.kind}.{key}") for key in ("camera", "board")]
        start = np.zeros(12) if all(T is not None for T in shared) else self.nuisance_start(robot)
        for part, T0, T in zip((slice(0, 6), slice(6, 12)), (self.L0, self.R0), shared, strict=True):
            if T is not None:
                start[part] = nuisance_of(T0, np.reshape(T, (4, 4)))
        return start

    # ---------------------------------------------------------------- Observation API
    def residuals(self, robot, nuisance) -> np.ndarray:
        return (pose_error(self.measured, self.modelled(robot, nuisance)) * self.scale).reshape(-1)

    def jacobian(self, robot, names, nuisance) -> np.ndarray:
        """``(6N, k + 12)``: d(modelled board pose)/d(robot parameters, camera frame, board frame)."""
        nuisance = np.asarray(nuisance, float)
        flange = robot.with_frames(tool=np.eye(4))
        F = flange.fk(self.q, conditions=self.conditions)
        J = identification_jacobian(flange, self.q, names, "pose", None, self.conditions)  # (N, 6, k)
        J[..., [i for i, n in enumerate(names) if n.startswith(("tool.", "smr"))]] = 0.0  # no tool here
        dp, w = J[:, :3], J[:, 3:]
        if self.inverted:  # G = F^-1: its turn -R_F^T w, its move -R_F^T (dp + t_F x w)
            RFt = np.swapaxes(F[:, :3, :3], 1, 2)
            dp = -RFt @ (dp + skew(F[:, :3, 3]) @ w)
            w = -RFt @ w
        G = self._chain(robot, F)
        L, R = self._frames(nuisance)
        C = L @ G @ R
        RL, RG = L[:3, :3], G[:, :3, :3]
        lever = skew(RG @ R[:3, 3])  # (N, 3, 3): w x (R_G t_R) = -[R_G t_R]x w
        robot_cols = np.concatenate([RL @ (dp - lever @ w), RL @ w], axis=1)  # (N, 6, k)
        N = self.n_items
        Jl_L, Jl_R = left_jacobian(nuisance[3:6]), left_jacobian(nuisance[9:12])
        left = np.zeros((N, 6, 6))
        left[:, :3, :3] = np.eye(3)
        left[:, :3, 3:] = -skew(C[:, :3, 3] - L[:3, 3]) @ Jl_L
        left[:, 3:, 3:] = Jl_L
        right = np.zeros((N, 6, 6))
        RLG = RL @ RG
        right[:, :3, :3] = RLG
        right[:, 3:, 3:] = RLG @ Jl_R
        out = np.concatenate([robot_cols, left, right], axis=2) * self.scale[None, :, None]
        return out.reshape(6 * N, -1)

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        """Residuals ``(P, 6N)`` of displaced robots ``X (P, k)`` with fixed camera and board frames."""
        _, frames = self.batch_tcp(robot, names, X, frames=True)
        F = frames[..., -1, :, :]  # the flange: frame {n}
        L, R = self._frames(np.asarray(nuisance, float))
        C = L @ self._chain(robot, F) @ R
        return (pose_error(self.measured[None], C) * self.scale).reshape(X.shape[0], -1)

    def profiled_residuals_batch(self, robot, names, X):
        raise IdentificationError(f"{self.kind} data carry a camera and a board frame estimated with the "
                                  "robot: calibrate them with method lsq or robust")


class EyeToHandObservation(CameraObservation):
    """A camera fixed in the cell, the board on the flange: ``C = L F(q) R``."""

    kind = "eye_to_hand"


class EyeInHandObservation(CameraObservation):
    """A camera on the flange, the board fixed in the cell (hand-eye): ``C = L F(q)^-1 R``."""

    kind = "eye_in_hand"
    inverted = True
