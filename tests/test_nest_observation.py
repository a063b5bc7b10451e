"""SMRs in known nests on a positioner's plate (kind ``nest``): the model point B F(q) E n_s, its
Jacobian against central differences (the plate frame's six parameters seen through the nests),
and the batch residuals against the single ones."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from cells import two_axis_cell
from jacobian_check import assert_columns_match

import robocal as rc
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

NESTS = np.array([[0.2, 0.0, 0.01], [0.0, 0.2, 0.01], [-0.15, -0.15, 0.02]])  # m, plate frame


def _plate_rows(rng, with_errors: bool = False):
    chain = two_axis_cell().positioners["STN1"].chain
    plate = make_transform(rotvec_to_matrix(rng.normal(0, 0.3, 3)), rng.normal(0, 0.05, 3))
    robot = replace(chain, tool=plate, smr=NESTS, nominal=None)
    if with_errors:
        robot = robot.with_values({"a2": 0.0003, "theta2": 0.001, "alpha2": robot.get("alpha2") + 0.0005})
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (12, 2))
    smr = np.tile([1, 2, 3], 4)
    T = robot.fk(q)
    points = np.einsum("nij,nj->ni", T[:, :3, :3], NESTS[smr - 1]) + T[:, :3, 3]
    return robot, rc.Measurements.from_arrays("nest", q, points=points, smr=smr)


def test_model_points_are_the_nests_on_the_plate(rng):
    robot, data = _plate_rows(rng)
    problem = CalibrationProblem(robot, data)
    np.testing.assert_allclose(problem.residuals(problem.start(robot)), 0.0, atol=1e-12)
    # not the flange-frame SMR offsets of Robot.tools_for: those ignore the plate's rotation
    flange_smr = robot.fk(data.joints, smr=data.smr)[:, :3, 3]
    assert np.abs(flange_smr - data.points).max() > 1e-3


def test_jacobian_matches_central_differences(rng, kernels):
    robot, data = _plate_rows(rng, with_errors=True)
    names = robot.default_free(orientation=True)
    names = [n for n in names if not n.startswith("smr")]
    assert {"tool.rx", "tool.ry", "tool.rz", "tool.x"} <= set(names)
    problem = CalibrationProblem(robot, data)
    space = ParameterSpace(tuple(names))
    state = problem.start(robot)
    J = problem.jacobian(state, space)
    assert np.abs(J[:, names.index("tool.rz")]).max() > 0.05  # the plate's turn moves the nests
    assert_columns_match(problem, state, space, J, len(names))


def test_batch_residuals_match(rng):
    robot, data = _plate_rows(rng, with_errors=True)
    names = ["theta2", "d2", "tool.x", "tool.rz", "base.ry"]
    problem = CalibrationProblem(robot, data)
    X = rng.normal(0, 1e-3, (4, len(names)))
    obs = problem.observations[0]
    batch = obs.residuals_batch(robot, names, X)
    for p in range(4):
        np.testing.assert_allclose(batch[p], obs.residuals(robot.displaced(names, X[p])), atol=1e-12)
    assert set(obs.not_observable(robot)) == {f"smr{s}.{c}" for s in (1, 2, 3) for c in "xyz"}


def test_a_derived_kind():
    """Nest rows are made by the cell calibration of a plate's point rows: no file, simulation or
    campaign kind of their own."""
    from robocal.data.kinds import KINDS, OBSERVED

    assert OBSERVED["nest"].derived and "nest" not in KINDS
    with pytest.raises(rc.DataError, match="unknown simulation kind 'nest'"):
        rc.simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 5, kind="nest")
