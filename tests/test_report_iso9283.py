"""ISO 9283 AP/RP on synthetic repeated measurements with known answers."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal.report.iso9283 import group_repeats, pose_accuracy_repeatability


def test_known_answer_by_construction():
    # pose 7: four points at distance 0.1 from G = C + (0.3, 0.4, 0) -> AP 0.5, l = 0.1, S_l = 0 -> RP 0.1
    C = np.array([100.0, 200.0, 300.0])
    G = C + [0.3, 0.4, 0.0]
    offsets = 0.1 * np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
    # pose 9: two points at distances 0.2 from G2 (S_l = 0); single pose 3 is ignored
    C2 = np.array([0.0, 0.0, 0.0])
    G2 = np.array([0.0, 0.0, 1.0])
    measured = np.vstack([G + offsets, [[5, 5, 5]], G2 + [[0, 0, 0.2], [0, 0, -0.2]]])
    commanded = np.vstack([np.tile(C, (4, 1)), [[5, 5, 5]], np.tile(C2, (2, 1))])
    pose_id = [7, 7, 7, 7, 3, 9, 9]
    joints = [[1, 2]] * 4 + [[0, 0]] + [[3, 4]] * 2
    g = pose_accuracy_repeatability(measured, commanded, pose_id, joints)
    assert len(g) == 2
    np.testing.assert_array_equal(g.pose_id, [7, 9])
    np.testing.assert_array_equal(g.n, [4, 2])
    np.testing.assert_allclose(g.ap, [0.5, 1.0], atol=1e-12)
    np.testing.assert_allclose(g.ap_xyz[0], [0.3, 0.4, 0.0], atol=1e-12)
    np.testing.assert_allclose(g.rp, [0.1, 0.2], atol=1e-12)
    np.testing.assert_array_equal(g.rows, [0, 0, 0, 0, -1, 1, 1])


def test_rp_matches_direct_formula_with_spread():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(30, 3)) * 0.02 + [1.0, 2.0, 3.0]
    g = pose_accuracy_repeatability(pts, np.zeros((30, 3)), np.zeros(30), np.zeros((30, 6)))
    G = pts.mean(axis=0)
    lj = np.linalg.norm(pts - G, axis=1)
    expected = lj.mean() + 3 * lj.std(ddof=1)
    np.testing.assert_allclose(g.rp, [expected], rtol=1e-12)
    np.testing.assert_allclose(g.ap, [np.linalg.norm(G)], rtol=1e-12)


def test_same_pose_id_different_joints_or_smr_are_different_poses():
    rows = group_repeats([1, 1, 1, 1], [[0, 0], [0, 0], [0, 1], [0, 1]], smr=[0, 1, 0, 0])
    np.testing.assert_array_equal(rows, [-1, -1, 0, 0])


def test_no_repeats_gives_empty():
    g = pose_accuracy_repeatability(np.zeros((3, 3)), np.zeros((3, 3)), [0, 1, 2], np.eye(3))
    assert len(g) == 0 and g.ap.shape == (0,)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(2, 8), st.integers(0, 2**31 - 1))
def test_groups_match_a_loop_over_poses(m, reps, seed):
    rng = np.random.default_rng(seed)
    cmd = rng.uniform(-1000, 1000, (m, 3))
    ids = np.repeat(np.arange(m), reps)
    perm = rng.permutation(ids.size)
    ids = ids[perm]
    meas = cmd[ids] + rng.normal(scale=0.5, size=(ids.size, 3))
    joints = np.column_stack([ids, -ids]).astype(float)
    g = pose_accuracy_repeatability(meas, cmd[ids], ids, joints)
    assert len(g) == m
    for k in range(m):
        pid = g.pose_id[k]
        P = meas[ids == pid]
        G = P.mean(axis=0)
        lj = np.linalg.norm(P - G, axis=1)
        np.testing.assert_allclose(g.ap[k], np.linalg.norm(G - cmd[pid]), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(g.rp[k], lj.mean() + 3 * lj.std(ddof=1), rtol=1e-9, atol=1e-12)
