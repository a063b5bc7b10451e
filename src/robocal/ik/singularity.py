"""How far joint configurations are from the singularities of a 6R arm, and which one is nearest.

* ``sigma_rel``: smallest over largest singular value of the 6 x n joint Jacobian (position rows
  in m, rotation rows in rad): 0 at a singularity, growing away from it (its scale depends on the
  arm's size, since the rows mix m and rad).
* the three classic singularities (:func:`classic_distances`), each measured on the model's own
  frames (so calibrated models with beta work too). They are the factors of the 6 x 6 Jacobian's
  determinant, for spherical wrists and for the offset wrists of the UR arms alike (a test finds
  every zero of the determinant along joint sweeps and checks that one of them vanishes there):

  - wrist: axes 4 and 6 aligned; ``wrist_deg`` = angle between them (|theta5| from 0 or 180 deg);
  - elbow: arm stretched or folded, the point of axis 4 at the origin of frame {4} on the line
    through axes 2 and 3 (seen along axis 3); ``elbow_deg`` = angle of that point from the line;
  - shoulder: the origin of frame {5}, on axis 5, in the plane through axis 1 parallel to axis 2;
    ``shoulder_mm`` = its distance from that plane (for an arm without sideways offsets it is the
    distance from axis 1).

  Frames {4} and {5} share their origin, the wrist centre, when the wrist is spherical. On an
  offset wrist (UR) they differ, and each measure needs its own: the elbow singularity does not
  depend on joint 4, so its point is the one joint 4 does not move (frame {4}); the shoulder's
  depends on joints 2-4 through the offset of axis 5 (the UR determinant's factor
  ``a2 c2 + a3 c23 + d5 s234``), so its point is on axis 5; and its distance is from the plane,
  not the axis, because the sideways offset along axis 2 (UR d4, PUMA 560 d3) never vanishes.

The nearest one is the smallest of wrist_deg / 90, elbow_deg / 90 and shoulder distance / arm
length (all 0 at the singularity, about 1 far from it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.model import Robot

SINGULAR_SIGMA = 0.01  # sigma_rel below which a configuration is reported as close to a singularity
KINDS = ("wrist", "elbow", "shoulder")
WRIST_AXES = (4, 6)    # joints whose aligned axes make the wrist singularity
ELBOW_FRAME = 4        # the elbow's point: origin of frame {4}, on axis 4
SHOULDER_FRAME = 5     # the shoulder's point: origin of frame {5}, on axis 5
MEASURE_JOINTS = {"wrist_deg": WRIST_AXES[1], "elbow_deg": ELBOW_FRAME, "shoulder_mm": SHOULDER_FRAME}


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


def _across(v: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The part of vectors ``v (N, 3)`` normal to the unit (or zero) vectors ``axis (N, 3)``."""
    return v - np.sum(v * axis, axis=1, keepdims=True) * axis


def classic_distances(frames: np.ndarray) -> dict[str, np.ndarray]:
    """Distances ``(N,)`` from the classic singularities (see the module docstring), from the
    frames ``(N, n + 1, 4, 4)`` of ``robot.fk(q, frames=True)``: ``wrist_deg`` (n >= 6),
    ``elbow_deg`` (n >= 4), ``shoulder_mm`` (n >= 5); a measure the chain is too short for is
    absent. With all three, ``nearest`` (one of KINDS) too."""
    n = frames.shape[1] - 1
    z, o = frames[:, :, :3, 2], frames[:, :, :3, 3]
    out = {}
    if n >= MEASURE_JOINTS["wrist_deg"]:
        s = np.linalg.norm(np.cross(z[:, WRIST_AXES[0]], z[:, WRIST_AXES[1]]), axis=1)
        out["wrist_deg"] = np.rad2deg(np.arcsin(np.clip(s, 0.0, 1.0)))
    if n >= MEASURE_JOINTS["elbow_deg"]:
        to_axis2 = _across(o[:, 2] - o[:, 3], z[:, 3])
        to_wrist = _across(o[:, ELBOW_FRAME] - o[:, 3], z[:, 3])
        cross = np.linalg.norm(np.cross(to_axis2, to_wrist), axis=1)
        out["elbow_deg"] = np.rad2deg(np.arctan2(cross, np.abs(np.sum(to_axis2 * to_wrist, axis=1))))
        arm = np.linalg.norm(to_axis2, axis=1) + np.linalg.norm(to_wrist, axis=1)
    if n >= MEASURE_JOINTS["shoulder_mm"]:
        z1 = z[:, 1]
        sideways = _across(z[:, 2], z1)  # axis 2's direction normal to axis 1 (zero if parallel)
        sideways = sideways / np.maximum(np.linalg.norm(sideways, axis=1, keepdims=True), 1e-15)
        r = _across(_across(o[:, SHOULDER_FRAME] - o[:, 1], z1), sideways)
        out["shoulder_mm"] = np.linalg.norm(r, axis=1) * 1e3
    if len(out) == len(KINDS):
        scores = np.stack([out["wrist_deg"] / 90, out["elbow_deg"] / 90,
                           out["shoulder_mm"] * 1e-3 / np.maximum(arm, 1e-9)], axis=1)
        out["nearest"] = np.asarray(KINDS)[np.argmin(scores, axis=1)]
    return out


def singularity_distance(robot: Robot, q) -> SingularityDistance:
    """Distances of joints ``(N, n)`` (rad) of an arm with a wrist (n >= 6) from its singularities."""
    q = robot.check_joints(q)
    if robot.n_joints < WRIST_AXES[1]:
        raise DataError(f"singularity distances need an arm with a wrist (at least {WRIST_AXES[1]} joints); "
                        f"{robot.name} has {robot.n_joints}")
    names = robot.joint_params
    s = np.linalg.svd(robot.jacobian(q, names, kind="pose"), compute_uv=False)
    sigma_rel = s[:, -1] / np.maximum(s[:, 0], 1e-300)
    c = classic_distances(robot.fk(q, frames=True)[1])
    return SingularityDistance(sigma_rel, c["nearest"], c["wrist_deg"], c["elbow_deg"], c["shoulder_mm"])
