"""Virtual laser tracker: known truth, noise models, determinism, plane contacts."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_measurements import MECA

from robocal import DataError, Robot
from robocal.calibration.evaluation import evaluate
from robocal.cli import main
from robocal.data import Measurements, simulate_tracker
from robocal.data.simulate import TRACKER_ANGULAR_URAD, TRACKER_RADIAL_MM, TRACKER_RADIAL_UM_PER_M


@pytest.mark.parametrize(("kind", "n_smr"), [("point", 1), ("point", 3), ("pose", 1), ("plane", 1)])
def test_zero_noise_evaluates_to_zero_against_truth(kind, n_smr):
    sim = simulate_tracker(MECA, 60, noise_mm=0.0, kind=kind, n_smr=n_smr, n_planes=3, seed=7)
    stats = evaluate(sim.truth, sim.data)
    assert stats["n"] == 60 * n_smr and stats["max"] < 1e-9
    assert sim.noise_floor_mm == 0.0
    if kind == "pose":
        assert stats["rotation_deg"]["max"] < 1e-9


def test_truth_has_realistic_errors_and_tracker_pose():
    sim = simulate_tracker(MECA, 10, n_smr=3, seed=11)
    t = sim.truth
    dl = np.abs(np.r_[t.a - MECA.a, t.d - MECA.d]) * 1e3
    da = np.rad2deg(np.abs(np.r_[t.alpha - MECA.alpha, t.theta - MECA.theta]))
    assert dl.min() >= 0.05 and dl.max() <= 0.5
    assert da.min() >= 0.005 and da.max() <= 0.05
    db = np.rad2deg(np.abs(t.beta - MECA.beta))
    assert (db[MECA.parallel] >= 0.005).all() and (db[~MECA.parallel] == 0).all()
    tracker_in_base = np.linalg.inv(t.base)[:3, 3]
    assert 2.0 <= np.linalg.norm(tracker_in_base) <= 4.0
    gaps = np.linalg.norm(t.smr - t.tool[:3, 3], axis=1)
    assert ((gaps >= 0.1) & (gaps <= 0.15)).all()
    np.testing.assert_array_equal(t.nominal[:30], MECA.nominal[:30])


def test_noise_floor_and_outliers():
    sim = simulate_tracker(MECA, 400, noise_mm=0.02, outliers=0.05, seed=2)
    clean = np.setdiff1d(np.arange(400), sim.outlier_rows)
    assert len(sim.outlier_rows) == 20
    err = sim.data.points - sim.truth.fk(sim.true_joints)[:, :3, 3]
    floor = np.sqrt(np.mean(np.sum(err[clean] ** 2, 1))) * 1e3
    assert sim.noise_floor_mm == pytest.approx(floor, rel=1e-9)
    assert sim.noise_floor_mm == pytest.approx(0.02 * np.sqrt(3), rel=0.1)
    gross = np.linalg.norm(err[sim.outlier_rows] - sim.noise[sim.outlier_rows], axis=1) * 1e3
    assert gross.min() >= 1.0 and gross.max() <= 5.0


def test_tracker_noise_model_is_anisotropic():
    sim = simulate_tracker(MECA, 3000, noise_model="tracker", seed=4)
    p = sim.data.points - sim.noise
    r = np.linalg.norm(p, axis=1)
    u = p / r[:, None]
    radial = np.einsum("ni,ni->n", sim.noise, u)
    transverse = np.linalg.norm(sim.noise - radial[:, None] * u, axis=1) / np.sqrt(2)
    expect_r = TRACKER_RADIAL_MM * 1e-3 + TRACKER_RADIAL_UM_PER_M * 1e-6 * r
    expect_t = TRACKER_ANGULAR_URAD * 1e-6 * r
    assert np.std(radial / expect_r) == pytest.approx(1.0, rel=0.05)
    assert np.sqrt(np.mean((transverse / expect_t) ** 2)) == pytest.approx(1.0, rel=0.05)


def test_workspace_box_and_joint_noise():
    box = np.array([[0.1, -0.2, 0.1], [0.3, 0.2, 0.4]])
    sim = simulate_tracker(MECA, 50, workspace_box=box, joint_noise_deg=0.01, seed=5)
    local = sim.truth.with_frames(base=np.eye(4)).fk(sim.true_joints)[:, :3, 3]
    assert ((local >= box[0]) & (local <= box[1])).all()
    assert MECA.within_limits(sim.true_joints).all()
    dq = np.rad2deg(sim.data.joints - sim.true_joints)
    assert np.std(dq) == pytest.approx(0.01, rel=0.2)


def test_plane_contacts_touch_their_planes():
    sim = simulate_tracker(MECA, 90, kind="plane", n_planes=3, seed=8, noise_mm=0.0)
    tips = sim.truth.fk(sim.true_joints)[:, :3, 3]
    n, c = sim.planes[sim.data.plane, :3], sim.planes[sim.data.plane, 3]
    assert np.abs(np.einsum("ni,ni->n", n, tips) - c).max() < 1e-11
    noisy = simulate_tracker(MECA, 90, kind="plane", n_planes=3, seed=8, noise_mm=0.01)
    tips = noisy.truth.fk(noisy.true_joints)[:, :3, 3]
    off = np.einsum("ni,ni->n", noisy.planes[noisy.data.plane, :3], tips) - noisy.planes[noisy.data.plane, 3]
    assert np.std(off) * 1e3 == pytest.approx(0.01, rel=0.25)
    assert noisy.noise_floor_mm == pytest.approx(np.sqrt(np.mean(off**2)) * 1e3, rel=1e-9)
    assert np.bincount(sim.data.plane).tolist() == [30, 30, 30]
    # varied orientations: tool z axes differ across contacts
    z = sim.truth.fk(sim.true_joints)[:, :3, 2]
    assert np.linalg.svd(z - z.mean(0), compute_uv=False)[-1] > 1.0


def test_bad_arguments():
    with pytest.raises(DataError):
        simulate_tracker(MECA, 10, kind="laser")
    with pytest.raises(DataError):
        simulate_tracker(MECA, 10, noise_model="gauss")
    with pytest.raises(DataError):
        simulate_tracker(MECA, 0)
    with pytest.raises(DataError):
        simulate_tracker(MECA, 10, kind="pose", n_smr=2)


def test_cli_same_seed_same_files(tmp_path):
    MECA.save(tmp_path / "meca.yaml")
    outs = []
    for k in (1, 2):
        args = [
            "simulate",
            "--robot",
            str(tmp_path / "meca.yaml"),
            "--poses",
            "30",
            "--smr",
            "2",
            "--seed",
            "9",
            "--outliers",
            "0.1",
            "-o",
            str(tmp_path / f"d{k}.csv"),
            "--truth",
            str(tmp_path / f"t{k}.yaml"),
        ]
        assert main(args) == 0
        outs.append([(tmp_path / f"{n}{k}.{e}").read_bytes() for n, e in (("d", "csv"), ("t", "yaml"))])
    assert outs[0] == outs[1]
    side = json.loads((tmp_path / "t1.sim.json").read_text())
    truth = Robot.load(tmp_path / "t1.yaml")
    data = Measurements.load(tmp_path / "d1.csv", robot=truth)
    assert len(side["outlier_rows"]) == 6 and side["noise_floor_mm"] > 0
    assert f"noise drawn {side['noise_floor_mm']:.6g} mm" in truth.description
    clean = ~np.isin(data.source_row, side["outlier_rows"])
    assert evaluate(truth, data.subset(clean))["rms"] == pytest.approx(side["noise_floor_mm"], rel=1e-9)
