"""A robot on a linear track: the e1 measurement column, simulated track campaigns, the arm and the
track calibrated together (known truth), the calibrated cell in every command."""

from __future__ import annotations

import numpy as np
import pytest

import robocal as rc
from robocal.core.errors import DataError, UnitError
from robocal.data.measurements import Measurements, parse_csv
from robocal.data.simulate import TRACK_SCALE_ERROR, simulate_tracker
from robocal.kinematics.cell import arm_model, carriage_frames
from robocal.kinematics.cell_file import TRACK_SCALE
from robocal.kinematics.model import Robot, cell_from_data

CELL = {"units": {"length": "mm", "angle": "deg"}, "name": "kr210 on a 6 m track",
        "robot": "kuka_kr210_r2700", "track": {"direction": [1, 0, 0], "limits": [0, 6000]},
        "mount": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}}


@pytest.fixture(scope="module")
def cell() -> Robot:
    return cell_from_data(CELL)


def test_e1_column_is_the_first_joint_in_metres(cell):
    text = ("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,e1_mm,x_mm,y_mm,z_mm\n"
            "0,-90,90,0,10,0,1500,1,2,3\n10,-80,80,5,20,5,2500.5,4,5,6\n")
    data = parse_csv(text, "t.csv")
    assert data.external == 1 and data.linear.tolist() == [True] + [False] * 6
    np.testing.assert_allclose(data.joints[:, 0], [1.5, 2.5005])
    np.testing.assert_allclose(data.joints[1, 1:], np.deg2rad([10, -80, 80, 5, 20, 5]))
    data.check_against(cell)
    again = parse_csv(data.to_csv(), "again")
    assert "e1_m," in data.to_csv()
    np.testing.assert_array_equal(again.joints, data.joints)
    assert again.external == 1 and again.linear.tolist() == data.linear.tolist()
    with pytest.raises(DataError, match="7 joint columns.*6 joints"):
        data.check_against(Robot.from_catalog("kuka_kr210_r2700"))


def test_track_in_angle_units_or_missing_is_refused(cell):
    deg = parse_csv("e1_deg,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n0,0,0,0,0,0,0,1,2,3\n")
    with pytest.raises(UnitError, match="e1.*angle units.*prismatic"):
        deg.check_against(cell)
    with pytest.raises(UnitError, match="unknown angle unit 'in'"):
        parse_csv("e1_in,q1_deg,x_mm,y_mm,z_mm\n0,0,1,2,3\n")
    with pytest.raises(DataError, match="6 joint columns.*7 joints.*e1"):
        parse_csv("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,2,3\n"
                  ).check_against(cell)


def test_arm_at_a_carriage_position_is_the_cell(cell):
    moved = cell.with_values({TRACK_SCALE: 2e-4})
    arm = arm_model(moved)
    assert arm_model(cell).has_opw_form  # a nominal catalog arm keeps its closed form
    q = np.c_[np.linspace(0, 6, 5), np.random.default_rng(0).uniform(-1, 1, (5, 6))]
    B = carriage_frames(moved, q[:, 0])
    for k in range(5):
        np.testing.assert_allclose(arm.with_frames(base=B[k]).fk(q[k, 1:]), moved.fk(q[k]), atol=1e-12)


def test_track_campaign_calibrates_arm_and_track_together(cell):
    sim = simulate_tracker(cell, 240, noise_mm=0.02, seed=4)
    truth = sim.truth
    assert abs(abs(truth.get(TRACK_SCALE)) - TRACK_SCALE_ERROR) < 1e-15
    assert sim.data.external == 1 and np.ptp(sim.data.joints[:, 0]) > 5.0  # spread along the track
    cal, val = sim.data.first_poses(160), sim.data.subset(np.arange(160, 240))
    result = rc.calibrate(cell, cal, validation=[val], nongeometric="none")
    est = result.robot.get(TRACK_SCALE)
    assert abs(est - truth.get(TRACK_SCALE)) < 5e-6  # 2e-4 identified to a few ppm
    stats = rc.evaluate(result.robot, val)  # held out: its own tracker frame, no refit
    assert stats["rms"] <= 1.3 * sim.noise_floor_mm
    assert "track: its direction and the mount's rotation" in result.summary()
    nominal_stats = rc.evaluate(cell, val, fit_frame=True)
    assert nominal_stats["rms"] > 20 * stats["rms"]  # the track errors are large before


def test_joint_noise_leaves_the_track_reading_alone(cell):
    sim = simulate_tracker(cell, 20, noise_mm=0.0, seed=1, joint_noise_deg=0.01)
    np.testing.assert_array_equal(sim.data.joints[:, 0], sim.true_joints[:, 0])


def test_measurements_from_arrays_validates_flags():
    with pytest.raises(DataError, match="linear"):
        Measurements.from_arrays("point", np.zeros((2, 3)), points=np.zeros((2, 3)), linear=[True, False])


def test_closed_form_on_the_track_and_compensation_keep_e1(cell):
    from robocal.deploy.compensation import compensate
    from robocal.ik import track

    rng = np.random.default_rng(7)
    q = np.c_[rng.uniform(0.2, 5.8, 12), rng.uniform(-0.8, 0.8, (12, 6))]
    T = cell.fk(q)
    sols = track.solve_all(cell, T, q[:, 0])  # (N, 8, 6): the arm's closed form at each e1
    found = np.isfinite(sols).all(axis=2)
    for k in range(12):
        assert found[k].any()
        err = [np.abs(cell.fk(track.with_track(q[k:k + 1, 0], sols[k, b][None])) - T[k]).max()
               for b in np.flatnonzero(found[k])]
        assert max(err) < 1e-9
        assert min(np.abs(sols[k, found[k]] - q[k, 1:]).max(axis=1)) < 1e-8  # the original is one
    truth = simulate_tracker(cell, 5, seed=2).truth  # a cell with track and arm errors
    res = compensate(truth, cell, truth.fk(q), e1=q[:, 0])
    assert res.converged.all()
    np.testing.assert_array_equal(res.joints[:, 0], q[:, 0])  # the program's e1 is kept
    np.testing.assert_allclose(truth.fk(res.joints)[:, :3, 3], truth.fk(q)[:, :3, 3], atol=1e-9)
    with pytest.raises(DataError, match="carriage position"):
        compensate(truth, cell, truth.fk(q))
    with pytest.raises(DataError, match="outside the track"):
        track.solve(truth, truth.fk(q), q[:, 0] + 7.0)


def test_cell_through_the_command_line(tmp_path, cell):
    """simulate -> calibrate -o -> evaluate, compensate, plan, export with the calibrated cell."""
    import yaml
    from scipy.spatial.transform import Rotation

    from robocal.cli import main
    from robocal.deploy.compensation import read_poses_csv

    (tmp_path / "track.yaml").write_text(yaml.safe_dump(CELL))
    d = str(tmp_path)
    assert main(["--quiet", "simulate", "--robot", f"{d}/track.yaml", "--poses", "150", "--seed", "5",
                 "-o", f"{d}/all.csv", "--truth", f"{d}/truth.yaml"]) == 0
    data = Measurements.load(f"{d}/all.csv")
    assert "e1_m" in (tmp_path / "all.csv").read_text().splitlines()[1]
    data.first_poses(100).save(f"{d}/cal.csv")
    data.subset(np.arange(100, 150)).save(f"{d}/val.csv")
    assert main(["--quiet", "calibrate", f"{d}/cal.csv", "--robot", f"{d}/track.yaml", "--nongeometric",
                 "none", "-o", f"{d}/cal.yaml", "--json", f"{d}/r.json"]) == 0
    assert main(["--quiet", "evaluate", f"{d}/cal.yaml", f"{d}/val.csv", "--json", f"{d}/e.json"]) == 0
    import json
    assert json.loads((tmp_path / "e.json").read_text())["evaluation"]["rms"] < 0.06
    lo, hi = cell.limits[:, 0], cell.limits[:, 1]
    q = np.random.default_rng(3).uniform(0.5 * (lo + hi) - 0.3 * (hi - lo), 0.5 * (lo + hi) + 0.3 * (hi - lo),
                                         (6, 7))
    T = cell.fk(q)  # flange poses in the cell's world (the controller's)
    quat = Rotation.from_matrix(T[:, :3, :3]).as_quat(scalar_first=True)
    rows = ["x_mm,y_mm,z_mm,qw,qx,qy,qz,e1_mm"] + [
        ",".join(repr(float(v)) for v in [*(T[k, :3, 3] * 1e3), *quat[k], q[k, 0] * 1e3]) for k in range(6)]
    (tmp_path / "targets.csv").write_text("\n".join(rows) + "\n")
    assert read_poses_csv(tmp_path / "targets.csv")[1]["e1"].shape == (6,)
    assert main(["--quiet", "compensate", f"{d}/cal.yaml", f"{d}/targets.csv", "--nominal",
                 f"{d}/track.yaml", "-o", f"{d}/cmd.csv"]) == 0
    cmd = np.loadtxt(tmp_path / "cmd.csv", delimiter=",", skiprows=2)  # the provenance marker, the header
    assert (tmp_path / "cmd.csv").read_text().splitlines()[1].startswith("e1_mm,q1_deg")
    np.testing.assert_allclose(cmd[:, 0], q[:, 0] * 1e3, rtol=0, atol=1e-9)  # e1 as the program has it
    assert main(["--quiet", "plan", "--robot", f"{d}/cal.yaml", "--nominal", f"{d}/track.yaml",
                 f"{d}/targets.csv", "-o", f"{d}/plan.csv"]) == 0
    planned = np.loadtxt(tmp_path / "plan.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(planned[:, 0], q[:, 0] * 1e3, atol=1e-9)
    assert main(["--quiet", "export", f"{d}/cal.yaml", "--urdf", f"{d}/cell.urdf"]) == 0
    assert 'type="prismatic"' in (tmp_path / "cell.urdf").read_text()


def test_poses_plans_a_campaign_along_the_track(tmp_path):
    import json

    import yaml

    from robocal.cli import main
    from robocal.data.measurements import read_joints

    (tmp_path / "track.yaml").write_text(yaml.safe_dump(CELL))
    d = str(tmp_path)
    assert main(["--quiet", "poses", "--robot", f"{d}/track.yaml", "-n", "20", "-o", f"{d}/p.csv",
                 "--json", f"{d}/p.json", "--candidates", "800", "--starts", "1", "--region-size",
                 "300"]) == 0
    assert (tmp_path / "p.csv").read_text().startswith("e1_mm,q1_deg")
    q = read_joints(tmp_path / "p.csv", cell_from_data(CELL))
    assert q.shape == (20, 7) and np.ptp(q[:, 0]) > 4.0  # e1 in m, spread along the track
    plan = json.loads((tmp_path / "p.json").read_text())
    np.testing.assert_allclose(plan["e1_mm"], q[:, 0] * 1e3, atol=1e-6)
    assert len(plan["joints_deg"][0]) == 6
    assert main(["--quiet", "poses", "--robot", f"{d}/track.yaml", "-n", "30", "-o", f"{d}/p2.csv",
                 "--rapid", f"{d}/p.mod"]) == 2
    assert not (tmp_path / "p2.csv").exists()


def test_a_lift_is_not_called_a_track(cell):
    """A prismatic joint 1 no cell file declares (a mobile manipulator's torso lift, a gantry axis):
    the summary names its freedoms without the track's mount and encoder scale."""
    from dataclasses import replace

    from robocal.kinematics.cell import declares_track, first_joint_identifiability

    lift = replace(cell, joint_errors=None, name="arm on a lift")
    assert declares_track(cell) and not declares_track(lift)
    assert first_joint_identifiability(Robot.from_catalog("kuka_kr210_r2700")) is None
    sim = simulate_tracker(lift, 120, noise_mm=0.02, seed=5)
    result = rc.calibrate(lift, sim.data, nongeometric="none")
    summary = result.summary()
    assert "prismatic joint 1 (a track, a lift, a gantry axis): its direction is the base frame" in summary
    assert "track: its direction" not in summary and "scale1" not in summary


def test_plan_path_on_a_track_cell_asks_for_the_carriage_positions(cell):
    """The API (not only ``robocal plan`` without an e1_mm column) says that an arm on a track is
    planned with its carriage positions, not that it has no branches."""
    from robocal.core.errors import DataError
    from robocal.ik.path import plan_path

    robot = cell
    with pytest.raises(DataError, match="is an arm on a track: plan its path with each pose's carriage"):
        plan_path(robot, robot.fk(np.zeros((2, robot.n_joints))))
