"""How far joint configurations are from the singularities of a 6R arm, and which one is nearest.

* ``sigma_rel``: smallest over largest singular value of the 6 x n joint Jacobian (position rows
  in m, rotation rows in rad): 0 at a singularity, about 0.05-0.2 in the open workspace of a
  1-2 m arm.
* the three classic singularities, each measured on the model's own frames (so calibrated models
  with beta work too):

  - wrist: axes 4 and 6 aligned; ``wrist_deg`` = angle between them (|theta5| from 0 or 180 deg);
  - elbow: arm stretched or folded, the wrist centre on the line through axes 2 and 3 (seen along
    axis 2); ``elbow_deg`` = angle of the upper arm from that line;
  - shoulder: the wrist centre on the axis of joint 1; ``shoulder_mm`` = its distance from it.

The nearest one is the smallest of wrist_deg / 90, elbow_deg / 90 and shoulder distance / arm
length (all 0 at the singularity, about 1 far from it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.kinematics.model import Robot

SINGULAR_SIGMA = 0.01  # sigma_rel below which a configuration is reported as close to a singularity
KINDS = ("wrist", "elbow", "shoulder")


@dataclass(frozen=True)
class SingularityDistance:
    """Per configuration ``(N,)``: ``sigma_rel``, ``nearest`` (one of KINDS), ``wrist_deg``,
    ``elbow_deg``, ``shoulder_mm``."""

    sigma_rel: np.ndarray
    nearest: np.ndarray
    wrist_deg: np.ndarray
    elbow_deg: np.ndarray
    shoulder_mm: np.ndarray

    @property
    def close(self) -> np.ndarray:
        """``(N,)`` bool: sigma_rel below SINGULAR_SIGMA."""
        return self.sigma_rel < SINGULAR_SIGMA

    def describe(self, i: int) -> str:
        """Configuration ``i``'s nearest singularity and the distances, for messages."""
        return (f"nearest the {self.nearest[i]} singularity (sigma_rel {self.sigma_rel[i]:.4f}, wrist "
                f"{self.wrist_deg[i]:.2f} deg, elbow {self.elbow_deg[i]:.2f} deg, shoulder "
                f"{self.shoulder_mm[i]:.1f} mm)")

    def columns(self) -> dict[str, np.ndarray]:
        """The per-configuration columns of a target table."""
        return {"sigma_rel": self.sigma_rel, "nearest_singularity": self.nearest,
                "wrist_deg": self.wrist_deg, "elbow_deg": self.elbow_deg, "shoulder_mm": self.shoulder_mm}


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-15)


def _angle_from_line(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle (rad, 0..pi/2) between the lines of vectors u and v ``(N, 3)``."""
    s = np.linalg.norm(np.cross(_unit(u), _unit(v)), axis=1)
    return np.arcsin(np.clip(s, 0.0, 1.0))


def singularity_distance(robot: Robot, q) -> SingularityDistance:
    """Distances of joints ``(N, 6)`` (rad) of a 6R arm with a wrist from its singularities."""
    q = robot.check_joints(q)
    names = [f"theta{i + 1}" for i in range(robot.n_joints)]
    J = robot.jacobian(q, names, kind="pose")
    s = np.linalg.svd(J, compute_uv=False)
    sigma_rel = s[:, -1] / np.maximum(s[:, 0], 1e-300)
    _, fr = robot.fk(q, frames=True)
    z = fr[:, :, :3, 2]
    o = fr[:, :, :3, 3]
    wrist = _angle_from_line(z[:, 4], z[:, 6])
    wc = o[:, 5]
    z2 = z[:, 2]

    def across_axis2(v):
        return v - np.einsum("ij,ij->i", v, z2)[:, None] * z2

    lower, upper = across_axis2(o[:, 3] - o[:, 2]), across_axis2(wc - o[:, 3])
    elbow = _angle_from_line(lower, upper)
    r = wc - o[:, 1]
    shoulder = np.linalg.norm(r - np.einsum("ij,ij->i", r, z[:, 1])[:, None] * z[:, 1], axis=1)
    arm = np.linalg.norm(lower, axis=1) + np.linalg.norm(upper, axis=1)
    scores = np.stack([wrist / (np.pi / 2), elbow / (np.pi / 2), shoulder / np.maximum(arm, 1e-9)], axis=1)
    nearest = np.asarray(KINDS)[np.argmin(scores, axis=1)]
    return SingularityDistance(sigma_rel, nearest, np.rad2deg(wrist), np.rad2deg(elbow), shoulder * 1e3)
