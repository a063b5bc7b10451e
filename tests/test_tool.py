"""The user's real tool: TCP identification on the calibrated model (4-point method), compensate and
plan with a tool and on calibrated models, and the distance to the nearest singularity."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.deploy.compensation import (
    controller_model,
    format_csv,
    frame_from_text,
    frame_to_text,
    pose_columns,
)
from robocal.deploy.tcp import identify_tcp
from robocal.ik.singularity import SINGULAR_SIGMA, singularity_distance
from robocal.kinematics.transforms import make_transform
from robocal.programs.simulate import touch_poses

TOOL = make_transform(Rotation.from_euler("xyz", [0, 30, 0], degrees=True).as_matrix(),
                      np.array([0.05, -0.01, 0.2]))


def test_tcp_identification_is_exact_on_the_true_model_and_realistic_on_a_calibrated_one():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    true = perturbed(nominal, 4)
    q = touch_poses(true, TOOL, np.array([1.1, 0.2, 0.5]), 8, np.random.default_rng(0))
    exact = identify_tcp(true, nominal, q)
    assert np.abs(exact.tcp - TOOL[:3, 3]).max() < 1e-9 and exact.residuals.max() < 1e-9
    assert np.abs(exact.point - [1.1, 0.2, 0.5]).max() < 1e-9
    # on the nominal model the TCP absorbs the robot's errors and the residuals show them
    off = identify_tcp(nominal, nominal, q)
    assert 0.05 < off.rms_mm < 2.0 and np.abs(off.tcp - TOOL[:3, 3]).max() < 3e-3
    assert "TCP in flange coordinates: x 50.000 y -10.000 z 200.000 mm" in exact.summary()


def test_tcp_identification_refuses_bad_sets():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    q = touch_poses(nominal, TOOL, np.array([1.1, 0.2, 0.5]), 6, np.random.default_rng(1))
    with pytest.raises(DataError, match="at least 4 poses"):
        identify_tcp(nominal, nominal, q[:3])
    same = np.repeat(q[:1], 5, axis=0) + np.array([0, 0, 0, 0, 0, 1e-3])[None] * np.arange(5)[:, None]
    with pytest.raises(DataError, match="orientations differ by only .* at least two different axes"):
        identify_tcp(nominal, nominal, same)
    moved = q.copy()
    moved[2, 0] += np.deg2rad(2.0)  # this pose touched somewhere else
    with pytest.raises(DataError, match=r"pose\(s\) \[.*3.*\] are .* mm from the common point"):
        identify_tcp(nominal, nominal, moved)


def test_cli_tool(tmp_path, capsys):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    true = perturbed(nominal, 4)
    true.save(tmp_path / "cal.yaml")
    q = touch_poses(true, TOOL, np.array([1.1, 0.2, 0.5]), 6, np.random.default_rng(2))
    (tmp_path / "touch.csv").write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n" + "\n".join(
        ",".join(repr(float(v)) for v in row) for row in np.rad2deg(q)) + "\n")
    assert main(["tool", str(tmp_path / "touch.csv"), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal",
                 "abb_irb2600", "--name", "tGun", "--rotation", "0,30,0",
                 "--json", str(tmp_path / "t.json")]) == 0
    out = capsys.readouterr().out
    assert "use: --tcp tGun=50.0000,-10.0000,200.0000,0.0000,30.0000,0.0000" in out
    assert json.loads((tmp_path / "t.json").read_text())["rms_mm"] < 1e-6
    # a bad --rotation is told in its own terms (three angles), before any work
    assert main(["tool", str(tmp_path / "touch.csv"), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal",
                 "abb_irb2600", "--rotation", "0,30"]) == 2
    assert "--rotation '0,30': expected rx,ry,rz (deg" in capsys.readouterr().err
    # --robot-base in metres is refused as filter refuses it (the same magnitude check)
    assert main(["tool", str(tmp_path / "touch.csv"), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal",
                 "abb_irb2600", "--robot-base", "0.5,0.2,0,0,0,0"]) == 2
    assert "--robot-base 0.5,0.2,0,0,0,0" in capsys.readouterr().err


def test_frame_text_round_trip():
    assert np.allclose(frame_from_text(frame_to_text(TOOL)), TOOL, atol=1e-6)
    with pytest.raises(DataError, match="x,y,z,rx,ry,rz"):
        frame_from_text("1,2,3")


def test_compensate_with_the_users_tool():
    """Targets of the real TCP: the calibrated flange carries it, corrected targets are for it on the
    nominal flange, and the controller's own IK of them lands the true robot on the targets."""
    nominal = rc.Robot.from_catalog("abb_irb2600")
    true = perturbed(nominal, 5)
    q = np.random.default_rng(3).uniform(nominal.limits[:, 0] * 0.5, nominal.limits[:, 1] * 0.5, (40, 6))
    q = q[singularity_distance(nominal, q).sigma_rel > 0.02]
    targets = true.fk(q) @ TOOL
    comp = rc.compensate(true, nominal, targets, tool=TOOL)
    assert comp.converged.all()
    assert np.abs(true.fk(comp.joints) @ TOOL - targets).max() < 1e-8
    assert np.abs(nominal.fk(comp.joints) @ TOOL - comp.corrected_targets).max() < 1e-12
    assert comp.corrected_model is true and len(comp.parameters) == 42


def test_plan_on_a_calibrated_model():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    cal = perturbed(nominal, 6)
    q = np.random.default_rng(4).uniform(nominal.limits[:, 0] * 0.5, nominal.limits[:, 1] * 0.5, (60, 6))
    q = q[singularity_distance(nominal, q).sigma_rel > 0.02][:25]
    flange = controller_model(cal, nominal, tool=TOOL)
    T = flange.fk(q)
    res = rc.ik.plan_path(flange, T, nominal=nominal)
    assert np.abs(flange.fk(res.joints) - T).max() < 1e-8
    assert res.cost <= res.greedy_cost
    # the same candidate count as the nominal closed form for the same poses
    nom_tool = nominal.with_frames(tool=nominal.tool @ TOOL)
    assert (res.candidates == rc.ik.plan_path(nom_tool, nom_tool.fk(q)).candidates).mean() > 0.9


def test_cli_plan_and_compensate_take_a_tool(tmp_path, capsys):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    cal = perturbed(nominal, 6)
    cal.save(tmp_path / "cal.yaml")
    q = np.deg2rad([[0, 10, 10, 0, 40, 0], [10, 15, 5, 10, 45, 5], [20, 20, 0, 20, 50, 10]])
    T = controller_model(cal, nominal, tool=TOOL).fk(q)
    (tmp_path / "p.csv").write_text(format_csv(*pose_columns(T, {"length": "mm", "orientation": "quat"})))
    tool = "50,-10,200,0,30,0"
    assert main(["plan", "--robot", str(tmp_path / "cal.yaml"), "--nominal", "abb_irb2600", "--tool", tool,
                 str(tmp_path / "p.csv"), "-o", str(tmp_path / "j.csv")]) == 0
    joints = np.loadtxt(tmp_path / "j.csv", delimiter=",", skiprows=1)
    assert np.abs(np.remainder(joints - np.rad2deg(q) + 180, 360) - 180).max() < 1e-6  # axes 4, 6: +-400 deg
    assert main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "p.csv"),
                 "--nominal", "abb_irb2600", "--targets-in", "robot", "--tool", tool,
                 "-o", str(tmp_path / "c.csv")]) == 0
    out = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=2, usecols=range(14))  # marker, header
    assert np.abs(out[:, :6] - np.rad2deg(q)).max() < 1e-6
    capsys.readouterr()


def test_singularity_distance_names_the_singularity():
    robot = rc.Robot.from_catalog("abb_irb2600")
    psi3 = np.rad2deg(np.arctan2(-0.115, 0.795))  # IRB 2600: stretched arm at q3 = -90 - psi3 + 90
    q = np.deg2rad([[10, 20, 10, 30, 0.0, 20],        # wrist: axis 5 at zero
                    [10, 20, -90 - psi3, 30, 40, 20],  # elbow: arm stretched
                    [10, 20, 10, 30, 40, 20]])         # far from all
    s = singularity_distance(robot, q)
    assert s.nearest[:2].tolist() == ["wrist", "elbow"]
    assert s.wrist_deg[0] < 1e-6 and s.elbow_deg[1] < 1e-6
    assert s.close[:2].all() and not s.close[2] and s.sigma_rel[2] > SINGULAR_SIGMA
    # shoulder: the wrist centre on the axis of joint 1
    _, fr = robot.fk(q[2:], frames=True)
    assert s.shoulder_mm[2] == pytest.approx(np.linalg.norm(fr[0, 5, :2, 3]) * 1e3, rel=1e-9)
