"""benchmarks/peer_sets.py and bench_peers.py: a clear skip without FIGAROH's data, and the
benchmark's path (loaders, robocal's default fit, the shared judging) on a tiny synthetic set laid
out like FIGAROH's example folders."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))

import bench_peers  # noqa: E402
import peer_sets  # noqa: E402

import robocal as rc  # noqa: E402

UR10_URDF = """<robot name="ur10">
<link name="base_link"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="l4"/><link name="l5"/>
<link name="wrist_3_link"/>
<joint name="shoulder_pan_joint" type="revolute"><parent link="base_link"/><child link="l1"/>
 <origin xyz="0 0 0.128" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-6.28" upper="6.28"/></joint>
<joint name="shoulder_lift_joint" type="revolute"><parent link="l1"/><child link="l2"/>
 <origin xyz="0 0.176 0" rpy="0 1.5708 0"/><axis xyz="0 1 0"/><limit lower="-6.28" upper="6.28"/></joint>
<joint name="elbow_joint" type="revolute"><parent link="l2"/><child link="l3"/>
 <origin xyz="0 -0.128 0.612" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-3.14" upper="3.14"/></joint>
<joint name="wrist_1_joint" type="revolute"><parent link="l3"/><child link="l4"/>
 <origin xyz="0 0 0.572" rpy="0 1.5708 0"/><axis xyz="0 1 0"/><limit lower="-6.28" upper="6.28"/></joint>
<joint name="wrist_2_joint" type="revolute"><parent link="l4"/><child link="l5"/>
 <origin xyz="0 0.116 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-6.28" upper="6.28"/></joint>
<joint name="wrist_3_joint" type="revolute"><parent link="l5"/><child link="wrist_3_link"/>
 <origin xyz="0 0 0.116" rpy="0 0 0"/><axis xyz="0 1 0"/><limit lower="-6.28" upper="6.28"/></joint>
</robot>
"""
NOISE_M = 20e-6


def _fake_data(root: Path) -> np.ndarray:
    """FIGAROH's folders with the UR10 example only: its URDF and a 6-D file of 45 poses measured
    exactly (plus 20 um noise) by a displaced copy of the model; returns the true positions."""
    for repo in peer_sets.REPOS:
        (root / repo).mkdir(parents=True)
    ur10 = root / "figaroh-examples/examples/ur10"
    (ur10 / "urdf").mkdir(parents=True)
    (ur10 / "data").mkdir()
    (ur10 / "urdf/ur10_robot.urdf").write_text(UR10_URDF)
    robot = peer_sets.nominal("ur10_point", root)
    rng = np.random.default_rng(3)
    q = rng.uniform(-1.5, 1.5, (45, 6))
    T = robot.fk(q)
    p = T[:, :3, 3] + rng.normal(0, NOISE_M, (45, 3))
    from scipy.spatial.transform import Rotation
    phi = Rotation.from_matrix(T[:, :3, :3]).as_euler("ZYX")[:, ::-1]
    spec = peer_sets.SPECS["ur10_pose"]
    header = "x1,y1,z1,phix1,phiy1,phiz1," + ",".join(spec.joint_columns)
    np.savetxt(ur10 / "data/calibration.csv", np.hstack([p, phi, q]), delimiter=",", header=header,
               comments="", fmt="%.12g")
    return p


def test_absent_data_skip_with_the_places_looked_at(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv(peer_sets.DATA_ENV, raising=False)
    monkeypatch.delenv("ROBOCAL_LIAO_DATA", raising=False)
    monkeypatch.setattr(peer_sets, "CACHE", tmp_path / "cache")
    with pytest.raises(peer_sets.DataUnavailableError, match="looked at: --data .*nowhere"):
        peer_sets.load("talos", tmp_path / "nowhere")
    assert bench_peers.main(["--data", str(tmp_path / "nowhere"), "--robocal-only"]) == 0
    out = capsys.readouterr().out
    assert "peer benchmark skipped: FIGAROH's example data not found" in out
    assert "IRB 120 paper comparison skipped" in out


def test_loader_reads_figaroh_layout_and_splits_every_third_pose(tmp_path):
    p = _fake_data(tmp_path)
    s = peer_sets.load("ur10_pose", tmp_path)
    assert s.calibration.kind == "pose" and len(s.calibration) == 30 and len(s.held_out) == 15
    np.testing.assert_allclose(s.held_out.points, p[2::3])  # poses 2, 5, 8 ...: held out
    spec = peer_sets.SPECS["ur10_pose"]
    rpy = peer_sets.read_session(tmp_path / spec.files[0], spec)
    np.testing.assert_allclose(rpy.rotations, s.robot.fk(rpy.joints)[:, :3, :3], atol=1e-9)
    assert "every 3rd pose held out (30 calibrate, 15 judge)" in s.description


def test_phi_is_figaroh_rpy_convention():
    """FIGAROH writes phix, phiy, phiz with pinocchio.rpy.matrixToRpy: the reader inverts that."""
    pin = pytest.importorskip("pinocchio")
    phi = np.array([0.3, -1.1, 2.5])
    R = pin.rpy.rpyToMatrix(*phi)
    from scipy.spatial.transform import Rotation
    np.testing.assert_allclose(Rotation.from_euler("ZYX", phi[::-1]).as_matrix(), R, atol=1e-12)


def test_bench_runs_robocal_default_on_a_tiny_synthetic_set(tmp_path, capsys):
    _fake_data(tmp_path)
    assert bench_peers.main(["--data", str(tmp_path), "--only", "ur10_point", "--robocal-only"]) == 0
    out = capsys.readouterr().out
    assert "FIGAROH rows skipped: --robocal-only" in out
    row = next(line for line in out.splitlines() if "robocal default" in line).split()
    assert float(row[3]) < 5 * NOISE_M * 1e3 * np.sqrt(3)  # held-out RMS (mm): at the noise


def test_refitting_the_frame_removes_a_rigid_motion_only():
    rng = np.random.default_rng(0)
    pred = rng.normal(size=(20, 3))
    T = rc.Robot.from_catalog("abb_irb2600").fk(np.zeros((1, 6)))[0]
    meas = pred @ T[:3, :3].T + T[:3, 3]
    assert bench_peers.judged(pred, meas, refit=True)["max"] < 1e-9
    assert bench_peers.judged(pred, meas, refit=False)["rms"] > 100


def _fake_liao(folder: Path, robot) -> None:
    """The Wu et al. 2015 layout (.mat files in mm/deg, Experiment.m with the test points at q = 0)
    measured exactly by ``robot`` (its base frame = the tracker's), SMRs and test points known."""
    from scipy.io import savemat

    folder.mkdir()
    rng = np.random.default_rng(5)
    smrs = np.array([[0.0, 0.0, 0.02], [0.03, 0.0, 0.02], [0.0, 0.03, 0.02]])
    tips = np.array([[0.01, 0.01, 0.03], [0.012, 0.008, 0.031]])

    def point(q, offset):
        _, frames = robot.fk(q, frames=True)
        return frames[:, -1, :3, :3] @ offset + frames[:, -1, :3, 3]

    q = rng.uniform(-1, 1, (36, 6))
    cal = np.stack([point(q, s) for s in smrs], axis=1).reshape(-1, 3)
    savemat(folder / "CaliJointAngles.mat", {"CaliJointAngles": np.rad2deg(q)})
    savemat(folder / "CaliPosition.mat", {"CaliPosition": cal * 1e3})
    lines = []
    for suffix, n, tip in (("", 10, tips[0]), ("2", 30, tips[1])):
        qt = rng.uniform(-1, 1, (n, 6))
        savemat(folder / f"TestJointAngles{suffix}.mat", {f"TestJointAngles{suffix}": np.rad2deg(qt)})
        savemat(folder / f"TestPosition{suffix}.mat", {f"TestPosition{suffix}": point(qt, tip) * 1e3})
        at_zero = point(np.zeros((1, 6)), tip)[0] * 1e3
        xyz = "\t".join(f"{v:.9f}" for v in at_zero)
        lines.append(f"TestPoint_Meas{suffix}=[{xyz}]*s;%Test Point")
    (folder / "Experiment.m").write_text("s=0.001;\n" + "\n".join(lines) + "\n")


def test_liao_campaign_places_the_test_point_from_its_reading_at_zero(tmp_path, monkeypatch):
    import liao_irb120

    monkeypatch.delenv(liao_irb120.DATA_ENV, raising=False)
    with pytest.raises(liao_irb120.LiaoUnavailableError, match="looked at: nothing"):
        liao_irb120.load(None)
    truth = rc.Robot.from_catalog("abb_irb120")
    _fake_liao(tmp_path / liao_irb120.FOLDER, truth)
    campaign = liao_irb120.load(tmp_path)  # the repository folder holding it
    assert len(campaign.calibration) == 108 and campaign.calibration.n_smr == 3
    assert len(campaign.test_joints) == 40
    assert liao_irb120.test_errors_mm(truth, campaign).max() < 1e-6  # the true model: exact
    assert liao_irb120.test_errors_mm(rc.calibrate(truth, campaign.calibration).robot, campaign).max() < 1e-3


def test_splits_are_fixed_disjoint_and_cover_the_session(tmp_path):
    """Split 0 is every third pose; splits 1.. hold out as many poses drawn with fixed seeds: the
    same on every call, different between splits, calibration and held-out disjoint and complete."""
    for n in (10, 34, 61):
        np.testing.assert_array_equal(np.flatnonzero(peer_sets.held_out_mask(n, 0)), np.arange(2, n, 3))
        masks = [peer_sets.held_out_mask(n, k) for k in range(1, 6)]
        for k, m in enumerate(masks, start=1):
            assert m.sum() == n // peer_sets.HOLD_EVERY
            np.testing.assert_array_equal(m, peer_sets.held_out_mask(n, k))  # deterministic
        assert len({m.tobytes() for m in masks}) == len(masks)  # distinct splits
    with pytest.raises(ValueError, match="split must be >= 0"):
        peer_sets.held_out_mask(10, -1)
    p = _fake_data(tmp_path)
    for k in range(4):
        s = peer_sets.load("ur10_pose", tmp_path, split=k)
        cal, held = s.calibration.points, s.held_out.points
        assert len(cal) + len(held) == len(p) and len(held) == len(p) // 3
        rows = {tuple(r) for r in np.round(np.vstack([cal, held]), 12)}
        assert len(rows) == len(p)  # disjoint, and together every pose
        again = peer_sets.load("ur10_pose", tmp_path, split=k)
        np.testing.assert_array_equal(again.held_out.points, held)
        assert (f"split {k}, a random third" in s.description) == (k > 0)


def test_next_day_has_two_splits_and_judges_the_markers_calibrated():
    assert peer_sets.n_splits("tiago_next_day", 10) == 2 and peer_sets.n_splits("tiago_next_day", 1) == 1
    assert peer_sets.n_splits("tiago", 10) == 10
    day = peer_sets.Session(np.zeros((2, 8)), np.arange(24.0).reshape(2, 4, 3), None, np.array([2, 3]),
                            Path("a.csv"), (0, 1, 2, 3))
    seen = day.with_markers((0, 1, 3))  # the other day saw markers 0, 1 and 3: renumbered 0, 1, 2
    assert seen.ids == (0, 1, 2)
    np.testing.assert_array_equal(seen.markers, day.markers[:, [0, 1, 3]])


def test_bench_summarises_several_splits(tmp_path, capsys):
    _fake_data(tmp_path)
    assert bench_peers.main(["--data", str(tmp_path), "--only", "ur10_point", "--robocal-only",
                             "--splits", "3"]) == 0
    out = capsys.readouterr().out
    assert "split 2: calibration.csv: split 2, a random third held out" in out
    row = next(line for line in out.splitlines() if line.split()[:2] == ["ur10_point", "3"]).split()
    assert float(row[2]) < 5 * NOISE_M * 1e3 * np.sqrt(3)  # mean held-out RMS over the 3 splits
    with pytest.raises(SystemExit):
        bench_peers.main(["--data", str(tmp_path), "--splits", "0"])


def test_a_judged_pose_with_a_typed_joint_typo_is_named_and_left_out(tmp_path):
    """Another day's pose the nominal model misses by far more than any honest pose (a typo in a
    typed joint) is not judged, and the note names its CSV line; the others are all kept."""
    p = _fake_data(tmp_path)
    robot = peer_sets.nominal("ur10_point", tmp_path)
    spec = peer_sets.SPECS["ur10_point"]
    day = peer_sets.read_session(tmp_path / spec.files[0], spec)
    kept, notes = peer_sets.without_typos(day, robot, pose_6d=False)
    assert len(kept.joints) == len(p) and notes == []
    joints = day.joints.copy()
    joints[7, 2] *= -1  # a sign typed wrong
    typo = peer_sets.Session(joints, day.markers, None, day.rows, day.file, day.ids)
    kept, notes = peer_sets.without_typos(typo, robot, pose_6d=False)
    assert len(kept.joints) == len(p) - 1 and 9 not in kept.rows  # pose 7 is CSV line 9
    assert "CSV lines 9 not judged" in notes[0]
