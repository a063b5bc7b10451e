"""Flush contacts (a flat tool face pressed onto a plane: its height and two tilts): Jacobian,
plane fit, simulation, recovery of known errors, blind spots, files, errors and the command line."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from jacobian_check import assert_columns_match
from scipy.spatial.transform import Rotation

from robocal import DataError, IdentificationError, Robot
from robocal.calibration.evaluation import evaluate
from robocal.calibration.pipeline import calibrate
from robocal.cli import main
from robocal.data.kinds import FLUSH_TILT_LENGTH_M, OBSERVED
from robocal.data.measurements import Measurements, parse_csv
from robocal.data.registration import umeyama
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.identify.observations.flush import FlushObservation, not_observable
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

IRB = Robot.from_catalog("abb_irb2600")
TILT_ERROR_RAD = np.array([2e-3, -1.5e-3, 0.0])  # the face mounted tilted on the flange (start model)


def flush_campaign(n: int, n_planes: int, noise_mm: float, seed: int):
    """Flush contacts of a perturbed IRB 2600 on random planes, and the nominal model a user
    starts from: the face's centre known (the drawing's tool translation), its normal tilted by
    TILT_ERROR_RAD (rad, flange axes) from the truth's."""
    sim = simulate_tracker(IRB, n, kind="flush", n_planes=n_planes, seed=seed, noise_mm=noise_mm)
    tool = sim.truth.tool.copy()
    tool[:3, :3] = rotvec_to_matrix(TILT_ERROR_RAD) @ tool[:3, :3]
    return sim, replace(IRB, tool=tool, nominal=None)


def orientation_spread_mdeg(model, truth, q) -> float:
    """RMS flange-orientation error (mdeg) of ``model`` against ``truth`` at joints ``q`` after
    the best rigid fit of the positions (the base frame, which contacts cannot see)."""
    A, B = model.fk(q), truth.fk(q)
    R = umeyama(A[:, :3, 3], B[:, :3, 3])[:3, :3]
    err = Rotation.from_matrix(np.swapaxes(B[:, :3, :3], 1, 2) @ (R @ A[:, :3, :3])).as_rotvec()
    return float(np.sqrt(np.mean(np.sum((err - err.mean(axis=0)) ** 2, axis=1)))) * 180e3 / np.pi


def test_jacobian_matches_finite_differences():
    """Every column (links, the tool's tilt and spin, joint zeros, the plane coefficients) against
    central differences, at a face whose normal is along no flange axis and contacts that are not
    flush (so every term of the residuals' derivatives is exercised)."""
    rng = np.random.default_rng(0)
    tool = make_transform(rotvec_to_matrix(np.array([0.3, -0.2, 0.1])), np.array([0.02, -0.01, 0.09]))
    sim = simulate_tracker(IRB.with_frames(tool=tool), 24, kind="flush", n_planes=3, seed=0, noise_mm=0.05)
    robot = IRB.with_frames(tool=sim.truth.tool)
    problem = CalibrationProblem(robot, sim.data)
    state = problem.start(robot)
    state = replace(state, nuisance=state.nuisance + rng.normal(0, 0.02, state.nuisance.size))
    names = ("alpha2", "a2", "theta3", "d4", "beta3", "a6", "theta6", "tool.x", "tool.rx", "tool.ry",
             "tool.rz")
    space = ParameterSpace(names, tuple(problem.nuisance_names))
    assert_columns_match(problem, state, space, problem.jacobian(state, space), len(names))


def test_plane_fit_is_the_least_squares_optimum_and_the_profiled_cost():
    sim, nominal = flush_campaign(45, 3, 0.01, seed=4)
    obs = CalibrationProblem(nominal, sim.data).observation
    coef = obs.nuisance_start(nominal)
    gradient = obs.jacobian(nominal, [], coef).T @ obs.residuals(nominal, coef)
    assert np.abs(gradient).max() < 1e-14  # the planes minimise the three rows' sum of squares
    names = ["a2", "d4", "tool.ry"]
    X = np.random.default_rng(1).normal(0, 1e-4, (5, 3))
    r, fitted = obs.profiled_residuals_batch(nominal, names, X)
    for p in (0, 4):
        robot = nominal.displaced(names, X[p])
        assert np.allclose(r[p], obs.residuals(robot, fitted[p]), atol=1e-13)
        assert np.allclose(fitted[p], obs.nuisance_start(robot), atol=1e-12)
    assert np.allclose(obs.residuals_batch(nominal, names, X, fitted[2])[2], r[2], atol=1e-13)


def test_simulated_faces_lie_flush_on_the_truths_planes():
    sim = simulate_tracker(IRB, 60, kind="flush", n_planes=3, seed=8, noise_mm=0.0)
    assert evaluate(sim.truth, sim.data)["max"] < 1e-9 and sim.noise_floor_mm == 0.0
    T = sim.truth.fk(sim.true_joints)
    n, c = sim.planes[sim.data.plane, :3], sim.planes[sim.data.plane, 3]
    assert np.abs(np.einsum("ni,ni->n", n, T[:, :3, 3]) - c).max() < 1e-12
    assert np.abs(np.einsum("ni,ni->n", n, T[:, :3, 2]) - 1).max() < 1e-12  # the face normal along n
    assert np.bincount(sim.data.plane).tolist() == [20, 20, 20]
    noisy = simulate_tracker(IRB, 300, kind="flush", n_planes=3, seed=8, noise_mm=0.01)
    T = noisy.truth.fk(noisy.true_joints)
    n, c = noisy.planes[noisy.data.plane, :3], noisy.planes[noisy.data.plane, 3]
    height = np.einsum("ni,ni->n", n, T[:, :3, 3]) - c
    tilt = np.arccos(np.clip(np.einsum("ni,ni->n", n, T[:, :3, 2]), -1, 1))
    assert 0.008 < height.std() * 1e3 < 0.012  # noise_mm along the normal
    sigma_tilt = 0.01e-3 / FLUSH_TILT_LENGTH_M  # two axes: the tilt's RMS is sqrt(2) sigma
    assert 0.8 < np.sqrt(np.mean(tilt**2)) / (np.sqrt(2) * sigma_tilt) < 1.2
    assert np.isclose(noisy.noise_floor_mm, np.sqrt(np.mean(np.sum(noisy.noise**2, axis=1))) * 1e3)


def test_known_errors_are_recovered_from_flush_contacts():
    """Link errors and a tilted face: the calibration reaches the contact noise on held-out
    contacts, recovers the face's tilt and the arm's orientation kinematics."""
    sim, nominal = flush_campaign(120, 3, 0.005, seed=2)
    cal, val = sim.data.subset(np.arange(90)), sim.data.subset(np.arange(90, 120))
    res = calibrate(nominal, cal, validation=val)
    assert res.solver.success
    rms = res.validation["rms"]  # the held-out contacts judged on the calibration's planes, mm
    assert rms < 1.3 * sim.noise_floor_mm
    assert rms < res.validation_before["rms"] / 30
    tilt_left = Rotation.from_matrix(res.robot.tool[:3, :3] @ sim.truth.tool[:3, :3].T).as_rotvec()
    assert np.linalg.norm(tilt_left[:2]) < 0.05 * np.linalg.norm(TILT_ERROR_RAD)
    q = sample_joints(sim.truth, 300, np.random.default_rng(5))
    before = orientation_spread_mdeg(nominal, sim.truth, q)
    assert orientation_spread_mdeg(res.robot, sim.truth, q) < before / 10
    assert "tool.rx" in res.space.robot and "tool.ry" in res.space.robot  # the tilt is estimated


def test_blind_spots_are_named():
    n = IRB.n_joints
    blind = set(not_observable(IRB))  # the face normal along the flange's z: joint 6's axis
    assert {"tool.x", "tool.y", "tool.z", "tool.rz", f"d{n}", f"a{n}", f"theta{n}", "base.rz", "d4"} <= blind
    # the spherical wrist's d5 moves the face within its plane: its column is round-off, its prior
    # would predict mm over the workspace (the flush residual's Jacobian, the independent check)
    assert f"d{n - 1}" in blind
    sim = simulate_tracker(IRB, 40, kind="flush", n_planes=3, seed=2, noise_mm=0.01)
    model = sim.truth
    obs = FlushObservation(sim.data, model)
    planes = obs.nuisance_start(model)

    def column(name: str, h: float = 1e-6) -> np.ndarray:  # central differences of the residuals
        return (obs.residuals(model.with_values({name: model.get(name) + h}), planes)
                - obs.residuals(model.with_values({name: model.get(name) - h}), planes)) / (2 * h)

    assert np.linalg.norm(column(f"d{n - 1}")) < 2e-3 * np.linalg.norm(column(f"a{n - 2}"))
    skew = IRB.with_values({f"alpha{n}": IRB.get(f"alpha{n}") + 0.1})  # not square: d5 tilts the face
    assert f"d{n - 1}" not in set(not_observable(skew))
    assert not {"tool.rx", "tool.ry", f"alpha{n}"} & blind
    along_x = IRB.with_frames(tool=make_transform(rotvec_to_matrix(np.array([0, np.pi / 2, 0])), np.zeros(3)))
    blind_x = set(not_observable(along_x))  # the face normal along the flange's x
    assert "tool.rx" in blind_x and f"d{n}" in blind_x and not {"tool.rz", f"theta{n}", f"a{n}"} & blind_x
    oblique = IRB.with_frames(tool=make_transform(rotvec_to_matrix(np.array([0.3, 0.2, 0])), np.zeros(3)))
    assert not {"tool.rx", "tool.ry", "tool.rz"} & set(not_observable(oblique))
    sim, nominal = flush_campaign(60, 3, 0.005, seed=3)
    res = calibrate(nominal, sim.data)
    assert not set(not_observable(nominal)) & set(res.space.robot)
    assert any("flush contacts" in w and "tool.rz" in w and "theta6" in w for w in res.warnings)


def test_csv_round_trip_and_its_column(tmp_path):
    sim = simulate_tracker(IRB, 12, kind="flush", n_planes=3, seed=1, noise_mm=0.01)
    data = replace(sim.data, sigma=None)
    path = tmp_path / "flush.csv"
    data.save(path)
    header = [line for line in path.read_text().splitlines() if not line.startswith("#")][0].split(",")
    assert "flush_plane" in header and "plane" not in header
    back = Measurements.load(path, robot=IRB)
    assert back.kind == "flush" and np.array_equal(back.plane, data.plane)
    assert np.array_equal(back.joints, data.joints)
    head = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg"
    assert parse_csv(f"{head},flush_plane\n0,10,20,0,30,0,4\n").kind == "flush"
    for text, match in ((f"{head},flush_plane,plane\n0,0,0,0,0,0,1,1\n", "plane, flush_plane mark different"),
                        (f"{head},flush_plane,x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,1,2,3\n", "flush contacts have"),
                        (f"{head},flush_plane\n0,0,0,0,0,0,1.5\n", "integer"),
                        (f"{head},flush_plane\n0,0,0,0,0,0,-1\n", "plane indices")):
        with pytest.raises(DataError, match=match):
            parse_csv(text)
    assert OBSERVED["flush"].column == "flush_plane" and OBSERVED["flush"].sees_tilt


def test_bad_flush_data_give_clear_errors():
    sim, nominal = flush_campaign(30, 3, 0.0, seed=4)
    data = sim.data
    with pytest.raises(IdentificationError, match="flush contacts .3 residuals each. cannot determine"):
        calibrate(nominal, data.subset(np.arange(9)))
    few = data.subset(np.flatnonzero(data.plane == 0)[:2].tolist() + np.flatnonzero(data.plane > 0).tolist())
    with pytest.raises(IdentificationError, match=r"plane\(s\) \[0\] have only \[2\].*at least 3"):
        CalibrationProblem(nominal, few)
    on_smr = Measurements.from_arrays("flush", data.joints, plane=data.plane, smr=np.ones(len(data), int))
    with pytest.raises(IdentificationError, match="flush contacts use the tool face"):
        CalibrationProblem(nominal, on_smr)
    with pytest.raises(DataError, match="flush measurements need"):
        Measurements.from_arrays("flush", data.joints)
    with pytest.raises(DataError, match=r"flush_plane indices must be >= 0"):  # the CSV column's name
        Measurements.from_arrays("flush", data.joints, plane=-np.ones(len(data), int))
    swapped = data.plane.copy()
    swapped[[4, 7]] = (swapped[[4, 7]] + 1) % 3  # two contacts numbered with the next plane
    with pytest.raises(IdentificationError, match=r"tilted by up to .* on plane\(s\) \[2\] \(rows \[9, 6, "):
        CalibrationProblem(nominal, replace(data, plane=swapped))
    sideways = nominal.with_frames(tool=make_transform(rotvec_to_matrix([0, np.pi / 2, 0]), np.zeros(3)))
    with pytest.raises(IdentificationError, match="face normal is the tool's z axis"):
        CalibrationProblem(sideways, data)  # the face normal given along the flange's x
    plane = Measurements.from_arrays("plane", data.joints[:9], plane=data.plane[:9])
    with pytest.raises(IdentificationError, match="plane0 is in two measurement sets"):
        CalibrationProblem(nominal, [data, plane])


def test_the_command_line_simulates_calibrates_and_evaluates(tmp_path, capsys):
    d = tmp_path
    assert main(["--quiet", "simulate", "--robot", "abb_irb2600", "--poses", "80", "--kind", "flush",
                 "--planes", "3", "--noise-mm", "0.005", "--seed", "6", "-o", str(d / "flush.csv"),
                 "--truth", str(d / "truth.yaml")]) == 0
    side = json.loads((d / "truth.sim.json").read_text())
    assert side["kind"] == "flush" and len(side["planes"]) == 3
    data = Measurements.load(d / "flush.csv")
    data.subset(np.arange(60)).save(d / "cal.csv")
    data.subset(np.arange(60, 80)).save(d / "val.csv")
    capsys.readouterr()
    assert main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--validate",
                 str(d / "val.csv"), "-o", str(d / "cal.yaml")]) == 0
    out = capsys.readouterr().out
    assert "validation flush" in out or "validation set" in out
    assert main(["--quiet", "evaluate", str(d / "cal.yaml"), str(d / "val.csv"), "--json",
                 str(d / "ev.json")]) == 0
    stats = json.loads((d / "ev.json").read_text())
    assert stats["kind"] == "flush" and stats["evaluation"]["rms"] < 2 * side["noise_floor_mm"]
