"""Variance components of 6-D observations: the position and the rotation noise from the data.

A 6-D observation (a camera's board poses, a 6-DOF probe) weighs a rad of rotation residual like
``length_scale`` m of position residual. The right scale is ``sigma_position / sigma_rotation``,
which the instrument's datasheet gives only roughly (a camera's depth and its board's size move
both). The iterated estimation of variance components (Foerstner, "Ein Verfahren zur Schaetzung
von Varianz- und Kovarianzkomponenten", AVN 86:446-453, 1979; Koch, "Parameter Estimation and
Hypothesis Testing in Linear Models", Springer 1999, sec. 3.6.4) estimates one variance per group
of rows from the fit's residuals:

    sigma_g^2 = sum_{i in g} w_i v_i^2 / sum_{i in g} w_i (1 - h_ii)

with ``v`` the residuals in the group's own unit (m or rad), ``w`` the rows' robust weights (1 for
least squares) and ``h_ii`` the leverage of row i in the weighted fit with its prior rows (so
``sum (1 - h_ii)`` is the group's share of the redundancy). The length scale becomes the ratio of
the two sigmas, the fit is redone with it, and so on until the ratio settles
(:data:`RATIO_TOL`, at most :data:`MAX_ROUNDS` fits; a step that reverses the previous one, as a
robust fit's weights can make it, is halved). With known sigmas this recovers them
(tests/test_instruments.py simulates it).

An observation takes part when it has ``variance_groups`` (position, rotation: three rows each)
and ``set_length_scale``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robocal.data.instruments import INSTRUMENTS, instrument_of
from robocal.identify.robust import leverage
from robocal.identify.solvers import SolverResult
from robocal.identify.space import ParameterSpace, State

EXCESS = 3.0  # estimated noise beyond this many times the instrument's documented noise: said
RATIO_TOL = 0.01  # the length scale has settled when a round changes it by less than 1 %
MAX_ROUNDS = 15  # fits at most (lsq settles in 2-4; robust weights can slow it to ~10)
MIN_GROUP_REDUNDANCY = 1.0  # a group with less redundancy than this has no variance of its own to give


@dataclass(frozen=True)
class Components:
    """One 6-D set's estimated noise: ``sigma_m`` (position, m, each axis), ``sigma_rad`` (rotation,
    rad, each axis), the ``length_scale`` (m per rad) they give, the redundancy of each group and
    the fits (``rounds``) it took; ``settled`` False when :data:`MAX_ROUNDS` were not enough;
    ``documented`` the instrument's (sigma_m, sigma_rad), when it documents both."""

    label: str
    sigma_m: float
    sigma_rad: float
    length_scale: float
    redundancy: tuple[float, float]
    rounds: int
    settled: bool
    documented: tuple[float, float] | None = None

    def to_dict(self) -> dict:
        return {"data": self.label, "sigma_position_mm": self.sigma_m * 1e3,
                "sigma_rotation_deg": float(np.rad2deg(self.sigma_rad)),
                "length_scale_m_per_rad": self.length_scale,
                "redundancy": list(self.redundancy), "rounds": self.rounds, "settled": self.settled}

    @property
    def warning(self) -> str | None:
        """A warning when the estimated noise exceeds :data:`EXCESS` times the instrument's
        documented noise, else None."""
        if self.documented is None:
            return None
        sigma_m, sigma_rad = self.documented
        over = [f"{what} {got:.3g} {unit} against {doc:.3g} documented" for what, got, doc, unit in (
            ("position", self.sigma_m * 1e3, sigma_m * 1e3, "mm"),
            ("rotation", np.rad2deg(self.sigma_rad), np.rad2deg(sigma_rad), "deg")) if got > EXCESS * doc]
        if not over:
            return None
        return (f"{self.label or 'the 6-D data'}: the poses scatter about the fit beyond what the instrument "
                f"explains ({'; '.join(over)}, per axis): a gross error the robust weights kept, a board "
                "detected badly (calibrate the camera, check the board's size), or errors the model lacks")

    def line(self) -> str:
        return (f"variance components of {self.label or 'the 6-D data'}: position "
                f"{self.sigma_m * 1e3:.3g} mm, rotation {np.rad2deg(self.sigma_rad):.3g} deg per axis "
                f"(weight {self.length_scale:.3g} m/rad, {self.rounds} fits"
                f"{'' if self.settled else ', not settled'})")


def takes_part(obs) -> bool:
    """Whether an observation has position and rotation groups whose weights can be estimated."""
    return getattr(obs, "variance_groups", None) == ("position", "rotation")


def chosen(problem, wanted: bool | None = None) -> list[int]:
    """Indices of the observations whose components are estimated: every 6-D set when ``wanted``,
    none when False; by default (None) the camera's and every 6-D set declared taken with an
    instrument other than a laser tracker (a tracker's 6-DOF probe keeps its fixed scale)."""
    def default(obs) -> bool:
        instrument = instrument_of(obs.data)
        return bool(instrument) and instrument != "tracker"

    return [k for k, obs in enumerate(problem.observations)
            if takes_part(obs) and (wanted or (wanted is None and default(obs)))]


def estimate(problem, state: State, space: ParameterSpace, item_weights: np.ndarray | None = None
             ) -> dict[int, tuple[float, float, float, float]]:
    """Per taking-part observation index: ``(sigma_m, sigma_rad, redundancy_position,
    redundancy_rotation)`` at ``state`` (see the module)."""
    J = problem.jacobian(state, space)
    r = problem.residuals(state)
    w = np.ones(r.size) if item_weights is None else np.repeat(item_weights, problem.item_rows())
    prior = space.prior_weight
    rows = np.flatnonzero(prior > 0)
    J_all = np.vstack([J, np.eye(space.size)[rows] * prior[rows, None]])
    h = leverage(J_all, np.r_[w, np.ones(rows.size)])[: r.size]
    out = {}
    blocks = zip(problem.observations, problem.row_blocks(), strict=True)
    for k, (obs, (block, per_item)) in enumerate(blocks):
        if not takes_part(obs):
            continue
        unit = problem.sigma[block] / np.tile(np.r_[np.ones(3), np.full(3, obs.length_scale)], obs.n_items)
        v = (r[block] * unit).reshape(-1, per_item)
        wi = w[block].reshape(-1, per_item)
        red = (1.0 - h[block]).reshape(-1, per_item) * wi
        groups = []
        for cols in (slice(0, 3), slice(3, 6)):
            redundancy = float(red[:, cols].sum())
            groups.append((np.sqrt(float((wi[:, cols] * v[:, cols] ** 2).sum()) / max(redundancy, 1e-300)),
                           redundancy))
        out[k] = (groups[0][0], groups[1][0], groups[0][1], groups[1][1])
    return out


def fit(solve: Callable[[State], SolverResult], problem, start: State, space: ParameterSpace,
        parts: list[int]) -> tuple[SolverResult, list[Components]]:
    """``solve`` from ``start``, then rounds of :func:`estimate` and refits until the length scale
    of every observation in ``parts`` (:func:`chosen`) settles; the last fit and the components
    (empty without parts)."""
    out = solve(start)
    if not parts:
        return out, []
    rounds, settled, last = 1, False, {}
    previous = dict.fromkeys(parts, 0.0)  # each set's last log step of its length scale
    while rounds < MAX_ROUNDS:
        last = estimate(problem, out.state, space, out.item_weights)
        changes = []
        for k, (s_m, s_rad, red_m, red_rad) in last.items():
            if k not in parts:
                continue
            obs = problem.observations[k]
            if min(red_m, red_rad) < MIN_GROUP_REDUNDANCY or not (s_m > 0 and s_rad > 0):
                continue
            step = float(np.log(s_m / s_rad / obs.length_scale))
            if step * previous[k] < 0:  # a reversal (robust weights moving with the scale): halve it
                step /= 2
            previous[k] = step
            changes.append(abs(step))
            obs.set_length_scale(obs.length_scale * np.exp(step))
        if not changes or max(changes) < RATIO_TOL:
            settled = True
            break
        out = solve(out.state)
        rounds += 1
    if not settled:
        last = estimate(problem, out.state, space, out.item_weights)
    found = []
    for k in parts:
        obs = problem.observations[k]
        s_m, s_rad, red_m, red_rad = last.get(k, (np.nan, np.nan, 0.0, 0.0))
        inst = INSTRUMENTS.get(instrument_of(obs.data))
        documented = (inst.sigma_m, inst.sigma_rad) if inst is not None and inst.length_scale > 0 else None
        found.append(Components(obs.data.label, float(s_m), float(s_rad), obs.length_scale,
                                (round(red_m, 3), round(red_rad, 3)), rounds, settled, documented))
    return out, found
