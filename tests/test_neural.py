"""Seed-002 BP network: initialisation, save/load without pickle, training lowers the index,
claim-10 compensation reproduces the solver's model."""

from __future__ import annotations

import numpy as np
import pytest

from robocal import Robot
from robocal.calibration.pipeline import calibrate
from robocal.core.errors import DataError, IdentificationError
from robocal.data.simulate import simulate_tracker
from robocal.identify.network import BPNetwork
from robocal.identify.neural import compensate, default_outputs, train
from robocal.identify.problem import CalibrationProblem


@pytest.fixture(scope="module")
def sim():
    return simulate_tracker(Robot.from_catalog("abb_irb2600"), 60, noise_mm=0.02, seed=4)


def test_init_in_unit_interval_and_round_trip(tmp_path, rng):
    net = BPNetwork.init(6, 9, ["a2", "theta3"], rng)
    for f in ("W1", "b1", "W2", "b2"):
        w = getattr(net, f)
        assert ((w > 0) & (w < 1)).all()
    x = rng.normal(size=(5, 6))
    for suffix in (".npz", ".json"):
        net.save(tmp_path / f"n{suffix}")
        back = BPNetwork.load(tmp_path / f"n{suffix}")
        assert back.outputs == net.outputs
        assert np.array_equal(back.parameter_errors(x), net.parameter_errors(x))
    (tmp_path / "bad.json").write_text('{"format": "other"}')
    with pytest.raises(DataError, match="not a robocal BP network"):
        BPNetwork.load(tmp_path / "bad.json")


@pytest.mark.parametrize("index", ["mae", "mse"])
def test_training_lowers_the_index_and_compensation_matches(sim, index):
    robot = Robot.from_catalog("abb_irb2600")
    res = calibrate(robot, sim.data, method="neural", index=index, epochs=300, outputs="all")
    costs = [h["cost"] for h in res.solver.history]
    assert costs[-1] < 0.5 * costs[0]
    assert [h["iteration"] for h in res.solver.history] == list(range(len(costs)))
    problem = CalibrationProblem(res.start, sim.data)
    _, x, _, indices, _ = train(problem, problem.start(res.start), res.solver.network.outputs,
                                index=index, epochs=300)
    assert all(b <= a for a, b in zip(indices, indices[1:], strict=False))  # steps raising E are undone
    assert res.after["rms"] < res.before["rms"]
    comp = compensate(res.solver.network, res.start, x)
    assert np.allclose(comp.values, res.robot.values)


def test_threshold_stops_and_bad_options(sim):
    robot = Robot.from_catalog("abb_irb2600")
    res = calibrate(robot, sim.data, method="neural", epochs=400, threshold=1e3, n_consecutive=3)
    assert res.solver.success and res.solver.status == "threshold" and res.solver.nit == 3
    assert set(res.solver.network.outputs) == set(default_outputs(res.names))
    with pytest.raises(IdentificationError, match="8-10"):
        calibrate(robot, sim.data, method="neural", hidden=4)
