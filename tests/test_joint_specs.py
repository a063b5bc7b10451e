"""Joint kinds from the model (Robot.joints): names, types, units, CSV columns and limits of a
revolute arm, a SCARA with a prismatic quill and an arm on a track, and the messages, range checks
and joints files that use them."""

from __future__ import annotations

import numpy as np
import pytest

from robocal.campaign.constraints import limits_with_margin
from robocal.campaign.files import poses_csv
from robocal.core.errors import DataError, PlausibilityError, UnitError
from robocal.data.measurements import Measurements
from robocal.identify.plausibility import check_joint_limits
from robocal.kinematics.model import PRISMATIC, REVOLUTE, Robot, cell_from_data

CELL = {"units": {"length": "mm", "angle": "deg"}, "robot": "kuka_kr210_r2700",
        "track": {"direction": [1, 0, 0], "limits": [0, 6000]}}


def _scara() -> Robot:
    """Four joints: shoulder and elbow (revolute), the quill (prismatic, m), the wrist (revolute)."""
    return Robot(alpha=np.zeros(4), a=np.array([0.0, 0.4, 0.3, 0.0]), beta=np.zeros(4), theta=np.zeros(4),
                 d=np.array([0.2, 0.0, 0.0, 0.0]), prismatic=[False, False, True, False],
                 limits=np.array([[-2.5, 2.5], [-2.5, 2.5], [-0.2, 0.0], [-6.0, 6.0]]), name="scara")


def test_a_revolute_arm_has_joints_in_degrees():
    robot = Robot.from_catalog("abb_irb2600")
    joints = robot.joints
    assert [j.column for j in joints] == [f"q{i}_deg" for i in range(1, 7)]
    assert {j.kind for j in joints} == {REVOLUTE} and robot.external_axes == 0
    np.testing.assert_array_equal([j.limits for j in joints], robot.limits)
    assert joints[1].shown(np.pi / 2) == 90.0


def test_a_scara_quill_is_prismatic_in_mm():
    robot = _scara()
    assert [j.column for j in robot.joints] == ["q1_deg", "q2_deg", "q3_mm", "q4_deg"]
    assert robot.joints[2].kind == PRISMATIC and robot.joints[2].unit == "mm"
    assert robot.joints[2].describe(-0.25) == "q3 = -250 mm (limits -200 .. 0)"
    text = poses_csv(np.array([[0.1, -0.2, -0.05, 1.0]]), spec=robot.joints)
    header, row = text.splitlines()[:2]
    assert header.startswith("q1_deg,q2_deg,q3_mm,q4_deg")
    assert row.split(",")[2] == "-50"  # the quill in mm, not 2.9 "deg"
    np.testing.assert_array_equal(robot.joints_shown([[0.1, -0.2, -0.05, 1.0]]),
                                  [[np.rad2deg(0.1), np.rad2deg(-0.2), -50.0, np.rad2deg(1.0)]])


def test_a_track_is_e1_in_mm_and_the_arm_q1_to_q6():
    cell = cell_from_data(CELL)
    assert cell.external_axes == 1
    assert [j.column for j in cell.joints] == ["e1_mm"] + [f"q{i}_deg" for i in range(1, 7)]
    assert cell.joints[0].limits == (0.0, 6.0)


def _data(robot: Robot, q: np.ndarray) -> Measurements:
    return Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3], linear=robot.prismatic,
                                    external=robot.external_axes)


def test_a_track_reading_past_its_end_is_named_in_mm():
    cell = cell_from_data(CELL)
    q = np.zeros((2, 7))
    q[:, 2] = -np.pi / 2
    q[1, 0] = 6.3434  # 343.4 mm past the track's end: not 363 "deg" past 343.8
    with pytest.raises(PlausibilityError, match=r"more than 90 deg \(100 mm on a prismatic joint\)") as err:
        check_joint_limits(cell, _data(cell, q), "the data")
    assert "row 2 e1 = 6343.4 mm (limits 0 .. 6000)" in str(err.value)
    warnings: list[str] = []
    q[1, 0] = 6.0005  # 0.5 mm: within the tolerance
    check_joint_limits(cell, _data(cell, q), "the data", warnings=warnings)
    assert not warnings
    q[1, 0] = 6.05  # 50 mm: warned, not refused (a revolute joint's 1 deg / 90 deg are not mm)
    check_joint_limits(cell, _data(cell, q), "the data", warnings=warnings)
    assert len(warnings) == 1 and "e1 = 6050 mm (limits 0 .. 6000)" in warnings[0]


def test_a_revolute_reading_keeps_its_message():
    robot = Robot.from_catalog("abb_irb2600")
    q = np.zeros((1, 6))
    q[0, 1] = np.deg2rad(300.0)
    expected = r"more than 90 deg outside .*: 1 row\(s\): row 1 q2 = 300 deg \(limits -95 \.\. 155\)"
    with pytest.raises(PlausibilityError, match=expected):
        check_joint_limits(robot, _data(robot, q), "the data")


def _wide_wrist() -> Robot:
    """An IRB 2600 whose wrist turns +-2700 deg (several turns either way)."""
    base = Robot.from_catalog("abb_irb2600")
    wide = np.array(base.limits)
    wide[5] = np.deg2rad([-2700.0, 2700.0])
    return Robot(alpha=base.alpha, a=base.a, beta=base.beta, theta=base.theta, d=base.d, base=base.base,
                 tool=base.tool, limits=wide, name="wide")


def test_a_joint_limited_beyond_two_turns_reads_inside_its_limits(tmp_path):
    robot = _wide_wrist()
    q = np.zeros((1, 6))
    q[0, 5] = np.deg2rad(1500.0)  # 4 turns: inside its own limits
    check_joint_limits(robot, _data(robot, q), "the data")
    q[0, 4] = np.deg2rad(1500.0)  # but on a joint limited to less than 2 turns: not a real reading
    with pytest.raises(DataError, match="beyond 2 turns"):
        check_joint_limits(robot, _data(robot, q), "the data")
    q[0, 4] = 0.0
    _data(robot, q).save(tmp_path / "wide.csv")  # SI columns: q6_rad = 26.2
    assert Measurements.load(tmp_path / "wide.csv", robot=robot).joints[0, 5] == q[0, 5]
    with pytest.raises(UnitError, match="> 2 turns"):  # without the robot: degrees under _rad?
        Measurements.load(tmp_path / "wide.csv")


def test_a_margin_that_leaves_no_room_names_the_quill_in_mm():
    limits_with_margin(_scara(), 10.0)  # 10 mm off either end of a 200 mm quill (not 10 deg = 175 mm)
    with pytest.raises(DataError, match=r"margin of 101 mm leaves no room on joint 3 \(limits -200 to 0 mm"):
        limits_with_margin(_scara(), 101.0)


def test_a_gantry_is_no_track_and_a_track_counts_its_arm_joints():
    gantry = Robot(alpha=np.array([0.0, -np.pi / 2, -np.pi / 2, 0.0]), a=np.zeros(4), beta=np.zeros(4),
                   theta=np.array([0.0, np.pi / 2, 0.0, 0.0]), d=np.zeros(4),
                   prismatic=[True, True, True, False], name="gantry",
                   limits=np.array([[0.0, 2.0], [0.0, 1.0], [-0.5, 0.0], [-3.0, 3.0]]))
    assert gantry.external_axes == 0 and [j.column for j in gantry.joints][:3] == ["q1_mm", "q2_mm", "q3_mm"]
    three = Measurements.from_arrays("point", np.zeros((2, 3)), points=np.ones((2, 3)))
    with pytest.raises(DataError, match=r"has 4 joints: use"):
        three.check_against(gantry)
    with pytest.raises(DataError, match=r"has 7 joints \(e1 for its track, then q1\.\.q6\)"):
        three.check_against(cell_from_data(CELL))


def test_a_margin_and_a_joint_distance_count_a_prismatic_joint_in_mm():
    from robocal.campaign.constraints import conflict_rows, margin_unit

    robot = _scara()
    lim = limits_with_margin(robot, 1.0)
    np.testing.assert_allclose(lim[2], [-0.199, -0.001])  # 1 mm off the quill's ends, not 17.5 mm
    np.testing.assert_allclose(lim[0], [-2.5 + np.deg2rad(1.0), 2.5 - np.deg2rad(1.0)])
    assert margin_unit(robot) == "deg, mm on q3" and margin_unit(Robot.from_catalog("abb_irb2600")) == "deg"
    q = np.zeros((3, 4))
    q[1, 2], q[2, 0] = -0.005, np.deg2rad(5.0)  # 5 mm down the quill, 5 deg on the shoulder
    conflicts = conflict_rows(q, 4.0, robot.prismatic)
    np.testing.assert_array_equal(conflicts(0), [1, 0, 0])
    np.testing.assert_array_equal(conflict_rows(q, 6.0, robot.prismatic)(0), [1, 1, 1])


def _scara_plan():
    import robocal as rc

    return rc.plan_poses(_scara(), 12, n_candidates=200, region_size=80, starts=1, seed=1)


def test_a_scara_campaign_writes_its_quill_in_mm_and_its_page_says_so():
    from robocal.report.campaign import render_campaign

    plan = _scara_plan()
    out = plan.to_dict()
    assert out["robot"]["joints"] == ["q1_deg", "q2_deg", "q3_mm", "q4_deg"]
    quill = np.array(out["joints_deg"])[:, 2]
    np.testing.assert_allclose(quill, plan.joints[:, 2] * 1e3, atol=1e-4)
    assert (quill <= -1.0).all() and (quill >= -199.0).all()  # mm, within the 1 mm margin
    np.testing.assert_array_equal(np.round(plan.joints[:, 2] * 1e3, 4), plan.joints[:, 2] * 1e3)
    page = render_campaign(out)
    assert "<th>q3 (mm)</th>" in page and "q3 (deg)" not in page


def test_an_ordinary_arm_keeps_its_robot_section_and_labels():
    from robocal.report.format import joint_columns

    robot = Robot.from_catalog("abb_irb2600")
    assert robot.section() == {"name": "abb_irb2600", "description": robot.description, "n_joints": 6}
    assert joint_columns({"robot": robot.section()}, 6)[1] == ("q2", "deg")
    cell = cell_from_data(CELL)
    assert cell.section()["joints"][:2] == ["e1_mm", "q1_deg"]
    assert joint_columns({"robot": cell.section()}, 7)[:2] == [("e1", "mm"), ("q1", "deg")]


def test_coverage_gives_a_prismatic_joint_in_mm():
    from robocal.trust.coverage import covered_text, joint_coverage

    robot = _scara()
    q = np.array([[0.1, -0.2, -0.05, 1.0], [0.3, 0.2, -0.01, 2.0]])
    rows = joint_coverage(robot, q)
    assert set(rows[0]) == {"joint", "limits_deg", "covered_deg", "fraction"}
    assert set(rows[2]) == {"joint", "limits_mm", "covered_mm", "fraction"}
    np.testing.assert_allclose(rows[2]["limits_mm"], [-200.0, 0.0])
    np.testing.assert_allclose(rows[2]["covered_mm"], [-50.0, -10.0])
    assert rows[2]["fraction"] == pytest.approx(0.2)
    assert covered_text(robot, rows[2]) == "q3 (covered -50..-10 of -200..0 mm)"
    assert covered_text(robot, rows[1]) == "q2 (covered -11..11 of -143..143 deg)"
    cell = cell_from_data(CELL)
    track = joint_coverage(cell, np.zeros((2, 7)))[0]
    assert covered_text(cell, track) == "e1 (covered 0..0 of 0..6000 mm)"


def test_a_scara_calibration_reports_its_quill_in_mm():
    import robocal as rc
    from robocal.report.html import render_report

    robot = _scara()
    q = np.random.default_rng(3).uniform(robot.limits[:, 0], robot.limits[:, 1], (40, 4))
    data = Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3] + 1e-5, linear=robot.prismatic)
    result = rc.calibrate(robot, data, nongeometric="none", register_frames=False, force=True)
    out = result.to_dict()
    assert out["robot"]["joints"] == ["q1_deg", "q2_deg", "q3_mm", "q4_deg"]
    np.testing.assert_allclose(np.array(out["observations"]["joints_deg"])[:, 2], q[:, 2] * 1e3)
    cov = out["predicted_accuracy"]["coverage"][2]
    assert "limits_mm" in cov and "limits_deg" not in cov
    page = render_report(out)
    assert "q3 (mm)" in page and "q3 (deg)" not in page
    assert "mm on q3" in page  # the joint distance's unit


def test_measurements_read_against_a_model_take_its_joint_names(tmp_path):
    cell = cell_from_data(CELL)
    q = np.zeros((2, 7))
    q[:, 0], q[:, 3] = [1.0, 2.0], -np.pi / 2
    points = cell.fk(q)[:, :3, 3]
    plain = Measurements.from_arrays("point", q, points=points, linear=cell.prismatic)  # q1_m: no track named
    plain.save(tmp_path / "q1.csv")
    assert (tmp_path / "q1.csv").read_text().count("q1_m,") == 1
    data = Measurements.load(tmp_path / "q1.csv", robot=cell)
    assert data.external == 1 and data.to_csv().count("e1_m,") == 1  # the model's e1, saved as such
    np.testing.assert_array_equal(data.joints, q)
    scara = _scara()
    q4 = np.array([[0.1, -0.2, -0.05, 1.0]])
    angles = Measurements.from_arrays("point", q4, points=scara.fk(q4)[:, :3, 3])
    expected = r"joint 3 \(q3\) is prismatic \(give it in mm or m\): its column is q3_mm"
    with pytest.raises(UnitError, match=expected):
        angles.check_against(scara)


def test_a_repeated_pose_on_a_track_is_within_its_tolerance_in_mm():
    from robocal.trust.provenance import repeated_rows

    ref = np.zeros((1, 7))
    q = np.zeros((3, 7))
    q[1, 0], q[2, 0] = 5e-6, 1e-4  # 0.005 mm and 0.1 mm along the track (0.1 mm < 0.01 "deg" = 0.17 mm)
    slides = np.r_[True, np.zeros(6, bool)]
    np.testing.assert_array_equal(repeated_rows(ref, q, prismatic=slides), [True, True, False])
    np.testing.assert_array_equal(repeated_rows(ref, q), [True, True, True])  # without the kinds: rad


def test_a_joint_column_exchange_on_a_track_names_the_arm_joints():
    from dataclasses import replace

    from robocal.data.simulate import simulate_tracker
    from robocal.trust.diagnosis import fit_rms_mm, joint_mixup

    cell = cell_from_data(CELL)
    data = simulate_tracker(cell, 30, noise_mm=0.0, seed=2).data
    q = data.joints.copy()
    q[:, [2, 3]] = q[:, [3, 2]]  # the arm's q2 and q3 (columns 3 and 4 after e1)
    swapped = replace(data, joints=q)
    given = fit_rms_mm(cell, swapped)
    assert joint_mixup(cell, swapped, given).startswith("joint columns q2 and q3 look exchanged")


def test_a_track_campaign_page_shows_the_carriage_in_mm():
    from robocal.report.campaign import render_campaign

    page = {"robot": {"name": "cell", "n_joints": 7}, "joints_deg": [[0.0, -90.0, 90.0, 0.0, 10.0, 0.0]],
            "e1_mm": [1500.0], "tcp_mm": [[1.0, 2.0, 3.0]]}
    for campaign in (page, {**page, "robot": cell_from_data(CELL).section()}):  # older file, this one
        html = render_campaign(campaign)
        assert "<th>e1 (mm)</th><th>q1 (deg)</th>" in html and "q7" not in html
        assert "1500.0000" in html


def test_joint_params_name_the_quills_d():
    assert _scara().joint_params == ["theta1", "theta2", "d3", "theta4"]


@pytest.mark.parametrize("kind", ["distance", "plane"])
def test_a_scara_bar_or_plane_simulation_moves_its_quill_as_a_slide(kind):
    from robocal.data.simulate import simulate_tracker

    sim = simulate_tracker(_scara(), 20, kind=kind, seed=4, noise_mm=0.0)  # was LinAlgError (a theta3 column)
    q = sim.data.joints
    assert np.isfinite(q).all() and len(q) >= 20


def test_a_joints_file_with_a_quill_in_degrees_is_refused(tmp_path):
    from robocal.campaign.files import read_planned
    from robocal.data.measurements import read_joints

    path = tmp_path / "poses.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg\n10,20,-50,30\n")  # was: -50 deg read as a -0.87 m quill
    expected = r"joint column 3 \(q3\) is in angle units but scara's joint 3 \(q3\) is prismatic"
    with pytest.raises(UnitError, match=expected):
        read_planned(path, _scara())
    with pytest.raises(UnitError, match=expected):
        read_joints(path, _scara())
    path.write_text("q1_deg,q2_deg,q3_mm,q4_deg\n10,20,-50,30\n")
    np.testing.assert_allclose(read_planned(path, _scara()).joints[0, 2], -0.05)


def test_analyze_checks_a_joints_files_kinds(tmp_path, capsys):
    from robocal.cli import main

    _scara().save(tmp_path / "scara.yaml")
    path = tmp_path / "poses.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg\n10,20,-50,30\n20,-30,-60,40\n")
    assert main(["analyze", str(path), "--robot", str(tmp_path / "scara.yaml")]) == 2
    assert "joint 3 (q3) is prismatic" in capsys.readouterr().err


def test_a_scara_registers_from_points():
    from robocal.data.registration import register_frame, turns_about_one_axis
    from robocal.data.simulate import simulate_tracker

    robot = _scara()
    assert turns_about_one_axis(robot) and not turns_about_one_axis(Robot.from_catalog("abb_irb2600"))
    sim = simulate_tracker(robot, 30, seed=2, noise_mm=0.0)  # was: "the pose set is degenerate"
    assert register_frame(robot, sim.data).rms < 2e-3  # m: the nominal model, the truth's errors left
