"""Several measurement files of different kinds identified together in one problem (issue 17)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from jacobian_check import central_difference
from test_distance import ballbar
from test_plane import tracker_rms_mm

import robocal as rc
from robocal.cli import main
from robocal.core.errors import IdentificationError
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.identify.problem import KIND_SIGMA, CalibrationProblem

ROBOT = rc.Robot.from_catalog("abb_irb2600")


@pytest.fixture(scope="module")
def planes():
    """A plane campaign (3 planes, probe noise 0.01 mm) and its truth; the start model carries the
    probe as taught to 1 mm."""
    sim = simulate_tracker(ROBOT, 90, kind="plane", n_planes=3, noise_mm=0.01, seed=1)
    start = ROBOT.with_frames(tool=sim.truth.tool.round(3))
    return sim, start


def test_combined_jacobian_matches_finite_differences(planes):
    sim, start = planes
    points = simulate_tracker(ROBOT, 12, noise_mm=0.0, seed=5).data
    bar = ballbar(sim.truth, 6, 0.0, seed=3)
    problem = CalibrationProblem(start, [sim.data.subset(np.arange(30)), bar, points])
    space = problem.space(start, ["a2", "theta3", "d4", "beta3", "tool.x", "base.rz"])
    state = problem.start(start)
    J = problem.jacobian(state, space)
    assert J.shape == (30 + 6 + 36, space.size)
    assert np.allclose(problem.sigma, np.repeat([KIND_SIGMA["plane"], KIND_SIGMA["distance"],
                                                 KIND_SIGMA["point"]], [30, 6, 36]))
    h = 1e-7
    for k in range(space.size):
        fd = central_difference(problem, state, space, k, h)
        assert np.allclose(J[:, k], fd, rtol=1e-5, atol=1e-5 * np.abs(J[:, k]).max())


def test_a_file_without_information_changes_nothing():
    """Points alone and points plus a ball bar whose sigma makes it carry no weight give the same
    calibration: the combination adds rows, nothing else."""
    sim = simulate_tracker(ROBOT, 60, noise_mm=0.02, seed=2)
    bar = ballbar(sim.truth, 10, 0.005, seed=4)
    alone = rc.calibrate(ROBOT, sim.data, sigma={"point": 2e-5})
    both = rc.calibrate(ROBOT, [sim.data, bar], sigma={"point": 2e-5, "distance": 0.99})
    assert alone.names == both.names
    np.testing.assert_allclose(both.robot.values, alone.robot.values, atol=1e-9)


def test_a_scale_bar_makes_the_scale_identifiable(planes):
    """Plane contacts cannot see the scale (d4 held); a scale bar's distances can: with them d4 is
    estimated and the probe tip is right up to a rigid motion, not only up to a similarity."""
    sim, start = planes
    cal, val = sim.data.subset(np.arange(60)), sim.data.subset(np.arange(60, 90))
    truth = sim.truth
    bar = ballbar(truth, 8, 0.005, seed=9)  # measured pairs; the scale bar of docs/how-to/planes-scale-bar.md
    alone = rc.calibrate(start, cal, validation=val)
    both = rc.calibrate(start, [cal, bar], validation=val)
    assert "d4" not in alone.names and "d4" in both.names
    assert any("held at their nominal" in w for w in alone.warnings)
    q = sample_joints(truth, 200, np.random.default_rng(7))
    assert tracker_rms_mm(both.robot, truth, q) < 0.05 < tracker_rms_mm(alone.robot, truth, q)
    assert both.validation["rms"] <= 1.35 * 0.01
    files = both.to_dict()["per_file"]
    assert [(f["role"], f["kind"]) for f in files] == [("calibration", "plane"), ("calibration", "distance"),
                                                        ("validation", "plane")]


def test_points_plus_distances_identify_at_least_as_well_as_points():
    sim = simulate_tracker(ROBOT, 300, noise_mm=0.02, seed=6)
    cal, val = sim.data.split_poses(60, seed=0)
    bar = ballbar(sim.truth, 40, 0.005, seed=8)
    q = sample_joints(sim.truth, 200, np.random.default_rng(3))

    def model_error(res):
        err = res.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum(err**2, axis=1))) * 1e3)

    points = rc.calibrate(ROBOT, cal, validation=val)
    both = rc.calibrate(ROBOT, [cal, bar], validation=val)
    assert model_error(both) <= model_error(points) * 1.02
    assert both.validation["rms"] <= points.validation["rms"] * 1.02
    alone = rc.calibrate(ROBOT.with_frames(tool=sim.truth.tool), bar)  # distances alone keep working
    assert not any(n.startswith("base.") for n in alone.names)


def test_robust_weights_each_kind_by_its_own_scale(planes):
    """Outliers in the plane file are rejected by that file's own robust scale; the distance file,
    10x more precise, keeps all its pairs."""
    sim, start = planes
    contacts = sim.data.subset(np.arange(60))
    bar = ballbar(sim.truth, 12, 0.005, seed=10)
    res = rc.calibrate(start, [contacts, bar], method="robust")
    blocks = res.problem.item_blocks()
    assert res.solver.item_weights[blocks[1]].min() > 0
    assert res.solver.success


def test_plane_ids_are_plates_across_files(planes):
    sim, start = planes
    with pytest.raises(IdentificationError, match="plane0 is in two measurement sets"):
        rc.calibrate(start, [sim.data.subset(np.arange(30)), sim.data.subset(np.arange(30, 60))])
    with pytest.raises(IdentificationError, match="sigma for unknown kind"):
        rc.calibrate(start, sim.data, sigma={"planes": 1e-5})


def test_cli_several_files_and_validations(planes, tmp_path):
    sim, start = planes
    start.save(tmp_path / "start.yaml")
    sim.data.subset(np.arange(60)).save(tmp_path / "contacts.csv")
    sim.data.subset(np.arange(60, 90)).save(tmp_path / "held_out.csv")
    ballbar(sim.truth, 8, 0.005, seed=9).save(tmp_path / "bar.csv")
    ballbar(sim.truth, 5, 0.005, seed=11).save(tmp_path / "bar_val.csv")
    assert main(["--quiet", "calibrate", str(tmp_path / "contacts.csv"), str(tmp_path / "bar.csv"),
                 "--robot", str(tmp_path / "start.yaml"), "--sigma", "distance=0.005", "--validate",
                 str(tmp_path / "held_out.csv"), str(tmp_path / "bar_val.csv"), "--json",
                 str(tmp_path / "r.json"), "--report", str(tmp_path / "r.html")]) == 0
    result = json.loads((tmp_path / "r.json").read_text())
    assert [f["kind"] for f in result["data"]["files"]] == ["plane", "distance"]
    assert result["data"]["files"][1]["sigma_mm"] == pytest.approx(0.005)
    assert set(result["per_kind"]) == {"calibration plane", "calibration distance", "validation plane",
                                       "validation distance"}
    assert result["per_kind"]["validation distance"]["rms"] < 0.02
    assert "Per file" in (tmp_path / "r.html").read_text()


def test_simulated_scale_bar_of_a_plane_campaigns_truth(planes, tmp_path):
    """`simulate --kind distance --as-is` on the truth of a plane campaign: placements of a bar whose
    certified length both rows record, the true tips that length plus the noise apart."""
    sim, _ = planes
    bar = simulate_tracker(sim.truth, 8, kind="distance", noise_mm=0.005, bar_length_m=0.5, seed=3,
                           as_is=True)
    tips = sim.truth.fk(bar.data.joints)[:, :3, 3]
    true = np.linalg.norm(tips[0::2] - tips[1::2], axis=1)
    assert np.allclose(bar.data.distance, 0.5) and np.allclose(true - 0.5, bar.noise[0::2, 0], atol=1e-12)
    assert 0.001 < bar.noise_floor_mm < 0.012
    sim.truth.save(tmp_path / "truth.yaml")
    assert main(["--quiet", "simulate", "--robot", str(tmp_path / "truth.yaml"), "--as-is", "--kind",
                 "distance", "--poses", "8", "--noise-mm", "0.005", "--seed", "3", "-o",
                 str(tmp_path / "bar.csv"), "--truth", str(tmp_path / "bar_truth.yaml")]) == 0
    assert np.array_equal(rc.Measurements.load(tmp_path / "bar.csv").joints, bar.data.joints)


def test_joint_error_terms_on_a_combined_problem():
    """Tracker points and a ball bar identify gear and compliance errors together: the terms'
    columns stack like the geometric ones, and the model reaches the truth only with them."""
    names, values = ["gear2_s1", "gear3_c1", "comp2_6"], [2e-4, -1.5e-4, 4e-4]
    true_robot = ROBOT.with_joint_errors(names).with_values(dict(zip(names, values, strict=True)))
    sim = simulate_tracker(true_robot, 80, noise_mm=0.02, seed=9)
    bar = ballbar(sim.truth, 40, 0.005, seed=10)
    q = sample_joints(sim.truth, 200, np.random.default_rng(4))

    def model_error(res):
        err = res.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum(err**2, axis=1))) * 1e3)

    plain = rc.calibrate(ROBOT, [sim.data, bar])
    terms = rc.calibrate(ROBOT, [sim.data, bar], nongeometric="compliance,gear")
    assert plain.model_selection is None and plain.robot.joint_errors is None  # several files: none
    assert terms.nongeometric["terms"] == ["compliance", "gear"]
    sigma = dict(zip(terms.unknowns, terms.sigma, strict=True))
    for name, value in zip(names, values, strict=True):
        assert abs(terms.robot.get(name) - value) < 5 * sigma[name]
    assert model_error(terms) < 0.5 * model_error(plain)
    assert model_error(terms) < 0.02
