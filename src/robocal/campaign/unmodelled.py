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
every candidate (:func:`scan`: one ``(p, p)`` inverse per member tried and a Woodbury update per
candidate), so the plan trades noise against what the fit absorbs, and ``sqrt(V)`` is an accuracy
prediction that includes the unmodelled error.
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
    SINGULAR,
    itself_only,
    one_blas_thread,
    packing,
)
from robocal.campaign.information import Information, Noise, candidate_blocks, whitened_rows
from robocal.data.measurements import Measurements
from robocal.errors import DataError
from robocal.identify.priors import prior_sigma
from robocal.kinematics import thermal
from robocal.kinematics.joint_errors import CONDITION_TERMS, candidate_names, parse_terms
from robocal.trust.coverage import region_matrix

DEFAULT_TERMS = ("compliance", "backlash", "travel")  # the non-geometric errors of common arms


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


def unmodelled_error(robot, data: Measurements, noise: Noise, info: Information, q_region: np.ndarray,
                     rms_mm: float, terms=DEFAULT_TERMS) -> Unmodelled | None:
    """The unmodelled error of RMS ``rms_mm`` (mm over the region joints ``q_region (R, n)``) as
    the joint-error ``terms`` of ``robot`` that the fit (``info``) does not estimate; None when it
    is zero (DataError when none of the terms is left with an effect)."""
    if not (np.isfinite(rms_mm) and rms_mm >= 0):
        raise DataError(f"the unmodelled error must be a finite RMS >= 0 mm, got {rms_mm}")
    terms = tuple(parse_terms(terms))
    conditions = set(terms) & {*CONDITION_TERMS, thermal.GROUPS_TERM}
    if conditions:
        raise DataError("the unmodelled error is modelled by joint-error terms that need no recorded "
                        f"conditions: not {', '.join(sorted(conditions))}")
    if rms_mm == 0:
        return None
    fitted = set(info.robot_names) | set(robot.joint_error_names)
    names = [nm for nm in candidate_names(robot.n_joints, terms) if nm not in fitted]
    full = robot.with_joint_errors([*robot.joint_error_names, *names])
    obs, rows = whitened_rows(full, data, noise, names)
    N = candidate_blocks(obs, data, rows)[0]
    keep = np.sum(N**2, axis=(0, 1)) > 0  # terms no candidate moves (a vertical axis's compliance)
    names, N = [nm for nm, k in zip(names, keep, strict=True) if k], N[:, :, keep]
    if not names:
        raise DataError(f"the unmodelled terms {', '.join(terms)} have no effect here that the calibrated "
                        "model does not already fit: name other terms (--unmodelled-terms)")
    k, p = len(info.robot_names), len(info.names)
    A = region_matrix(full, [*info.robot_names, *names], q_region)
    A_fitted, A_cross = np.zeros((p, p)), np.zeros((p, len(names)))
    A_fitted[:k, :k] = A[:k, :k] / np.outer(info.scale[:k], info.scale[:k])
    A_cross[:k] = A[:k, k:] / info.scale[:k, None]
    sigma2 = prior_sigma(full, names) ** 2
    variance = sigma2 * (rms_mm * 1e-3) ** 2 / float(np.sum(np.diag(A)[k:] * sigma2))
    return Unmodelled(rms_m=float(rms_mm) * 1e-3, terms=terms, names=names, N=N, variance=variance,
                      A_cross=A_cross)


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


def scan(G: np.ndarray, A: np.ndarray, um: Unmodelled, M: np.ndarray, X: np.ndarray,
         candidates: np.ndarray) -> np.ndarray:
    """``V`` (m^2) after adding each of ``candidates (K,)`` to a design of information ``M (p, p)``
    and cross information ``X (p, m)`` (see :class:`Scans`)."""
    return Scans(G, A, um, M, X).values()[np.asarray(candidates, int)]


class Scans:
    """A design (information ``M (p, p)``, cross information ``X (p, m)``) and, for every
    candidate ``c`` of ``G (C, r, p)``, the products that give ``V`` after adding it.

    With ``B = M^-1``, ``D = B A B``, ``T0 = B X``, a block ``G_c`` and ``S_c = I + G_c B G_c^T``,
    the Woodbury identity gives ``(M + G_c^T G_c)^-1 (X + G_c^T N_c) = T0 + B G_c^T K_c`` with
    ``K_c = S_c^-1 (N_c - G_c T0)``, so that

        V_c = V - trace(S_c^-1 QD_c) + sum_a P_a (K_c^T (2 GDX_c + QD_c K_c - 2 GBC_c))_aa

    from the ``(r, r)`` forms ``QB_c = G_c B G_c^T``, ``QD_c = G_c D G_c^T`` and the ``(r, m)``
    products ``GBX_c = G_c T0``, ``GDX_c = G_c D X``, ``GBC_c = G_c B A_cross`` (``P`` the
    unmodelled variances). A design change (adding or removing one block ``H``) changes ``B`` and
    ``D`` by rank ``r`` (:meth:`updated`), and every candidate's forms and products by the same
    rank: one ``(C r, p) x (p, 2r)`` product updates them all, where computing them afresh
    (:class:`Scans` of ``M, X``) costs ``(C r, p) x (p, 2p + 3m)``. ``values`` costs
    ``O(C r^2 (r + m))``: no ``(p, p)`` work per candidate.
    """

    def __init__(self, G: np.ndarray, A: np.ndarray, um: Unmodelled, M: np.ndarray, X: np.ndarray,
                 state: tuple | None = None) -> None:
        self.G, self.A, self.um, self.M, self.X = G, A, um, M, X
        C, r, p = G.shape
        self.rows = G.reshape(C * r, p)
        if state is None:
            B = np.linalg.inv(M)
            B = 0.5 * (B + B.T)
            D = B @ A @ B
            D = 0.5 * (D + D.T)
            GB, GD = (self.rows @ B).reshape(C, r, p), (self.rows @ D).reshape(C, r, p)
            Gt = G.transpose(0, 2, 1)
            QB, QD = GB @ Gt, GD @ Gt
            Y = (self.rows @ np.hstack([B @ X, D @ X, B @ um.A_cross])).reshape(C, r, -1)
            state = (B, D, QB, QD, Y)
        self.B, self.D, self.QB, self.QD, self.Y = state
        T0 = self.B @ X
        P = um.variance
        self.value = float(np.einsum("ij,ji->", self.B, A) + np.einsum("ia,ia,a->", T0, A @ T0, P)
                           - 2.0 * np.einsum("ia,ia,a->", T0, um.A_cross, P) + um.rms_m**2)

    def values(self) -> np.ndarray:
        """``V`` (m^2) after adding each candidate ``(C,)``."""
        m = len(self.um.variance)
        GBX, GDX, GBC = self.Y[..., :m], self.Y[..., m: 2 * m], self.Y[..., 2 * m:]
        S_inv = _spd_inverse(self.QB + np.eye(self.QB.shape[-1]))
        K = S_inv @ (self.um.N - GBX)
        return (self.value - np.einsum("crs,csr->c", S_inv, self.QD)
                + np.einsum("cra,cra->c", K * self.um.variance, 2.0 * (GDX - GBC) + self.QD @ K))

    def updated(self, index: int, sign: float) -> Scans:
        """The design with candidate ``index`` added (``sign`` +1) or removed (-1); computed afresh
        when removing it leaves ``M`` (numerically) singular."""
        H, N_i = self.G[index], self.um.N[index]
        r = H.shape[0]
        M, X = self.M + sign * (H.T @ H), self.X + sign * (H.T @ N_i)
        Pm = H @ self.B                                           # (r, p)
        S = np.eye(r) + sign * (Pm @ H.T)
        if sign < 0 and np.linalg.det(S) <= SINGULAR:
            return Scans(self.G, self.A, self.um, M, X)
        E = sign * np.linalg.inv(S)
        E = 0.5 * (E + E.T)
        R = self.D @ H.T                                          # (p, r)
        F = E @ (Pm @ self.A @ Pm.T) @ E
        B = self.B - Pm.T @ E @ Pm
        D = self.D - Pm.T @ E @ R.T - R @ E @ Pm + Pm.T @ F @ Pm
        GPR = (self.rows @ np.hstack([Pm.T, R])).reshape(len(self.G), r, 2 * r)
        GP, GR = GPR[..., :r], GPR[..., r:]                       # G_c B H^T, G_c D H^T
        GPE = GP @ E
        GPt = GP.transpose(0, 2, 1)
        cross = GPE @ GR.transpose(0, 2, 1)
        QB = self.QB - GPE @ GPt
        QD = self.QD - cross - cross.transpose(0, 2, 1) + (GP @ F) @ GPt
        PX, RX = Pm @ X, R.T @ X                                  # H B X', H D X'
        W = sign * N_i - E @ PX
        zero = np.zeros_like(W)
        step = np.block([[W, F @ PX - E @ RX, -E @ (Pm @ self.um.A_cross)], [zero, W, zero]])
        Y = self.Y + (GPR.reshape(-1, 2 * r) @ step).reshape(self.Y.shape)
        return Scans(self.G, self.A, self.um, M, X,
                     (0.5 * (B + B.T), 0.5 * (D + D.T), QB, QD, Y))


def _spd_inverse(S: np.ndarray) -> np.ndarray:
    """The inverses ``(C, r, r)`` of symmetric positive definite ``S (C, r, r)``: by the Cholesky
    factor ``L`` (``S^-1 = L^-T L^-1``, ``L^-1`` by forward substitution, a loop over the ``r``
    rows of one block vectorised over the candidates: numpy's batched inverse solves each small
    matrix in its own LAPACK call, several times slower); by ``numpy.linalg.inv`` when some
    ``S_c`` is not numerically positive definite."""
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return np.linalg.inv(S)
    Li = np.zeros_like(S)
    for k in range(S.shape[-1]):  # row k of L^-1 from the rows above it
        Li[:, k, k] = 1.0
        Li[:, k, :k] = -np.einsum("cj,cjb->cb", L[:, k, :k], Li[:, :k, :k])
        Li[:, k, : k + 1] /= L[:, k, k, None]
    return Li.transpose(0, 2, 1) @ Li


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
    (every allowed candidate scored by :func:`scan`), until a whole sweep changes nothing. Returns
    the sorted design and its ``V`` (m^2)."""
    members = [int(m) for m in members]
    blocked = np.sum([blocked_by(m) for m in members], axis=0)
    M = np.diag(prior) + RIDGE * np.eye(G.shape[-1]) + np.einsum("cri,crj->ij", G[members], G[members])
    X = _cross(G, um, members)
    design = Scans(G, A, um, M, X)
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
                design, changes = Scans(G, A, um, design.M, design.X), 0
            changed = True
        if not changed:
            break
    return np.asarray(sorted(members), int), mean_square(G, A, prior, um, members)
