"""The unmodelled-error search's fast path (candidate forms updated by rank r) against direct
evaluation: every scan value against ``mean_square`` of the design with the candidate added, the
updated forms against forms computed afresh after random sequences of changes, the small-block
helpers against numpy, and the Fedorov polish against the same sweeps scored directly."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal.campaign.exchange import (
    IMPROVEMENT_RTOL,
    block_abt,
    block_inverses,
    cholesky_inverse,
    itself_only,
)
from robocal.campaign.unmodelled import (
    Candidates,
    Scans,
    Unmodelled,
    _cross,
    mean_square,
    polish,
)


def _random_problem(seed: int, C: int, r: int, p: int, m: int):
    """Candidate blocks G, N, region matrices and priors like the planner's (scaled unknowns)."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(C, r, p)) * rng.uniform(0.3, 2.0, (C, 1, 1))
    if r > 1:
        G[rng.random(C) < 0.2, -1] = 0.0  # some candidates give fewer rows (an SMR not seen)
    N = rng.normal(size=(C, r, m))
    R = 30
    Jf, Jn = rng.normal(size=(R, 3, p)), rng.normal(size=(R, 3, m))
    A = np.einsum("rik,ril->kl", Jf, Jf) / R
    variance = rng.uniform(0.1, 2.0, m)
    rms = float(np.sqrt(np.sum(np.diag(np.einsum("rik,ril->kl", Jn, Jn) / R) * variance)))
    prior = np.r_[rng.uniform(0.2, 2.0, p - 1), 0.0]  # the last unknown has no prior (a frame)
    um = Unmodelled(rms_m=rms, terms=("compliance",), names=[f"c{i}" for i in range(m)], N=N,
                    variance=variance, A_cross=np.einsum("rik,ril->kl", Jf, Jn) / R)
    return G, A, prior, um


def _information(G, prior, um, design):
    M = np.diag(prior) + np.einsum("cri,crj->ij", G[design], G[design])
    return M, _cross(G, um, design)


shapes = st.tuples(st.integers(0, 10_000), st.integers(1, 6), st.integers(3, 7), st.integers(1, 5))


@settings(max_examples=30, deadline=None)
@given(shapes)
def test_every_scan_value_is_the_direct_value(shape):
    seed, r, p, m = shape
    C = 12
    G, A, prior, um = _random_problem(seed, C, r, p, m)
    design = list(np.random.default_rng(seed).choice(C, 1 + p // r, replace=False))
    M, X = _information(G, prior, um, design)
    fast = Scans(Candidates.of(G, A, um), M, X).values()
    direct = [mean_square(G, A, prior, um, [*design, c]) for c in range(C)]  # a loop in the test only
    np.testing.assert_allclose(fast, direct, rtol=1e-9)


@settings(max_examples=25, deadline=None)
@given(shapes, st.lists(st.integers(0, 10**6), min_size=1, max_size=12))
def test_updated_forms_are_the_forms_computed_afresh(shape, moves):
    """Random additions and removals: the forms updated by rank r equal those of a fresh start
    from the same information, and the scan values stay the direct ones."""
    seed, r, p, m = shape
    C = 10
    G, A, prior, um = _random_problem(seed, C, r, p, m)
    design = list(range(2 + p // r))
    cands = Candidates.of(G, A, um)
    scans = Scans(cands, *_information(G, prior, um, design))
    for move in moves:
        outside = [c for c in range(C) if c not in design]
        if move % 2 and outside:
            j = outside[move % len(outside)]
            design.append(j)
            scans = scans.updated(j, 1.0)
        else:  # remove one, keeping more rows than unknowns
            i = design[move % len(design)]
            if (len(design) - 1) * max(r - 1, 1) < p + 1:
                continue
            design.remove(i)
            scans = scans.updated(i, -1.0)
    fresh = Scans(cands, *_information(G, prior, um, design))
    for name in ("B", "D", "QB", "QD", "WW", "WZ"):
        a, b = getattr(scans, name), getattr(fresh, name)
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-9 * np.max(np.abs(b)), err_msg=name)
    assert scans.value == pytest.approx(mean_square(G, A, prior, um, design), rel=1e-9)
    direct = [mean_square(G, A, prior, um, [*design, c]) for c in range(C)]
    np.testing.assert_allclose(scans.values(), direct, rtol=1e-8)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 9))
def test_small_inverses_are_numpys(seed, r):
    rng = np.random.default_rng(seed)
    L = rng.normal(size=(40, r, r))
    S = L @ L.transpose(0, 2, 1) + np.eye(r)
    S_inv, logdet = cholesky_inverse(S)
    np.testing.assert_allclose(S_inv, np.linalg.inv(S), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(logdet, np.linalg.slogdet(S)[1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(block_inverses(S.transpose(1, 2, 0)).transpose(2, 0, 1), np.linalg.inv(S),
                               rtol=1e-9, atol=1e-12)
    if r > 1:  # not positive definite: refused, and numpy's inverse in the scans
        S[3] = np.diag(np.r_[-1.0, np.ones(r - 1)])
        with pytest.raises(np.linalg.LinAlgError):
            cholesky_inverse(S)
        np.testing.assert_allclose(block_inverses(S.transpose(1, 2, 0)).transpose(2, 0, 1), np.linalg.inv(S),
                                   rtol=1e-9, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000), st.integers(1, 18), st.integers(1, 6), st.integers(1, 9))
def test_block_products_are_einsums(seed, a, k, b):
    rng = np.random.default_rng(seed)
    X, Y = rng.normal(size=(a, k, 50)), rng.normal(size=(b, k, 50))
    np.testing.assert_allclose(block_abt(X, Y), np.einsum("akc,bkc->abc", X, Y), rtol=1e-12, atol=1e-12)


def _direct_polish(G, A, prior, um, members, blocked_by, rng):
    """The Fedorov sweeps of ``polish`` with every candidate scored by ``mean_square``."""
    members = list(members)
    current = mean_square(G, A, prior, um, members)
    while True:
        changed = False
        for i in rng.permutation(members):
            blocked = np.sum([blocked_by(k) for k in members if k != i], axis=0)
            others = [k for k in members if k != i]
            tried = np.array([mean_square(G, A, prior, um, [*others, c]) if blocked[c] == 0 else np.inf
                              for c in range(len(G))])  # a loop in the test only
            j = int(np.argmin(tried))
            if j == i or not tried[j] < current - IMPROVEMENT_RTOL * current:
                continue
            members[members.index(i)] = j
            current, changed = float(tried[j]), True
        if not changed:
            return sorted(members), current


@pytest.mark.parametrize(("seed", "r", "minimum_gap"),
                         [(0, 3, 0), (1, 1, 0), (2, 6, 0), (3, 3, 2), (4, 2, 3)])
def test_polish_makes_the_exchanges_direct_evaluation_makes(seed, r, minimum_gap):
    """The fast sweeps and the same sweeps scored directly choose the same members (with a
    minimum gap between chosen indices as the conflict rule where given)."""
    C, p, m, n = 24, 6, 3, 5
    G, A, prior, um = _random_problem(seed, C, r, p, m)

    def gap(j: int) -> np.ndarray:
        out = np.zeros(C, np.int64)
        out[max(0, j - minimum_gap + 1): j + minimum_gap] = 1
        return out

    blocked_by = gap if minimum_gap else itself_only(C)
    start = list(range(0, n * max(minimum_gap, 1), max(minimum_gap, 1)))
    fast, value = polish(G, A, prior, um, start, blocked_by, np.random.default_rng(seed))
    direct, direct_value = _direct_polish(G, A, prior, um, start, blocked_by, np.random.default_rng(seed))
    assert fast.tolist() == direct
    assert value == pytest.approx(direct_value, rel=1e-9)


def test_removing_an_essential_member_starts_afresh():
    """Removing the only candidate that sees an unknown without a prior leaves M singular but for
    the search's ridge: a rank-r downdate would lose precision (here 1e-6 relative), so the forms
    are computed afresh, as from the information itself."""
    from robocal.campaign.exchange import RIDGE

    G, A, prior, um = _random_problem(5, 10, 3, 5, 2)
    G[1:, :, -1] = 0.0  # only candidate 0 moves the last unknown (no prior)
    design = [0, 2, 3, 4]
    M, X = _information(G, prior, um, design)
    M = M + RIDGE * np.eye(len(M))
    cands = Candidates.of(G, A, um)
    without = Scans(cands, M, X).updated(0, -1.0)
    fresh = Scans(cands, M - G[0].T @ G[0], X - G[0].T @ um.N[0])
    np.testing.assert_array_equal(without.QB, fresh.QB)
    np.testing.assert_array_equal(without.values(), fresh.values())
