"""Compensation on simulated truth, the seed-000 parameter export, pose CSV files, robocal compensate."""

from __future__ import annotations

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.deploy.compensation import (
    format_csv,
    parameter_table,
    pose_columns,
    read_poses_csv,
    residual_mm,
)
from robocal.ik.numeric import nominal_seeds


def simulated_cell(name="abb_irb2600", n=300, seed=0):
    """Nominal catalog robot, a 'true' robot (0.05-0.5 mm, 0.005-0.05 deg errors), a 'calibrated'
    estimate of it with residual errors ten times smaller, and reachable targets."""
    nominal = rc.Robot.from_catalog(name)
    true = perturbed(nominal, seed)
    calibrated = perturbed(true, seed + 1, length_mm=(0.005, 0.05), angle_deg=(0.0005, 0.005))
    rng = np.random.default_rng(seed + 2)
    q = rng.uniform(nominal.limits[:, 0] * 0.6, nominal.limits[:, 1] * 0.6, (3 * n, 6))
    o = nominal.opw
    phi = q[:, 2] * o.signs[2] - o.offsets[2] + np.arctan2(o.a2, o.c3)
    q = q[np.abs(np.sin(phi)) > 0.1][:n]  # off the stretched arm, which the nominal may not reach
    return nominal, true, calibrated, true.fk(q)


def test_compensation_on_simulated_truth():
    nominal, true, calibrated, targets = simulated_cell()
    comp = rc.compensate(calibrated, nominal, targets)
    assert comp.converged.all() and comp.position_error.max() <= 1e-10
    before = residual_mm(true, nominal_seeds(nominal, targets), targets)
    after = residual_mm(true, comp.joints, targets)
    assert np.sqrt(np.mean(after**2)) * 5 < np.sqrt(np.mean(before**2))
    # the controller's own nominal IK of the corrected targets gives the same joints
    via_cartesian = nominal_seeds(nominal, comp.corrected_targets)
    assert np.allclose(residual_mm(true, via_cartesian, targets), after, atol=1e-6)


def test_parameter_export_is_eta_minus_delta():
    nominal, _, calibrated, _ = simulated_cell(n=1)
    rows = parameter_table(calibrated, nominal)
    assert len(rows) == 5 * 6 + 12
    for r in rows:
        assert r["nominal"] - r["delta"] == pytest.approx(r["calibrated"], abs=1e-15)
    assert any(abs(r["delta"]) > 0 for r in rows if r["name"].startswith("theta"))


@pytest.mark.parametrize("layout", [{"length": "mm", "orientation": "quat"},
                                    {"length": "m", "orientation": "deg"},
                                    {"length": "mm", "orientation": "rad"}])
def test_pose_csv_round_trip(tmp_path, layout):
    _, _, _, targets = simulated_cell(n=20)
    cols, vals = pose_columns(targets, layout)
    path = tmp_path / "t.csv"
    path.write_text(format_csv(cols, vals))
    back, got = read_poses_csv(path)
    assert got == layout
    assert np.abs(back - targets).max() < 1e-12


@pytest.mark.parametrize("text, match", [
    ("x_mm,y_mm,z_mm\n1,2,3\n", "orientation"),
    ("x,y,z,qw,qx,qy,qz\n1,2,3,1,0,0,0\n", "x_mm"),
    ("x_mm,y_mm,z_mm,qw,qx,qy,qz\n1,2,3,2,0,0,0\n", "unit length"),
    ("x_mm,y_mm,z_mm,qw,qx,qy,qz\n1,2,abc,1,0,0,0\n", "numeric"),
])
def test_pose_csv_errors(tmp_path, text, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(DataError, match=match):
        read_poses_csv(p)


def test_cli_compensate(tmp_path, capsys):
    nominal, _, calibrated, targets = simulated_cell(n=15)
    calibrated.save(tmp_path / "cal.yaml")
    cols, vals = pose_columns(targets, {"length": "mm", "orientation": "deg"})
    (tmp_path / "targets.csv").write_text(format_csv(cols, vals))
    out, par = tmp_path / "commands.csv", tmp_path / "params.csv"
    code = main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "targets.csv"), "--nominal",
                 "abb_irb2600", "--parameters", str(par), "-o", str(out), "--targets-in", "model",
                 "--tool", "measured"])
    assert code == 0
    marker, header = out.read_text().splitlines()[:2]  # the provenance marker, then the header
    assert marker.startswith("# robocal ") and "model " in marker
    header = header.split(",")
    assert header == [f"q{i}_deg" for i in range(1, 7)] + cols + [
        "converged", "sigma_rel", "nearest_singularity", "wrist_deg", "elbow_deg", "shoulder_mm"]
    table = np.loadtxt(out, delimiter=",", skiprows=2, usecols=range(len(header) - 5))
    comp = rc.compensate(rc.Robot.load(tmp_path / "cal.yaml"), nominal, targets)
    assert np.allclose(np.deg2rad(table[:, :6]), comp.joints, atol=1e-12)
    assert (table[:, -1] == 1).all()
    assert par.read_text().startswith("name,unit,nominal,calibrated,delta")
    (tmp_path / "bad.csv").write_text("x_mm,y_mm,z_mm\n1,2,3\n")
    assert main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "bad.csv"), "--nominal",
                 "abb_irb2600", "-o", str(tmp_path / "never.csv")]) == 2
    assert not (tmp_path / "never.csv").exists()


def test_compensation_after_a_real_calibration_on_simulated_truth():
    """Issue goal: after calibrate, the compensated joints put the true robot within 1.2x the
    model's validation RMS of the targets, and at least 5x closer than the nominal joints."""
    import robocal as rc

    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = rc.simulate_tracker(nominal, 220, seed=21)
    cal = sim.data.subset(sim.data.pose_id < 120)
    val = sim.data.subset(sim.data.pose_id >= 120)
    res = rc.calibrate(nominal, cal, validation=val)
    controller = res.start  # the controller's model: nominal links, registered tracker frame and SMR
    targets = controller.fk(val.joints[:60])
    comp = rc.compensate(res.robot, controller, targets)
    assert comp.converged.all()
    err = np.linalg.norm(sim.truth.fk(comp.joints)[:, :3, 3] - targets[:, :3, 3], axis=1) * 1e3
    nominal_err = np.linalg.norm(sim.truth.fk(val.joints[:60])[:, :3, 3] - targets[:, :3, 3], axis=1) * 1e3
    rms, nominal_rms = np.sqrt(np.mean(err**2)), np.sqrt(np.mean(nominal_err**2))
    assert rms <= 1.2 * res.validation["rms"]
    assert nominal_rms >= 5 * rms


def test_targets_in_the_robot_base_frame():
    """A tracker-frame calibration compensates targets given in robot coordinates."""
    import robocal as rc

    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = rc.simulate_tracker(nominal, 150, seed=22)
    res = rc.calibrate(nominal, sim.data)
    controller = nominal.with_frames(tool=res.start.tool)  # the controller's TCP: the SMR
    q = sim.data.joints[:40]
    targets = controller.fk(q)  # robot base frame
    comp = rc.compensate(res.robot, controller, targets, targets_frame="robot")
    # the truth in robot coordinates, with the calibrated model's identified frame {0} as the robot's
    truth = sim.truth.with_frames(base=nominal.base @ np.linalg.inv(res.robot.base) @ sim.truth.base)
    err = np.linalg.norm(truth.fk(comp.joints)[:, :3, 3] - targets[:, :3, 3], axis=1)
    before = np.linalg.norm(truth.fk(q)[:, :3, 3] - targets[:, :3, 3], axis=1)
    assert comp.converged.all()
    assert np.sqrt(np.mean(err**2)) < 0.05e-3 < 0.2 * np.sqrt(np.mean(before**2))
    with pytest.raises(DataError, match="targets_frame"):
        rc.compensate(res.robot, controller, targets, targets_frame="tracker")
