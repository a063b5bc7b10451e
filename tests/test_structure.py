"""The shared structure: the parameter space, the one damped least-squares loop, the one solver
result, the OPW form a robot says it has, immutable models and data, atomic output sets."""

from __future__ import annotations

import pickle
from dataclasses import FrozenInstanceError, replace

import numpy as np
import pytest

import robocal as rc
from robocal.core.damped_least_squares import DAMPING_FACTOR, DAMPING_MAX, DAMPING_START, Status, minimize
from robocal.core.errors import DataError, IdentificationError, ModelError
from robocal.core.io import write_all
from robocal.data.simulate import perturbed, simulate_tracker
from robocal.identify.problem import CalibrationProblem
from robocal.identify.solvers import SOLVERS, SolverResult
from robocal.identify.space import ParameterSpace, block_of


def test_parameter_space_declares_every_block_and_moves_states():
    robot = rc.Robot.from_catalog("abb_irb2600").with_joint_errors(["gear2_s1", "backlash3"])
    sim = simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 40, kind="plane", n_planes=2, seed=1)
    problem = CalibrationProblem(robot, sim.data)
    space = problem.space(robot, ["a2", "base.x", "tool.z", "gear2_s1"])
    assert space.blocks() == {"links": ["a2"], "base": ["base.x"], "tool": ["tool.z"],
                              "joint_errors": ["gear2_s1"],
                              "nuisance": ["plane0.a", "plane0.b", "plane0.c", "plane1.a", "plane1.b",
                                           "plane1.c"]}
    state = problem.start(robot)
    step = np.arange(1, space.size + 1) * 1e-4
    moved = space.apply(state, step)
    assert moved.robot.get("a2") == pytest.approx(robot.get("a2") + 1e-4)
    assert moved.robot.get("gear2_s1") == pytest.approx(4e-4)
    assert np.allclose(moved.nuisance - state.nuisance, step[4:])
    assert [block_of(n) for n in ("beta3", "smr2.y", "comp2_5", "backlash6", "plane12.c")] == \
        ["links", "smr", "joint_errors", "joint_errors", "nuisance"]
    with pytest.raises(IdentificationError, match="named twice"):
        ParameterSpace(("a2", "a2"))
    with pytest.raises(IdentificationError, match="not robot parameters"):
        ParameterSpace(("plane0.a",))


class _Quadratics:
    """Members i minimise (x - t_i)^2 / 2 from x = 0 (exact Newton steps)."""

    def __init__(self, targets, broken=()):
        self.t = np.asarray(targets, float)
        self.size = self.t.size
        self.x = np.zeros(self.size)
        self.broken = set(broken)  # members whose trial cost never decreases (a stall)
        self.trials = np.zeros(self.size, int)  # trial points evaluated per member

    def cost(self):
        return 0.5 * (self.x - self.t) ** 2

    def linearize(self, m):
        pass

    def propose(self, m, damping):
        self.step = np.zeros(self.size)
        self.step[m] = (self.t[m] - self.x[m]) / (1.0 + damping)
        return self.cost()[m] - 0.5 * (self.x[m] + self.step[m] - self.t[m]) ** 2

    def converged(self, m, predicted):
        return np.abs(self.x[m] - self.t[m]) < 1e-12

    def trial_cost(self, m):
        self.trials[m] += 1
        new = 0.5 * (self.x[m] + self.step[m] - self.t[m]) ** 2
        return np.where([i in self.broken for i in m], np.inf, new)

    def accept(self, m):
        self.x[m] += self.step[m]


def test_damped_loop_converges_stalls_and_counts_per_member():
    problem = _Quadratics([1.0, -2.0, 0.0, 3.0], broken=[3])
    out = minimize(problem, max_iter=50)
    assert list(out.status) == [Status.CONVERGED, Status.CONVERGED, Status.CONVERGED, Status.STALLED]
    assert np.allclose(problem.x[:3], [1.0, -2.0, 0.0]) and problem.x[3] == 0.0
    assert out.nit[2] == 0 and out.nit[0] >= 1
    limited = minimize(_Quadratics([1.0]), max_iter=1)
    assert limited.status[0] == Status.MAX_ITERATIONS and limited.nit[0] == 1
    # the broken member gives up once its damping passes DAMPING_MAX, not before or after
    damping, rejected = DAMPING_START, 0
    while damping <= DAMPING_MAX:
        damping *= DAMPING_FACTOR
        rejected += 1
    assert problem.trials[3] == rejected


def test_every_method_returns_the_same_result_type():
    robot = rc.Robot.from_catalog("abb_irb2600")
    data = simulate_tracker(robot, 40, noise_mm=0.01, seed=2).data
    options = {"genetic": {"generations": 3, "population": 8}, "swarm": {"iterations": 3, "particles": 8},
               "neural": {"epochs": 5}}
    for method in SOLVERS:
        res = rc.calibrate(robot, data, method=method, **options.get(method, {}))
        out = res.solver
        assert isinstance(out, SolverResult) and isinstance(out.status, Status)
        assert out.success == (out.status in (Status.CONVERGED, Status.THRESHOLD))
        assert all(set(h) == {"iteration", "cost", "rms"} for h in out.history)
        assert all(isinstance(h["iteration"], int) for h in out.history)
        assert (out.network is not None) == (method == "neural")
        assert (out.item_weights is not None) == (method == "robust")
    limited = rc.calibrate(robot, data, method="genetic", generations=3, population=8).solver
    assert limited.status == Status.MAX_ITERATIONS and not limited.success
    assert "stopped at the generation limit" in limited.message


def test_a_robot_says_whether_it_keeps_its_opw_form():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    assert nominal.has_opw_form and nominal.with_frames(base=np.eye(4)).has_opw_form
    calibrated = perturbed(nominal, 1)
    assert calibrated.opw == nominal.opw and not calibrated.has_opw_form
    assert calibrated.nominal_robot().has_opw_form
    assert not nominal.with_joint_errors(["gear1_s1"]).has_opw_form
    T = nominal.fk(np.zeros((1, 6)))
    with pytest.raises(ModelError, match="no longer follows its nominal OPW form"):
        rc.ik.solve_all(calibrated, T)
    assert rc.ik.solve(calibrated, T).converged.all()  # numeric IK, seeded by the nominal form
    assert not rc.Robot.from_catalog("ur5").has_opw_form
    # computed once per model (cached): copies made by replace/pickle recompute or keep the right one
    assert pickle.loads(pickle.dumps(nominal)).has_opw_form
    assert not pickle.loads(pickle.dumps(calibrated)).has_opw_form
    assert replace(calibrated, **nominal.links._asdict()).has_opw_form
    with pytest.raises(FrozenInstanceError):
        nominal.has_opw_form = False


def test_models_and_measurements_are_immutable(rng):
    robot = rc.Robot.from_catalog("meca500").with_joint_errors(["gear1_s1"])
    for f in ("alpha", "a", "beta", "theta", "d", "base", "tool", "limits", "parallel", "nominal", "smr"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(robot, f)[0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        robot.joint_errors.values[0] = 1.0
    q = rng.uniform(-1, 1, (5, 6))
    data = rc.Measurements.from_arrays("point", q, points=rng.normal(size=(5, 3)))
    q[0, 0] = 99.0  # the caller's array stays the caller's
    assert data.joints[0, 0] != 99.0
    for f in ("joints", "points", "pose_id", "smr", "source_row", "approach"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(data, f)[0] = 0


def test_output_sets_are_written_all_or_none(tmp_path):
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_text("old a")
    write_all({a: "new a", b: b"new b"})
    assert a.read_text() == "new a" and b.read_bytes() == b"new b"
    locked = tmp_path / "locked.txt"
    locked.write_text("keep")
    locked.chmod(0o444)  # read-only (also when running as root, who could write it)
    with pytest.raises(DataError, match="read-only"):
        write_all({a: "newer a", locked: "x"})
    assert a.read_text() == "new a" and locked.read_text() == "keep"
    with pytest.raises(DataError, match="does not exist"):
        write_all({a: "newer a", tmp_path / "missing" / "c.txt": "x"})
    assert a.read_text() == "new a"
