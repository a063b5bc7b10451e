"""``nongeometric="auto"``: choose the joint-error model by cross-validation on the calibration data.

Candidates: the geometric model and every combination of the joint-error terms the data can
carry (compliance, gear, backlash, travel, and cyclic when the frequency search finds any; payload
and thermal when the data record payloads and temperatures that vary; thermal_groups, a k per link
group, only with thermal and over a temperature span of at least
:data:`robocal.kinematics.thermal.MIN_GROUP_SPAN_K`).
Each is judged by K-fold cross-validation on the calibration data alone, folds by whole poses
(every SMR of a pose in the same fold; distance data: by pair), repeated over REPEATS partitions
into folds (each pose's share of the squared error averaged over them: less of one partition's
luck). The approach directions and
moves each row carries come from the full measuring order (``Measurements.approach`` and
``.travel`` are kept through subsets), so a pose's backlash direction is the one of the pose
measured before it, whichever fold that one is in.

Cost: one calibration of the largest model (all fixed terms; the *superset*), from nominal. Every
candidate's fold fits then start from that full-data fit: the problem is linearised there once
(one Jacobian with the columns of every candidate term) and each fold fit is the Gauss-Newton
step from it on the fold's training poses — with the terms a candidate leaves out set to zero —
computed from per-fold normal matrices, so 32 candidates x K folds cost a few small solves each.
A fold fit keeps, of the candidate's joint-error columns, those its own training poses separate
from the geometry and from each other (the third identifiability stage on the fold's R factor),
as calibrating those poses would: a column only the left-out poses show (a joint's gear harmonic
where the training poses barely turn it) is held at zero instead of fitted to noise and
extrapolated (Meca500, random 490/70 split, the compliance, gear, backlash, cyclic candidate's
worst fold: 0.0282 mm, 0.0247 with it, its nonlinear fold calibration 0.0239).
The calibration is close to linear over the differences between candidates (sub-millimetre
displacements; the second-order error of the step is below a micrometre), which
tests/test_model_selection.py checks against full nonlinear fold calibrations. The cyclic
frequencies are searched again inside each fold on its training poses only, so the
cross-validated error of a candidate with cyclic terms includes the search (nested; a search on
all the data would favour it wrongly); the frequencies of the full data are then polished to
their exact least-squares values (:meth:`FrequencyScan.polish`; the folds skip this, which can
only make their error a little pessimistic). Finally the chosen model is calibrated with the
joint-error parameters the candidate kept named explicitly (the model cross-validated is the
model delivered; its own third identifiability stage may still drop one that is confounded at
the nominal model): for lsq from the superset's estimate (``calibrate(..., warm_start=)``, a few
iterations to the same minimum), for robust from nominal (its IGG3 weights depend on the path, so
the result is the robust calibration of that model named explicitly).

The calibrations themselves are the caller's (:func:`robocal.calibration.pipeline.calibrate` passes its
``fit(terms, validations, warm_start)``), so this module sits below the API layer.

Choice (the paired one-standard-error rule, capped, on winsorized errors): each pose's share of a
candidate's cross-validated squared error is capped at the WINSOR_QUANTILE (95 %) quantile of all
the candidates' shares; the candidate with the lowest such (winsorized) RMS is the best, unless a
simpler one — fewer identified parameters — is within one *paired* standard error of it (on the
capped shares) and within SELECTION_TOLERANCE (2%) of it; then the simplest such one. On real
tracker sets a few poses carry much of the cross-validated error (5 % of the poses 40 % of it on
the Meca500 and IRB 120): plain, those poses decide the RMS differences and the paired SE, which
hid a term every other pose gains from (Meca500 README split: auto chose compliance, backlash,
cyclic at 0.0184 mm held out while the gear term's set reached 0.0174; winsorized it chooses that
set, 0.0173). The table keeps the plain cross-validated RMS (``cv_rms_mm``) next to the winsorized
one (``cv_robust_rms_mm``). The paired standard error is that of the difference between the two
candidates' errors over the same held-out poses (each pose's share of the mean squared error,
candidate minus best, summed over the poses): what the two share (a pose's noise, a fold's luck,
an error neither models) cancels, so it measures whether the data tell them apart. The earlier
rule took the standard error of the best candidate's own error over the 5 folds, which on an arm
with a large error no candidate models (a 7-axis, cable-driven arm: millimetres) is many times
larger than the differences between candidates and so chose the geometric model while a
joint-error model was 7% better held out. The cap bounds what the rule gives away for simplicity:
the chosen model's cross-validated error is never more than SELECTION_TOLERANCE above the lowest
one (``benchmarks/bench_auto_selection.py`` measures the held-out side on the real and simulated
sets). The chosen model's final calibration must converge: one that does not is marked in the
table (``not_converged``, ``x``) and the rule is applied to the others. Every fit (superset,
folds, final) carries the same parameter priors (:mod:`robocal.identify.priors`): the fold fits
add the prior rows to their normal equations. Robust calibrations: the fold fits use the
superset's IGG3 weights and the error is scored on the observations it kept.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from robocal.core.errors import IdentificationError
from robocal.identify import normal
from robocal.identify.frequency_search import FrequencyScan
from robocal.identify.identifiability import DEFAULT_RTOL, independent_columns
from robocal.identify.normal import Normal, r_factor, row_chunks
from robocal.identify.priors import JOINT_ERROR_SIGMA, prior_sigma
from robocal.identify.space import ParameterSpace, State, block_of
from robocal.kinematics import thermal
from robocal.kinematics.joint_errors import (
    CONDITION_TERMS,
    TERMS,
    candidate_names,
    cyclic_names,
    is_refinement,
    term_of,
)

FOLDS = 5
REPEATS = 3  # partitions into folds (seeds seed, seed + 1, ...) the cross-validation averages over
# the choice caps each pose's share of a candidate's cross-validated squared error at this quantile
# of all the candidates' shares (module docstring: a few poses carried 40 % of it on real sets)
WINSOR_QUANTILE = 0.95
# cyclic: searched for; scale: declared by a model with a track, never tried by the selection
FIXED_TERMS = tuple(t for t in TERMS if t not in ("cyclic", "scale"))
MIN_POSES_PER_FOLD = 5
# the most the chosen (simpler) model's cross-validated RMS may exceed the lowest one's, relative
SELECTION_TOLERANCE = 0.02
# fit(terms, validations, warm_start) -> CalibrationResult: one calibration with those terms
Fit = Callable[[list, list, object], object]
EIGEN_RCOND = 1e-13  # relative cut-off of the scaled normal matrix's eigenvalues in a fold fit
CHOLESKY_MIN_PIVOT = 1e-10  # smallest squared Cholesky pivot (unit diagonal) trusted without cut-off


@dataclass
class _Linearised:
    """The superset fit linearised: weighted columns of every candidate unknown, residuals."""

    A: np.ndarray          # (M, k) weighted columns: geometric + nuisance, then joint errors
    r: np.ndarray          # (M,) weighted residuals at the superset estimate
    k0: int                # geometric + nuisance columns
    ng_names: list[str]    # names of the joint-error columns A[:, k0:]
    ng_values: np.ndarray  # their values at the superset estimate (0 where it dropped them)
    Jtheta: np.ndarray     # (M, n) weighted theta columns (cyclic columns are built from them)
    sigma: np.ndarray      # (M,) residual scale of each row (m)
    rows: int              # residual rows per item
    group: np.ndarray      # (N,) fold group of each item
    weight: np.ndarray     # (N,) item weight (robust; 1 otherwise)
    q_item: np.ndarray | None  # (N, n) joints of each item (None: items span two poses)
    prior_w2: np.ndarray   # (k,) squared prior weight of each column of A (0: no prior)
    prior_offset: np.ndarray  # (k,) each column's value minus its prior mean (SI)
    cyclic_w2: float       # squared prior weight of a cyclic column


def _linearise(result, ng_names: list[str]) -> _Linearised:
    """Columns of the (one-set) result's unknowns plus every name of ``ng_names`` at its estimate."""
    problem, state = result.problem, result.state
    obs = problem.observation
    robot = state.robot.with_joint_errors(list(dict.fromkeys(state.robot.joint_error_names + ng_names)))
    values = robot.values_of(ng_names)
    n = robot.n_joints
    geometric = [nm for nm in result.names if block_of(nm) != "joint_errors"]
    thetas = [f"theta{i + 1}" for i in range(n)]
    space = ParameterSpace((*geometric, *ng_names, *[t for t in thetas if t not in geometric]),
                           tuple(problem.nuisance_names))
    state = State(robot, state.nuisance)
    J = problem.jacobian(state, space)  # one pass: robot columns (with the thetas), then nuisance
    column = {nm: j for j, nm in enumerate(space.names)}
    # without nuisance A is J's leading columns (a view: no second (M, k) array), else a copy
    A = J[:, : len(geometric) + len(ng_names)] if not space.nuisance else \
        J[:, [column[nm] for nm in (*geometric, *space.nuisance, *ng_names)]]
    Jtheta = J[:, [column[t] for t in thetas]]
    r = problem.residuals(state)
    data, rows = obs.data, obs.rows_per_item
    item_of_rows = obs.item_of_rows()
    group = np.empty(obs.n_items, dtype=np.int64)
    one_pose = obs.n_items == len(data)
    group[item_of_rows] = data.pose_id if one_pose else item_of_rows
    q_item = None
    if one_pose:
        q_item = np.empty((obs.n_items, n))
        q_item[item_of_rows] = data.joints
    weights = result.solver.item_weights
    weight = np.ones(obs.n_items) if weights is None else np.asarray(weights, float)
    # the priors of the superset's space (robocal.identify.priors), for every column of A
    est = result.space
    w_of = dict(zip(est.names, est.prior_weight, strict=True))
    mean_of = dict(zip(est.names, est.prior_mean or [0.0] * est.size, strict=True))
    noise = est.noise
    geo_w = np.array([w_of.get(nm, 0.0) for nm in geometric])
    geo_offset = state.robot.values_of(geometric) - np.array([mean_of.get(nm, 0.0) for nm in geometric])
    ng_w = noise / prior_sigma(robot, ng_names) if ng_names else np.zeros(0)
    w2 = np.r_[geo_w, np.zeros(len(space.nuisance)), ng_w] ** 2
    offset = np.r_[geo_offset, np.zeros(len(space.nuisance)), values]
    cyclic_w2 = float((noise / JOINT_ERROR_SIGMA["cyclic"]) ** 2) if est.has_prior else 0.0
    return _Linearised(A, r, A.shape[1] - len(ng_names), list(ng_names), values, Jtheta, problem.sigma,
                       rows, group, weight, q_item, w2 if est.has_prior else np.zeros_like(w2), offset,
                       cyclic_w2)


def _folds(group: np.ndarray, k: int, seed: int) -> np.ndarray:
    """Fold index ``(N,)`` of each item: whole groups, assigned at random in equal numbers."""
    labels = np.unique(group)
    order = np.random.default_rng(seed).permutation(labels.size)
    fold_of_label = np.empty(labels.size, dtype=np.int64)
    fold_of_label[order] = np.arange(labels.size) % k
    return fold_of_label[np.searchsorted(labels, group)]


@dataclass
class _Candidate:
    terms: tuple[str, ...]
    columns: np.ndarray   # indices into the linearised A (geometric + the kept joint errors)
    zeroed: np.ndarray    # joint-error columns held at zero (left out or dropped)
    cyclic: bool
    ng_names: list[str]   # the kept joint-error parameters (without the cyclic ones)


def _solve(G: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Least-squares step from the normal equations ``G x = h`` (column-scaled; Cholesky, or an
    eigen-decomposition with a cut-off when a fold leaves the columns nearly dependent)."""
    d = np.sqrt(np.maximum(np.diag(G), 1e-300))
    Gs, hs = G / np.outer(d, d), h / d
    try:
        factor = scipy.linalg.cho_factor(Gs)
        if np.min(np.abs(np.diag(factor[0]))) ** 2 > CHOLESKY_MIN_PIVOT:
            return scipy.linalg.cho_solve(factor, hs) / d
    except np.linalg.LinAlgError:
        pass
    w, V = np.linalg.eigh(Gs)
    keep = w > EIGEN_RCOND * max(w[-1], 1e-300)
    return (V[:, keep] @ ((V[:, keep].T @ hs) / w[keep])) / d


class _CrossValidation:
    """K-fold fits of candidate column sets from the linearised superset, by normal equations.

    Nothing of size (rows x columns) is held beyond the linearised superset itself: each fold's
    normal equations (training rows, and the full data's as fold K) are accumulated chunk by chunk
    (:mod:`robocal.identify.normal`), and a candidate's test errors are computed chunk by chunk
    from the unweighted columns (one product with the steps of every fold)."""

    def __init__(self, lin: _Linearised, fold: np.ndarray, k: int, scan: FrequencyScan | None,
                 fold_cyclic: list[list[tuple[int, float]]], full_cyclic: list[tuple[int, float]],
                 rtol: float = DEFAULT_RTOL):
        self.lin, self.k, self.scan, self.rtol = lin, k, scan, rtol
        rows = lin.rows
        self.row_fold = np.repeat(fold, rows)
        self.row_weight = np.sqrt(np.repeat(lin.weight, rows))
        self.scored = lin.weight > 0
        self.unweighted = bool(np.all(lin.weight == 1.0))  # lsq: no weighted copy of a chunk
        self.r = lin.r * self.row_weight
        self.n_columns = lin.A.shape[1]
        self.cyclic = [*fold_cyclic, full_cyclic]  # per fold, then the full data's (fold k)
        self.chunk = max(rows, normal.CHUNK_ROWS // rows * rows)  # whole items per chunk
        self.gram = [Normal.zeros(self.n_columns + 2 * len(found)) for found in self.cyclic]
        # the pose (group) index of each scored test item, in the order _errors returns them
        labels, group_index = np.unique(lin.group, return_inverse=True)
        self.n_groups = labels.size
        self.test_group = np.concatenate([group_index[(fold == f) & self.scored] for f in range(k)])
        for s in row_chunks(lin.r.size, self.chunk):
            A = self._weighted(s)
            for f, gram in enumerate(self.gram):
                B = np.hstack([A, self._extra(s, f) * self.row_weight[s, None]])
                train = self.row_fold[s] != f  # all rows for the full data (f == k)
                gram.add(B[train], self.r[s][train])
        # each fold's R factor of its training rows: the identifiability selection a calibration of
        # those poses makes (the module docstring)
        self.fold_r = [r_factor(lambda s, f=f: self._weighted(s)[self.row_fold[s] != f], lin.r.size,
                                self.n_columns, self.chunk) for f in range(k)]

    def _weighted(self, s: slice) -> np.ndarray:
        """The rows ``s`` of A with the item weights (A's own rows for lsq)."""
        return self.lin.A[s] if self.unweighted else self.lin.A[s] * self.row_weight[s, None]

    def _fold_columns(self, cand: _Candidate, f: int) -> tuple[np.ndarray, np.ndarray]:
        """(columns, zeroed) of candidate ``cand`` on fold ``f``'s training poses: of its kept
        joint-error columns those the fold's own poses separate from the geometry and from each
        other (the third identifiability stage on the fold's R factor), the others held at zero
        like the terms it leaves out; the full data's (f == k) as the candidate keeps them."""
        lin = self.lin
        if f == self.k:
            return cand.columns, cand.zeroed
        ng = cand.columns[cand.columns >= lin.k0]
        if not ng.size:
            return cand.columns, cand.zeroed
        geo = cand.columns[cand.columns < lin.k0]
        later = np.array([is_refinement(lin.ng_names[j - lin.k0]) for j in ng], bool)
        keep = ng[independent_columns(self.fold_r[f][:, np.r_[geo, ng]], geo.size, self.rtol, later)]
        return np.r_[geo, keep], np.setdiff1d(np.arange(lin.k0, self.n_columns), keep)

    def _extra(self, s: slice, f: int) -> np.ndarray:
        """The unweighted cyclic columns of fold ``f``'s frequencies on the rows ``s``."""
        if self.scan is None:
            return np.zeros((s.stop - s.start, 0))
        rows = self.lin.rows
        return self.scan.columns(self.lin.Jtheta[s], rows, self.cyclic[f],
                                 items=slice(s.start // rows, s.stop // rows))

    def _fit(self, gram: Normal, cand: _Candidate, n_extra: int, f: int):
        """Step ``x`` on the candidate's columns on fold ``f`` (:meth:`_fold_columns`; then the
        cyclic ones) for its Gram set: ``(cols, x, zeroed)``."""
        G, h = gram.G, gram.h  # G's first n_columns columns are those of A: the left-out terms' too
        k = self.n_columns
        columns, zeroed = self._fold_columns(cand, f)
        cols = np.r_[columns, np.arange(k, k + n_extra)] if cand.cyclic else columns
        v = self.lin.ng_values[zeroed - self.lin.k0]
        rhs = h[cols] + G[np.ix_(cols, zeroed)] @ v  # residual with the left-out terms at zero
        # the priors (MAP): each column's prior row pulls its total value towards the prior mean
        w2 = np.r_[self.lin.prior_w2, np.full(n_extra, self.lin.cyclic_w2)][cols]
        offset = np.r_[self.lin.prior_offset, np.zeros(n_extra)][cols]
        return cols, _solve(G[np.ix_(cols, cols)] + np.diag(w2), rhs - w2 * offset), zeroed

    def _errors(self, steps: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list[np.ndarray]:
        """Per fold (then the full data): the position error (m) of its scored test items (every
        scored item for the full data) after its step ``(cols, x, zeroed)`` with the columns
        ``zeroed`` (the left-out terms, those the fold cannot separate) at zero."""
        lin, k = self.lin, self.n_columns
        Y = np.zeros((k, len(steps)))  # the change of the unweighted model along A's columns, per fold
        extra = []
        for f, (cols, x, zeroed) in enumerate(steps):
            Y[zeroed, f] = lin.ng_values[zeroed - lin.k0]
            geo = cols < k
            Y[cols[geo], f] -= x[geo]
            extra.append(-x[~geo])
        out: list[list[np.ndarray]] = [[] for _ in steps]
        for s in row_chunks(lin.r.size, self.chunk):
            base = lin.r[s][:, None] + lin.A[s] @ Y  # (rows, folds + 1): residuals after each step
            scored = self.scored[s.start // lin.rows: s.stop // lin.rows]
            for f in range(len(steps)):
                rows = self.row_fold[s] == f if f < self.k else slice(None)
                e = base[rows, f]
                if extra[f].size:
                    e = e + self._extra(s, f)[rows] @ extra[f]
                items = np.linalg.norm((e * lin.sigma[s][rows]).reshape(-1, lin.rows)[:, :3], axis=1)
                out[f].append(items[scored[rows[:: lin.rows]] if f < self.k else scored])
        return [np.concatenate(parts) for parts in out]

    def evaluate(self, cand: _Candidate) -> dict:
        """Cross-validated RMS (mm), its standard error over the folds, and the full-data fit's RMS."""
        steps = [self._fit(gram, cand, 2 * len(found), f)
                 for f, (gram, found) in enumerate(zip(self.gram, self.cyclic, strict=True))]
        *folds, fit = self._errors(steps)
        fold_rms = [np.sqrt(np.mean(err**2)) for err in folds]
        squares = np.concatenate(folds) ** 2
        return {"cv_rms_mm": float(np.sqrt(np.mean(squares)) * 1e3),
                "cv_se_mm": float(np.std(fold_rms, ddof=1) / np.sqrt(self.k) * 1e3),
                "fold_rms_mm": [float(v * 1e3) for v in fold_rms],
                "calibration_rms_mm": float(np.sqrt(np.mean(fit ** 2)) * 1e3),
                "n_params": int(steps[-1][0].size),
                # per pose (group, sorted): its share of the cross-validated mean squared error
                # (m^2), for the paired comparison of candidates (popped by select_error_model)
                "mse_contributions": np.bincount(self.test_group, weights=squares,
                                                 minlength=self.n_groups) / squares.size}


def _candidates(lin: _Linearised, terms: list[str], has_cyclic: bool, rtol: float) -> list[_Candidate]:
    """Every combination of ``terms`` (cyclic last), its kept joint-error columns (third stage)."""
    geo = np.arange(lin.k0)
    R = r_factor(lambda s: lin.A[s], *lin.A.shape)  # same column geometry as A, K x K
    present = [t for t in terms if t != "cyclic"] + (["cyclic"] if has_cyclic else [])
    out = []
    for size in range(len(present) + 1):
        for combo in itertools.combinations(present, size):
            if thermal.GROUPS_TERM in combo and "thermal" not in combo:
                continue  # the groups' ks are deviations from the shared k: never without it
            idx = np.array([lin.k0 + j for j, nm in enumerate(lin.ng_names) if term_of(nm) in combo],
                           dtype=np.int64)
            later = np.array([is_refinement(lin.ng_names[j - lin.k0]) for j in idx], bool)
            kept = idx[independent_columns(R[:, np.r_[geo, idx]], lin.k0, rtol, later)] if idx.size else idx
            zeroed = np.setdiff1d(np.arange(lin.k0, lin.A.shape[1]), kept)
            out.append(_Candidate(combo, np.r_[geo, kept], zeroed, "cyclic" in combo,
                                  [lin.ng_names[j - lin.k0] for j in kept]))
    return out


def paired_se_mm(contrib: np.ndarray, contrib_best: np.ndarray, rms_mm: float, rms_best_mm: float) -> float:
    """Standard error (mm) of a candidate's cross-validated RMS minus the best one's, from the
    paired per-pose differences of their contributions (m^2) to the mean squared error: the
    error common to both (the poses' noise, the folds' luck) cancels."""
    d = contrib - contrib_best
    if d.size < 2:
        return 0.0  # one pose shows no difference to be within
    se_mse = np.sqrt(d.size) * np.std(d, ddof=1)  # the MSE difference is the sum of d over the poses
    total_m = (rms_mm + rms_best_mm) * 1e-3
    return float(se_mse / total_m * 1e3) if total_m > 0 else 0.0


def _choose(rows: list[dict], contributions: list[np.ndarray]) -> tuple[int, int, str]:
    """(chosen, best) indices by the paired one-standard-error rule capped at
    SELECTION_TOLERANCE, on the winsorized cross-validated errors (module docstring), and the
    reason in words. ``contributions[i]``: each pose's share (m^2) of candidate i's
    cross-validated mean squared error (same poses, same order for every candidate). Sets each
    row's ``cv_robust_rms_mm`` and ``cv_paired_se_mm`` (``None`` for the best)."""
    C = np.asarray(contributions)
    W = np.minimum(C, np.quantile(C, WINSOR_QUANTILE))  # no pose weighs more than the cap
    for row, w in zip(rows, W, strict=True):
        row["cv_robust_rms_mm"] = float(np.sqrt(w.sum()) * 1e3)
    best = min(range(len(rows)), key=lambda i: rows[i]["cv_robust_rms_mm"])
    rms_b = rows[best]["cv_robust_rms_mm"]
    cap = SELECTION_TOLERANCE * rms_b
    eligible = []
    for i, row in enumerate(rows):
        se = None if i == best else paired_se_mm(W[i], W[best], row["cv_robust_rms_mm"], rms_b)
        row["cv_paired_se_mm"] = se
        if i == best or row["cv_robust_rms_mm"] - rms_b <= min(se, cap):
            eligible.append(i)
    chosen = min(eligible, key=lambda i: (rows[i]["n_params"], rows[i]["cv_robust_rms_mm"]))
    if chosen == best:
        reason = (f"lowest winsorized cross-validated error ({rms_b:.4f} mm); no model with fewer "
                  f"parameters within one paired standard error of it (at most {SELECTION_TOLERANCE:.0%})")
    else:
        reason = (f"fewest parameters ({rows[chosen]['n_params']}) within one paired standard error "
                  f"({rows[chosen]['cv_paired_se_mm']:.4f} mm, at most {SELECTION_TOLERANCE:.0%}) of the "
                  f"lowest winsorized cross-validated error ({rms_b:.4f} mm, {_label(rows[best]['terms'])})")
    return chosen, best, reason


def _label(terms) -> str:
    return ", ".join(terms) if terms else "geometric"


def _full_search(lin: _Linearised) -> tuple:
    """``(scan, arrays, found, polished)``: the frequency scan of the full data, the (weighted)
    arrays it searches, the cyclic frequencies found and those polished; ``(None, (), [], [])``
    without joint readings. The same for every partition into folds: computed once."""
    if lin.q_item is None:
        return None, (), [], []
    scan = FrequencyScan(lin.q_item, lin.group)
    if np.all(lin.weight == 1.0):  # lsq: no weighted copy of the (M, k) columns
        args = (lin.A, lin.r, lin.Jtheta, lin.rows)
    else:
        w = np.sqrt(np.repeat(lin.weight, lin.rows))[:, None]
        args = (lin.A * w, lin.r * w[:, 0], lin.Jtheta * w, lin.rows)
    full = scan.search(*args)
    return scan, args, full, scan.polish(full, *args)


def _fold_searches(searched: tuple, cv_fold: np.ndarray | None, k: int) -> list:
    """The cyclic frequencies of each fold's training items (``searched``: :func:`_full_search`;
    none when the full data have none)."""
    scan, args, full, _ = searched
    return [scan.search(*args, mask=cv_fold != f) for f in range(k)] if full else [[] for _ in range(k)]


def _search(lin: _Linearised, cv_fold: np.ndarray | None, k: int):
    """The cyclic frequencies of the full data and of each fold's training items."""
    searched = _full_search(lin)
    return searched[0], searched[3], _fold_searches(searched, cv_fold, k)


def select_error_model(fit: Fit, data, validations: list, *, seed: int = 0, rtol: float,
                       warm_final: bool = True):
    """The calibration (``fit``, see :data:`Fit`) of ``data`` with the joint-error model chosen by
    cross-validation (module docstring); its ``model_selection`` holds the candidate table, the
    choice and the cost. ``warm_final``: the final fit starts from the superset's estimate (else
    from nominal, as the calibration of the chosen model named explicitly)."""
    t0 = time.perf_counter()
    n_groups = np.unique(getattr(data, data.spec.group)).size
    if n_groups < FOLDS * MIN_POSES_PER_FOLD:
        raise IdentificationError(
            f"choosing the error model by {FOLDS}-fold cross-validation needs at least "
            f"{FOLDS * MIN_POSES_PER_FOLD} poses, the data have {n_groups}: name the terms instead "
            "(e.g. --nongeometric compliance,backlash) or leave them out")
    fixed = [t for t in FIXED_TERMS if _term_has_data(t, data)]
    superset = fit(fixed, [], None)
    t_superset = time.perf_counter() - t0
    lin = _linearise(superset, candidate_names(superset.robot.n_joints, fixed))
    searched = _full_search(lin)
    scan, full_cyclic = searched[0], searched[3]
    fold_cyclic, repeats = [], []
    for r in range(REPEATS):  # the same candidates judged over REPEATS partitions into folds
        fold = _folds(lin.group, FOLDS, seed + r)
        found = _fold_searches(searched, fold, FOLDS)
        fold_cyclic += found
        cv = _CrossValidation(lin, fold, FOLDS, scan, found, full_cyclic, rtol)
        if not repeats:
            cands = _candidates(lin, fixed, bool(full_cyclic), rtol)
        repeats.append([cv.evaluate(c) for c in cands])
    cyclic_params = [nm for i, f in full_cyclic for nm in cyclic_names(i + 1, f)]
    rows = [{"terms": list(c.terms), **_pooled([rep[j] for rep in repeats]),
             "parameters": c.ng_names + (cyclic_params if c.cyclic else [])} for j, c in enumerate(cands)]
    contributions = [row.pop("mse_contributions") for row in rows]
    chosen, best, reason = _choose(rows, contributions)
    del lin, cv, scan, searched  # the linearised superset's (M, k) arrays are not needed by the final fit
    t_select = time.perf_counter() - t0
    while True:  # the chosen model must converge: one that does not is marked and the rule rerun
        final = fit(rows[chosen]["parameters"], validations, superset if warm_final else None)
        if final.solver.success:
            break
        rows[chosen]["not_converged"] = final.solver.message
        open_rows = [i for i in range(len(rows)) if "not_converged" not in rows[i]]
        if not open_rows:
            break
        sub, best_sub, reason = _choose([rows[i] for i in open_rows], [contributions[i] for i in open_rows])
        chosen, best = open_rows[sub], open_rows[best_sub]
        reason += " (the candidates marked x did not converge)"
    total = time.perf_counter() - t0
    final.model_selection = {
        "method": f"{FOLDS}-fold cross-validation by pose on the calibration data ({REPEATS} partitions), "
                  f"paired one-standard-error rule on the errors winsorized at the "
                  f"{WINSOR_QUANTILE:.0%} quantile (at most {SELECTION_TOLERANCE:.0%})",
        "tolerance": SELECTION_TOLERANCE,
        "folds": FOLDS, "seed": seed, "n_poses": n_groups,
        "candidates": rows, "chosen": chosen, "best": best, "reason": reason,
        "chosen_terms": rows[chosen]["terms"],
        "cyclic_frequencies": [{"joint": i + 1, "cycles_per_rev": f} for i, f in full_cyclic],
        "cyclic_frequencies_per_fold": [len(f) for f in fold_cyclic],
        # the order terms the data cannot carry (payload and thermal need recorded conditions: not listed)
        "terms_without_data": [t for t in FIXED_TERMS if t not in fixed and t not in CONDITION_TERMS
                               and t != thermal.GROUPS_TERM],
        "time_s": {"superset_fit": t_superset, "selection": t_select - t_superset,
                   "final_fit": total - t_select, "total": total},
    }
    return final


def _pooled(evaluations: list[dict]) -> dict:
    """One candidate's cross-validation over several partitions into folds: each pose's share of
    the mean squared error averaged over the partitions (so the cross-validated RMS is the RMS over
    every test prediction), the folds' RMS of all partitions and their standard error."""
    folds = [v for e in evaluations for v in e["fold_rms_mm"]]
    contrib = np.mean([e["mse_contributions"] for e in evaluations], axis=0)
    return {"cv_rms_mm": float(np.sqrt(contrib.sum()) * 1e3),
            "cv_se_mm": float(np.std(folds, ddof=1) / np.sqrt(len(folds))),
            "fold_rms_mm": folds, "calibration_rms_mm": evaluations[0]["calibration_rms_mm"],
            "n_params": evaluations[0]["n_params"], "mse_contributions": contrib}


def _term_has_data(term: str, data) -> bool:
    """Backlash needs approach directions and travel needs moves (the measuring order); payload
    and thermal need the recorded payload and temperature, varying over the data (a constant one
    is indistinguishable from the geometry and the arm's own compliance)."""
    if term == "payload":
        return data.payload is not None and np.unique(data.payload, axis=0).shape[0] > 1
    if term == "thermal":
        return data.temperature is not None and np.ptp(data.temperature) > 0
    if term == thermal.GROUPS_TERM:  # an arm with link groups, over a span that can tell them apart
        kinds = np.zeros(data.n_joints, bool) if data.linear is None else np.asarray(data.linear, bool)
        return (data.temperature is not None and np.ptp(data.temperature) >= thermal.MIN_GROUP_SPAN_K
                and bool((thermal.link_groups(kinds) >= 0).any()))
    if term == "backlash":
        return data.approach is not None and bool(np.any(data.approach))
    if term == "travel":
        return data.travel is not None and bool(np.any(data.travel))
    return True


def calibrate_cyclic(fit: Fit, others: list[str], validations: list):
    """The term ``cyclic`` with the terms ``others``: calibrate ``others``, search the cyclic
    frequencies in that fit's residuals, calibrate again with them (from the first fit)."""
    base = fit(others, [], None)
    lin = _linearise(base, candidate_names(base.robot.n_joints, others))
    _, found, _ = _search(lin, None, 0)
    names = [nm for i, f in found for nm in cyclic_names(i + 1, f)]
    result = fit(others + names, validations, base)
    if not names:
        result.warnings.append("no significant cyclic error found in the data; calibrated without "
                               "the cyclic term")
    return result


def selection_table(ms: dict) -> str:
    """The candidate table as text (CLI and summary)."""
    lines = [f"error model chosen by {ms['method']} ({ms['n_poses']} poses):",
             f"  {'model':44s} {'params':>6s} {'CV RMS mm':>10s} {'+- SE':>8s} {'robust mm':>9s} "
             f"{'paired SE':>9s} {'fit RMS mm':>10s}"]
    order = sorted(range(len(ms["candidates"])), key=lambda i: ms["candidates"][i]["cv_rms_mm"])
    for i in order:
        c = ms["candidates"][i]
        mark = "*" if i == ms["chosen"] else "x" if "not_converged" in c else "b" if i == ms["best"] else " "
        paired = c.get("cv_paired_se_mm")
        robust = c.get("cv_robust_rms_mm")
        lines.append(f"{mark} {_label(c['terms']):44s} {c['n_params']:6d} {c['cv_rms_mm']:10.4f} "
                     f"{c['cv_se_mm']:8.4f} {'-' if robust is None else f'{robust:.4f}':>9s} "
                     f"{'-' if paired is None else f'{paired:.4f}':>9s} {c['calibration_rms_mm']:10.4f}")
    lines.append(f"  chosen (*): {_label(ms['chosen_terms'])} — {ms['reason']}")
    if ms.get("cyclic_frequencies"):
        lines.append("  cyclic errors found (joint: cycles/rev): " + ", ".join(
            f"J{c['joint']}: {c['cycles_per_rev']:g}" for c in ms["cyclic_frequencies"]))
    if ms.get("terms_without_data"):
        lines.append("  not tried (the data carry no measuring order): "
                     + ", ".join(ms["terms_without_data"]))
    t = ms["time_s"]
    lines.append(f"  time: superset fit {t['superset_fit']:.2f} s, selection {t['selection']:.2f} s, "
                 f"final fit {t['final_fit']:.2f} s")
    return "\n".join(lines)
