"""Non-geometric terms: analytic columns vs finite differences, fk/YAML round trip, simulated
truth with injected compliance, gear and backlash errors, the residual model, real data."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from jacobian_check import central_difference, joint_error_jacobian
from robots import require_datasets

from robocal import Robot
from robocal.calibration.pipeline import calibrate
from robocal.core.errors import IdentificationError, ModelError
from robocal.data.simulate import simulate_tracker
from robocal.identify.problem import CalibrationProblem
from robocal.identify.residual import ResidualModel
from robocal.identify.space import ParameterSpace, State
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.joint_errors import JointErrorModel, parse_terms, term_names

NAMES = ["comp2_3", "comp2_6", "comp3_6", "comp5_6", "gear1_s1", "gear2_c1", "gear3_s2", "gear5_c2",
         "backlash1", "backlash2", "backlash4"]
VALUES = np.array([4e-4, 3e-4, 5e-4, 2e-3, 2e-4, -1.5e-4, 1e-4, -2e-4, 2e-4, -1.5e-4, 3e-4])


def _robot_with_errors():
    robot = Robot.from_catalog("abb_irb2600")
    return replace(robot, joint_errors=JointErrorModel(tuple(NAMES), VALUES))


def test_fk_applies_joint_offsets_and_yaml_round_trips(tmp_path, rng):
    robot = _robot_with_errors()
    q = rng.uniform(-1.5, 1.5, (20, 6))
    dq = robot.joint_errors.offsets(robot, q)
    plain = replace(robot, joint_errors=None)
    assert np.allclose(robot.fk(q), plain.fk(q + dq))
    # gear terms by hand; backlash only acts with approach directions
    assert np.allclose(dq[:, 0], 2e-4 * np.sin(q[:, 0]))
    s = np.sign(rng.normal(size=q.shape)).astype(int)
    assert np.allclose(robot.joint_errors.offsets(robot, q, Conditions(s))[:, 0] - dq[:, 0], 2e-4 * s[:, 0])
    assert np.allclose(robot.fk(q, conditions=Conditions(s)),
                       plain.fk(q + robot.joint_errors.offsets(robot, q, Conditions(s))))
    robot.save(tmp_path / "m.yaml")
    back = Robot.load(tmp_path / "m.yaml")
    assert back.joint_errors.names == robot.joint_errors.names
    assert np.array_equal(back.joint_errors.values, VALUES)
    assert np.array_equal(back.fk(q), robot.fk(q))
    assert back.nominal_robot().joint_errors is None
    with pytest.raises(ModelError, match="comp"):
        JointErrorModel.from_dict({"parameters": {"comp3_2": 1.0}}, 6)


def test_compliance_torque_is_zero_about_a_vertical_axis(rng):
    robot = Robot.from_catalog("abb_irb2600")
    q = rng.uniform(-1.5, 1.5, (10, 6))
    model = JointErrorModel(tuple(term_names(6, "compliance")), np.ones(15))
    assert np.allclose(model.offsets(robot, q)[:, 0], 0.0, atol=1e-12)  # joint 1 is vertical


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_jacobian_columns_match_finite_differences(kind):
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 15, kind=kind, noise_mm=0.0, seed=3)
    # pose rows differentiate the rotation-vector error exactly only at zero error
    values = 0.5 * VALUES if kind == "point" else 1e-6 * VALUES
    geometric = ("a2", "theta3", "d4")
    problem, state, space, J = joint_error_jacobian(sim.truth, sim.data, NAMES, values, geometric)
    h = 1e-7
    for c in range(3, space.size):
        fd = central_difference(problem, state, space, c, h)
        assert np.allclose(J[:, c], fd, rtol=1e-5, atol=1e-7)


def test_population_residuals_of_joint_error_displacements_equal_one_at_a_time(rng):
    """batch_tcp's joint errors (basis kept per robot) give the residuals of each displaced robot."""
    names = ["comp2_3", "gear2_s1", "backlash2", "travel3", "cyc4_50_c"]
    start = Robot.from_catalog("abb_irb2600").with_joint_errors(names)
    problem = CalibrationProblem(start, simulate_tracker(start, 20, noise_mm=0.0, seed=4).data)
    space = ParameterSpace((*names, "a3"))  # a3 not displaced: the compliance basis moves with it
    other = start.displaced([*names, "a3"], [2e-3, 1e-3, -2e-4, 1e-3, 5e-5, 0.05])
    for robot in (start, other, start):
        X = rng.normal(0.0, 1e-3, (4, space.size)) * np.r_[np.ones(len(names)), 0.0]
        r, _ = problem.profiled_residuals_batch(robot, space.robot, X)
        for x, rx in zip(X, r, strict=True):
            one = problem.residuals(State(robot.displaced(space.robot, x), np.zeros(0)))
            np.testing.assert_allclose(rx, one, rtol=0, atol=1e-13)


def test_simulated_truth_reaches_noise_floor_only_with_the_terms():
    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(_robot_with_errors(), 240, noise_mm=0.02, n_smr=2, seed=7)
    cal, val = sim.data.split_poses(0.5, seed=1)
    plain = calibrate(robot, cal, validation=val, nongeometric=None)
    full = calibrate(robot, cal, validation=val, nongeometric="compliance,gear,backlash")
    floor = sim.noise_floor_mm
    assert full.validation["rms"] <= 1.1 * floor
    assert plain.validation["rms"] >= 2.0 * full.validation["rms"]
    assert full.nongeometric["terms"] == ["compliance", "gear", "backlash"]
    assert {"comp3_6", "gear1_s1", "backlash1", "backlash4"} <= set(full.nongeometric["kept"])
    est = dict(zip(full.nongeometric["kept"], full.robot.joint_errors.values, strict=True))
    assert est["backlash1"] == pytest.approx(2e-4, abs=2e-5)
    assert est["backlash4"] == pytest.approx(3e-4, abs=3e-5)
    assert not any(nm.startswith("comp1_") for nm in full.nongeometric["kept"])
    assert full.robot.joint_errors is not None and "nongeometric" in full.to_dict()
    with pytest.raises(IdentificationError, match="unknown non-geometric"):
        parse_terms("compliance,friction")


@pytest.mark.slow
def test_residual_model_learns_a_smooth_field_and_refuses_noise(tmp_path, rng):
    q = rng.uniform(-2, 2, (160, 6))
    smr = np.zeros(160, int)
    pose = np.arange(160)
    field = 1e-4 * np.stack([np.sin(q[:, 1]), np.cos(q[:, 2]), np.sin(q[:, 1] + q[:, 2])], axis=1)
    noise = rng.normal(0, 1e-6, (160, 3))
    model = ResidualModel.fit(q[:120], smr[:120], pose[:120], field[:120] + noise[:120])
    err = field[120:] - model.predict(q[120:], smr[120:])
    assert np.sqrt(np.mean(err**2)) < 0.2 * np.sqrt(np.mean(field[120:] ** 2))
    pure = ResidualModel.fit(q, smr, pose, rng.normal(0, 1e-5, (160, 3)))
    assert np.allclose(pure.predict(q, smr), 0.0) or pure.cv_rms_mm <= pure.zero_rms_mm
    for suffix in (".npz", ".json"):
        model.save(tmp_path / f"r{suffix}")
        back = ResidualModel.load(tmp_path / f"r{suffix}")
        assert np.allclose(back.predict(q, smr), model.predict(q, smr))


def test_real_meca500_no_worse_with_the_terms():
    ds = require_datasets() / "meca500-faro"
    from robocal.data.importer import import_tracker

    cal, val = (import_tracker(sorted(ds.glob(f"{p}_data__*_Output.csv")), joints="cols=0-5:deg",
                               points="cols=6-8:m").data for p in ("cal", "val"))
    robot = Robot.from_catalog("meca500")
    plain = calibrate(robot, cal, validation=val, nongeometric=None)
    full = calibrate(robot, cal, validation=val, nongeometric="compliance,gear")
    assert full.validation["rms"] <= plain.validation["rms"]


def test_real_irb120_and_meca500_reach_the_goals_with_backlash():
    """Issue goals: IRB 120 held-out RMS <= 0.45 mm, Meca500 <= 0.040 mm (geometric: 0.596, 0.043)."""
    from robocal.data.datasets import irb120, meca500

    root = require_datasets()
    terms = "compliance,gear,backlash"
    cal, val = irb120(root)
    res = calibrate(Robot.from_catalog("abb_irb120"), cal, validation=val, nongeometric=terms)
    assert res.validation["rms"] <= 0.45
    cal, val = meca500(root)
    res = calibrate(Robot.from_catalog("meca500"), cal, validation=val, nongeometric=terms)
    assert res.validation["rms"] <= 0.040


def test_jacobian_of_a_robot_with_joint_errors_matches_finite_differences(rng):
    """Robot.jacobian differentiates the FK the robot applies, joint errors and backlash included."""
    errors = JointErrorModel(("gear2_s1", "gear3_c1", "backlash5"), np.array([0.01, -0.02, 0.003]))
    robot = replace(Robot.from_catalog("abb_irb2600"), joint_errors=errors)
    q = rng.uniform(-1.5, 1.5, (8, 6))
    s = np.sign(rng.normal(size=q.shape)).astype(int)
    names = ["a2", "theta3", "d4", "alpha5", "tool.x"]
    J = robot.jacobian(q, names, conditions=Conditions(s))
    h = 1e-7
    for k in range(len(names)):
        e = np.zeros(len(names))
        e[k] = h
        fd = (robot.displaced(names, e).fk(q, conditions=Conditions(s))[:, :3, 3]
              - robot.displaced(names, -e).fk(q, conditions=Conditions(s))[:, :3, 3]) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-8)
