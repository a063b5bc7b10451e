"""OPW parameter sets and their closed-form forward kinematics (ortho-parallel arm, spherical wrist).

Convention of Brandstoetter, Angerer and Hofbaur (2014) as implemented in opw_kinematics: the
paper's zero pose has the arm straight up (+Z); the robot's joint ``q`` maps to the paper angle
``theta = q * sign - offset``. ``opw_fk`` is written from the paper's formulas, independently of
the MDH chain, and serves as the truth the catalog is checked against.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import ModelError

GEOMETRY = ("a1", "a2", "b", "c1", "c2", "c3", "c4")


@dataclass(frozen=True)
class OPWParameters:
    """Seven lengths (m), six offsets (rad) and six sign corrections (+-1)."""

    a1: float
    a2: float
    b: float
    c1: float
    c2: float
    c3: float
    c4: float
    offsets: tuple[float, ...] = (0.0,) * 6
    signs: tuple[int, ...] = (1,) * 6

    def __post_init__(self) -> None:
        for name in GEOMETRY:
            value = getattr(self, name)
            if isinstance(value, bool) or not np.isfinite(np.asarray(value, dtype=float)).all() \
                    or np.ndim(value) != 0:
                raise ModelError(f"OPW parameter {name} must be one finite number (m), got {value!r}")
            object.__setattr__(self, name, float(value))
        offsets = np.asarray(self.offsets, dtype=float).reshape(-1)
        if offsets.shape != (6,) or not np.isfinite(offsets).all():
            raise ModelError(f"OPW offsets must be 6 finite angles (rad), got {list(self.offsets)}")
        signs = np.asarray(self.signs, dtype=float).reshape(-1)
        if signs.shape != (6,) or not np.isin(signs, (-1.0, 1.0)).all():
            raise ModelError(f"OPW signs must be 6 values of +1 or -1, got {list(self.signs)}")
        object.__setattr__(self, "offsets", tuple(float(v) for v in offsets))
        object.__setattr__(self, "signs", tuple(int(v) for v in signs))

    def to_dict(self) -> dict:
        """Plain data for the model YAML's ``opw`` (SI: lengths m, offsets rad, signs +-1)."""
        out = {k: getattr(self, k) for k in GEOMETRY}
        out["offsets"] = list(self.offsets)
        out["signs"] = list(self.signs)
        return out


def opw_fk(params: OPWParameters, q) -> np.ndarray:
    """Flange poses ``(N, 4, 4)`` (m) for robot joints ``q`` ``(N, 6)`` (rad), vectorised.

    Wrist centre C = Rz(t1) [a1 + c2 sin t2 + k sin(t2 + t3 + psi3), b, c2 cos t2 + k cos(t2 + t3 +
    psi3)] + [0, 0, c1] with k = sqrt(a2^2 + c3^2), psi3 = atan2(a2, c3); orientation
    R = Rz(t1) Ry(t2 + t3) Rz(t4) Ry(t5) Rz(t6); flange = C + c4 R e_z.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if q.ndim != 2 or q.shape[1] != 6:
        raise ModelError(f"OPW forward kinematics needs joints of shape (N, 6), got {q.shape}")
    t = q * np.asarray(params.signs, float) - np.asarray(params.offsets, float)
    s, c = np.sin(t), np.cos(t)
    psi3 = np.arctan2(params.a2, params.c3)
    k = np.hypot(params.a2, params.c3)
    t23 = t[:, 1] + t[:, 2]
    cx1 = params.c2 * s[:, 1] + k * np.sin(t23 + psi3) + params.a1
    cz1 = params.c2 * c[:, 1] + k * np.cos(t23 + psi3)
    cx0 = cx1 * c[:, 0] - params.b * s[:, 0]
    cy0 = cx1 * s[:, 0] + params.b * c[:, 0]
    cz0 = cz1 + params.c1
    s23, c23 = np.sin(t23), np.cos(t23)
    zero = np.zeros_like(t23)
    # R_0c = Rz(t1) Ry(t2 + t3)
    r0c = np.stack([
        np.stack([c[:, 0] * c23, -s[:, 0], c[:, 0] * s23], -1),
        np.stack([s[:, 0] * c23, c[:, 0], s[:, 0] * s23], -1),
        np.stack([-s23, zero, c23], -1),
    ], -2)
    c4, s4, c5, s5, c6, s6 = c[:, 3], s[:, 3], c[:, 4], s[:, 4], c[:, 5], s[:, 5]
    # R_ce = Rz(t4) Ry(t5) Rz(t6)
    rce = np.stack([
        np.stack([c4 * c5 * c6 - s4 * s6, -c4 * c5 * s6 - s4 * c6, c4 * s5], -1),
        np.stack([s4 * c5 * c6 + c4 * s6, -s4 * c5 * s6 + c4 * c6, s4 * s5], -1),
        np.stack([-s5 * c6, s5 * s6, c5], -1),
    ], -2)
    R = r0c @ rce
    out = np.zeros((q.shape[0], 4, 4))
    out[:, :3, :3] = R
    out[:, :3, 3] = np.stack([cx0, cy0, cz0], -1) + params.c4 * R[:, :, 2]
    out[:, 3, 3] = 1.0
    return out
