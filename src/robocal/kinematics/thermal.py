"""Thermal expansion of the arm: every link length grows with the arm's temperature.

The link lengths ``a_i, d_i`` of the arm (the base height ``d_1`` included) are scaled by
``s = 1 + k (T - T_ref)``: ``T`` (deg C) the arm's temperature at the pose, ``T_ref`` the
reference, the calibration data's mean temperature (saved with the model), ``k`` (1/K) one
expansion coefficient for the whole arm (about 11.5e-6 for steel, 23e-6 for aluminium): parameter
``thermal``. The tracker-to-base frame, the tool and the SMRs are not scaled (the tracker frame is
fitted to each data set; tool and SMR are short). Joint angles and twists do not change.

The TCP moves by ``dp/dk = (T - T_ref) sum_i (a_i dp/da_i + d_i dp/dd_i)``: a translation, pose
by pose, from the link-length columns of the geometric Jacobian. Without a temperature the model
predicts the arm at ``T_ref``.
"""

from __future__ import annotations

import numpy as np

from robocal.kinematics.fk import LinkArrays

NAME = "thermal"
UNIT = "1/K"
DEFAULT_REFERENCE_C = 20.0  # T_ref of a model whose calibration recorded no temperature


def scale(k: float | np.ndarray, temperature: np.ndarray | None, reference: float) -> np.ndarray | None:
    """``(..., N)`` length scale ``1 + k (T - T_ref)`` for ``k`` scalar or ``(P,)`` (a batch:
    ``(P, N)``) and ``temperature (N,)`` deg C; None without a temperature (the arm at T_ref)."""
    if temperature is None:
        return None
    k = np.asarray(k, float)
    return 1.0 + k[..., None] * (np.asarray(temperature, float) - reference)


def scaled_links(links: LinkArrays, s: np.ndarray | None) -> LinkArrays:
    """``links`` with ``a, d`` multiplied by the per-pose scale ``s (..., N)`` (shape ``(..., N, n)``);
    ``links`` unchanged when ``s`` is None."""
    if s is None:
        return links
    s = s[..., None]
    return LinkArrays(links.alpha, np.asarray(links.a) * s, links.beta, links.theta, np.asarray(links.d) * s)


def translation_axis(u: np.ndarray, links: LinkArrays, temperature: np.ndarray | None,
                     reference: float) -> np.ndarray:
    """``(3, N)`` m per (1/K): the TCP translation per unit of ``k``, from the motion axes
    ``u (3, P, N)`` of :func:`robocal.kinematics.jacobian.motion_axes` (the a_i axes at 5i + 1,
    the d_i axes at 5i + 4) and the unscaled ``links`` ``(n,)``."""
    n = len(links.a)
    if temperature is None:
        return np.zeros((3, u.shape[-1]))
    L = 5 * n
    a, d = (np.asarray(v, float)[:, None] for v in (links.a, links.d))
    growth = u[:, 1:L:5] * a + u[:, 4:L:5] * d
    return growth.sum(axis=1) * (np.asarray(temperature, float) - reference)


def reference_of(temperatures: list[np.ndarray | None]) -> float:
    """T_ref (deg C): the mean of the recorded temperatures of the data sets, or
    :data:`DEFAULT_REFERENCE_C` when none recorded one."""
    t = [np.asarray(x, float) for x in temperatures if x is not None]
    return float(np.concatenate(t).mean()) if t else DEFAULT_REFERENCE_C
