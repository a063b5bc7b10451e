"""Held-out accuracy of the joint-error models and of ``nongeometric="auto"``, and what the
automatic choice costs.

Data: the real IRB 120 (first 500 poses calibrate, last 500 judge) and Meca500 (490 / 70) sets
(skipped when ../shared/datasets is absent) and simulated IRB 2600 campaigns (100 / 100 poses):
without joint errors (three seeds), with compliance + gear + backlash, with travel + cyclic.
For every data set: every combination of the terms calibrated by hand (the held-out set only
judges, nothing is tuned on it), then ``auto`` (chosen by cross-validation on the calibration
part). Columns: calibration RMS, the cross-validated RMS that auto computed for the same
model, held-out RMS and max (mm), time. Then auto's held-out RMS against the best hand-chosen
model and against the geometric one, and the selection cost: time of ``auto`` / time of one
calibration of the model it chose (best of REPEATS, interleaved), plus the neural method
(seed 002) for reference. Under each data set: where auto's time goes, the cyclic frequencies and
travel coefficients it found; on the real sets also the lowest-CV hand-chosen model's compliance
parameters dropped one at a time (how fragile it is), the joint-error stage without its
variance-inflation rule (what the rule changes), a refit on the held-out set itself (the best a
model of those terms can do there) and the learned residual model on top of compliance + gear.
"""

from __future__ import annotations

import itertools
import time
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

import numpy as np

from robocal import Robot
from robocal.calibration.evaluation import model_errors
from robocal.calibration.pipeline import calibrate
from robocal.data.datasets import irb120, meca500
from robocal.data.simulate import simulate_tracker
from robocal.identify import identifiability
from robocal.identify.residual import ResidualModel
from robocal.kinematics.joint_errors import TERMS, JointErrorModel, cyclic_names

DS = Path(__file__).resolve().parents[2] / "shared" / "datasets"
REPEATS = 3
INJECTED = {
    "compliance+gear+backlash": (["comp2_3", "comp2_6", "comp3_6", "comp5_6", "gear1_s1", "gear2_c1",
                                  "gear3_s2", "gear5_c2", "backlash1", "backlash2", "backlash4"],
                                 [4e-4, 3e-4, 5e-4, 2e-3, 2e-4, -1.5e-4, 1e-4, -2e-4, 2e-4, -1.5e-4, 3e-4]),
    "travel+cyclic": (["travel1", "travel2", "travel3", *cyclic_names(1, 120), *cyclic_names(4, 80)],
                      [1e-3, -8e-4, 6e-4, 1.5e-4, -1e-4, 2e-4, 1e-4]),
}


def _sets():
    robot = Robot.from_catalog("abb_irb2600")
    for seed in (1, 2, 3):
        sim = simulate_tracker(robot, 200, noise_mm=0.02, seed=seed)
        cal, val = sim.data.split_poses(0.5, seed=0)
        yield f"IRB 2600 sim, no joint errors (seed {seed})", "abb_irb2600", cal, val
    for label, (names, values) in INJECTED.items():
        true = replace(robot, joint_errors=JointErrorModel(tuple(names), np.array(values)))
        sim = simulate_tracker(true, 200, noise_mm=0.02, n_smr=2, seed=7)
        yield f"IRB 2600 sim, {label}", "abb_irb2600", *sim.data.split_poses(0.5, seed=0)
    if DS.is_dir():
        yield "IRB 120 (real, 500/500)", "abb_irb120", *irb120(DS)
        yield "Meca500 (real, 490/70)", "meca500", *meca500(DS)


def _timed(*args, **kw):
    t = time.perf_counter()
    result = calibrate(*args, **kw)
    return result, time.perf_counter() - t


def _label(terms) -> str:
    return ", ".join(terms) if terms else "geometric"


@contextmanager
def _without_vif_rule():
    """The joint-error identifiability stage without its variance-inflation floor."""
    saved = identifiability.STAGES, identifiability.NG_RTOL
    identifiability.STAGES = (*saved[0][:-1], (saved[0][-1][0], 0.0))
    identifiability.NG_RTOL = 0.0
    try:
        yield
    finally:
        identifiability.STAGES, identifiability.NG_RTOL = saved


def _auto_details(auto) -> None:
    """Where auto's time went, the cyclic frequencies and travel coefficients it found."""
    ms = auto.model_selection
    t = ms["time_s"]
    found = ", ".join(f"J{c['joint']} {c['cycles_per_rev']:g}" for c in ms["cyclic_frequencies"]) or "none"
    travel = [r for r in auto.parameter_table()
              if r["name"].startswith("travel") and r["status"] == "estimated"]
    print(f"    auto's time: largest model's fit {t['superset_fit']:.3f} s, selection "
          f"{t['selection']:.3f} s, final fit {t['final_fit']:.3f} s; cyclic frequencies (cycles/rev): "
          f"{found}")
    if travel:
        print("    travel coefficients: " + ", ".join(f"{r['name']} {r['estimate']:+.2f} {r['unit']}"
                                                 for r in travel))


def _real_details(robot, cal, val, cv: dict, held: dict) -> None:
    """The real data sets: the lowest-CV model's fragility, the VIF rule, an oracle refit and the
    learned residual model (module docstring)."""
    lowest = min(cv, key=cv.get)
    res = calibrate(robot, cal, validation=val, nongeometric=",".join(lowest))
    kept = list(res.robot.joint_errors.names) if res.robot.joint_errors is not None else []
    comp = [nm for nm in kept if nm.startswith("comp")]
    print(f"    lowest CV ({_label(lowest)}, {cv[lowest]:.4f} mm): held out {res.validation['rms']:.4f} mm; "
          f"its compliance parameters {', '.join(comp) or 'none'}")
    for nm in comp:
        drop = calibrate(robot, cal, validation=val, nongeometric=",".join(k for k in kept if k != nm))
        print(f"      without {nm}: held out {drop.validation['rms']:.4f} mm")
    cgb = ("compliance", "gear", "backlash")
    with _without_vif_rule():
        free = calibrate(robot, cal, validation=val, nongeometric="auto")
        plain = calibrate(robot, cal, validation=val, nongeometric=",".join(cgb))
    free_cv = {tuple(c["terms"]): c["cv_rms_mm"] for c in free.model_selection["candidates"]}
    print(f"    compliance, gear, backlash: CV {free_cv[cgb]:.4f} -> {cv[cgb]:.4f} mm, held out "
          f"{plain.validation['rms']:.4f} -> {held[cgb]:.4f} mm with the variance-inflation rule "
          f"(auto without it: {_label(free.model_selection['chosen_terms'])}, "
          f"{free.validation['rms']:.4f} mm)")
    oracle = calibrate(robot, val, nongeometric=",".join(cgb))
    print(f"    compliance, gear, backlash fitted on the held-out set itself: {oracle.after['rms']:.4f} mm")
    cg = calibrate(robot, cal, validation=val, nongeometric="compliance,gear")
    model = ResidualModel.fit(cal.joints, cal.smr, cal.pose_id, model_errors(cg.robot, cal))
    err = model_errors(cg.robot, val) - model.predict(val.joints, val.smr)
    rms = float(np.sqrt(np.mean(np.sum(err**2, axis=1))) * 1e3)
    chose = "zero correction" if not len(model.coef) else "a correction"
    print(f"    learned residual on compliance, gear: {chose} chosen; held out {cg.validation['rms']:.4f} -> "
          f"{rms:.4f} mm")


def main() -> None:
    print(f"{'data':44s} {'model':44s} {'cal RMS':>8s} {'CV RMS':>8s} {'held-out':>9s} {'max':>7s} "
          f"{'time':>6s}")
    summary = []
    for label, name, cal, val in _sets():
        robot = Robot.from_catalog(name)
        auto, _ = _timed(robot, cal, validation=val, nongeometric="auto")
        ms = auto.model_selection
        cv = {tuple(c["terms"]): c["cv_rms_mm"] for c in ms["candidates"]}
        held = {}
        for size in range(len(TERMS) + 1):
            for combo in itertools.combinations(TERMS, size):
                if combo and combo not in cv:
                    continue  # a term the data cannot carry (e.g. no cyclic frequency found)
                res, t = _timed(robot, cal, validation=val, nongeometric=",".join(combo) or None)
                held[combo] = res.validation["rms"]
                print(f"{label:44s} {_label(combo):44s} {res.after['rms']:8.4f} {cv.get(combo, np.nan):8.4f} "
                      f"{res.validation['rms']:9.4f} {res.validation['max']:7.3f} {t:6.2f}s")
        chosen = tuple(ms["chosen_terms"])
        spec = ms["candidates"][ms["chosen"]]["parameters"]
        t_auto, t_one = [], []
        for _ in range(REPEATS):  # interleaved: the machine's load changes over time
            t_auto.append(_timed(robot, cal, nongeometric="auto")[1])
            t_one.append(_timed(robot, cal, nongeometric=",".join(spec) or None)[1])
        print(f"{label:44s} {'auto -> ' + _label(chosen):44s} {auto.after['rms']:8.4f} "
              f"{cv[chosen]:8.4f} {auto.validation['rms']:9.4f} {auto.validation['max']:7.3f} "
              f"{min(t_auto):6.2f}s")
        _auto_details(auto)
        if "real" in label:
            _real_details(robot, cal, val, cv, held)
        if name == "meca500" or "no joint errors (seed 1)" in label:
            res, t = _timed(robot, cal, validation=val, method="neural")
            print(f"{label:44s} {'neural (seed 002)':44s} {res.after['rms']:8.4f} {'':8s} "
                  f"{res.validation['rms']:9.4f} {res.validation['max']:7.3f} {t:6.2f}s")
        best = min(held, key=held.get)
        summary.append((label, _label(chosen), auto.validation["rms"], _label(best), held[best], held[()],
                        min(t_auto) / min(t_one), min(t_auto), min(t_one)))
    print("\nauto against the best hand-chosen model and the geometric one (held-out RMS, mm); "
          f"selection cost = time(auto) / time(one calibration of the chosen model), best of {REPEATS}")
    print(f"{'data':44s} {'auto chose':36s} {'auto':>7s} {'best by hand':36s} {'best':>7s} {'ratio':>6s} "
          f"{'geometric':>9s} {'cost':>6s} {'auto s':>7s} {'one s':>6s}")
    for label, chosen, a, best, b, g, ratio, ta, t1 in summary:
        print(f"{label:44s} {chosen:36s} {a:7.4f} {best:36s} {b:7.4f} {a / b:6.3f} {g:9.4f} {ratio:5.1f}x "
              f"{ta:7.2f} {t1:6.2f}")


if __name__ == "__main__":
    main()
