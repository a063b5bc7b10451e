"""A real tool's TCP on the calibrated model: the controllers' 4-point method with calibrated
kinematics.

The TCP touches one fixed point in N >= 4 flange orientations and the joints are recorded. With
``R_i, p_i`` the calibrated flange poses (controller base frame) and ``t`` the TCP in flange
coordinates, ``R_i t + p_i = P`` for the unknown fixed point ``P``: 3N linear equations in the
6 unknowns (t, P), solved by least squares. ``t`` is determined only if the orientations differ
about at least two axes; a set whose spread is below ``MIN_SPREAD_DEG`` is refused. The residual
of each pose says how well it touched the point (and how good the model is there).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.compensate import controller_model
from robocal.errors import DataError
from robocal.kinematics.model import Robot

MIN_POSES = 4
MIN_SPREAD_DEG = 5.0  # smallest orientation spread about the weakest axis for a determined TCP
MAX_RESIDUAL_MM = 2.0  # poses further than this from one common point did not touch it


@dataclass(frozen=True)
class ToolCalibration:
    """``tcp`` (3,) m in the flange frame (ROS-I tool0); ``point`` (3,) m, the touched point in
    the controller's base frame; ``residuals`` (N,) m per pose; ``spread_deg`` the orientation
    spread about the weakest axis."""

    tcp: np.ndarray
    point: np.ndarray
    residuals: np.ndarray
    spread_deg: float

    @property
    def rms_mm(self) -> float:
        return float(np.sqrt(np.mean(self.residuals**2)) * 1e3)

    def summary(self) -> str:
        t, p = self.tcp * 1e3, self.point * 1e3
        lines = [f"TCP in flange coordinates: x {t[0]:.3f} y {t[1]:.3f} z {t[2]:.3f} mm",
                 f"touched point (robot base): x {p[0]:.3f} y {p[1]:.3f} z {p[2]:.3f} mm",
                 f"residuals over {len(self.residuals)} poses: RMS {self.rms_mm:.3f} mm, max "
                 f"{self.residuals.max() * 1e3:.3f} mm; orientation spread {self.spread_deg:.1f} deg"]
        lines += [f"  pose {i + 1}: {r * 1e3:.3f} mm" for i, r in enumerate(self.residuals)]
        return "\n".join(lines)


def identify_tcp(calibrated: Robot, nominal: Robot, q, robot_base=None) -> ToolCalibration:
    """TCP of a tool from joints ``(N, 6)`` (rad) at which it touched one fixed point, on the
    calibrated model's flange (see the module docstring and :func:`controller_model`)."""
    flange = controller_model(calibrated, nominal, robot_base)
    q = flange.check_joints(q)
    N = q.shape[0]
    if N < MIN_POSES:
        raise DataError(f"the 4-point method needs at least {MIN_POSES} poses touching one point, got {N}")
    F = flange.fk(q)
    R, p = F[:, :3, :3], F[:, :3, 3]
    A = np.concatenate([R, -np.broadcast_to(np.eye(3), R.shape)], axis=2).reshape(3 * N, 6)
    b = -p.reshape(-1)
    # how well the orientations determine t: the weakest direction of the centred rotations
    centred = (R - R.mean(axis=0)).reshape(3 * N, 3)
    spread = np.linalg.svd(centred, compute_uv=False)[-1] / np.sqrt(N)
    spread_deg = float(np.rad2deg(2 * np.arcsin(min(spread / np.sqrt(2), 1.0))))
    if spread_deg < MIN_SPREAD_DEG:
        raise DataError(f"the {N} poses' orientations differ by only {spread_deg:.2f} deg about their "
                        f"weakest axis (need >= {MIN_SPREAD_DEG:g}): the TCP is not determined. Touch the "
                        "point with the tool tilted about at least two different axes, by 30 deg or more")
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    t, P = x[:3], x[3:]
    residuals = np.linalg.norm(np.einsum("nij,j->ni", R, t) + p - P, axis=1)
    if residuals.max() * 1e3 > MAX_RESIDUAL_MM:
        bad = np.flatnonzero(residuals * 1e3 > MAX_RESIDUAL_MM) + 1
        raise DataError(f"pose(s) {bad.tolist()} are {residuals.max() * 1e3:.2f} mm from the common point "
                        f"(limit {MAX_RESIDUAL_MM:g} mm): they did not touch the same point, or the joints "
                        "belong to another robot or are in another unit")
    return ToolCalibration(t, P, residuals, spread_deg)
