"""Calibration accuracy (simulated and real data); the plausibility checks on the real data and
on the mistakes they refuse; speed: robocal lsq vs scipy least_squares with a finite-difference
Jacobian on the same residual (what pybotics does) vs pybotics itself, simulated ABB IRB 2600.

``python benchmarks/bench_calibrate.py [accuracy] [plausibility] [speed]`` runs the parts named
(all without arguments)."""

from __future__ import annotations

import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from results import figure, table
from scipy.optimize import least_squares
from timing import best_time, interleaved, kernel_choices

from robocal import RobocalError, Robot
from robocal.calibration.pipeline import calibrate
from robocal.data.registration import register
from robocal.data.simulate import simulate_tracker
from robocal.identify.lsq import gauss_newton
from robocal.identify.plausibility import spread
from robocal.identify.problem import CalibrationProblem
from robocal.kinematics.catalog import catalog_names
from robocal.kinematics.kernels import use_kernels
from robocal.report.metrics import position_stats

SPEED_ROUNDS = {100: 60, 1000: 8}  # poses -> timed rounds (the best of each call is kept)
PYBOTICS_MAX_POSES = 100  # pybotics loops over poses in Python: ~minutes per 100-pose fit
DATASETS = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def _validation_rms(robot, val) -> float:
    return position_stats(val.points - robot.fk(val.joints, smr=val.smr)[:, :3, 3])["rms"]


def solve_problem(nominal, cal, names):
    """The calibration problem, the registered start state and the estimated space every solver
    below starts from."""
    start = register(nominal, cal)
    problem = CalibrationProblem(start, cal)
    return problem, problem.start(start), problem.space(start, names)


def robocal_solve(problem, state0, space):
    """robocal's solve step alone: damped Gauss-Newton with the analytic Jacobian."""
    return gauss_newton(problem, state0, space).state.robot


def scipy_fd(problem, state0, space):
    """scipy.optimize.least_squares, 2-point finite-difference Jacobian, same residual and start."""

    def fun(x):
        return problem.residuals(space.apply(state0, x))

    sol = least_squares(fun, np.zeros(space.size), jac="2-point", method="trf", x_scale="jac",
                        xtol=1e-12, ftol=1e-12)
    return space.apply(state0, sol.x).robot


def pybotics_fit(nominal, cal):
    """pybotics' own accuracy optimisation (plain MDH, per-pose error norms, scipy 'lm')."""
    from pybotics.kinematic_chain import MDHKinematicChain
    from pybotics.optimization import OptimizationHandler, optimize_accuracy
    from pybotics.robot import Robot as PRobot

    start = register(nominal, cal)
    rows = np.column_stack([start.alpha, start.a * 1e3, start.theta, start.d * 1e3])
    probot = PRobot(MDHKinematicChain(rows))
    world = start.base.copy()
    world[:3, 3] *= 1e3  # pybotics works in mm
    probot.world_frame = world
    probot.tool.position = start.tool[:3, 3] * 1e3
    mask = np.ones((6, 4), bool)
    mask[0] = False  # joint 1 is redundant with the world frame
    mask[1, 3] = mask[5, 3] = mask[5, 2] = False  # d2 ~ d3 (parallel axes), d6 ~ tool z, theta6 ~ tool
    handler = OptimizationHandler(probot, kinematic_chain_mask=mask.ravel().tolist(),
                                  tool_mask=[True] * 3 + [False] * 3, world_mask=[True] * 6)
    x0 = handler.generate_optimization_vector()
    sol = least_squares(optimize_accuracy, x0, args=(handler, cal.joints, cal.points * 1e3), method="lm")
    handler.apply_optimization_vector(sol.x)
    fitted = handler.robot

    def rms(val):
        pred = np.array([fitted.fk(q)[:3, 3] for q in val.joints]) / 1e3
        return position_stats(val.points - pred)["rms"]

    return rms


def _pybotics_rows(nominal, cal, val) -> list:
    try:
        import pybotics  # noqa: F401
    except ImportError:
        print("  (pybotics not installed: `make bench` installs it with --no-deps)")
        return []
    if len(cal) > PYBOTICS_MAX_POSES:
        print(f"  (pybotics skipped above {PYBOTICS_MAX_POSES} poses: it needs minutes per fit)")
        return []
    t_pb, rms = best_time(lambda: pybotics_fit(nominal, cal), 1)
    return [("pybotics: its own fit (FD J, per-pose norms)", t_pb, rms(val))]


def _floor_mm(sim, rows) -> float:
    return float(np.sqrt(np.mean(np.sum(sim.noise[rows] ** 2, axis=1)))) * 1e3


def accuracy_goals(seeds=range(5)) -> None:
    """Validation RMS against the noise floor on simulated data, and the real data sets."""
    nominal = Robot.from_catalog("abb_irb2600")
    rows = []
    for label, outliers, methods in (("isotropic noise", 0.0, ("lsq",)),
                                     ("5% outliers of 1-5 mm", 0.05, ("robust", "lsq"))):
        ratios = {m: [] for m in methods}
        for seed in seeds:
            sim = simulate_tracker(nominal, 300, seed=seed, outliers=outliers)
            clean = ~np.isin(np.arange(len(sim.data)), sim.outlier_rows)
            val_rows = np.flatnonzero((sim.data.pose_id >= 100) & clean)
            cal = sim.data.subset(np.flatnonzero(sim.data.pose_id < 100))
            val = sim.data.subset(val_rows)
            for m in methods:
                res = calibrate(nominal, cal, method=m, validation=val, nongeometric=None)
                ratios[m].append(res.validation["rms"] / _floor_mm(sim, val_rows))
        for m in methods:
            r = np.array(ratios[m])
            rows.append([label, m, f"{r.mean():.3f}", f"{r.max():.3f}", " ".join(f"{v:.3f}" for v in r)])
    table("accuracy: simulated abb_irb2600, 100 calibration / 200 validation poses, noise 0.02 mm: "
          "validation RMS / noise floor", ["case", "method", "mean", "max", "per seed"], rows, key="accuracy")
    if not DATASETS.is_dir():
        print(f"(real data sets not found at {DATASETS}: skipped)")
        return
    from robocal.data.datasets import irb120, meca500

    rows = []
    for name, robot, (cal, val) in (("Meca500 490/70", "meca500", meca500(DATASETS)),
                                    ("IRB 120 500/500 x 3 SMRs", "abb_irb120", irb120(DATASETS))):
        for m in ("lsq", "robust"):
            res = calibrate(Robot.from_catalog(robot), cal, method=m, validation=val, nongeometric=None)
            v, vb = res.validation, res.validation_before
            rows.append([name, m, f"{vb['rms']:.4f}", f"{v['rms']:.4f}", f"{v['mean']:.4f}",
                         f"{v['max']:.4f}"])
    table("real data: held-out position error, mm (geometric model; joint errors: bench_nongeometric)",
          ["data", "method", "nominal + frame RMS", "RMS", "mean", "max"], rows, key="real")


# each plausibility check by the words of its message
CHECKS = {"spread": "points spread", "residual": "frames fitted): the model misses",
          "corrections": "the calibration corrected", "validation": "the validation data: the model misses"}


def _plausibility_row(label: str, robot, cal, validation=None) -> list:
    """One calibration forced past the plausibility checks: the measured-over-model spread ratio
    and the nominal model's residual (frames fitted) that the checks judge, the validation
    residual of the calibrated model, and the checks that fired."""
    try:
        res = calibrate(robot, cal, validation=validation, nongeometric=None, force=True)
    except RobocalError as exc:
        return [label, "", "", "", f"refused before the checks: {str(exc)[:90]}"]
    ratio = spread(cal.points) / spread(res.start.fk(cal.joints, smr=cal.smr)[:, :3, 3])
    forced = [w for w in res.warnings if w.startswith("FORCED")]
    fired = [check for check, words in CHECKS.items() if any(words in w for w in forced)]
    val = f"{res.validation['rms']:.4g}" if validation is not None else ""
    return [label, f"{ratio:.4f}", f"{res.before['rms']:.4g}", val, ", ".join(fired) or "none"]


def plausibility_checks() -> None:
    """The real data sets and issue 12's mistakes through rc.calibrate with force=True: what the
    plausibility checks (robocal.identify.plausibility) measure on each."""
    if not DATASETS.is_dir():
        print(f"(real data sets not found at {DATASETS}: plausibility skipped)")
        return
    from robocal.data.datasets import irb120, meca500

    (meca_cal, meca_val), (irb_cal, _) = meca500(DATASETS), irb120(DATASETS)
    meca = Robot.from_catalog("meca500")
    rows = [_plausibility_row("Meca500 data, meca500", meca, meca_cal),
            _plausibility_row("IRB 120 data, abb_irb120", Robot.from_catalog("abb_irb120"), irb_cal),
            _plausibility_row("Meca500, metres under _mm (points / 1000)", meca,
                              replace(meca_cal, points=meca_cal.points * 1e-3)),
            _plausibility_row("Meca500, radians under _deg (joints / 57.3)", meca,
                              replace(meca_cal, joints=np.deg2rad(meca_cal.joints)))]
    for name in catalog_names():
        robot = Robot.from_catalog(name)
        if name != "meca500" and robot.n_joints == meca.n_joints:
            rows.append(_plausibility_row(f"Meca500 data, wrong robot {name}", robot, meca_cal))
    rows.append(_plausibility_row("IRB 120, validation = Meca500 data", Robot.from_catalog("abb_irb120"),
                                  irb_cal, meca_val))
    table("plausibility checks, forced (spread ratio: measured / registered nominal model; limits 1/3-3, "
          "unit beyond 300)", ["case", "spread", "nominal mm", "validation mm", "checks that fire"], rows,
          key="plausibility")


def speed_rows(nominal, n: int) -> list:
    """(label, wall s, CPU s, validation RMS mm) for ``n`` calibration poses: the three timed
    calls alternate round by round (:func:`timing.interleaved`), so a busy machine slows them
    alike; CPU time counts every thread (scipy's linear algebra runs on every core)."""
    sim = simulate_tracker(nominal, n + 200, seed=42)
    cal = sim.data.subset(np.flatnonzero(sim.data.pose_id < n))
    val = sim.data.subset(np.flatnonzero(sim.data.pose_id >= n))
    res = calibrate(nominal, cal, nongeometric=None)
    problem, state0, space = solve_problem(nominal, cal, res.names)
    calls = {"solve": lambda: robocal_solve(problem, state0, space),
             "fd": lambda: scipy_fd(problem, state0, space),
             "full": lambda: calibrate(nominal, cal, nongeometric=None)}
    best = interleaved(calls, SPEED_ROUNDS[n])
    rows = [("robocal solve (analytic J, LM)", *best["solve"], _validation_rms(calls["solve"](), val)),
            ("scipy least_squares solve (FD J, trf)", *best["fd"], _validation_rms(calls["fd"](), val)),
            ("robocal calibrate(): whole pipeline", *best["full"], _validation_rms(res.robot, val))]
    return rows + [(label, t, float("nan"), rms) for label, t, rms in _pybotics_rows(nominal, cal, val)]


def speed() -> None:
    """Each pose count with the numpy kernels (what a calibration of this size runs by default: it
    does not import numba) and with the numba kernels (the ``fast`` extra, once numba is imported):
    the forward kinematics of both the residual and the Jacobian, for robocal and scipy alike."""
    nominal = Robot.from_catalog("abb_irb2600")
    out, load = [], os.getloadavg()[0]
    for kernel in kernel_choices("robocal.kinematics.fk_numba"):
        for n in SPEED_ROUNDS:
            with use_kernels(kernel):
                rows = speed_rows(nominal, n)
            _, wall0, cpu0, _ = rows[0]
            out += [[n, kernel, label, f"{wall * 1e3:.1f}", "" if np.isnan(cpu) else f"{cpu * 1e3:.1f}",
                     f"{rms:.4f}", f"{wall / wall0:.1f}x", "" if np.isnan(cpu) else f"{cpu / cpu0:.1f}x"]
                    for label, wall, cpu, rms in rows]  # pybotics (timed alone): no CPU time
            figure(f"speed_ratio_{n}_{kernel}", f"{rows[1][1] / wall0:.1f}x")
            figure(f"speed_cpu_ratio_{n}_{kernel}", f"{rows[1][2] / cpu0:.1f}x")
            figure(f"solve_ms_{n}_{kernel}", f"{wall0 * 1e3:.1f}")
    table("calibration speed: simulated abb_irb2600, noise 0.02 mm, 200 validation poses, best of "
          f"{SPEED_ROUNDS[100]} (1,000 poses: of {SPEED_ROUNDS[1000]}) rounds that alternate the three calls "
          "(the solve rows start from the same registered model with the same identifiable parameters); "
          f"load average {load:.1f} at its start, {os.getloadavg()[0]:.1f} at its end",
          ["poses", "kernels", "what", "wall (ms)", "CPU (ms)", "validation RMS (mm)",
           "vs robocal solve, wall", "CPU"], out, key="speed")


PARTS = {"accuracy": accuracy_goals, "plausibility": plausibility_checks, "speed": speed}


def main(parts: list[str] | None = None) -> None:
    for name in parts or PARTS:
        PARTS[name]()


if __name__ == "__main__":
    main(sys.argv[1:])
