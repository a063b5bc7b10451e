"""Thermal expansion per link group: the grouping, the FK against independently scaled links, the
Jacobian columns against finite differences, the model file (per-group ks and T_ref; a one-k
file unchanged), the simulated per-group truth, and the calibration and auto on campaigns with
different true ks per group and with one k."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from jacobian_check import assert_columns_match, joint_error_jacobian

from robocal import Robot
from robocal.calibration.model_selection import _term_has_data
from robocal.calibration.pipeline import calibrate
from robocal.cli import main
from robocal.core.errors import DataError, ModelError
from robocal.data.measurements import Measurements
from robocal.data.simulate import simulate_tracker
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics import thermal
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.joint_errors import parse_terms, term_names

KR210 = "kuka_kr210_r2700"
GROUPS = ["thermal", *thermal.GROUP_NAMES]
ALUMINIUM_FOREARM = {"forearm": 23e-6}  # the rest steel (11.5e-6)


def test_link_groups_of_common_arms_a_track_and_a_short_arm():
    six = np.zeros(6, bool)
    assert thermal.link_groups(six).tolist() == [0, 0, 1, 2, 3, 3]  # d1, a1 | a2 | a3, d4 | d5, d6
    assert thermal.link_groups(np.zeros(7, bool)).tolist() == [0, 0, 1, 2, 2, 3, 3]
    assert thermal.link_groups(np.r_[True, six]).tolist() == [-1, 0, 0, 1, 2, 3, 3]  # the track: shared
    assert thermal.link_groups(np.zeros(4, bool)).tolist() == [-1] * 4  # too short: no groups
    assert term_names(6, "thermal_groups") == GROUPS
    assert parse_terms("thermal_groups,payload") == ["thermal_groups", "payload"]


@settings(max_examples=15, deadline=None)
@given(st.lists(st.floats(-30e-6, 30e-6), min_size=5, max_size=5), st.floats(-10.0, 60.0))
def test_each_link_group_scales_its_own_links(values, t):
    robot = Robot.from_catalog(KR210)
    t_ref = 25.0
    warm = robot.with_joint_errors(GROUPS).with_values(dict(zip(GROUPS, values, strict=True)))
    warm = warm.with_reference_temperature(t_ref)
    k = values[0] + np.r_[0.0, values[1:]][np.array([1, 1, 2, 3, 4, 4])]  # shared + the link's group
    s = 1 + k * (t - t_ref)
    scaled = replace(robot, a=robot.a * s, d=robot.d * s)  # written out: link by link
    q = np.random.default_rng(1).uniform(-1.0, 1.0, (4, 6))
    hot = Conditions(temperature=np.full(4, t))
    np.testing.assert_allclose(warm.fk(q, conditions=hot), scaled.fk(q), atol=1e-13)


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_group_columns_match_finite_differences(kind, rng):
    robot = Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 15, kind=kind, noise_mm=0.0, seed=3)
    data = replace(sim.data, temperature=rng.uniform(20.0, 35.0, len(sim.data)))
    names = [*GROUPS, "comp2_3"]
    values = np.array([11.5e-6, 1e-6, -2e-6, 11.5e-6, 3e-6, 4e-4])
    problem, state, space, J = joint_error_jacobian(sim.truth, data, names, values, ("a2", "d1"), 26.0)
    assert np.abs(J[:, 2:]).max(axis=0).min() > 1e-3  # every column moves the TCP
    assert_columns_match(problem, state, space, J, n_geometric=2)
    # the shared k is the sum of the groups' columns (every link of the arm is in a group)
    np.testing.assert_allclose(J[:, 2], J[:, 3:7].sum(axis=1), rtol=1e-9, atol=1e-12)


def test_model_file_saves_the_per_group_ks_and_a_one_k_file_means_the_same(tmp_path):
    robot = Robot.from_catalog(KR210)
    per_group = robot.with_joint_errors(GROUPS).with_values(
        {"thermal": 11.5e-6, "thermal_forearm": 11.5e-6}).with_reference_temperature(27.5)
    per_group.save(tmp_path / "g.yaml")
    text = yaml.safe_load((tmp_path / "g.yaml").read_text())["joint_errors"]
    assert text["thermal_k_per_group"] == pytest.approx(
        {"base": 11.5e-6, "upper_arm": 11.5e-6, "forearm": 23e-6, "wrist": 11.5e-6}, rel=1e-12)
    assert text["reference_temperature_c"] == 27.5
    back = Robot.load(tmp_path / "g.yaml")
    assert back.joint_errors.thermal_groups() == per_group.joint_errors.thermal_groups()
    q, t = np.random.default_rng(2).uniform(-1, 1, (5, 6)), np.linspace(15, 40, 5)
    np.testing.assert_array_equal(back.fk(q, conditions=Conditions(temperature=t)),
                                  per_group.fk(q, conditions=Conditions(temperature=t)))
    # the derived per-group ks must agree with the parameters: an edit there alone is refused
    text["thermal_k_per_group"]["forearm"] = 30e-6
    model = yaml.safe_load((tmp_path / "g.yaml").read_text())
    model["joint_errors"] = text
    (tmp_path / "edited.yaml").write_text(yaml.safe_dump(model))
    with pytest.raises(ModelError, match="derived from them"):
        Robot.load(tmp_path / "edited.yaml")
    # a file of one k (as written before the groups) loads and scales every link by it
    one = robot.with_joint_errors(["thermal"]).with_values({"thermal": 11.5e-6})
    one = one.with_reference_temperature(22.0)
    one.save(tmp_path / "one.yaml")
    assert "thermal_k_per_group" not in (tmp_path / "one.yaml").read_text()
    loaded = Robot.load(tmp_path / "one.yaml")
    assert loaded.joint_errors.thermal_groups() is None
    s = 1 + 11.5e-6 * (t - 22.0)[:, None]
    for i in range(5):
        scaled = replace(robot, a=robot.a * s[i], d=robot.d * s[i])
        row = Conditions(temperature=t[i:i + 1])
        np.testing.assert_allclose(loaded.fk(q[i:i + 1], conditions=row), scaled.fk(q[i:i + 1]), atol=1e-13)


def test_simulated_per_group_truth_is_reproduced_by_the_fitted_terms():
    robot = Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 30, noise_mm=0.0, seed=5, temperatures=(20, 35),
                           thermal_k=ALUMINIUM_FOREARM, payloads=[0, 100])
    d = sim.data
    assert sim.truth.joint_errors.thermal_groups() == pytest.approx(
        {"base": 11.5e-6, "upper_arm": 11.5e-6, "forearm": 23e-6, "wrist": 11.5e-6})
    p = sim.truth.fk(d.joints, smr=d.smr, conditions=d.conditions)[:, :3, 3]
    np.testing.assert_allclose(p, d.points, rtol=0, atol=1e-9)
    one = simulate_tracker(robot, 30, noise_mm=0.0, seed=5, temperatures=(20, 35), thermal_k=11.5e-6)
    assert one.truth.joint_errors.thermal_groups() is None and one.truth.joint_errors.thermal_k() == 11.5e-6
    for bad, match in (({"elbow": 1e-5}, "unknown link group"), (2e-3, "not plausible")):
        with pytest.raises(DataError, match=match):
            simulate_tracker(robot, 5, temperatures=(20, 30), thermal_k=bad)
    with pytest.raises(DataError, match="needs temperatures"):
        simulate_tracker(robot, 5, thermal_k=1e-5)
    with pytest.raises(DataError, match="carries its own thermal expansion"):
        simulate_tracker(sim.truth, 5, as_is=True, temperatures=(20, 30), thermal_k=1e-5)


def test_simulate_cli_thermal_k(tmp_path, capsys):
    out, truth = tmp_path / "warm.csv", tmp_path / "truth.yaml"
    assert main(["--quiet", "simulate", "--robot", KR210, "--poses", "10", "--temperatures", "20:35",
                 "--thermal-k", "forearm=23e-6,all=12e-6", "-o", str(out), "--truth", str(truth)]) == 0
    assert Robot.load(truth).joint_errors.thermal_groups() == pytest.approx(
        {"base": 12e-6, "upper_arm": 12e-6, "forearm": 23e-6, "wrist": 12e-6})
    capsys.readouterr()
    with pytest.raises(SystemExit) as bad:  # argparse's one line, exit 2
        main(["simulate", "--robot", KR210, "--poses", "10", "--temperatures", "20:35",
              "--thermal-k", "forearm:23e-6", "-o", str(out), "--truth", str(truth)])
    assert bad.value.code == 2 and "GROUP=K" in capsys.readouterr().err
    assert main(["simulate", "--robot", KR210, "--poses", "10", "--temperatures", "20:35",
                 "--thermal-k", "elbow=2e-5", "-o", str(out), "--truth", str(truth)]) == 2
    assert "unknown link group" in capsys.readouterr().err


def _campaign(thermal_k, seed=1, n=200):
    robot = Robot.from_catalog(KR210)
    cal = simulate_tracker(robot, n, noise_mm=0.02, seed=seed, temperatures=(20, 35), thermal_k=thermal_k)
    held = simulate_tracker(cal.truth, 60, noise_mm=0.02, seed=seed + 100, as_is=True, temperatures=(35, 35))
    return robot, cal, held


def test_per_group_ks_are_identified_and_beat_one_k_on_an_aluminium_forearm():
    robot, cal, held = _campaign(ALUMINIUM_FOREARM)
    one = calibrate(robot, cal.data, validation=held.data, nongeometric="thermal")
    groups = calibrate(robot, cal.data, validation=held.data, nongeometric="thermal_groups")
    k = groups.robot.joint_errors.thermal_groups()
    assert k["forearm"] == pytest.approx(23e-6, rel=0.1) and k["upper_arm"] == pytest.approx(11.5e-6, rel=0.1)
    floor = held.noise_floor_mm
    assert groups.validation["rms"] <= 1.15 * floor < 1.5 * floor < one.validation["rms"]
    rows = groups.to_dict()["thermal_groups"]
    assert [r["group"] for r in rows] == list(thermal.GROUPS)
    assert {r["source"] for r in rows} <= {"own", "shared"} and "own" in {r["source"] for r in rows}
    assert "thermal expansion per link group" in groups.summary()
    assert "thermal_groups" not in one.to_dict()


def test_auto_keeps_one_k_when_the_arm_has_one_and_tries_groups_only_over_a_wide_span():
    robot, cal, held = _campaign(None, seed=2)
    ms = calibrate(robot, cal.data, nongeometric="auto").model_selection
    tried = [tuple(c["terms"]) for c in ms["candidates"]]
    assert ("thermal", "thermal_groups") in tried and ("thermal_groups",) not in tried
    assert "thermal" in ms["chosen_terms"] and "thermal_groups" not in ms["chosen_terms"]
    narrow = replace(cal.data, temperature=20.0 + (cal.data.temperature - 20.0) / 5)  # a 3 K span
    assert _term_has_data("thermal", narrow) and not _term_has_data("thermal_groups", narrow)
    assert not _term_has_data("thermal_groups", replace(cal.data, temperature=None))
    # a 4-axis arm: no link groups
    four = Measurements.from_arrays("point", cal.data.joints[:, :4], points=cal.data.points,
                                    conditions=Conditions(temperature=cal.data.temperature))
    assert _term_has_data("thermal", four) and not _term_has_data("thermal_groups", four)


def test_a_group_the_data_do_not_determine_falls_back_to_the_shared_k():
    robot = Robot.from_catalog(KR210)  # a short, noisy campaign over 6 K: the wrist's 215 mm is not seen
    cal = simulate_tracker(robot, 60, noise_mm=0.05, seed=4, temperatures=(20, 26),
                           thermal_k=ALUMINIUM_FOREARM)
    result = calibrate(robot, cal.data, nongeometric="thermal_groups")
    out = result.to_dict()
    rows = {r["group"]: r for r in out["thermal_groups"]}
    assert rows["forearm"]["source"] == "own" and rows["wrist"]["source"] == "shared"
    shared_k = result.robot.joint_errors.thermal_k()
    assert all(r["k_per_K"] == shared_k for r in rows.values() if r["source"] == "shared")
    dropped = {d["name"]: d["reason"] for d in out["dropped"]}
    assert "thermal" not in dropped  # of the redundant set a deviation is set aside, not the shared k
    assert dropped["thermal_wrist"].startswith("not determined by these data")


def test_link_length_columns_at_a_temperature_are_exact(rng):
    """With only thermal terms (no joint-error basis depending on the links) every column of the
    link lengths at a recorded temperature matches finite differences to rounding."""
    robot = Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 12, noise_mm=0.0, seed=7)
    data = replace(sim.data, temperature=rng.uniform(0.0, 60.0, len(sim.data)))
    truth = sim.truth.with_joint_errors(GROUPS).with_values({"thermal": 23e-6, "thermal_forearm": 60e-6})
    truth = truth.with_reference_temperature(20.0)
    problem = CalibrationProblem(truth, data)
    space = ParameterSpace(("a2", "a3", "d1", "d4", "d6"))
    state = problem.start(truth)
    J = problem.jacobian(state, space)
    for c in range(space.size):
        e = np.zeros(space.size)
        e[c] = 1e-6
        fd = -(problem.residuals(space.apply(state, e)) - problem.residuals(space.apply(state, -e))) / 2e-6
        np.testing.assert_allclose(J[:, c], fd, rtol=1e-7, atol=1e-9)
