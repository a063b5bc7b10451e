"""Held-out accuracy of the payload and thermal terms on a simulated KR 210 R2700 cell.

Campaign: 300 poses (tracker points, 0.02 mm isotropic noise) in three blocks at 0, 75 and
150 kg (centre of mass 250 mm along the flange's z axis), the arm warming from 20 to 35 deg C
within each block (:mod:`robocal.data.simulated_physics`). Held out: 100 other poses of the same
true robot at 110 kg and 28 deg C (``as_is``). Calibrated with the geometric model,
``nongeometric="payload,thermal"`` and ``"auto"``; the held-out RMS is compared with the noise
floor of the held-out set (goals: 1.3x for the named terms, 1.5x for auto). Three seeds.

Then the program goal: a KRL program of 100 targets (a tool 200 mm along the flange, in a work
object) that sets ``$LOAD = {M 120.0, CM {X 0, Y 0, Z 300 ...}}``, filtered with the calibrated
model (3 SMRs per pose so the flange's orientation is seen) at ``temperature=30`` (the load read
from the program) and run on the true robot at 120 kg and 30 deg C through the nominal controller:
its RMS error at the targets against the model's own error there (the true robot at the joints
where the calibrated model reaches each target); goal: within 1.3x + 0.002 mm.

Then the link groups: two campaigns of 300 poses warming from 20 to 35 deg C (no payload), one of an
arm whose forearm is aluminium (k 23e-6/K, the rest steel 11.5e-6/K) and one of an all-steel arm,
calibrated without a thermal term, with one k (``thermal``), with a k per link group
(``thermal_groups``) and ``auto``; held out: 100 other poses of the same arm at 28 deg C and 100 at
35 deg C (the warm end, where the groups differ most), each against its noise floor. Three seeds;
recorded as the table ``payload_thermal.groups``.

Then an independent truth (``benchmarks/payload_truth.py``, written without robocal's payload term):
joints yielding 1-4 mm at the reach under the heaviest load (a KR 210's order, ten times the
simulator's), the moments taken at the deflected frames, the load's true centre of mass (60, -40,
320) mm while the rows record the program's nominal (0, 0, 250) mm; held out at 110 kg and 28 deg C.
Variants: the centre of mass recorded right, and the links' own weight added (which the payload
term does not model: the compliance term's). Each row: the worst held-out RMS / noise floor over the
seeds, what auto chose and the centre of mass's error the payload term recovered from joints 2 and 3
(truth (60, -40, 70) mm). Recorded as the table ``payload_thermal.independent``.

Run: ``PYTHONPATH=src python benchmarks/bench_payload_thermal.py`` (or ``benchmarks/run.py
payload_thermal`` to record it in results.json).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from robocal import Robot
from robocal.calibration.pipeline import calibrate
from robocal.data.simulate import simulate_tracker
from robocal.deploy.tcp import identify_tcp
from robocal.ik import solve as ik_solve
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.load import lever_correction
from robocal.kinematics.transforms import invert_transform, make_transform
from robocal.programs import filter_program
from robocal.programs.simulate import execute, touch_poses, write_program

sys.path.insert(0, str(Path(__file__).resolve().parent))
import payload_truth  # noqa: E402
from results import figure, table  # noqa: E402

SEEDS = (1, 2, 3)
N_CAL, N_HELD = 300, 100
NOISE_MM = 0.02
GOALS = {"payload,thermal": 1.3, "auto": 1.5}
GROUP_TRUTHS = {"aluminium forearm": {"forearm": 23e-6}, "all steel": None}
GROUP_MODELS = ("none", "thermal", "thermal_groups", "auto")
GROUP_HELD_C = (28.0, 35.0)
INDEPENDENT_VARIANTS = {"centre of mass off": {},
                        "centre of mass recorded": {"recorded_com": payload_truth.TRUE_COM_M},
                        "own weight too": {"own_weight": True}}
INDEPENDENT_MODELS = ("payload,thermal", "auto")
LEVER_JOINTS = (2, 3)  # the joints whose lever to the load changes with the arm's configuration


def campaign(seed: int):
    """(calibration data, held-out data, held-out noise floor mm, truth)."""
    robot = Robot.from_catalog("kuka_kr210_r2700")
    cal = simulate_tracker(robot, N_CAL, noise_mm=NOISE_MM, seed=seed, payloads=[0, 75, 150],
                           temperatures=(20, 35))
    held = simulate_tracker(cal.truth, N_HELD, noise_mm=NOISE_MM, seed=seed + 100, as_is=True,
                            payloads=[110], temperatures=(28, 28))
    return cal.data, held.data, held.noise_floor_mm, cal.truth


def main() -> None:
    robot = Robot.from_catalog("kuka_kr210_r2700")
    print(f"{'seed':>4} {'model':>16} {'held-out RMS mm':>16} {'floor mm':>9} {'ratio':>6} {'goal':>5} "
          f"{'time s':>7}  chosen / thermal k (truth 11.5e-6)")
    worst = {}
    for seed in SEEDS:
        data, held, floor, _ = campaign(seed)
        for model in ("none", "payload,thermal", "auto"):
            t0 = time.perf_counter()
            res = calibrate(robot, data, validation=held, nongeometric=model)
            dt = time.perf_counter() - t0
            rms = res.validation["rms"]
            ratio = rms / floor
            worst[model] = max(worst.get(model, 0.0), ratio)
            errors = res.robot.joint_errors
            k = errors.thermal_k() if errors is not None else None
            chosen = res.model_selection["chosen_terms"] if getattr(res, "model_selection", None) else ""
            goal = GOALS.get(model)
            print(f"{seed:>4} {model:>16} {rms:>16.4f} {floor:>9.4f} {ratio:>6.2f} "
                  f"{'' if goal is None else f'{goal:.1f}':>5} {dt:>7.1f}  {chosen} "
                  f"{'' if k is None else f'k={k:.4g}'}")
    for model, goal in GOALS.items():
        verdict = "meets" if worst[model] <= goal else "MISSES"
        print(f"worst ratio {model}: {worst[model]:.2f} ({verdict} the {goal}x goal)")
    print(f"worst ratio geometric only: {worst['none']:.2f}")
    independent_truth()
    link_groups()
    k = krl_program()
    goal = 1.3 * k["model"] + 0.002
    print(f"KRL program at 120 kg (read from $LOAD), 30 deg C: filtered RMS {k['filtered']:.4f} mm, "
          f"unfiltered {k['unfiltered']:.4f} mm, the model's own error {k['model']:.4f} mm; "
          f"goal <= {goal:.4f} mm: {'meets' if k['filtered'] <= goal else 'MISSES'} ({k['load_note']})")


def independent_truth(seeds=SEEDS) -> list:
    """The independent-truth section (module docstring): one row per variant and model."""
    rows = []
    for variant, options in INDEPENDENT_VARIANTS.items():
        worst = dict.fromkeys(INDEPENDENT_MODELS, 0.0)
        chosen, deltas = [], []
        for seed in seeds:
            robot, data, held, floor, _ = payload_truth.campaign(seed, N_CAL, N_HELD, NOISE_MM, **options)
            for model in INDEPENDENT_MODELS:
                res = calibrate(robot, data, validation=held, nongeometric=model)
                worst[model] = max(worst[model], res.validation["rms"] / floor)
                errors = res.robot.joint_errors
                if model == "auto":
                    chosen.append(", ".join(res.model_selection["chosen_terms"]) or "geometric")
                elif errors is not None:
                    delta = lever_correction(dict(zip(errors.names, errors.values, strict=True)),
                                             LEVER_JOINTS)
                    if delta is not None:
                        deltas.append(delta * 1e3)
            print(f"independent truth, {variant}, seed {seed}: " + ", ".join(
                f"{m} {worst[m]:.2f}" for m in INDEPENDENT_MODELS)
                + f" (worst so far); auto chose {chosen[-1]}", flush=True)
        mean_delta = np.mean(deltas, axis=0) if deltas else None
        rows.append([variant, *(f"{worst[m]:.2f}" for m in INDEPENDENT_MODELS),
                     "; ".join(dict.fromkeys(chosen)),
                     "-" if mean_delta is None else " ".join(f"{v:.0f}" for v in mean_delta)])
    table(f"KR 210 R2700, independent payload truth (benchmarks/payload_truth.py), {N_CAL} poses at 0/75/150 "
          f"kg 20-35 deg C, held out {N_HELD} at 110 kg 28 deg C, seeds {seeds}: worst held-out RMS / noise "
          "floor (goal 1.3), what auto chose, the centre of mass's error recovered (mm, mean;"
          " truth 60 -40 70 when off)",
          ["truth", *INDEPENDENT_MODELS, "auto chose", "centre of mass error mm"], rows,
          key="independent")
    return rows


def link_groups() -> None:
    """The per-group section (module docstring): one row per true arm and model, the worst held-out
    RMS / noise floor over the seeds at each held-out temperature, the forearm's k and what auto chose."""
    robot = Robot.from_catalog("kuka_kr210_r2700")
    rows = []
    for truth_name, thermal_k in GROUP_TRUTHS.items():
        worst = {m: [0.0] * len(GROUP_HELD_C) for m in GROUP_MODELS}
        rms_mm = {m: [[] for _ in GROUP_HELD_C] for m in GROUP_MODELS}
        forearm = {m: [] for m in GROUP_MODELS}
        chosen: dict[str, int] = {}
        for seed in SEEDS:
            cal = simulate_tracker(robot, N_CAL, noise_mm=NOISE_MM, seed=seed, temperatures=(20, 35),
                                   thermal_k=thermal_k)
            held = [simulate_tracker(cal.truth, N_HELD, noise_mm=NOISE_MM, seed=seed + 100 + j, as_is=True,
                                     temperatures=(t, t)) for j, t in enumerate(GROUP_HELD_C)]
            for model in GROUP_MODELS:
                res = calibrate(robot, cal.data, validation=[h.data for h in held], nongeometric=model)
                per_file = [f for f in res.per_file() if f["role"] != "calibration"]
                for j, (f, h) in enumerate(zip(per_file, held, strict=True)):
                    rms_mm[model][j].append(f["after"]["rms"])
                    worst[model][j] = max(worst[model][j], f["after"]["rms"] / h.noise_floor_mm)
                errors = res.robot.joint_errors
                groups = None if errors is None else errors.thermal_groups()
                k = groups["forearm"] if groups else (errors.thermal_k() if errors is not None else None)
                if k is not None:
                    forearm[model].append(k)
                if model == "auto":
                    label = ", ".join(res.model_selection["chosen_terms"]) or "geometric"
                    chosen[label] = chosen.get(label, 0) + 1
        for model in GROUP_MODELS:
            ks = forearm[model]
            rows.append([truth_name, model,
                         *(f"{np.mean(r):.4f}" for r in rms_mm[model]),
                         *(f"{w:.2f}" for w in worst[model]),
                         f"{np.mean(ks) * 1e6:.1f}" if ks else "-",
                         "; ".join(f"{c} x{n}" for c, n in chosen.items()) if model == "auto" else ""])
        figure(f"groups_{'alu' if thermal_k else 'steel'}_auto", "; ".join(
            f"{c} ({n} of {len(SEEDS)})" for c, n in chosen.items()))
    table(f"KR 210 R2700, {N_CAL} poses 20-35 deg C, {NOISE_MM} mm noise, seeds {SEEDS}: held-out RMS (mean, "
          "mm) and worst RMS / noise floor at 28 and 35 deg C, the forearm's k (mean, 1e-6/K; truth 23 "
          "or 11.5)",
          ["true arm", "model", "RMS 28 C", "RMS 35 C", "worst/floor 28 C", "worst/floor 35 C",
           "forearm k", "auto chose"], rows, key="groups")


def krl_program(seed: int = 1, n_targets: int = 100) -> dict:
    """The program goal (module docstring): RMS errors (mm) at the targets of the filtered program,
    of the unfiltered one and of the model's own error."""
    nominal = Robot.from_catalog("kuka_kr210_r2700")
    sim = simulate_tracker(nominal, N_CAL, n_smr=3, noise_mm=NOISE_MM, seed=seed, payloads=[0, 75, 150],
                           temperatures=(20, 35))
    cal = calibrate(nominal, sim.data, nongeometric="payload,thermal").robot
    load = [120.0, 0.0, 0.0, 0.3]
    truth = sim.truth.with_frames(base=nominal.base @ invert_transform(cal.base) @ sim.truth.base,
                                  tool=nominal.tool).with_conditions(load, 30.0)
    rng = np.random.default_rng(seed)
    mid, half = nominal.limits.mean(axis=1), np.minimum(np.ptp(nominal.limits, axis=1), 2 * np.pi) * 0.35
    lo, hi = mid - half, mid + half  # well inside the limits
    q = rng.uniform(lo, hi, (4 * n_targets, 6))
    q = q[singularity_distance(nominal, q).sigma_rel > 0.02][:n_targets]
    tool = make_transform(np.eye(3), np.array([0.0, 0.0, 0.2]))
    frame = make_transform(np.eye(3), np.array([1.2, -0.4, 0.3]))
    # the real TCP on the calibrated flange (the SMR data cannot tell where the flange is), from 8
    # poses touching one point at the program's conditions, as bench_filter does
    warm = cal.with_conditions(load, 30.0)
    touch = touch_poses(truth, tool, np.array([1.5, 0.3, 0.7]), 8, rng)
    real = tool.copy()
    real[:3, 3] = identify_tcp(warm, nominal, touch).tcp
    with tempfile.TemporaryDirectory() as tmp:
        paths, tools, frames = write_program("krl", tmp, nominal, q, tool, frame)
        src = next(p for p in paths if p.suffix == ".src")
        text = src.read_text()
        head = text.index("\n", text.upper().index("DEF ")) + 1
        load_line = "$LOAD = {M 120.0, CM {X 0, Y 0, Z 300, A 0, B 0, C 0}, J {X 0, Y 0, Z 0}}\n"
        src.write_text(text[:head] + load_line + text[head:])
        res = filter_program(paths, cal, nominal, tools=tools, frames=frames, temperature=30.0,
                             tcp={"1": real})
        reached_u, X0 = execute(paths, truth, nominal, tools=tools, frames=frames)
        out = []
        for p in paths:
            o = p.with_name(p.stem + "_f" + p.suffix)
            o.write_bytes(res.outputs[p])
            out.append(o)
        reached_f, _ = execute(out, truth, nominal, tools=tools, frames=frames)
    model = warm.with_frames(base=nominal.base, tool=nominal.tool @ real)
    q0 = ik_solve(nominal.with_frames(tool=nominal.tool @ tool), X0, q).joints
    perfect = truth.fk(ik_solve(model, X0, q0).joints) @ tool

    def rms(A):
        return float(np.sqrt(np.mean(np.sum((A[:, :3, 3] - X0[:, :3, 3]) ** 2, axis=1)))) * 1e3

    return {"filtered": rms(reached_f), "unfiltered": rms(reached_u), "model": rms(perfect),
            "load_note": (res.loads or [""])[0]}


if __name__ == "__main__":
    main()
