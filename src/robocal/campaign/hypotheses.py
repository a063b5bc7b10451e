"""Planning for what the planner does not know: the SMR's place on the flange.

The calibration estimates the SMR's position on the flange (and with it, off the flange axis, the
last joint's zero), so a plan need not know it; but the information a pose gives depends on it.
A plan made for the nominal point alone (by default the model's TCP, on the flange axis for a
catalog arm) ignores the last joint's rotation, which an SMR off the axis turns into a lever; on
simulated arms whose true SMR sits tens of mm off the axis, 12 such poses left about 1.2 times the
error of 20 random ones.

When the user does not give the SMR, its offset from the nominal point is an unknown with a prior:
a box of half-width ``SMR_BOX_MM`` on each axis (zero mean, covariance ``(h^2 / 3) I``). The design
criterion is then its expectation over that prior, ``E_s[trace(M_s^-1 A_s)]`` (``M_s``, ``A_s``: the
posterior information and the region matrix with the SMR at ``s``), computed by a quadrature exact
for the prior's mean and covariance: the four vertices of a regular tetrahedron, ``s0 + sigma v``
with ``v`` in ``{(1,1,1), (1,-1,-1), (-1,1,-1), (-1,-1,1)}`` (a spherical 2-design: mean 0, second
moment ``I``), weighed equally (:func:`robocal.campaign.exchange.averaged_search`). The predicted
accuracy is the same expectation.
"""

from __future__ import annotations

import numpy as np

from robocal.campaign.exchange import criterion_value

SMR_BOX_MM = 50.0  # half-width of the prior box of an SMR the user does not give (each axis, mm)
TETRAHEDRON = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])


def smr_hypotheses(smr: np.ndarray, box_mm: float = SMR_BOX_MM) -> np.ndarray:
    """SMR positions ``(4, 3)`` m on the flange around the nominal ``smr (3,)`` m: the quadrature
    points of a uniform prior box of half-width ``box_mm`` (mm) on each axis (see the module
    docstring: their mean is ``smr`` and their covariance the box's, ``(box^2 / 3) I``)."""
    sigma = box_mm * 1e-3 / np.sqrt(3.0)
    return np.asarray(smr, dtype=float).reshape(1, 3) + sigma * TETRAHEDRON


def mean_criterion(problems: list[tuple[np.ndarray, np.ndarray, np.ndarray]], indices,
                   criterion: str = "I") -> float:
    """The mean over the hypotheses ``problems`` (``(G, A, prior)`` each) of the criterion of the
    design ``indices`` (m^2 for I), from scratch."""
    return float(np.mean([criterion_value(G, A, indices, criterion, prior) for G, A, prior in problems]))
