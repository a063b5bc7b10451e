"""Planning for the error the calibration will not fit (a bias-aware design).

A calibration fits the unknowns of its model, but the robot also carries errors that model does
not describe: compliance under its own weight, backlash, the travel-dependent errors of joint-error
terms the fit leaves out. They do not average out like measurement noise: the fitted parameters
absorb them, in a way that depends on the poses measured, and a design optimal for noise alone
(the extreme poses of I-optimality) can absorb them badly. On the real ABB IRB 120 data a
noise-optimal plan of 20 poses did worse held out than 20 random ones.

Here the unmodelled error is the joint-error terms ``terms`` (:mod:`robocal.kinematics.joint_errors`)
with random values ``c ~ N(0, P)``: ``P`` has the shape of their priors
(:func:`robocal.identify.priors.prior_sigma`) scaled so that their TCP error over the region has
the RMS ``u`` the user states (``u^2 = trace(A_nn P)``; a previous geometric calibration's
unmodelled error approximates it: a fit absorbs little of these terms over the workspace). With the
fitted unknowns' whitened blocks ``G_j``, the unmodelled terms' ``N_j``, ``M = diag(prior) + sum
G_j^T G_j`` and ``X = sum G_j^T N_j`` over the design, the fitted MAP estimate errs at a region
pose by ``J_f (theta_hat - theta) - J_n c``, whose mean square over the region is

    V = trace(A_ff M^-1) + trace(A_ff M^-1 X P X^T M^-1) - 2 trace(M^-1 X P A_fn^T) + u^2

(``A`` the region matrix of :func:`robocal.trust.coverage.region_matrix` over the fitted and the
unmodelled unknowns; the first term is the I-criterion of :mod:`robocal.campaign.exchange`).
:func:`search` improves the noise-optimal design and random ones for ``V`` by Fedorov sweeps over
every candidate (:class:`Scans`: four ``(r, r)`` forms per candidate, updated by rank ``r`` after
each change of the design, give every candidate's ``V`` by the Woodbury identity), so the plan
trades noise against what the fit absorbs, and ``sqrt(V)`` is an accuracy prediction that includes
the unmodelled error.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robocal.campaign.exchange import (
    IMPROVEMENT_RTOL,
    MAX_SWEEPS,
    REFRESH_EVERY,
    RIDGE,
    block_abt,
    block_inverses,
    itself_only,
    one_blas_thread,
    packing,
)
from robocal.campaign.information import Information, candidate_blocks
from robocal.core.errors import DataError
from robocal.data.measurements import Measurements
from robocal.identify.priors import prior_sigma
from robocal.kinematics import thermal
from robocal.kinematics.joint_errors import CONDITION_TERMS, candidate_names, parse_terms
from robocal.trust.coverage import region_matrix
from robocal.trust.posterior import Noise, whitened_rows

MAX_UNMODELLED_MM = 1000.0  # an unmodelled error of a metre is no robot's to plan for
DEFAULT_TERMS = ("compliance", "backlash", "travel")  # the non-geometric errors of common arms
DOWNDATE_MIN_DET = 1e-4  # removing a block with det(I - H B H^T) below this: forms afresh (a rank-r
                         # downdate would amplify the rounding by about its inverse)


@dataclass(frozen=True)
class Unmodelled:
    """The unmodelled error of a plan: its RMS ``rms_m`` (m) over the region, the joint-error
    parameters ``names`` (m of them) that model it, the candidates' whitened rows of them
    ``N (C, r, m)`` (the rows of the planner's blocks ``G``; SI), their variances ``variance (m,)``
    (SI^2), and the region's cross matrix ``A_cross (p, m)`` (the planner's scaled unknowns by
    these parameters)."""

    rms_m: float
    terms: tuple[str, ...]
    names: list[str]
    N: np.ndarray
    variance: np.ndarray
    A_cross: np.ndarray


def check_terms(terms) -> tuple[str, ...]:
    """Validated unmodelled ``terms``: joint-error terms that need no recorded conditions."""
    terms = tuple(parse_terms(terms))
    conditions = set(terms) & {*CONDITION_TERMS, thermal.GROUPS_TERM}
    if conditions:
        raise DataError("the unmodelled error is modelled by joint-error terms that need no recorded "
                        f"conditions: not {', '.join(sorted(conditions))}")
    return terms


def measured_values(robot, measured: Measurements, terms=DEFAULT_TERMS) -> tuple[dict[str, float], float]:
    """The joint-error ``terms``' values (SI) the measurements ``measured`` of ``robot`` (the
    nominal model; e.g. candidates measured in an earlier campaign) show: their calibration with
    those terms (the default calibration's method and priors); and that calibration's residual
    (3-D RMS, degrees of freedom corrected, mm): the instrument's noise and what the terms leave,
    what a held-out measurement adds to the calibrated model's error."""
    from robocal.calibration.pipeline import calibrate

    result = calibrate(robot, measured, nongeometric=",".join(check_terms(terms)))
    errors = result.robot.joint_errors
    values = {} if errors is None else dict(zip(errors.names, errors.values.tolist(), strict=True))
    return values, float(result.predicted_accuracy["validated_mm"])


def unmodelled_error(robot, data: Measurements, noise: Noise, info: Information, q_region: np.ndarray,
                     rms_mm: float, terms=DEFAULT_TERMS, values: dict[str, float] | None = None
                     ) -> Unmodelled | None:
    """The unmodelled error as the joint-error ``terms`` of ``robot`` that the fit (``info``) does
    not estimate: of RMS ``rms_mm`` (mm over the region joints ``q_region (R, n)``) in the shape
    of their priors, or, with ``values`` (:func:`measured_values`), in the shape of their measured
    magnitudes (independent: a design is not tuned to one noisy estimate of the combination) and
    of the RMS the measured values make together over the region (their fitted values compensate
    each other where the terms are correlated; ``rms_mm`` unused); None when it is zero
    (DataError when none of the terms is left with an effect)."""
    if not (np.isfinite(rms_mm) and 0 <= rms_mm <= MAX_UNMODELLED_MM):  # 1e308 overflowed (exit 3)
        raise DataError(f"the unmodelled error must be a finite RMS >= 0 mm (at most {MAX_UNMODELLED_MM:g}), "
                        f"got {rms_mm}")
    terms = check_terms(terms)
    if rms_mm == 0 and values is None:
        return None
    fitted = set(info.robot_names) | set(robot.joint_error_names)
    names = [nm for nm in candidate_names(robot.n_joints, terms) if nm not in fitted]
    full = robot.with_joint_errors([*robot.joint_error_names, *names])
    obs, rows = whitened_rows(full, data, noise, names)
    N = candidate_blocks(obs, data, rows)[0]
    keep = np.sum(N**2, axis=(0, 1)) > 0  # terms no candidate moves (a vertical axis's compliance)
    if values is not None:  # and terms the measurements show none of
        keep &= np.array([values.get(nm, 0.0) != 0.0 for nm in names], bool)
    names, N = [nm for nm, k in zip(names, keep, strict=True) if k], N[:, :, keep]
    if not names:
        if values is not None:
            return None
        raise DataError(f"the unmodelled terms {', '.join(terms)} have no effect here that the calibrated "
                        "model does not already fit: name other terms (--unmodelled-terms)")
    k, p = len(info.robot_names), len(info.names)
    A = region_matrix(full, [*info.robot_names, *names], q_region)
    A_fitted, A_cross = np.zeros((p, p)), np.zeros((p, len(names)))
    A_fitted[:k, :k] = A[:k, :k] / np.outer(info.scale[:k], info.scale[:k])
    A_cross[:k] = A[:k, k:] / info.scale[:k, None]
    if values is None:
        sigma2 = prior_sigma(full, names) ** 2
        rms_m = float(rms_mm) * 1e-3
    else:  # each term's measured magnitude, scaled to the error the measured values make together
        v = np.array([values[nm] for nm in names])
        sigma2 = v**2
        rms_m = float(np.sqrt(v @ A[k:, k:] @ v))
    variance = sigma2 * rms_m**2 / float(np.sum(np.diag(A)[k:] * sigma2))
    return Unmodelled(rms_m=rms_m, terms=terms, names=names, N=N, variance=variance, A_cross=A_cross)


def _values(M: np.ndarray, X: np.ndarray, A: np.ndarray, um: Unmodelled) -> np.ndarray:
    """``V`` (m^2) of designs with information ``M (D, p, p)`` and cross information ``X (D, p, m)``."""
    Mi = np.linalg.inv(M)
    T = Mi @ X
    AT = A @ T
    return (np.einsum("dij,ji->d", Mi, A) + np.einsum("dia,dia,a->d", T, AT, um.variance)
            - 2.0 * np.einsum("dia,ia,a->d", T, um.A_cross, um.variance) + um.rms_m**2)


def _cross(G: np.ndarray, um: Unmodelled, indices) -> np.ndarray:
    """``X = sum_j G_j^T N_j (p, m)`` over the candidates ``indices``."""
    return np.einsum("crp,crm->pm", G[indices], um.N[indices])


def mean_square(G: np.ndarray, A: np.ndarray, prior: np.ndarray, um: Unmodelled, indices) -> float:
    """``V`` (m^2) of the design ``indices`` computed from scratch (no ridge)."""
    idx = np.asarray(indices, int)
    H = G[idx].reshape(-1, G.shape[-1])
    M = H.T @ H + np.diag(prior)
    return float(_values(M[None], _cross(G, um, idx)[None], A, um)[0])


@dataclass(frozen=True)
class Candidates:
    """What a search's scans share: the blocks ``G (C, r, p)``, the region matrices ``A (p, p)``
    and ``A_cross`` scaled by the unmodelled terms' standard deviations (``(p, m)``: the terms
    then have unit variance), and each candidate's fitted and scaled unmodelled rows side by side,
    component-wise ``rows (r, p + m, C)`` (the products over all candidates are then ``r`` BLAS
    products and their ``(r, r)`` results long vectors)."""

    G: np.ndarray
    A: np.ndarray
    um: Unmodelled
    cross: np.ndarray
    rows: np.ndarray

    @classmethod
    def of(cls, G: np.ndarray, A: np.ndarray, um: Unmodelled) -> Candidates:
        sd = np.sqrt(um.variance)
        rows = np.concatenate([G, um.N * sd], axis=2).transpose(1, 2, 0)
        return cls(G=G, A=A, um=um, cross=um.A_cross * sd, rows=np.ascontiguousarray(rows))


class Scans:
    """A design (information ``M (p, p)``, cross information ``X (p, m)``) and, for every
    candidate ``c``, four ``(r, r)`` forms that give ``V`` after adding it.

    With ``B = M^-1``, ``D = B A B`` and the unmodelled terms scaled to unit variance (``N``,
    ``X``, ``A_cross`` times their standard deviations), ``T = B X`` and ``Z = D X - B A_cross``,
    a block ``G_c`` and ``S_c = I + G_c B G_c^T``, the Woodbury identity gives
    ``(M + G_c^T G_c)^-1 (X + G_c^T N_c) = T + B G_c^T S_c^-1 W_c`` with ``W_c = N_c - G_c T``, so

        V_c = V - trace(S_c^-1 QD_c) + 2 trace(S_c^-1 WZ_c) + trace(S_c^-1 QD_c S_c^-1 WW_c)

    with ``QB_c = G_c B G_c^T`` (in ``S_c``), ``QD_c = G_c D G_c^T``, ``WW_c = W_c W_c^T`` and
    ``WZ_c = W_c (G_c Z)^T``: ``(r, r)`` each, whatever the number of terms. Adding or removing a
    block ``H`` changes ``B``, ``D``, ``T`` and ``Z`` by rank ``r`` (:meth:`updated`): every
    candidate's forms change by products of five ``(r, r)`` blocks (``G_c B H^T``, ``G_c D H^T``
    and three of ``W_c``, ``G_c Z`` by the change), one ``(C r, p + m) x (p + m, 5 r)`` product for
    all, where computing them afresh costs ``(C r, p) x (p, 2 p + 2 m)``.
    """

    def __init__(self, cands: Candidates, M: np.ndarray, X: np.ndarray, state: tuple | None = None) -> None:
        self.cands, self.M, self.X = cands, M, X
        A, cross = cands.A, cands.cross
        if state is None:
            B = np.linalg.inv(M)
            B = 0.5 * (B + B.T)
            D = B @ A @ B
            state = (B, 0.5 * (D + D.T)) + self._forms(B, 0.5 * (D + D.T))
        self.B, self.D, self.QB, self.QD, self.WW, self.WZ = state
        self.T = self.B @ self.scaled_X
        self.Z = self.D @ self.scaled_X - self.B @ cross
        self.value = float(np.einsum("ij,ji->", self.B, A) + np.einsum("ia,ia->", self.T, A @ self.T)
                           - 2.0 * np.einsum("ia,ia->", self.T, cross) + self.cands.um.rms_m**2)

    @property
    def scaled_X(self) -> np.ndarray:
        return self.X * np.sqrt(self.cands.um.variance)

    def _forms(self, B: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, ...]:
        """``QB, QD, WW, WZ (r, r, C)`` from scratch."""
        rows = self.cands.rows
        p = len(B)
        X = self.scaled_X
        T, Z = B @ X, D @ X - B @ self.cands.cross
        G, N = rows[:, :p], rows[:, p:]
        GB, GD = B @ G, D @ G                                      # (r, p, C)
        W = N - T.T @ G                                            # (r, m, C)
        return block_abt(GB, G), block_abt(GD, G), block_abt(W, W), block_abt(W, Z.T @ G)

    def values(self) -> np.ndarray:
        """``V`` (m^2) after adding each candidate ``(C,)``."""
        S_inv = block_inverses(self.QB + np.eye(len(self.QB))[:, :, None])
        Y = block_abt(block_abt(S_inv, self.QD), S_inv)                     # S^-1 QD S^-1 (all symmetric)
        return self.value + np.einsum("abc,bac->c", S_inv, 2.0 * self.WZ - self.QD) + np.einsum(
            "abc,abc->c", Y, self.WW)

    def updated(self, index: int, sign: float) -> Scans:
        """The design with candidate ``index`` added (``sign`` +1) or removed (-1); computed afresh
        when removing it leaves ``M`` nearly singular (:data:`DOWNDATE_MIN_DET`)."""
        cands = self.cands
        H = cands.G[index]
        r, p = H.shape
        N_i = cands.rows[:, p:, index]                             # (r, m) scaled
        M, X = self.M + sign * (H.T @ H), self.X + sign * (H.T @ cands.um.N[index])
        Pm = H @ self.B                                            # (r, p)
        S = np.eye(r) + sign * (Pm @ H.T)
        if sign < 0 and np.linalg.det(S) < DOWNDATE_MIN_DET:
            return Scans(cands, M, X)
        E = sign * np.linalg.inv(S)
        E = 0.5 * (E + E.T)
        R = self.D @ H.T                                           # (p, r)
        F = E @ (Pm @ cands.A @ Pm.T) @ E
        B = self.B - Pm.T @ E @ Pm
        D = self.D - Pm.T @ E @ R.T - R @ E @ Pm + Pm.T @ F @ Pm
        Xs = X * np.sqrt(cands.um.variance)
        PX = Pm @ Xs
        O1 = sign * N_i - E @ PX                                   # W_c' = W_c - GP_c O1
        O2 = F @ PX - E @ (R.T @ Xs) + E @ (Pm @ cands.cross)      # G_c Z' = G_c Z + GP_c O2 + GR_c O1
        m = N_i.shape[1]
        step = np.zeros((p + m, 5 * r))                            # on [G_c, N_c]: the five blocks
        step[:p, :r], step[:p, r: 2 * r] = Pm.T, R
        step[:p, 2 * r: 3 * r], step[p:, 2 * r: 3 * r] = -self.T @ O1.T, O1.T
        step[:p, 3 * r: 4 * r], step[p:, 3 * r: 4 * r] = -self.T @ O2.T, O2.T
        step[:p, 4 * r:] = self.Z @ O1.T
        # GP = G_c B H^T, GR = G_c D H^T, a = W_c O1^T, b = W_c O2^T, c = G_c Z O1^T: (r, r, C) each
        GP, GR, a, b, c = np.split(step.T @ cands.rows, 5, axis=1)
        # the forms' changes as few products X_c Y_c^T of (r, r) blocks as their symmetry allows
        GPE, GPF, GPO11, GPO12 = np.split(_times(GP, np.hstack([E, F, O1 @ O1.T, O1 @ O2.T])), 4, axis=1)
        QB = self.QB - block_abt(GPE, GP)
        dQD = block_abt(0.5 * GPF, GP) - block_abt(GPE, GR)                 # QD' = QD + dQD + dQD^T
        dWW = block_abt(0.5 * GPO11 - a, GP)                           # WW' = WW + dWW + dWW^T
        QD = self.QD + dQD + dQD.transpose(1, 0, 2)
        WW = self.WW + dWW + dWW.transpose(1, 0, 2)
        WZ = self.WZ + block_abt(b - GPO12, GP) + block_abt(a - GPO11, GR) - block_abt(GP, c)
        return Scans(cands, M, X, (0.5 * (B + B.T), 0.5 * (D + D.T), QB, QD, WW, WZ))


def _times(X: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``X_c K`` for per-candidate ``X (r, k, C)`` (component-wise) and one ``K (k, l)``."""
    return K.T @ X


def search(G: np.ndarray, A: np.ndarray, prior: np.ndarray, um: Unmodelled, init,
           conflicts: Callable[[int], np.ndarray] | None, rng: np.random.Generator,
           starts: int) -> tuple[np.ndarray, float]:
    """The best design for ``V`` of :func:`polish` from ``init`` (the noise-optimal design) and from
    ``starts`` random ones (no two members conflicting): the noise-optimal design's extreme poses
    are often a local optimum of ``V``. Returns the sorted design and its ``V`` (m^2)."""
    C, n = len(G), len(init)
    blocked_by = itself_only(C) if conflicts is None else conflicts
    best = None
    with one_blas_thread():
        for design in [list(init)] + [packing(C, blocked_by, rng.permutation(C), n) for _ in range(starts)]:
            if len(design) < n:
                continue  # the conflicts left no room for a random packing of n
            found = polish(G, A, prior, um, design, blocked_by, rng)
            if best is None or found[1] < best[1]:
                best = found
    return best


def polish(G: np.ndarray, A: np.ndarray, prior: np.ndarray, um: Unmodelled, members,
           blocked_by: Callable[[int], np.ndarray], rng: np.random.Generator,
           max_sweeps: int = MAX_SWEEPS) -> tuple[np.ndarray, float]:
    """Fedorov sweeps from the design ``members`` for ``V`` (``blocked_by(j)``: the candidates that
    may not join ``j``): each member in turn is exchanged for the candidate that lowers ``V`` most
    (every allowed candidate scored by :class:`Scans` of the design without it), until a whole sweep
    changes nothing; the forms are computed afresh every ``REFRESH_EVERY`` changes. Returns the
    sorted design and its ``V`` (m^2)."""
    members = [int(m) for m in members]
    blocked = np.sum([blocked_by(m) for m in members], axis=0)
    M = np.diag(prior) + RIDGE * np.eye(G.shape[-1]) + np.einsum("cri,crj->ij", G[members], G[members])
    X = _cross(G, um, members)
    cands = Candidates.of(G, A, um)
    design = Scans(cands, M, X)
    current = float(_values(M[None], X[None], A, um)[0])
    changes = 0
    for _ in range(max_sweeps):
        changed = False
        for i in rng.permutation(members):  # each member in turn: one scan of the candidates
            i = int(i)
            without = design.updated(i, -1.0)
            tried = np.where(blocked - blocked_by(i) == 0, without.values(), np.inf)
            j = int(np.argmin(tried))
            if j == i or not tried[j] < current - IMPROVEMENT_RTOL * current:
                continue
            members[members.index(i)] = j
            blocked += blocked_by(j) - blocked_by(i)
            design, current, changes = without.updated(j, 1.0), float(tried[j]), changes + 2
            if changes >= REFRESH_EVERY:  # from scratch: the updates' rounding does not accumulate
                design, changes = Scans(cands, design.M, design.X), 0
            changed = True
        if not changed:
            break
    return np.asarray(sorted(members), int), mean_square(G, A, prior, um, members)
