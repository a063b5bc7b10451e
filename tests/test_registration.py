"""Registration: a random tracker frame and SMR offsets recovered from points (any orientation)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import random_frame
from test_measurements import MECA

from robocal import DataError
from robocal.data import Measurements, register, register_frame, simulate_tracker
from robocal.data.registration import umeyama
from robocal.kinematics.transforms import invert_transform, make_transform, rotvec_to_matrix


def test_umeyama_recovers_a_rigid_transform(rng):
    src = rng.normal(size=(20, 3))
    T = random_frame(rng, 3.0)
    np.testing.assert_allclose(umeyama(src, src @ T[:3, :3].T + T[:3, 3]), T, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 3))
def test_zero_noise_recovers_random_tracker_frame(seed, n_smr):
    # nominal robot as truth (no link errors): the frame and offsets are exactly identifiable
    sim = simulate_tracker(MECA, 40, noise_mm=0.0, n_smr=n_smr, seed=seed, error_scale=0.0)
    reg = register_frame(MECA, sim.data)
    assert np.abs(reg.base[:3, 3] - sim.truth.base[:3, 3]).max() < 1e-9
    assert np.abs(reg.base[:3, :3] - sim.truth.base[:3, :3]).max() < 1e-9
    truth_offsets = np.vstack([sim.truth.tool[:3, 3], sim.truth.smr])
    assert np.abs(reg.offsets - truth_offsets).max() < 1e-9
    assert reg.rms < 1e-9


def test_a_model_that_carries_several_smrs_registers_again():
    # a calibrated model saved with its SMR offsets, fitted to new data (the tracker moved)
    sim = simulate_tracker(MECA, 30, noise_mm=0.0, n_smr=2, seed=4, error_scale=0.0)
    again = register(sim.truth, sim.data)
    np.testing.assert_allclose(again.smr, sim.truth.smr, atol=1e-9)
    np.testing.assert_allclose(again.base, sim.truth.base, atol=1e-9)


def test_any_tracker_orientation_including_upside_down(rng):
    q = rng.uniform(MECA.limits[:, 0], MECA.limits[:, 1], (30, 6))
    tool = np.array([0.02, -0.03, 0.09])
    for rv in ([np.pi, 0, 0], [0, np.pi - 1e-9, 0], [2.0, -1.5, 0.7]):
        B = make_transform(rotvec_to_matrix(np.array(rv)), rng.uniform(-4, 4, 3))
        truth = MECA.with_frames(base=B, tool=make_transform(np.eye(3), tool))
        data = Measurements.from_arrays("point", q, points=truth.fk(q)[:, :3, 3])
        robot = register(MECA, data)
        assert np.abs(robot.base - B).max() < 1e-9 and np.abs(robot.tool[:3, 3] - tool).max() < 1e-9


def test_noise_stays_within_the_noise(rng):
    sim = simulate_tracker(MECA, 200, noise_mm=0.02, n_smr=3, seed=3, error_scale=0.0)
    reg = register_frame(MECA, sim.data)
    # the fit's residual RMS cannot exceed the noise floor (it absorbs a little of the noise)
    assert reg.rms * 1e3 <= sim.noise_floor_mm
    assert reg.rms * 1e3 > 0.9 * sim.noise_floor_mm
    true_pts = sim.truth.fk(sim.true_joints, smr=sim.data.smr)[:, :3, 3]
    model = register(MECA, sim.data).fk(sim.data.joints, smr=sim.data.smr)[:, :3, 3]
    # the registered model reproduces the true points far better than the noise
    assert np.sqrt(np.mean(np.sum((model - true_pts) ** 2, 1))) * 1e3 < 0.3 * sim.noise_floor_mm
    tracker_err = np.linalg.norm(invert_transform(reg.base)[:3, 3] - invert_transform(sim.truth.base)[:3, 3])
    assert tracker_err * 1e3 < 0.5


def test_pose_data_give_the_tool_rotation():
    sim = simulate_tracker(MECA, 30, kind="pose", noise_mm=0.0, seed=6, error_scale=0.0)
    robot = register(MECA, sim.data)
    assert np.abs(robot.tool - sim.truth.tool).max() < 1e-9
    assert np.abs(robot.base - sim.truth.base).max() < 1e-9


def test_registered_nominal_keeps_nominal_links():
    sim = simulate_tracker(MECA, 30, n_smr=2, seed=1)
    robot = register(MECA, sim.data)
    np.testing.assert_array_equal(robot.nominal[:30], MECA.nominal[:30])
    np.testing.assert_array_equal(robot.nominal[30:], robot.values[30:])
    assert robot.smr.shape == (1, 3)


def test_rejects_plane_data_and_missing_smr(rng):
    q = rng.normal(size=(5, 6))
    with pytest.raises(DataError, match="point or pose"):
        register(MECA, Measurements.from_arrays("plane", q, plane=np.zeros(5, int)))
    with pytest.raises(DataError, match="SMR index"):
        register(
            MECA, Measurements.from_arrays("point", q, points=rng.normal(size=(5, 3)), smr=[0, 2, 0, 2, 0])
        )


def test_nearest_rotation_is_the_frobenius_projection():
    """The one rotation projection the frame fits share: a rotation maps to itself, a perturbed one
    to a proper rotation no farther than the rotations around it (brute force), a reflection's
    determinant is fixed."""
    from robocal.kinematics.transforms import nearest_rotation, rotvec_to_matrix

    rng = np.random.default_rng(4)
    R = rotvec_to_matrix(rng.normal(size=3))
    assert np.allclose(nearest_rotation(R), R, atol=1e-14)
    M = R + 0.05 * rng.normal(size=(3, 3))
    P = nearest_rotation(M)
    assert np.allclose(P @ P.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(P), 1.0)
    others = P @ rotvec_to_matrix(0.02 * rng.normal(size=(500, 3)))
    assert np.linalg.norm(P - M) <= np.linalg.norm(others - M, axis=(1, 2)).min()
    assert np.isclose(np.linalg.det(nearest_rotation(np.diag([1.0, 1.0, -1.0]))), 1.0)


def test_kabsch_rotation_is_the_transposed_projection_of_the_cross_covariance():
    from robocal.kinematics.transforms import kabsch_rotation, nearest_rotation

    rng = np.random.default_rng(8)
    for H in rng.normal(size=(50, 3, 3)):
        assert np.allclose(kabsch_rotation(H), nearest_rotation(H).T, atol=1e-12)
