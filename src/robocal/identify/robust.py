"""Method ``robust`` (seed 003): ridge estimation with IGG3 equivalent weights, iterated.

Each outer iteration fits the model with the current item weights and a ridge term on the
(column-scaled) parameter errors, then recomputes the weights from the standardised
residuals: each residual divided by sqrt(1 - h_ii), h_ii its leverage (the diagonal of the hat
matrix of the weighted Jacobian: the residual's cofactor q_vv of geodesy's IGG3), so rows the fit
absorbs more (a small file of a kind that alone sees a parameter) are not mistaken for outliers.
The scale is the median absolute deviation of those residuals, per measurement set (so each
kind is judged by its own noise); an item's statistic is its residual norm over (scale *
sqrt(rows per item)).
IGG3: weight 1 up to k0, (k0/|v|)((k1-|v|)/(k1-k0))^2 between k0 and k1, 0 beyond k1.

Stopping (convergence by construction): the outer loop has converged when no weight changes by
more than WEIGHT_TOL, or when the fit no longer moves (no residual changed by more than FIT_TOL of
the residuals' robust scale: a weight still settling slowly near k0 or k1 then changes nothing the
data can see). An item whose weight change reverses direction (its weight pushes the fit across k0
or k1 and back: a cycle, no fixed point) has its further weight steps halved at each reversal, so
it settles at a weight in between instead of cycling until ``max_outer``. The estimate carries the
parameter priors of its space (MAP rows, :mod:`robocal.identify.priors`) besides the ridge.

Ridge parameter (in the scaled problem):
- ``double-h`` (default): h1 = k s^2 / |x_LS|^2 (Hoerl-Kennard-Baldwin), then
  h2 = k s^2 / |x(h1)|^2 from the ridge solution with h1;
- ``gcv``: minimises generalised cross-validation over a log grid;
- ``lcurve``: the corner (maximum curvature) of the L-curve over the same grid;
- ``none``: IGG3 reweighting without ridge.
"""

from __future__ import annotations

import numpy as np

from robocal.core.damped_least_squares import Status
from robocal.core.errors import IdentificationError
from robocal.identify.linalg import ScaledSVD
from robocal.identify.lsq import gauss_newton
from robocal.identify.solvers import SolverResult, history_entry
from robocal.identify.space import ParameterSpace, State

MAD_TO_SIGMA = 1.4826
WEIGHT_TOL = 1e-4  # the weights have settled when none changes by more than this ...
FIT_TOL = 1e-2  # ... or the fit has: no residual moved by more than this fraction of the noise scale


def igg3_weights(v: np.ndarray, k0: float = 1.5, k1: float = 3.0) -> np.ndarray:
    """IGG3 equivalent weights of standardised residuals ``v``."""
    if not 0 < k0 < k1:
        raise IdentificationError(f"IGG3 needs 0 < k0 < k1, got k0={k0}, k1={k1}")
    a = np.abs(v)
    mid = (k0 / np.maximum(a, 1e-300)) * ((k1 - a) / (k1 - k0)) ** 2
    return np.where(a <= k0, 1.0, np.where(a <= k1, mid, 0.0))


MAX_LEVERAGE = 0.99  # a row the fit reproduces exactly carries no test of itself: capped
MIN_REDUNDANCY = 0.3  # local redundancy (1 - leverage) below which a row's residual tests nothing


def leverage(J: np.ndarray, row_weights: np.ndarray) -> np.ndarray:
    """``(M,)`` leverage h_ii of each residual row of the weighted least-squares fit with Jacobian
    ``J (M, k)`` and row weights ``(M,)`` (0 for rejected rows: leverage 0), capped below 1."""
    sw = np.sqrt(row_weights)
    svd = ScaledSVD.of(J * sw[:, None])
    keep = svd.s > 1e-12 * svd.s[0] if svd.s.size else svd.s.astype(bool)
    U = (svd.Js @ (svd.Vt[keep].T / svd.s[keep])) if svd.U is None else svd.U[:, keep]
    return np.minimum(np.sum(U**2, axis=1), MAX_LEVERAGE)


def standardized(r: np.ndarray, rows: int) -> tuple[np.ndarray, float]:
    """Per-item statistics ``(N,)`` and the robust residual scale (MAD) of residuals ``(M,)``."""
    scale = MAD_TO_SIGMA * np.median(np.abs(r - np.median(r)))
    scale = max(scale, 1e-15)
    per_item = np.linalg.norm(r.reshape(-1, rows), axis=1)
    return per_item / (scale * np.sqrt(rows)), scale


def ridge_parameter(J: np.ndarray, r: np.ndarray, prior: np.ndarray, rule: str = "double-h",
                    svd: ScaledSVD | None = None) -> float:
    """Ridge parameter (scaled units) for the linearised problem J x = r around ``prior``
    (``svd``: ``ScaledSVD.of(J)`` when the caller has it)."""
    if rule == "none":
        return 0.0
    svd = ScaledSVD.of(J) if svd is None else svd
    m, k = J.shape
    x_ls = svd.solve(r) + prior
    res = r - J @ (x_ls - prior)
    s2 = float(res @ res) / max(m - k, 1)
    if rule == "double-h":
        h1 = k * s2 / max(float(np.sum((x_ls * svd.scale) ** 2)), 1e-300)
        x_h1 = svd.solve(r, damping=h1, prior=prior) + prior
        return k * s2 / max(float(np.sum((x_h1 * svd.scale) ** 2)), 1e-300)
    s = svd.s
    grid = np.logspace(np.log10(s[-1] ** 2 * 1e-6 + 1e-300), np.log10(s[0] ** 2), 60)
    beta = svd.project(r)
    z = svd.Vt @ (prior * svd.scale)
    res_norm, sol_norm, gcv = [], [], []
    r_perp = float(r @ r - beta @ beta)
    for h in grid:
        f = s**2 / (s**2 + h)
        c = (s * beta - h * z) / (s**2 + h)  # solution coefficients of the total, minus prior
        total = c + z
        res_norm.append(float(np.sum((beta - s * c) ** 2)) + r_perp)
        sol_norm.append(float(np.sum(total**2)))
        gcv.append(m * res_norm[-1] / (m - np.sum(f)) ** 2)
    if rule == "gcv":
        return float(grid[int(np.argmin(gcv))])
    if rule == "lcurve":
        x, y = np.log(np.maximum(res_norm, 1e-300)), np.log(np.maximum(sol_norm, 1e-300))
        t = np.log(grid)
        dx, dy = np.gradient(x, t), np.gradient(y, t)
        ddx, ddy = np.gradient(dx, t), np.gradient(dy, t)
        curvature = (dx * ddy - dy * ddx) / np.maximum((dx**2 + dy**2) ** 1.5, 1e-300)
        return float(grid[int(np.argmax(curvature))])
    raise IdentificationError(f"unknown ridge rule {rule!r}: double-h, gcv, lcurve or none")


def standardized_items(problem, r: np.ndarray) -> tuple[np.ndarray, float]:
    """Per-item statistics ``(n_items,)`` of a problem's weighted residuals ``r (M,)``, each
    measurement set standardised by its own robust scale (IGG3 per kind), and the largest
    per-item scale (what the progress shows)."""
    stats, scales = [], []
    for rows, per_item in problem.row_blocks():
        v, scale = standardized(r[rows], per_item)
        stats.append(v)
        scales.append(scale * np.sqrt(per_item))
    return np.concatenate(stats), max(scales)


def solve(problem, start: State, space: ParameterSpace, *, k0: float = 1.5, k1: float = 3.0,
          ridge: str = "double-h", max_outer: int = 30, progress=None, **_) -> SolverResult:
    """Robust ridge estimation from ``start`` over ``space``."""
    item_rows = problem.item_rows()
    item_w = np.ones(problem.n_items)
    relax, last_step = np.ones(problem.n_items), np.zeros(problem.n_items)
    state, total = start, None
    r = problem.residuals(state)
    r_before = r
    J = problem.jacobian(state, space)  # at ``state``: built once per state, reused below
    history = [history_entry(0, float(r @ r), problem.n_items)]
    status = Status.MAX_ITERATIONS
    for outer in range(1, max_outer + 1):
        row_w = np.repeat(item_w, item_rows)
        sw = np.sqrt(row_w)
        Jw = J * sw[:, None]
        svd = ScaledSVD.of(Jw)
        prior = np.zeros(J.shape[1]) if total is None else total
        h = ridge_parameter(Jw, r * sw, prior, ridge, svd)
        gn = gauss_newton(problem, state, space, row_weights=row_w, ridge=h, prior=prior,
                          jacobian=J, svd=svd)
        state, total = gn.state, gn.total
        r = problem.residuals(state)
        J = problem.jacobian(state, space) if gn.jacobian is None else gn.jacobian
        redundancy = 1.0 - leverage(J, row_w)
        v, scale = standardized_items(problem, r / np.sqrt(redundancy))
        # an item the fit almost reproduces (local redundancy below MIN_REDUNDANCY) is not
        # controlled by the others: a gross error there cannot be told from the fit, so it keeps
        # its weight rather than being judged on a residual that says nothing
        uncontrolled = np.maximum.reduceat(redundancy < MIN_REDUNDANCY, np.r_[0, np.cumsum(item_rows)[:-1]])
        step = np.where(uncontrolled, 1.0, igg3_weights(v, k0, k1)) - item_w
        # an item whose weight change reverses direction is oscillating (its weight moves the fit
        # across k0 or k1 and back): each reversal halves its steps, so it settles in between
        reversed_ = step * last_step < 0
        relax = np.where(reversed_, relax / 2, relax)
        last_step = np.where(step != 0, step, last_step)
        new_w = item_w + relax * step
        change = float(np.max(np.abs(new_w - item_w)))
        # a weight settling slowly (an item near k0 or k1: its weight converges linearly) no longer
        # moves the estimate: the fit, not the last digit of a weight, is what must settle
        moved = float(np.max(np.abs(r - r_before))) / max(MAD_TO_SIGMA * float(np.median(np.abs(r))), 1e-300)
        r_before = r
        item_w = new_w
        history.append(history_entry(outer, float(r @ (r * np.repeat(item_w, item_rows))),
                                     problem.n_items))
        if progress is not None:  # the robust scale of one item's residual
            progress(outer, scale)
        if change < WEIGHT_TOL or (outer > 1 and moved < FIT_TOL):
            status = Status.CONVERGED
            break
    nit = len(history) - 1
    message = (f"IGG3 weights and fit converged in {nit} iterations" if status is Status.CONVERGED
               else f"IGG3 weights still changing after {max_outer} iterations")
    return SolverResult(state=state, status=status, message=message, nit=nit, history=history,
                        item_weights=item_w)


# Gross errors in a least-squares fit (a mislabelled motion-capture marker, a mistyped joint, a
# reading of the wrong target): an item beyond GROSS_K1 robust sigmas of its set cannot be noise
# (a normal residual passes 8 sigma once in 10^15), so least squares refits without it; between
# GROSS_K0 and GROSS_K1 it is down-weighted as IGG3 does. Data without such items are fitted by plain
# least squares, unchanged; heavy-tailed noise is the method `robust` (k0, k1 = 1.5, 3).
GROSS_K0 = 5.0
GROSS_K1 = 8.0


def without_gross_errors(problem, fitted: SolverResult, space: ParameterSpace,
                         progress=None) -> SolverResult:
    """A least-squares result ``fitted`` refitted with its gross errors rejected (items beyond
    :data:`GROSS_K1` robust sigmas of their set: IGG3 weights with k0 = :data:`GROSS_K0`, no ridge,
    from ``fitted``'s state); ``fitted`` itself when it has none."""
    v, _ = standardized_items(problem, problem.residuals(fitted.state))
    if not np.any(np.abs(v) > GROSS_K1):
        return fitted
    out = solve(problem, fitted.state, space, k0=GROSS_K0, k1=GROSS_K1, ridge="none", progress=progress)
    return SolverResult(state=out.state, status=out.status, nit=fitted.nit + out.nit,
                        history=fitted.history + out.history[1:], item_weights=out.item_weights,
                        message=f"{fitted.message}; gross errors rejected ({out.message})")
