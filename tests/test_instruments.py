"""Motion capture and cameras as instruments: markers on any link, a camera's board poses (eye-to-hand
and eye-in-hand), variance components of 6-D data, and the instrument registry. Every formula
against an independent truth: central differences, simulated data with known frames and noise."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from jacobian_check import assert_columns_match

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError, IdentificationError
from robocal.data.instruments import INSTRUMENTS, declared, default_method, instrument_spec
from robocal.data.measurements import parse_csv
from robocal.data.registration import umeyama
from robocal.identify.observations.rigid import hand_eye, left_jacobian
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.transforms import make_transform, matrix_to_rotvec, rotvec_to_matrix

ROBOT = rc.Robot.from_catalog("ur10")
GEOMETRY = [n for n in ROBOT.parameter_names if not n.startswith(("base.", "tool.", "smr"))]


def _jacobian_case(data, truth):
    """Problem built on the nominal robot (reference frames from it), judged at ``truth`` with the
    frames fitted there: residuals ~0 and nuisance far from 0 (the left Jacobians act)."""
    problem = CalibrationProblem(ROBOT, data)
    state = problem.start(truth)
    space = ParameterSpace(tuple(GEOMETRY), tuple(problem.nuisance_names))
    return problem, state, space


def test_left_jacobian_against_differences():
    phi, d = np.array([0.4, -1.1, 0.7]), np.array([1e-7, -2e-7, 1.5e-7])
    turn = rotvec_to_matrix(phi + d) @ rotvec_to_matrix(phi).T
    np.testing.assert_allclose(matrix_to_rotvec(turn), left_jacobian(phi) @ d, rtol=1e-6, atol=1e-14)


def test_hand_eye_recovers_both_frames_exactly():
    rng = np.random.default_rng(1)
    A = make_transform(rotvec_to_matrix(rng.normal(size=(20, 3))), rng.normal(size=(20, 3)))
    L = make_transform(rotvec_to_matrix(rng.normal(size=3)), rng.normal(size=3))
    R = make_transform(rotvec_to_matrix(rng.normal(size=3)), rng.normal(size=3))
    L_hat, R_hat = hand_eye(A, L @ A @ R)
    np.testing.assert_allclose(L_hat, L, atol=1e-9)
    np.testing.assert_allclose(R_hat, R, atol=1e-9)
    with pytest.raises(IdentificationError, match="one axis only"):
        turns = make_transform(rotvec_to_matrix(np.outer(np.linspace(0, 2, 10), [0, 0, 1])),
                               rng.normal(size=(10, 3)))
        hand_eye(turns, L @ turns @ R)


@pytest.mark.parametrize("kind,mount", [("eye_to_hand", "cell"), ("eye_in_hand", "flange")])
def test_camera_jacobian_against_central_differences(kind, mount):
    sim = rc.simulate_camera(ROBOT, 12, mount=mount, noise_mm=0.0, noise_deg=0.0, seed=4)
    problem, state, space = _jacobian_case(sim.data, sim.truth)
    assert np.abs(problem.residuals(state)).max() < 1e-9
    assert np.abs(state.nuisance).max() > 1e-4  # the truth's frames differ from the nominal's
    assert_columns_match(problem, state, space, problem.jacobian(state, space), space.size)


def test_marker_jacobian_against_differences_and_zero_beyond_its_link():
    sim = rc.simulate_markers(ROBOT, 10, links=[6, 6, 4, 2], noise_mm=0.0, seed=5)
    problem, state, space = _jacobian_case(sim.data, sim.truth)
    assert np.abs(problem.residuals(state)).max() < 1e-9
    J = problem.jacobian(state, space)
    assert_columns_match(problem, state, space, J, space.size)
    rows = np.repeat(sim.data.link, 3)
    for name in ("alpha3", "a3", "theta3", "d3", "theta5"):  # links beyond 2 do not move a link-2 marker
        assert not J[rows == 2, space.names.index(name)].any()
    assert np.abs(J[rows == 4, space.names.index("theta3")]).max() > 1e-3
    assert not J[rows == 4, space.names.index("theta5")].any()


def test_marker_jacobian_with_a_joint_error_term():
    sim = rc.simulate_markers(ROBOT, 8, links=[6, 3], noise_mm=0.0, seed=6)
    truth = sim.truth.with_joint_errors(["gear2_c1", "gear5_c1"]).with_values(
        {"gear2_c1": 1e-3, "gear5_c1": 2e-3})
    problem = CalibrationProblem(ROBOT, sim.data)
    state = problem.start(truth)
    space = ParameterSpace((*GEOMETRY, "gear2_c1", "gear5_c1"), tuple(problem.nuisance_names))
    J = problem.jacobian(state, space)
    assert_columns_match(problem, state, space, J, space.size)  # steps of 1e-7 rad: a metre of lever
    rows = np.repeat(sim.data.link, 3)
    assert not J[rows == 3, space.names.index("gear5_c1")].any()


@pytest.mark.parametrize("mount", ["cell", "flange"])
def test_camera_and_board_frames_recovered(mount):
    """No robot error: the calibration must give back the simulated camera and board frames."""
    sim = rc.simulate_camera(ROBOT, 40, mount=mount, noise_mm=0.2, noise_deg=0.05, error_scale=0.0, seed=7)
    result = rc.calibrate(ROBOT, sim.data, params=[], method="lsq")
    frames = result.problem.observation.frames(result.state.nuisance)
    camera, board = (frames["camera_on_flange"], frames["board_in_world"]) if mount == "flange" else \
        (frames["camera_in_world"], frames["board_on_flange"])
    truth = {k: np.array(v) for k, v in sim.info["frames"].items()}
    for got, want in ((camera, truth["camera"]), (board, truth["board"])):
        assert np.abs(got[:3, 3] - want[:3, 3]).max() < 0.5e-3  # m: 40 poses of 0.2 mm noise
        turn = np.arccos(np.clip((np.trace(got[:3, :3] @ want[:3, :3].T) - 1) / 2, -1.0, 1.0))
        assert np.rad2deg(turn) < 0.05
    (section,) = result.to_dict()["instrument_frames"]  # the same frames, in mm and a quaternion
    name = "camera_on_flange" if mount == "flange" else "camera_in_world"
    np.testing.assert_allclose(section["frames"][name]["xyz_mm"], camera[:3, 3] * 1e3, atol=1e-9)
    q = section["frames"][name]["quaternion_wxyz"]
    turn = np.array(q[1:]) / np.linalg.norm(q[1:]) * 2 * np.arccos(q[0])
    np.testing.assert_allclose(rotvec_to_matrix(turn), camera[:3, :3], atol=1e-9)
    assert name + ": x, y, z" in result.summary()


def test_camera_calibration_reaches_the_noise_on_held_out_poses():
    sim = rc.simulate_camera(ROBOT, 90, mount="flange", noise_mm=0.3, noise_deg=0.05, seed=8)
    fit, check = sim.data.split_poses(60, seed=0)
    result = rc.calibrate(ROBOT, fit, validation=check)
    floor = 0.3 * np.sqrt(3)  # mm, 3-D RMS of the position noise
    assert result.method == "robust"  # a camera's default
    assert result.validation_before["rms"] > 2 * floor and result.validation["rms"] < 1.3 * floor


def test_two_held_out_camera_poses_are_judged_with_the_calibration_frames():
    sim = rc.simulate_camera(ROBOT, 32, mount="flange", noise_mm=0.3, noise_deg=0.05, seed=12)
    fit, check = sim.data.split_poses(30, seed=0)
    result = rc.calibrate(ROBOT, fit, validation=check, method="lsq")
    assert result.validation["n"] == 2 and result.validation["rms"] < 2.0
    with pytest.raises(IdentificationError, match="2 poses cannot fix a camera's and a board's frames"):
        rc.calibrate(ROBOT, check)


def test_marker_offsets_and_capture_frame_recovered():
    sim = rc.simulate_markers(ROBOT, 40, links=[6, 6, 4, 3], noise_mm=0.05, error_scale=0.0, seed=9)
    result = rc.calibrate(ROBOT, sim.data, params=[], method="lsq")
    offsets = result.state.nuisance[6:].reshape(-1, 3)
    np.testing.assert_allclose(offsets, sim.info["frames"]["markers"], atol=0.1e-3)
    obs = result.problem.observation
    W = obs._split(result.state.nuisance)[0]
    np.testing.assert_allclose(W, np.array(sim.info["frames"]["capture"]), atol=0.2e-3)


def test_markers_on_links_calibrate_the_robot_and_reject_swapped_markers():
    sim = rc.simulate_markers(ROBOT, 60, links=[6, 6, 6, 4], noise_mm=0.1, outliers=0.03, seed=10)
    result = rc.calibrate(ROBOT, sim.data)
    assert result.method == "robust"
    rejected = np.flatnonzero(result.solver.item_weights == 0)
    assert set(sim.outlier_rows) <= set(rejected)
    q = np.random.default_rng(0).uniform(-2, 2, (200, 6))
    _, frames = result.robot.fk(q, frames=True)
    _, true = sim.truth.fk(q, frames=True)
    a, b = frames[:, 6, :3, 3], true[:, 6, :3, 3]  # flange positions, compared after a rigid fit
    T = umeyama(a, b)
    error = np.linalg.norm(a @ T[:3, :3].T + T[:3, 3] - b, axis=1)
    before = np.linalg.norm(ROBOT.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3], axis=1)
    assert np.sqrt(np.mean(error**2)) < 0.25 * np.sqrt(np.mean(before**2))


@pytest.mark.parametrize("noise_mm,noise_deg", [(0.5, 0.2), (0.2, 1.0), (1.0, 0.05)])
def test_variance_components_recover_the_noise(noise_mm, noise_deg):
    sim = rc.simulate_camera(ROBOT, 150, mount="cell", noise_mm=noise_mm, noise_deg=noise_deg, seed=3)
    result = rc.calibrate(ROBOT, sim.data, method="lsq")
    (found,) = result.variance_components
    assert found.settled
    assert found.sigma_m * 1e3 == pytest.approx(noise_mm, rel=0.1)
    assert np.rad2deg(found.sigma_rad) == pytest.approx(noise_deg, rel=0.1)
    assert found.length_scale == pytest.approx(noise_mm * 1e-3 / np.deg2rad(noise_deg), rel=0.15)
    assert "variance components" in result.summary()
    section = result.to_dict()["variance_components"][0]
    assert section["sigma_position_mm"] == pytest.approx(found.sigma_m * 1e3)


def test_noise_beyond_the_camera_s_documented_is_said():
    quiet = rc.simulate_camera(ROBOT, 60, noise_mm=1.0, noise_deg=0.3, seed=5).data
    assert not [w for w in rc.calibrate(ROBOT, quiet, method="lsq").warnings if "scatter about the fit" in w]
    loud = rc.simulate_camera(ROBOT, 60, noise_mm=5.0, noise_deg=0.3, seed=5).data
    said = [w for w in rc.calibrate(ROBOT, loud, method="lsq").warnings if "scatter about the fit" in w]
    assert len(said) == 1 and "position" in said[0] and "rotation" not in said[0]


def test_variance_components_on_demand_for_tracker_poses_and_off():
    sim = rc.simulate_tracker(ROBOT, 60, kind="pose", noise_mm=0.05, rotation_noise_deg=0.01, seed=2)
    assert rc.calibrate(ROBOT, sim.data, nongeometric=None).variance_components == []
    found = rc.calibrate(ROBOT, sim.data, nongeometric=None, variance_components=True).variance_components
    assert len(found) == 1 and found[0].sigma_m * 1e3 == pytest.approx(0.05, rel=0.2)
    cam = rc.simulate_camera(ROBOT, 30, seed=1).data
    assert rc.calibrate(ROBOT, cam, variance_components=False).variance_components == []


def test_instrument_registry_and_validation():
    assert set(INSTRUMENTS) == {"tracker", "mocap", "camera"}
    assert INSTRUMENTS["tracker"].sigma_m < INSTRUMENTS["mocap"].sigma_m < INSTRUMENTS["camera"].sigma_m
    assert all(i.source for i in INSTRUMENTS.values())
    with pytest.raises(DataError, match="unknown instrument 'vicon': use one of tracker, mocap, camera"):
        instrument_spec("vicon")
    q = np.zeros((2, 6))
    with pytest.raises(DataError, match="a mocap does not measure pose rows"):
        rc.Measurements.from_arrays("pose", q, points=np.ones((2, 3)),
                                    rotations=np.tile(np.eye(3), (2, 1, 1)), instrument="mocap")
    data = rc.Measurements.from_arrays("point", q, points=np.ones((2, 3)))
    assert default_method([data]) == "lsq"
    assert default_method(declared([data], "mocap")) == "robust"
    with pytest.raises(DataError, match="declares the instrument 'mocap', not 'camera'"):
        declared(declared([data], "mocap"), "camera")
    from robocal.cli.args import INSTRUMENT_NAMES
    assert tuple(INSTRUMENTS) == INSTRUMENT_NAMES


def test_csv_declares_instrument_kind_and_links():
    cam = rc.simulate_camera(ROBOT, 5, mount="flange", seed=2).data
    back = parse_csv(cam.to_csv())
    assert (back.kind, back.instrument) == ("eye_in_hand", "camera")
    np.testing.assert_allclose(back.points, cam.points, atol=1e-15)
    mocap = rc.simulate_markers(ROBOT, 3, links=[6, 2], seed=2).data
    back = parse_csv(mocap.to_csv())
    assert back.kind == "marker" and back.instrument == "mocap" and back.link.tolist() == mocap.link.tolist()
    text = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,2,3\n"
    assert parse_csv("# instrument: mocap\n" + text).instrument == "mocap"
    with pytest.raises(DataError, match="unknown instrument 'laser'"):
        parse_csv("# instrument: laser\n" + text, "f.csv")
    with pytest.raises(DataError, match="unknown instrument 'laser tracker'"):  # not ignored for its space
        parse_csv("# Instrument: Laser Tracker\n" + text, "f.csv")
    with pytest.raises(DataError, match="'# kind: eye in hand': unknown"):
        parse_csv("# kind: eye in hand\n" + text, "f.csv")
    with pytest.raises(DataError, match="'# kind: eye_in_hand' needs the columns x_mm,y_mm,z_mm and qw..qz"):
        parse_csv("# kind: eye_in_hand\n" + text, "f.csv")
    with pytest.raises(DataError, match="a 'link' column names the link carrying each marker"):
        parse_csv("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,link\n0,0,0,0,0,0,6\n", "f.csv")


def test_marker_rows_are_checked_against_the_robot():
    data = rc.simulate_markers(ROBOT, 4, links=[6, 3], seed=1).data
    with pytest.raises(IdentificationError, match="link 7 does not exist"):
        CalibrationProblem(ROBOT, replace(data, link=np.where(data.link == 6, 7, data.link)))
    with pytest.raises(IdentificationError, match="marker 1 is on two links"):
        CalibrationProblem(ROBOT, replace(data, link=np.where(np.arange(len(data)) == 1, 5, data.link)))
    with pytest.raises(IdentificationError, match="markers on moving links"):
        CalibrationProblem(ROBOT, replace(data, link=np.zeros_like(data.link)))


def test_eye_in_hand_data_taken_for_eye_to_hand_are_refused():
    sim = rc.simulate_camera(ROBOT, 30, mount="flange", noise_mm=0.2, noise_deg=0.05, seed=11)
    wrong = rc.Measurements.from_arrays("eye_to_hand", sim.data.joints, points=sim.data.points,
                                        rotations=sim.data.rotations)
    with pytest.raises(rc.PlausibilityError):
        rc.calibrate(ROBOT, wrong)


def test_cli_simulates_calibrates_and_evaluates_a_camera(tmp_path, capsys):
    data, truth = tmp_path / "cam.csv", tmp_path / "truth.yaml"
    assert main(["simulate", "--robot", "ur10", "--poses", "30", "--kind", "eye_to_hand", "--noise-mm",
                 "0.5", "--rotation-noise-deg", "0.2", "-o", str(data), "--truth", str(truth)]) == 0
    out = tmp_path / "cal.yaml"
    report = tmp_path / "r.html"
    assert main(["calibrate", str(data), "--robot", "ur10", "-o", str(out), "--report", str(report)]) == 0
    assert "6-D noise (variance components)" in report.read_text() and "camera" in report.read_text()
    assert main(["calibrate", str(data), "--robot", "ur10", "--method", "lsq"]) == 0
    text = capsys.readouterr().out
    assert "lsq: " in text and "variance components of" in text
    assert main(["evaluate", str(out), str(data)]) == 0
    assert "eye_to_hand errors" in capsys.readouterr().out
    plain = tmp_path / "points.csv"
    assert main(["simulate", "--robot", "ur10", "--poses", "30", "-o", str(plain), "--truth",
                 str(truth)]) == 0
    assert main(["calibrate", str(plain), "--robot", "ur10", "--instrument", "mocap",
                 "--nongeometric", "none"]) == 0
    with pytest.raises(SystemExit):
        main(["calibrate", str(plain), "--robot", "ur10", "--instrument", "vicon"])
    capsys.readouterr()
    assert main(["calibrate", str(data), "--robot", "ur10", "--instrument", "mocap"]) != 0
    assert "declares the instrument 'camera', not 'mocap'" in capsys.readouterr().err


def test_subsets_and_files_keep_links_and_instrument(tmp_path):
    data = rc.simulate_markers(ROBOT, 6, links=[6, 2], seed=3).data
    first, rest = data.split_poses(3, seed=0)
    assert first.instrument == rest.instrument == "mocap"
    assert first.link.tolist() == [6, 2] * 3 and len(rest) == 6
    path = tmp_path / "m.csv"
    first.save(path)
    back = rc.Measurements.load(path)
    assert back.link.tolist() == first.link.tolist() and back.instrument == "mocap"
    assert data.first_poses(2).link.tolist() == [6, 2, 6, 2]


def test_markers_default_to_the_flange():
    text = ("# kind: marker\nq1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm,smr\n"
            "0,0,0,0,0,0,1,2,3,0\n10,0,0,0,0,0,1,2,3,1\n")
    data = parse_csv(text)
    assert data.kind == "marker" and data.link is None
    assert parse_csv(data.to_csv()).kind == "marker"
    sim = rc.simulate_markers(ROBOT, 20, noise_mm=0.0, seed=4).data  # three markers on the flange
    plain = replace(sim, link=None)
    a, b = (CalibrationProblem(ROBOT, d) for d in (sim, plain))
    np.testing.assert_allclose(a.residuals(a.start(ROBOT)), b.residuals(b.start(ROBOT)), atol=1e-12)


def test_a_fit_that_rejects_every_measurement_says_so():
    """Camera poses without orientation noise: the estimated rotation noise goes to 0 and the robust
    weights reject every pose; the calibration says so (it said 'the data set is empty')."""
    robot = rc.Robot.from_catalog("kuka_kr6_r700")
    sim = rc.simulate_camera(robot, 30, mount="flange", noise_mm=0.02, noise_deg=0.0, seed=0)
    with pytest.raises(IdentificationError, match="rejected every measurement.*lsq method without variance"):
        rc.calibrate(robot, sim.data)
    assert rc.calibrate(robot, sim.data, method="lsq", variance_components=False).after["rms"] < 0.1  # mm


def test_six_d_kinds_share_one_length_scale_rule():
    """Tracker 6-DOF poses and camera poses weigh rotation rows alike and refuse a scale <= 0."""
    from robocal.identify.observations.camera import EyeToHandObservation
    from robocal.identify.observations.pose import PoseObservation

    pose = rc.simulate_tracker(ROBOT, 6, kind="pose", noise_mm=0.0, seed=1).data
    cam = rc.simulate_camera(ROBOT, 6, noise_mm=0.0, noise_deg=0.0, seed=1).data
    for obs in (PoseObservation(pose, ROBOT), EyeToHandObservation(cam, ROBOT)):
        obs.set_length_scale(0.25)
        assert obs.scale.tolist() == [1.0, 1.0, 1.0, 0.25, 0.25, 0.25]
        with pytest.raises(IdentificationError, match=f"length scale of {obs.kind} rows must be positive"):
            obs.set_length_scale(-1.0)
