"""The UR form: 6R arms with three parallel axes (J2, J3, J4) and an offset wrist, recognised
from the MDH chain itself (Universal Robots UR3..UR30 and e-series, and any model of that form).

The chain ``T_i = Rx(alpha_i) Tx(a_i) Ry(beta_i) Rz(theta_i + q_i) Tz(d_i)`` has the UR form when

* axis 2 is perpendicular to axis 1 (alpha2 = +-90 deg, beta2 = 0);
* axes 2, 3 and 4 are parallel (alpha3, alpha4 in {0, 180 deg}, beta3 = beta4 = 0) and the two
  arm links between them have length (a3, a4 != 0);
* axis 5 is perpendicular to axis 4 (alpha5 = +-90 deg, beta5 = 0) and axis 6 to axis 5
  (alpha6 = +-90 deg, beta6 = 0), and axis 6 meets axis 5 (a6 = 0).

alpha1, a1, beta1 (the fixed frame before joint 1), every theta offset and the d offsets and a2,
a5 are free. A calibrated model (beta on the parallel axes, alphas a little off) no longer has
the form: it keeps numeric IK, seeded by its nominal model's closed form. Detection tolerates
``UR_MATCH_TOL`` (1e-12 rad / m) so that converted tables (degrees, mm) still match.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.kinematics.transforms import make_transform

UR_MATCH_TOL = 1e-12  # rad / m: how far a chain may be from the exact UR structure and still have it


@dataclass(frozen=True)
class URForm:
    """What the closed form needs of a UR-form chain (m, rad, signs +-1).

    ``pre``: the fixed transform Rx(alpha1) Tx(a1) Ry(beta1) before joint 1; ``theta`` (6,) offsets;
    ``d1``; ``s2`` = sin(alpha2) and ``a2``; ``sg3``, ``sg4`` = cos(alpha3), cos(alpha4); ``a3``,
    ``a4`` the arm links; ``c2`` the arm plane's offset along the parallel axes (d2 + sg3 d3 +
    sg3 sg4 d4); ``s5``, ``a5``, ``d5``; ``s6`` = sin(alpha6) and ``d6``."""

    pre: np.ndarray
    theta: np.ndarray
    d1: float
    s2: float
    a2: float
    sg3: float
    sg4: float
    a3: float
    a4: float
    c2: float
    s5: float
    a5: float
    d5: float
    s6: float
    d6: float

    def geometry(self) -> np.ndarray:
        """The scalars as one float array (the compiled kernel's argument): d1 s2 a2 sg3 sg4 a3 a4
        c2 s5 a5 d5 s6 d6."""
        return np.array([self.d1, self.s2, self.a2, self.sg3, self.sg4, self.a3, self.a4, self.c2,
                         self.s5, self.a5, self.d5, self.s6, self.d6])


def _near(values, allowed) -> bool:
    """Every value within UR_MATCH_TOL of one of the ``allowed`` values."""
    gap = np.abs(np.asarray(values, float)[:, None] - np.asarray(allowed, float)[None, :]).min(axis=1)
    return bool((gap <= UR_MATCH_TOL).all())


def ur_form(alpha, a, beta, theta, d) -> URForm | None:
    """The UR form of MDH link arrays ``(6,)`` (rad, m), or None when the chain does not have it."""
    alpha, a, beta, theta, d = (np.asarray(v, float) for v in (alpha, a, beta, theta, d))
    if alpha.shape != (6,):
        return None
    s, c = np.sin(alpha), np.cos(alpha)
    if not (_near(s[[1, 4, 5]], (1.0, -1.0)) and _near(c[[2, 3]], (1.0, -1.0))
            and _near(np.append(beta[1:], a[5]), (0.0,))):
        return None
    if min(abs(a[2]), abs(a[3])) <= UR_MATCH_TOL:
        return None
    ca, sa, cb, sb = np.cos(alpha[0]), np.sin(alpha[0]), np.cos(beta[0]), np.sin(beta[0])
    rx = np.array([[1.0, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1.0, 0], [-sb, 0, cb]])
    pre = make_transform(rx @ ry, rx @ np.array([a[0], 0.0, 0.0]))
    sg3, sg4 = float(np.round(c[2])), float(np.round(c[3]))
    c2 = float(d[1] + sg3 * d[2] + sg3 * sg4 * d[3])
    return URForm(pre=pre, theta=theta.copy(), d1=float(d[0]), s2=float(np.round(s[1])), a2=float(a[1]),
                  sg3=sg3, sg4=sg4, a3=float(a[2]), a4=float(a[3]), c2=c2,
                  s5=float(np.round(s[4])), a5=float(a[4]), d5=float(d[4]), s6=float(np.round(s[5])),
                  d6=float(d[5]))


# A chain this close to the UR structure (its constrained angles within UR_SEED_TOL rad of their
# values, a6 within UR_SEED_LENGTH m of 0) is a calibrated UR arm: its nearest UR-form chain seeds it
UR_SEED_TOL = 0.05
UR_SEED_LENGTH = 0.01


def nearest_ur_links(alpha, a, beta, theta, d) -> tuple[np.ndarray, ...] | None:
    """The UR-form chain nearest MDH link arrays ``(6,)`` (rad, m) -- alpha2, alpha5, alpha6 on
    +-90 deg, alpha3, alpha4 on 0 or 180 deg, beta2..beta6 and a6 zero, the rest kept -- as
    (alpha, a, beta, theta, d), or None when the chain is not that close to the form (a calibrated
    or factory-calibrated UR is: its deviations are milliradians and millimetres). Its closed form
    seeds numeric inverse kinematics on the chain; it is no model of the arm."""
    alpha, a, beta, theta, d = (np.array(v, float) for v in (alpha, a, beta, theta, d))
    if alpha.shape != (6,):
        return None
    snapped = alpha.copy()
    for i, grid in ((1, np.pi / 2), (2, np.pi), (3, np.pi), (4, np.pi / 2), (5, np.pi / 2)):
        k = np.round(alpha[i] / grid)
        if (grid == np.pi / 2 and k % 2 == 0) or abs(alpha[i] - k * grid) > UR_SEED_TOL:
            return None
        snapped[i] = k * grid
    if np.abs(beta[1:]).max() > UR_SEED_TOL or abs(a[5]) > UR_SEED_LENGTH:
        return None
    beta[1:] = 0.0
    a[5] = 0.0
    links = (snapped, a, beta, theta, d)
    return links if ur_form(*links) is not None else None
