"""Normal equations and R factors accumulated over chunks of rows (robocal.identify.normal), and
the results that use them: the same with one chunk as with chunks of a few rows."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal import Robot, calibrate
from robocal.calibration.model_selection import _candidates, _CrossValidation, _folds, _linearise, _search
from robocal.data.simulate import simulate_tracker
from robocal.identify import normal
from robocal.identify.normal import Normal, r_factor, row_chunks
from robocal.kinematics.joint_errors import JointErrorModel, candidate_names, cyclic_names


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 60), st.integers(1, 8), st.integers(1, 70), st.integers(0, 2**31))
def test_chunked_normal_equations_and_r_factor_match_the_whole_matrix(m, k, size, seed):
    rng = np.random.default_rng(seed)
    J, r = rng.normal(size=(m, k)) * 10.0 ** rng.uniform(-3, 3, k), rng.normal(size=m)
    chunks = list(row_chunks(m, size))
    assert np.array_equal(np.concatenate([np.arange(m)[s] for s in chunks]), np.arange(m))
    ne = Normal.zeros(k)
    for s in chunks:
        ne.add(J[s], r[s])
    assert ne.rows == m
    np.testing.assert_allclose(ne.G, J.T @ J, rtol=1e-12, atol=1e-12 * np.abs(J.T @ J).max())
    np.testing.assert_allclose(ne.h, J.T @ r, rtol=1e-12, atol=1e-12 * np.abs(J).max() * np.abs(r).sum())
    assert ne.rr == pytest.approx(r @ r, rel=1e-12)
    R = r_factor(lambda s: J[s], m, k, size)
    assert R.shape == (k, k) and np.allclose(np.tril(R, -1), 0.0)
    np.testing.assert_allclose(R.T @ R, J.T @ J, rtol=1e-10, atol=1e-10 * np.abs(J.T @ J).max())
    whole = scipy.linalg.qr(J, mode="r")[0][:k]
    np.testing.assert_allclose(np.abs(np.diag(R)[: min(m, k)]), np.abs(np.diag(whole)[: min(m, k)]),
                               rtol=1e-9, atol=1e-9 * np.abs(whole).max())


def test_a_chunk_holds_at_least_one_row():
    with pytest.raises(ValueError, match="at least one row"):
        list(row_chunks(10, 0))


@pytest.mark.slow
def test_cross_validation_with_chunks_of_a_few_rows_matches_one_chunk(monkeypatch):
    """Every candidate's cross-validated and fit errors, and the kept columns, from chunks of sixteen
    poses equal those from one chunk to 1e-9 (cyclic columns found per fold included), with and
    without the item weights of a robust fit (some down-weighted, some rejected)."""
    robot = Robot.from_catalog("abb_irb2600")
    names = ["travel1", "backlash2", *cyclic_names(1, 120), *cyclic_names(4, 80)]
    truth = replace(robot, joint_errors=JointErrorModel(tuple(names), np.array([1e-3, 2e-4, 1.5e-4, -1e-4,
                                                                                2e-4, 1e-4])))
    sim = simulate_tracker(truth, 150, noise_mm=0.02, seed=7)
    fixed = ["backlash", "travel"]
    superset = calibrate(robot, sim.data, nongeometric=",".join(fixed))
    unweighted = _linearise(superset, candidate_names(6, fixed))
    fold = _folds(unweighted.group, 5, 0)
    scan, full, per_fold = _search(unweighted, fold, 5)
    assert full  # the cyclic columns take part
    weights = np.random.default_rng(3).choice([1.0, 0.4, 0.0], unweighted.weight.size, p=[0.8, 0.15, 0.05])
    for lin in (unweighted, replace(unweighted, weight=weights)):
        _compare(monkeypatch, lin, fold, scan, per_fold, full, fixed)


def _compare(monkeypatch, lin, fold, scan, per_fold, full, fixed):
    def table(chunk_rows):
        monkeypatch.setattr(normal, "CHUNK_ROWS", chunk_rows)
        cands = _candidates(lin, fixed, True, 1e-7)
        cv = _CrossValidation(lin, fold, 5, scan, per_fold, full)
        return [c.columns for c in cands], [cv.evaluate(c) for c in cands]

    (cols_one, one), (cols_few, few) = table(10**9), table(48)
    assert all(np.array_equal(a, b) for a, b in zip(cols_one, cols_few, strict=True))
    for a, b in zip(one, few, strict=True):
        assert a["n_params"] == b["n_params"]
        for key in ("cv_rms_mm", "cv_se_mm", "calibration_rms_mm"):
            assert b[key] == pytest.approx(a[key], rel=1e-9)
        np.testing.assert_allclose(b["fold_rms_mm"], a["fold_rms_mm"], rtol=1e-9)


@pytest.mark.parametrize("chunk_rows", [7, 10**9])
def test_orthonormal_basis_from_chunks_projects_like_the_svd(monkeypatch, chunk_rows):
    """The frequency search's basis of a model's columns (from the chunked R factor) spans what the
    SVD of the whole scaled matrix keeps, orthonormal to rounding, with ill-conditioned and
    dependent columns."""
    from robocal.identify import frequency_search

    monkeypatch.setattr(normal, "CHUNK_ROWS", chunk_rows)
    rng = np.random.default_rng(5)
    A = rng.normal(size=(90, 8)) * np.logspace(-4, 3, 8)
    A[:, 5] = A[:, 1] * 2e3 + A[:, 2] * 1e-9  # nearly dependent: kept only above the cut-off
    A[:, 6] = A[:, 3] - A[:, 4] * 1e-2  # dependent combination, kept
    A[:, 7] = 0.0
    U = frequency_search._orthonormal(A)
    norms = np.linalg.norm(A, axis=0)
    Us, s, _ = np.linalg.svd(A / np.where(norms > 0, norms, 1.0), full_matrices=False)
    ref = Us[:, s > 1e-10 * s[0]]
    assert U.shape == ref.shape
    np.testing.assert_allclose(U.T @ U, np.eye(U.shape[1]), atol=1e-12)
    x = rng.normal(size=90)
    np.testing.assert_allclose(U @ (U.T @ x), ref @ (ref.T @ x), atol=1e-9 * np.linalg.norm(x))
