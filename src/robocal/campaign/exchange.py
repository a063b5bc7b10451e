"""Exchange search for the best ``n`` of ``C`` candidate measurement blocks (optimal design).

Candidate ``j`` contributes the information ``G_j^T G_j`` (``G_j`` its ``(r, p)`` block of
noise-weighted identification-Jacobian rows: 3 rows for a tracker point, zero rows where an
SMR is not seen); a design ``S`` has the posterior information matrix
``M = diag(prior) + sum_{j in S} G_j^T G_j``, with ``prior`` the parameters' prior precisions
(``1 / sigma_prior^2`` in the scaled unknowns, 0 where a parameter has no prior), so that ``M^-1``
is the MAP posterior covariance the calibration will have.
Criteria, all minimised:

- ``I``: ``trace(M^-1 A)``, the mean predicted variance of the TCP position over a region whose
  averaged ``J^T J`` is ``A`` (I-optimality);
- ``D``: ``-log det M`` (D-optimality; the O1 index with the columns scaled once);
- ``O4``: ``-lambda_min(M) / sqrt(lambda_max(M))`` (the O4 index with the columns scaled once).

For I and D one candidate scan costs a few numpy operations over all candidates: with
``B = M^-1`` and ``D = B A B``, the Sherman-Morrison-Woodbury identity gives the criterion after
adding block ``H`` as ``trace(B A) - trace((I + H B H^T)^-1 H D H^T)`` (and ``-log det`` falls by
``log det(I + H B H^T)``), so the search keeps ``QB_j = G_j B G_j^T`` and ``QD_j = G_j D G_j^T``
for every candidate and updates them by a rank-r correction after each change of the design
(one ``(C r, p) x (p, 2r)`` product; with the optional ``threadpoolctl`` these run on one BLAS
thread: many small products gain nothing from threads and lose much when the machine is busy).
O4 has no such update: its scan ranks the candidates by the
first-order gain of the smallest eigenvalue and evaluates the best ``O4_SCREEN`` exactly.

The search (Fedorov / DETMAX family), from each of ``starts`` random starts: a random minimal
design, completed greedily; then DETMAX steps (add the best candidate, remove the member whose
removal costs least) until the one removed is the one added; then, on the best starts, Fedorov
sweeps (each member in turn is exchanged for the best candidate if that lowers the criterion)
until a whole sweep changes nothing. Candidates that conflict with a member (the candidate
itself, or one closer than a minimum joint distance) are never added.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.core.progress import Progress

try:  # optional (extra 'threads'): the search's many small BLAS products run best on one thread
    from threadpoolctl import threadpool_limits
except ImportError:  # pragma: no cover - without it the BLAS library keeps its own thread count
    threadpool_limits = None

CRITERIA = ("I", "D", "O4")
RIDGE = 1e-9            # ridge on the scaled information matrix: B stays finite before full rank
REFRESH_EVERY = 40      # design changes between recomputations from scratch (rounding drift)
IMPROVEMENT_RTOL = 1e-9  # an exchange counts when it lowers the criterion by more than this
O4_SCREEN = 32          # O4: candidates evaluated exactly per scan
SINGULAR = 1e-13         # I - H B H^T below this (det): removing H would make M singular
MAX_SWEEPS = 25         # Fedorov sweeps per polished start
POLISHED_STARTS = 2     # starts that get Fedorov sweeps after DETMAX (the best ones)


@dataclass(frozen=True)
class ExchangeResult:
    """``indices (n,)`` the chosen candidates (sorted), ``value`` their criterion (exact, no
    ridge)."""

    indices: np.ndarray
    value: float


def criterion_value(G: np.ndarray, A: np.ndarray | None, indices, criterion: str = "I",
                    prior: np.ndarray | None = None) -> float:
    """The criterion of a design computed from scratch (``inf`` when M is singular); ``prior``
    ``(p,)`` the prior precisions (default none)."""
    H = G[np.asarray(indices, int)].reshape(-1, G.shape[-1])
    M = H.T @ H + np.diag(_prior(prior, G.shape[-1]))
    w, V = np.linalg.eigh(M)
    if w[0] <= w[-1] * 1e-13 or w[-1] <= 0:
        return float("inf")
    if criterion == "I":
        return float(np.einsum("ij,ji->", (V / w) @ V.T, A))
    if criterion == "D":
        return float(-np.sum(np.log(w)))
    return float(-w[0] / np.sqrt(w[-1]))


def block_abt(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``X_c Y_c^T`` ``(a, b, C)`` for per-candidate matrices stored component-wise ``X (a, k, C)``,
    ``Y (b, k, C)``: for ``k <= 3`` a sum of ``k`` elementwise products (in the order of numpy's
    sum over k, without its ``(a, b, k, C)`` temporary)."""
    k = X.shape[1]
    if k > 3:
        return np.einsum("akc,bkc->abc", X, Y)
    out = X[:, None, 0, :] * Y[None, :, 0, :]
    for j in range(1, k):  # a loop over the rows of one block only
        out += X[:, None, j, :] * Y[None, :, j, :]
    return out


def det_adj3(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Determinant ``(C,)`` and adjugate ``(3, 3, C)`` of symmetric 3x3 matrices ``(3, 3, C)``."""
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 1], S[1, 2], S[2, 2]
    adj = np.empty_like(S)
    adj[0, 0] = d * f - e * e
    adj[0, 1] = adj[1, 0] = c * e - b * f
    adj[0, 2] = adj[2, 0] = b * e - c * d
    adj[1, 1] = a * f - c * c
    adj[1, 2] = adj[2, 1] = b * c - a * e
    adj[2, 2] = a * d - b * b
    return a * adj[0, 0] + b * adj[0, 1] + c * adj[0, 2], adj


def _inverse_trace(S: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``trace(S_c^-1 Q_c)`` for symmetric ``S, Q (r, r, C)`` (inf where S_c is singular)."""
    r = S.shape[0]
    if r == 1:
        ok = S[0, 0] > SINGULAR
        return np.where(ok, Q[0, 0] / np.where(ok, S[0, 0], 1.0), np.inf)
    if r == 3:
        det, adj = det_adj3(S)
        ok = det > SINGULAR
        return np.where(ok, np.einsum("ijc,jic->c", adj, Q) / np.where(ok, det, 1.0), np.inf)
    Sc, Qc = S.transpose(2, 0, 1), Q.transpose(2, 0, 1)
    try:  # all positive definite (adding a block): by the Cholesky factors
        S_inv, logdet = cholesky_inverse(Sc)
        return np.where(logdet > np.log(SINGULAR), np.einsum("cij,cji->c", S_inv, Qc), np.inf)
    except np.linalg.LinAlgError:
        pass
    sign, logdet = np.linalg.slogdet(Sc)
    ok = (sign > 0) & (logdet > np.log(SINGULAR))
    X = np.linalg.solve(np.where(ok[:, None, None], Sc, np.eye(r)), Qc)
    return np.where(ok, np.trace(X, axis1=1, axis2=2), np.inf)


def cholesky_inverse(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inverses ``(C, r, r)`` and log-determinants ``(C,)`` of symmetric positive definite
    ``S (C, r, r)`` by their Cholesky factors ``L`` (``S^-1 = L^-T L^-1``, ``L^-1`` by forward
    substitution: a loop over the ``r`` rows of one block, vectorised over the candidates; numpy's
    batched inverse and solve run one LAPACK call per small matrix, several times slower).
    ``numpy.linalg.LinAlgError`` when some ``S_c`` is not positive definite."""
    L = np.linalg.cholesky(S)
    Li = np.zeros_like(S)
    for k in range(S.shape[-1]):  # row k of L^-1 from the rows above it
        Li[:, k, k] = 1.0
        Li[:, k, :k] = -np.einsum("cj,cjb->cb", L[:, k, :k], Li[:, :k, :k])
        Li[:, k, : k + 1] /= L[:, k, k, None]
    return Li.transpose(0, 2, 1) @ Li, 2.0 * np.sum(np.log(np.diagonal(L, axis1=1, axis2=2)), axis=1)


def block_inverses(S: np.ndarray) -> np.ndarray:
    """The inverses ``(r, r, C)`` of symmetric positive definite ``S (r, r, C)`` (component-wise):
    by the adjugate for ``r`` 1 and 3 (elementwise over the candidates), else by the Cholesky factors
    (:func:`cholesky_inverse`; numpy's inverse when one is not
    numerically positive definite)."""
    r = len(S)
    if r == 1:
        return 1.0 / S
    if r == 3:
        det, adj = det_adj3(S)
        return adj / det
    Sc = S.transpose(2, 0, 1)
    try:
        S_inv = cholesky_inverse(Sc)[0]
    except np.linalg.LinAlgError:  # not numerically positive definite: numpy's inverse
        S_inv = np.linalg.inv(Sc)
    return S_inv.transpose(1, 2, 0)


def _logdet(S: np.ndarray) -> np.ndarray:
    """``log det S_c`` for symmetric ``S (r, r, C)`` (-inf where S_c is singular)."""
    r = S.shape[0]
    if r in (1, 3):
        det = S[0, 0] if r == 1 else det_adj3(S)[0]
        return np.where(det > SINGULAR, np.log(np.maximum(det, SINGULAR)), -np.inf)
    sign, logdet = np.linalg.slogdet(S.transpose(2, 0, 1))
    return np.where(sign > 0, logdet, -np.inf)


def _prior(prior: np.ndarray | None, p: int) -> np.ndarray:
    """The prior precisions ``(p,)`` (zeros when there are none)."""
    return np.zeros(p) if prior is None else np.asarray(prior, dtype=float)


def _identity(r: int) -> np.ndarray:
    return np.eye(r)[:, :, None]


class _Design:
    """A design and, for I and D, the per-candidate quadratic forms of the Woodbury scans,
    stored component-wise (``(r, r, C)``: elementwise numpy on long vectors is fast where
    stacks of tiny matrices are not)."""

    def __init__(self, G: np.ndarray, A: np.ndarray | None, criterion: str,
                 conflicts: Callable[[int], np.ndarray], prior: np.ndarray | None = None) -> None:
        self.G = G
        self.C, self.r, self.p = G.shape
        self.prior = _prior(prior, self.p)
        self.M0 = np.diag(self.prior) + RIDGE * np.eye(self.p)  # before any candidate
        self.Gt = np.ascontiguousarray(G.transpose(1, 2, 0))  # (r, p, C)
        self.A = A
        self.criterion = criterion
        self.conflicts = conflicts
        self.members: list[int] = []
        self.blocked = np.zeros(self.C, np.int64)  # members conflicting with each candidate
        self.changes = 0

    # ------------------------------------------------------------ state
    def reset(self, members) -> None:
        self.members = [int(m) for m in members]
        self.blocked[:] = 0
        for m in self.members:
            self.blocked += self.conflicts(m)
        self.refresh()

    def _forms(self, K: np.ndarray) -> np.ndarray:
        """``G_c K G_c^T`` ``(r, r, C)`` for a symmetric ``K (p, p)``."""
        U = K @ self.Gt                                   # (r, p, C)
        return np.einsum("akc,bkc->abc", U, self.Gt)

    def refresh(self) -> None:
        """Recompute M, its inverse and the candidates' quadratic forms from scratch."""
        H = self.G[self.members].reshape(-1, self.p)
        self.M = H.T @ H + self.M0
        if self.criterion == "O4":
            self.value = self._o4(self.M[None])[0]
            return
        self.B = np.linalg.inv(self.M)
        self.B = 0.5 * (self.B + self.B.T)
        self.QB = self._forms(self.B)
        if self.criterion == "I":
            self.D = self.B @ self.A @ self.B
            self.QD = self._forms(self.D)
            self.value = float(np.einsum("ij,ji->", self.B, self.A))
        else:
            self.value = float(-np.linalg.slogdet(self.M)[1])
        self.changes = 0

    def _o4(self, Ms: np.ndarray) -> np.ndarray:
        w = np.linalg.eigvalsh(Ms)
        return -w[:, 0] / np.sqrt(np.maximum(w[:, -1], 1e-300))

    # ------------------------------------------------------------ Woodbury updates
    def _updated(self, index: int, sign: float):
        """B, D, QB, QD after adding (sign +1) or removing (-1) candidate ``index``."""
        H = self.G[index]
        P = H @ self.B                                        # (r, p)
        E = sign * np.linalg.inv(np.eye(self.r) + sign * (H @ P.T))
        E = 0.5 * (E + E.T)
        B = self.B - P.T @ E @ P
        if self.criterion == "I":
            R = self.D @ H.T                                  # (p, r) = B A B H^T
            F = E @ (P @ self.A @ P.T) @ E
            D = self.D - P.T @ E @ R.T - R @ E @ P + P.T @ F @ P
            X = np.hstack([P.T, R]).T @ self.Gt               # (r, 2r, C): G B H^T, G D H^T
            GP, GR = X[:, : self.r], X[:, self.r :]
            QB = self.QB - block_abt(E.T @ GP, GP)                # E.T @ GP: per row a, (G B H^T E)
            W = E.T @ GR - 0.5 * (F.T @ GP)
            WG = block_abt(W, GP)
            QD = self.QD - WG - WG.transpose(1, 0, 2)
            return 0.5 * (B + B.T), 0.5 * (D + D.T), QB, QD
        GP = P @ self.Gt                                      # (r, r, C)
        return 0.5 * (B + B.T), None, self.QB - block_abt(E.T @ GP, GP), None

    def _commit(self, index: int, sign: float, updated=None, value: float | None = None) -> None:
        H = self.G[index]
        self.M = self.M + sign * (H.T @ H)
        if sign > 0:
            self.members.append(int(index))
            self.blocked += self.conflicts(index)
        else:
            self.members.remove(int(index))
            self.blocked -= self.conflicts(index)
        self.changes += 1
        if self.criterion == "O4" or self.changes >= REFRESH_EVERY:
            self.refresh()
            return
        self.B, self.D, self.QB, self.QD = self._updated(index, sign) if updated is None else updated
        if self.criterion == "I":
            self.value = float(np.einsum("ij,ji->", self.B, self.A)) if value is None else value
        else:
            self.value = float(-np.linalg.slogdet(self.M)[1]) if value is None else value

    def add(self, index: int) -> None:
        self._commit(index, +1.0)

    def remove(self, index: int) -> None:
        self._commit(index, -1.0)

    # ------------------------------------------------------------ scans
    def add_values(self, allowed: np.ndarray, QB=None, QD=None, M=None, value=None) -> np.ndarray:
        """Criterion after adding each candidate ``(C,)`` (inf where not ``allowed``)."""
        QB = self.QB if QB is None and self.criterion != "O4" else QB
        QD = self.QD if QD is None and self.criterion == "I" else QD
        value = self.value if value is None else value
        out = np.full(self.C, np.inf)
        idx = np.flatnonzero(allowed)
        if not idx.size:
            return out
        if self.criterion == "O4":
            M = self.M if M is None else M
            w, V = np.linalg.eigh(M)
            gain = np.sum((self.G[idx] @ V[:, 0]) ** 2, axis=1)  # first-order rise of lambda_min
            top = idx[np.argsort(-gain)[:O4_SCREEN]]
            Hs = self.G[top]
            out[top] = self._o4(M[None] + Hs.transpose(0, 2, 1) @ Hs)
            return out
        full = idx.size == self.C
        S = (QB if full else QB[:, :, idx]) + _identity(self.r)
        if self.criterion == "I":
            out[idx] = value - _inverse_trace(S, QD if full else QD[:, :, idx])
        else:
            out[idx] = value - _logdet(S)
        return out

    def remove_values(self) -> np.ndarray:
        """Criterion after removing each member ``(len(members),)``."""
        m = np.asarray(self.members)
        if self.criterion == "O4":
            Hs = self.G[m]
            return self._o4(self.M[None] - Hs.transpose(0, 2, 1) @ Hs)
        S = _identity(self.r) - self.QB[:, :, m]
        if self.criterion == "I":
            return self.value + _inverse_trace(S, self.QD[:, :, m])
        return self.value - _logdet(S)

    def exact(self, members) -> float:
        """The criterion of ``members`` computed from scratch (no ridge)."""
        return criterion_value(self.G, self.A, members, self.criterion, self.prior)

    def allowed(self, without: int | None = None) -> np.ndarray:
        """Candidates that may join (no conflict with a member, ``without`` left out)."""
        blocked = self.blocked if without is None else self.blocked - self.conflicts(without)
        return blocked == 0


class _Average:
    """Several designs of the same candidates, one per hypothesis about what the planner does not
    know (e.g. the SMR's place on the flange): each ``_Design`` its own blocks ``G_k (C, r_k,
    p_k)``, region matrix and priors; the criterion is their mean (the expected criterion over the
    hypotheses, each weighed ``1 / K``). It offers what the search asks of a ``_Design`` (I and D:
    the Woodbury scans of every hypothesis, summed)."""

    def __init__(self, designs: list[_Design]) -> None:
        self.designs = designs
        self.weight = 1.0 / len(designs)
        self.C, self.criterion, self.conflicts = designs[0].C, designs[0].criterion, designs[0].conflicts
        self.r = min(d.r for d in designs)
        self.p = max(d.p for d in designs)

    @property
    def members(self) -> list[int]:
        return self.designs[0].members

    @property
    def value(self) -> float:
        return self.weight * sum(d.value for d in self.designs)

    def reset(self, members) -> None:
        for d in self.designs:
            d.reset(members)

    def add(self, index: int) -> None:
        for d in self.designs:
            d.add(index)

    def remove(self, index: int) -> None:
        for d in self.designs:
            d.remove(index)

    def allowed(self, without: int | None = None) -> np.ndarray:
        return self.designs[0].allowed(without)

    def add_values(self, allowed: np.ndarray, QB=None, QD=None, value=None) -> np.ndarray:
        """The mean criterion after adding each candidate ``(C,)`` (``QB``, ``QD``: each
        hypothesis's forms, from :meth:`_updated`; ``value``: the mean they start from)."""
        value = self.value if value is None else value
        QB, QD = QB or [None] * len(self.designs), QD or [None] * len(self.designs)
        gains = [d.add_values(allowed, QB=b, QD=q, value=0.0)
                 for d, b, q in zip(self.designs, QB, QD, strict=True)]
        return value + self.weight * np.sum(gains, axis=0)

    def remove_values(self) -> np.ndarray:
        return self.weight * np.sum([d.remove_values() for d in self.designs], axis=0)

    def _updated(self, index: int, sign: float):
        B, D, QB, QD = zip(*[d._updated(index, sign) for d in self.designs], strict=True)
        return list(B), list(D), list(QB), list(QD)

    def _commit(self, index: int, sign: float, updated=None, value: float | None = None) -> None:
        for k, d in enumerate(self.designs):
            d._commit(index, sign, None if updated is None else tuple(u[k] for u in updated))

    def exact(self, members) -> float:
        """The mean criterion of ``members`` computed from scratch."""
        return self.weight * sum(d.exact(members) for d in self.designs)


def _improves(new: float, old: float) -> bool:
    return new < old - IMPROVEMENT_RTOL * max(abs(old), 1e-300)


def packing(C: int, conflicts: Callable[[int], np.ndarray], order: np.ndarray, limit: int) -> list[int]:
    """Up to ``limit`` of the ``C`` candidates taken in ``order``, each skipped when it conflicts
    (``conflicts(j)``: the candidates that may not be chosen with ``j``) with one already taken."""
    members: list[int] = []
    blocked = np.zeros(C, np.int64)
    for j in order:  # sequential by nature: each pick blocks its neighbours
        if len(members) >= limit:
            break
        if blocked[j] == 0:
            members.append(int(j))
            blocked += conflicts(int(j))
    return members


def packing_of(design: _Design, n: int, rng: np.random.Generator) -> list[int]:
    """A random packing of ``n`` members for ``design`` (see :func:`packing`)."""
    return packing(design.C, design.conflicts, rng.permutation(design.C), n)


def itself_only(C: int) -> Callable[[int], np.ndarray]:
    """The conflicts without a minimum distance: a candidate conflicts with itself only."""
    def conflicts(j: int) -> np.ndarray:
        out = np.zeros(C, np.int64)
        out[j] = 1
        return out
    return conflicts


def _complete(design: _Design, n: int, rng: np.random.Generator) -> None:
    """Add the best allowed candidate until the design has ``n`` members; when the conflicts
    leave no room, start over from a random packing of ``n`` (DataError if none is found)."""
    while len(design.members) < n:
        values = design.add_values(design.allowed())
        j = int(np.argmin(values))
        if np.isfinite(values[j]):
            design.add(j)
            continue
        members = packing_of(design, n, rng)
        if len(members) < n:
            raise DataError(
                f"only {len(members)} poses could be chosen with no two closer than the minimum joint "
                f"distance (asked for {n}): lower the minimum distance or allow more candidates")
        design.reset(members)


def _start(design: _Design, n: int, n0: int, rng: np.random.Generator) -> None:
    """A random minimal design of ``n0`` non-conflicting members, completed greedily to ``n``."""
    design.reset(packing_of(design, n0, rng))
    _complete(design, n, rng)


def _detmax(design: _Design, max_steps: int) -> None:
    """Add the best candidate, remove the cheapest member; until the two coincide."""
    for _ in range(max_steps):
        old = design.value
        values = design.add_values(design.allowed())
        j = int(np.argmin(values))
        if not np.isfinite(values[j]):
            break
        design.add(j)
        removal = design.remove_values()
        i = design.members[int(np.argmin(removal))]
        design.remove(i)
        if i == j or not _improves(design.value, old):
            break


def _fedorov(design: _Design, rng: np.random.Generator, max_sweeps: int) -> None:
    """Sweeps: each member in turn is exchanged for the best candidate if that helps."""
    for _ in range(max_sweeps):
        changed = False
        for i in rng.permutation(design.members):
            i = int(i)
            if i not in design.members:
                continue
            removal = design.remove_values()
            removed_value = float(removal[design.members.index(i)])
            if not np.isfinite(removed_value):
                continue  # i is essential: without it M is singular
            allowed = design.allowed(without=i)
            if design.criterion == "O4":
                Hi = design.G[i]
                values = design.add_values(allowed, M=design.M - Hi.T @ Hi, value=removed_value)
            else:
                B, D, QB, QD = design._updated(i, -1.0)
                values = design.add_values(allowed, QB=QB, QD=QD, value=removed_value)
            j = int(np.argmin(values))
            if j == i or not _improves(float(values[j]), design.value):
                continue
            if design.criterion == "O4":
                design.remove(i)
            else:
                design._commit(i, -1.0, (B, D, QB, QD), removed_value)
            design.add(j)
            changed = True
        if not changed:
            break


def exchange_search(G: np.ndarray, A: np.ndarray | None, n: int, *, criterion: str = "I", starts: int = 4,
                    seed: int = 0, conflicts: Callable[[int], np.ndarray] | None = None,
                    init: np.ndarray | None = None, progress: Progress | None = None,
                    prior: np.ndarray | None = None) -> ExchangeResult:
    """The best ``n`` of the candidate blocks ``G (C, r, p)`` for ``criterion``.

    ``A (p, p)``: the region matrix (criterion I). ``prior (p,)``: the unknowns' prior precisions
    (the posterior's ``P^-1``; default none). ``conflicts(j)`` -> ``(C,)`` 0/1 ints: the
    candidates that may not be chosen together with ``j`` (default: ``j`` itself). ``init``: a
    design of at most ``n`` candidates to start from instead of the random starts (it is
    completed greedily, then improved). ``progress`` is advanced once per start.
    """
    if criterion not in CRITERIA:
        raise DataError(f"unknown criterion {criterion!r}: use one of {', '.join(CRITERIA)}")
    C, r, p = G.shape
    if not 0 < n <= C:
        raise DataError(f"cannot choose {n} of {C} candidates")
    if criterion == "I" and (A is None or A.shape != (p, p)):
        raise DataError("the I criterion needs the region matrix A (p, p)")
    if prior is not None and (np.shape(prior) != (p,) or not np.all(np.asarray(prior) >= 0)):
        raise DataError(f"the prior precisions must be {p} values >= 0")
    if conflicts is None:
        conflicts = itself_only(C)
    with one_blas_thread():
        return _search(_Design(G, A, criterion, conflicts, prior), n, starts, seed, init, progress)


def averaged_search(problems: list[tuple[np.ndarray, np.ndarray | None, np.ndarray | None]], n: int, *,
                    criterion: str = "I", starts: int = 4, seed: int = 0,
                    conflicts: Callable[[int], np.ndarray] | None = None, init: np.ndarray | None = None,
                    progress: Progress | None = None) -> ExchangeResult:
    """The best ``n`` candidates for the mean of ``criterion`` (I or D) over hypotheses: one
    ``(G, A, prior)`` per hypothesis (as :func:`exchange_search` takes them; the same ``C``
    candidates in each, the unknowns may differ). One hypothesis: :func:`exchange_search`."""
    if len(problems) == 1:
        G, A, prior = problems[0]
        return exchange_search(G, A, n, criterion=criterion, starts=starts, seed=seed, conflicts=conflicts,
                               init=init, progress=progress, prior=prior)
    if criterion not in ("I", "D"):
        raise DataError(f"a criterion averaged over hypotheses is I or D, not {criterion!r}")
    C = len(problems[0][0])
    if any(len(G) != C for G, _, _ in problems) or not 0 < n <= C:
        raise DataError(f"cannot choose {n} of {C} candidates in every hypothesis")
    conflicts = itself_only(C) if conflicts is None else conflicts
    with one_blas_thread():
        return _search(_Average([_Design(G, A, criterion, conflicts, prior) for G, A, prior in problems]),
                       n, starts, seed, init, progress)


def one_blas_thread():
    """A context in which BLAS runs on one thread (with the optional ``threadpoolctl``): a search's
    many small products gain nothing from threads and lose much when the machine is busy."""
    return threadpool_limits(1, user_api="blas") if threadpool_limits else nullcontext()


def _search(design: _Design | _Average, n, starts, seed, init, progress) -> ExchangeResult:
    r, p = design.r, design.p
    rng = np.random.default_rng(seed)
    n0 = min(n, int(np.ceil((p + 1) / r)))
    runs = []
    for s in range(1 if init is not None else max(1, int(starts))):
        if init is not None:
            design.reset(np.asarray(init, int).tolist())
            _complete(design, n, rng)
        else:
            _start(design, n, n0, rng)
        _detmax(design, max_steps=4 * n + 20)
        runs.append((design.value, list(design.members), s))
        if progress is not None:
            progress.update(info=f"start {s + 1}: {design.value:.6g}")
    runs.sort(key=lambda run: run[0])
    best = None
    for _, members, s in runs[:POLISHED_STARTS]:
        design.reset(members)
        _fedorov(design, np.random.default_rng([seed, s]), MAX_SWEEPS)
        _detmax(design, max_steps=4 * n + 20)
        exact = design.exact(design.members)
        if best is None or exact < best[0]:
            best = (exact, sorted(design.members))
    return ExchangeResult(indices=np.asarray(best[1], int), value=best[0])
