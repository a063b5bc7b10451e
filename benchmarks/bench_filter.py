"""Program filter benchmark: speed on 10,000-target programs in each format (goal < 5 s), one run
on 100,000-target programs (goal < 30 s and < 1 GB; each program is written by one process and
filtered by another, so that the peak memory measured is the filter's), and the
simulated-truth goal on 200-target programs (within 1.2x of a perfect filter, >= 10x better than
the unfiltered program); the UR5 drilling cell of issue 21 (a URScript program near the stretched
elbow: filtered within 1.2x of the calibrated model's own error at the drill, >= 10x better than
unfiltered, every target on the controller's branch). No open-source peer filters robot programs;
the reference measured in the same run is rc.compensate on the same poses (the IK alone, without
reading and writing the file)."""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results import figure, table
from scipy.spatial.transform import Rotation
from timing import best_time

import robocal as rc
from robocal.data.simulate import perturbed, simulate_tracker
from robocal.deploy.compensation import controller_model
from robocal.deploy.tcp import identify_tcp
from robocal.ik.closed_form import branch_slot
from robocal.ik.controller import nearest_solutions
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.transforms import invert_transform, make_transform
from robocal.programs import filter_program
from robocal.programs.filter import _nearest_joints, as_frames, controller_joints, target_poses
from robocal.programs.registry import dialect_for
from robocal.programs.simulate import execute, touch_poses, write_program
from robocal.programs.source import ProgramText

CASES = [("rapid", "abb_irb2600"), ("krl", "kuka_kr16_2"), ("fanuc", "fanuc_lrmate200id"),
         ("urscript", "ur5"), ("inform", "yaskawa_gp25"), ("val3", "staubli_tx2_140")]
# speed only: the UR program as PolyScope exports it, one pose variable per waypoint
SPEED_CASES = [(d, name, False) for d, name in CASES] + [("urscript", "ur5", True)]


def _joints(nominal, n, rng, dialect):
    lo, hi = np.maximum(nominal.limits[:, 0], -np.pi) * 0.7, np.minimum(nominal.limits[:, 1], np.pi) * 0.7
    if dialect == "urscript":  # a continuous path, as a UR program is
        steps = rng.uniform(-1, 1, (3 * n, 6)) * np.deg2rad(1.5)
        q = np.clip(np.deg2rad([0, -90, 90, -90, -90, 0]) + np.cumsum(steps, axis=0), lo, hi)
    else:
        q = rng.uniform(lo, hi, (3 * n, 6))
    return q[singularity_distance(nominal, q).sigma_rel > 0.02][:n]


def truth_experiment(dialect: str, robot_name: str, n_targets: int = 200, seed: int = 0,
                     folder=None, n_smr: int = 3) -> dict:
    """The filter on simulated truth: a robot with random errors measured by a virtual tracker
    (120 poses, ``n_smr`` SMRs on the tool: 3 so that the flange's orientation is seen; 0.02 mm
    noise),
    calibrated with ``rc.calibrate``; its real tool's TCP identified
    on the calibrated model by the 4-point method (8 poses); a program of ``n_targets`` targets
    in a work object; the program filtered; both programs executed on the true robot through
    the nominal controller. Returns RMS / max errors (mm, deg) from the intended targets of the
    filtered and unfiltered programs and of a perfect filter (the true robot at the joints where
    the calibrated model reaches each target), and the filter time (s)."""
    nominal = rc.Robot.from_catalog(robot_name)
    sim = simulate_tracker(nominal, 120, n_smr=n_smr, seed=seed)
    cal = rc.calibrate(nominal, sim.data).robot
    # the true robot as the controller sees it: the calibrated frame {0} is the base, tool0 the flange
    truth = sim.truth.with_frames(base=nominal.base @ invert_transform(cal.base) @ sim.truth.base,
                                  tool=nominal.tool)
    rng = np.random.default_rng(seed)
    reach = np.linalg.norm(nominal.fk(np.zeros((1, 6)))[0, :3, 3])
    tool = make_transform(Rotation.from_euler("xyz", [5, 25, 10], degrees=True).as_matrix(),
                          np.array([0.06, -0.02, 0.18]) * min(1.0, reach / 1.5))
    frame = make_transform(Rotation.from_euler("z", 20, degrees=True).as_matrix(),
                           np.array([0.3, -0.2, 0.1]) * reach)
    # the real tool's TCP on the calibrated flange, from 8 poses touching one point
    home = np.deg2rad([0, -90, 90, -90, -90, 0]) if nominal.opw is None else None
    touch = touch_poses(truth, tool, np.array([0.55, 0.1, 0.25]) * reach, 8, rng, home)
    tcp_cal = identify_tcp(cal, nominal, touch)
    real = tool.copy()
    real[:3, 3] = tcp_cal.tcp
    lo, hi = np.maximum(nominal.limits[:, 0], -np.pi) * 0.7, np.minimum(nominal.limits[:, 1], np.pi) * 0.7
    if dialect == "urscript":  # a continuous path away from singularities: the controller solves
        q = [home]  # each target near the previous one
        while len(q) < n_targets:
            step = q[-1] + rng.uniform(-1, 1, (16, 6)) * np.deg2rad(4)
            ok = np.flatnonzero(singularity_distance(nominal, step).sigma_rel > 0.02)
            if ok.size:
                q.append(np.clip(step[ok[0]], lo, hi))
        q = np.array(q)
    else:
        q = rng.uniform(lo, hi, (4 * n_targets, 6))
        q = q[singularity_distance(nominal, q).sigma_rel > 0.02][:n_targets]
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        paths, tools, frames = write_program(dialect, tmp, nominal, q, tool, frame)
        name = {"rapid": "treal", "val3": "tReal[0]"}.get(
            dialect, "1" if dialect in ("krl", "fanuc", "inform") else "default")
        if dialect == "urscript":
            name = next(t.tool for t in _parsed(paths, tools, frames).targets)
        start = time.perf_counter()
        res = filter_program(paths, cal, nominal, tools=tools, frames=frames, tcp={name: real})
        elapsed = time.perf_counter() - start
        out = []
        for p in paths:
            o = Path(tmp) / f"filtered_{p.name}"
            o.write_bytes(res.outputs[p])
            out.append(o.rename(o.with_name(p.name.replace(p.stem, p.stem + "_f"))))
        reached_f, X = execute(out, truth, nominal, tools=tools, frames=frames)
        reached_u, X0 = execute(paths, truth, nominal, tools=tools, frames=frames)
    flange = cal.with_frames(base=nominal.base, tool=nominal.tool @ real)
    q_nominal = rc.ik.solve(nominal.with_frames(tool=nominal.tool @ tool), X0, q).joints
    q_perfect = rc.ik.solve(flange, X0, q_nominal).joints
    perfect = truth.fk(q_perfect) @ tool

    def errors(A):
        pos = np.linalg.norm(A[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
        rot = np.rad2deg(np.linalg.norm(Rotation.from_matrix(
            A[:, :3, :3] @ np.swapaxes(X0[:, :3, :3], 1, 2)).as_rotvec(), axis=1))
        return {"rms_mm": float(np.sqrt(np.mean(pos**2))), "max_mm": float(pos.max()),
                "rms_deg": float(np.sqrt(np.mean(rot**2))), "max_deg": float(rot.max())}

    return {"targets": len(q), "filtered": errors(reached_f), "unfiltered": errors(reached_u),
            "perfect": errors(perfect), "seconds": elapsed, "tcp_rms_mm": tcp_cal.rms_mm,
            "warnings": len(res.warnings)}


def _parsed(paths, tools, frames):
    d = dialect_for(paths)
    return d.parse([ProgramText(p) for p in paths], as_frames(d, frames), as_frames(d, tools))


def speed(n: int = 10_000) -> None:
    tool = make_transform(np.eye(3), np.array([0.03, 0.0, 0.12]))
    frame = make_transform(np.eye(3), np.array([0.4, -0.1, 0.05]))
    rows, slowest = [], 0.0
    for dialect, name, variables in SPEED_CASES:
        nominal = rc.Robot.from_catalog(name)
        cal = perturbed(nominal, 0)
        q = _joints(nominal, n, np.random.default_rng(1), dialect)
        with tempfile.TemporaryDirectory() as tmp:
            paths, tools, frames = write_program(dialect, tmp, nominal, q, tool, frame,
                                                 variables=variables)
            size = sum(Path(p).stat().st_size for p in paths)
            t, res = best_time(lambda p=paths, tl=tools, fr=frames, c=cal, nm=nominal:
                               filter_program(p, c, nm, tools=tl, frames=fr, keep_unreached=True), repeat=3)
        targets = controller_model(nominal, nominal, tool=tool).fk(q)
        seeds = q if dialect == "urscript" else None
        t_comp, _ = best_time(lambda tg=targets, s=seeds, c=cal, nm=nominal:
                              rc.compensate(c, nm, tg, seeds=s, targets_frame="robot", tool=tool), repeat=3)
        filtered = sum(r["filtered"] for r in res.rows)
        slowest = max(slowest, t)
        rows.append([dialect + (" (a variable per waypoint)" if variables else ""), name, len(q),
                     f"{size / 1e6:.1f}", f"{t:.2f}", f"{t / len(q) * 1e6:.0f}",
                     "met" if t < 5 else "NOT met", filtered, f"{t_comp:.2f}", f"{t / t_comp:.1f}x"])
    figure("speed_targets", f"{n:,}")
    figure("speed_slowest_s", f"{slowest:.2f}")
    table(f"filter speed, {n:,}-target programs, best of 3",
          ["format", "robot", "targets", "MB", "filter (s)", "us/target", "goal < 5 s", "filtered",
           "rc.compensate alone (s)", "filter / compensate"], rows,
          key="speed")


LARGE = 100_000  # targets of the large-program case
LARGE_S = 30  # s: the goal for filtering and writing it


def large_write(dialect: str, name: str, folder: str, n: int = LARGE) -> None:
    """Write an ``n``-target program into ``folder`` with ``options.json`` (files, tools, frames).
    FANUC numbers positions with at most 5 digits: 99,999 targets there."""
    n = min(n, 99_999) if dialect == "fanuc" else n
    nominal = rc.Robot.from_catalog(name)
    tool = make_transform(np.eye(3), np.array([0.03, 0.0, 0.12]))
    frame = make_transform(np.eye(3), np.array([0.4, -0.1, 0.05]))
    q = _joints(nominal, n, np.random.default_rng(2), dialect)
    paths, tools, frames = write_program(dialect, folder, nominal, q, tool, frame)
    options = {"paths": [str(p) for p in paths], "tools": tools, "frames": frames, "targets": len(q)}
    (Path(folder) / "options.json").write_text(json.dumps(options))


def large_filter(name: str, folder: str) -> dict:
    """Filter the program :func:`large_write` wrote (this process does nothing else, so its peak
    memory is the filter's): wall and CPU time of filter_program and writing the result (s), the
    peak resident memory (MB), the motion counts."""
    options = json.loads((Path(folder) / "options.json").read_text())
    paths = [Path(p) for p in options["paths"]]
    nominal = rc.Robot.from_catalog(name)
    cal = perturbed(nominal, 0)
    out = Path(folder) / "out"
    out.mkdir()
    t0, c0 = time.perf_counter(), time.process_time()
    res = filter_program(paths, cal, nominal, tools=options["tools"], frames=options["frames"],
                         keep_unreached=True)
    res.write({p: out / p.name for p in paths}, out / "table")
    t, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # kB on Linux
    return {"targets": options["targets"], "mb_file": sum(p.stat().st_size for p in paths) / 1e6, "s": t,
            "cpu_s": cpu, "peak_mb": peak, "motions": res.summary_dict()["motions"]}


def large() -> None:
    rows = []
    for dialect, name in CASES:
        with tempfile.TemporaryDirectory() as tmp:
            for step in ("--large-write", "--large-filter"):
                done = subprocess.run([sys.executable, __file__, step, dialect, name, tmp],
                                      capture_output=True,
                                      text=True, check=True, cwd=Path(__file__).parent)
        r = json.loads(done.stdout.strip().splitlines()[-1])
        print(json.dumps(r), flush=True)
        m = r["motions"]
        rows.append([dialect, name, r["targets"], f"{r['mb_file']:.1f}", f"{r['s']:.1f}", f"{r['cpu_s']:.1f}",
                     f"{r['peak_mb']:.0f}", "met" if r["s"] < LARGE_S and r["peak_mb"] < 1024 else "NOT met",
                     f"{m['corrected']} + {m['named']} = {m['total']}"])
    figure("large_targets", f"{LARGE:,}")
    figure("large_slowest_s", f"{max(float(r[4]) for r in rows):.1f}")
    figure("large_peak_mb", f"{max(float(r[6]) for r in rows):.0f}")
    table(f"filter, {LARGE:,}-target programs, one run each (filter and write)",
          ["format", "robot", "targets", "MB", "filter + write (s)", "CPU (s)", "peak memory (MB)",
           f"goal < {LARGE_S} s, < 1 GB", "motions corrected + named = total"], rows, key="large")


def _ratios(rows: list[dict]) -> tuple[list[float], list[float]]:
    """Filtered / perfect and unfiltered / filtered RMS of :func:`truth_experiment` results."""
    return ([r["filtered"]["rms_mm"] / r["perfect"]["rms_mm"] for r in rows],
            [r["unfiltered"]["rms_mm"] / r["filtered"]["rms_mm"] for r in rows])


def _span(values, fmt: str) -> str:
    return f"{min(values):{fmt}}-{max(values):{fmt}}"


def truth(seeds=(0, 1, 2)) -> None:
    print("simulated truth, 200 targets, work object + real tool (TCP by the 4-point method on the "
          "calibrated model); RMS (max) error from the intended targets")
    rows = []
    for dialect, name in CASES:
        runs = [truth_experiment(dialect, name, 200, seed) for seed in seeds]
        ratio, gain = _ratios(runs)
        for key in ("filtered", "perfect", "unfiltered"):
            mm = ", ".join(f"{r[key]['rms_mm']:.4f} ({r[key]['max_mm']:.3f})" for r in runs)
            print(f"  {dialect:9s} {key:10s} mm: {mm}")
        rms = {key: [r[key]["rms_mm"] for r in runs] for key in ("filtered", "perfect", "unfiltered")}
        deg = {key: [r[key]["rms_deg"] for r in runs] for key in ("filtered", "unfiltered")}
        rows.append([f"{dialect}, {name}", _span(rms["filtered"], ".4f"), _span(rms["perfect"], ".4f"),
                     _span(rms["unfiltered"], ".2f"), _span(ratio, ".3f"), _span(gain, ".0f") + "x",
                     f"{_span(deg['filtered'], '.3f')} / {_span(deg['unfiltered'], '.3f')}"])
    table(f"simulated truth, 200-target programs, seeds {', '.join(map(str, seeds))}: RMS error from "
          "the intended targets (ranges over the seeds)",
          ["format, robot", "filtered mm", "perfect mm", "unfiltered mm",
           "filtered / perfect (goal <= 1.2)", "unfiltered / filtered (goal >= 10)",
           "orientation filtered / unfiltered deg"], rows, key="truth")
    rows, all_ratio, all_perfect, all_gain = [], [], [], []
    for dialect, name in CASES:
        runs = [truth_experiment(dialect, name, 200, seed, n_smr=1) for seed in seeds]
        ratio, gain = _ratios(runs)
        perfect = [r["perfect"]["rms_mm"] for r in runs]
        all_ratio += ratio
        all_perfect += perfect
        all_gain += gain
        rows.append([f"{dialect}, {name}", _span(ratio, ".3f"), _span(perfect, ".3f"),
                     _span(gain, ".1f") + "x"])
    table("the same with a single-SMR campaign (the flange's orientation not seen)",
          ["format, robot", "filtered / perfect", "perfect mm", "unfiltered / filtered"], rows,
          key="truth_one_smr")
    figure("one_smr_ratio", _span(all_ratio, ".2f"))
    figure("one_smr_perfect_mm", _span(all_perfect, ".3f"))
    figure("one_smr_gain", _span(all_gain, ".1f") + "x")


# ----------------------------------------------------------------------------- UR5 drilling
HOME_DEG = [10, -100, 35, -25, -90, 0]  # the arm reaching out, elbow 35 deg from stretched, drill down
DRILL = make_transform(np.eye(3), [0.0, 0.0, 0.16])  # the drill's TCP, as set_tcp gives it
APPROACH_M = 0.015
GRID, PITCH_M = 10, 0.012


def _p(T: np.ndarray) -> str:
    rv = Rotation.from_matrix(T[:3, :3]).as_rotvec()
    return "p[" + ", ".join(f"{v:.6f}" for v in (*T[:3, 3], *rv)) + "]"


def drilling_cell():
    """Nominal UR5, the hole targets (drill TCP poses, base frame) in program order, the taught
    joints (the controller's choice from home) and the script text."""
    nominal = rc.Robot.from_catalog("ur5")
    home = np.deg2rad(HOME_DEG)
    centre = nominal.fk(home)[0] @ DRILL  # the plate's centre hole; the drill axis is its normal
    holes = []
    for row in range(GRID):
        cols = range(GRID) if row % 2 == 0 else range(GRID - 1, -1, -1)  # serpentine
        for col in cols:
            offset = np.array([(col - (GRID - 1) / 2) * PITCH_M, (row - (GRID - 1) / 2) * PITCH_M, 0.0])
            holes.append(centre @ make_transform(np.eye(3), offset))
    above = make_transform(np.eye(3), [0.0, 0.0, -APPROACH_M])
    targets = np.array([T for h in holes for T in (h @ above, h, h @ above)])
    q = nearest_solutions(nominal.with_frames(tool=nominal.tool @ DRILL), targets, home).joints
    lines = ["def drill_plate():", f"  set_tcp({_p(DRILL)})", "  set_payload(2.1)",
             "  movej([" + ", ".join(f"{v:.6f}" for v in home) + "], a=1.4, v=1.05)"]
    for i in range(0, len(targets), 3):
        lines += [f"  movel({_p(targets[i])}, a=0.5, v=0.1)", f"  movel({_p(targets[i + 1])}, a=0.2, v=0.01)",
                  "  sleep(0.5)", f"  movel({_p(targets[i + 2])}, a=0.5, v=0.05)"]
    lines += ["end", "drill_plate()", ""]
    return nominal, targets, q, "\n".join(lines)


def ur_controller_joints(path, nominal):
    """The joints the emulated UR controller takes for the program's targets (as robocal.programs.
    simulate.execute runs them)."""
    d = dialect_for([path])
    program = d.parse([ProgramText(path)], as_frames(d, {}), as_frames(d, {}))
    _, P, W, tool = target_poses(d, program, program.targets)
    problems, warnings = [], []
    q = controller_joints(d, program, program.targets, nominal, W @ P @ invert_transform(tool), problems,
                          warnings)
    if problems:
        raise AssertionError(f"the controller cannot run {problems[:5]}")
    return q, tool[0], warnings


def drilling_experiment(folder, seed: int = 4) -> dict:
    """The UR5 drilling cell (:func:`drilling_cell`) on simulated truth: the robot calibrated from
    120 simulated tracker poses (3 SMRs); the drill's TCP identified on the calibrated flange from 8
    poses touching one point (it absorbs what the calibration cannot tell apart at the flange: d6,
    theta6 against the SMRs); the script written to ``folder``, filtered, and both run on the true
    robot by the emulated controller. Returns the taught joints, the controller's joints of the
    filtered program, the RMS errors (mm) of the filtered and unfiltered programs and the model's
    own (the true robot where the calibrated model puts the drill on each target), the filter's
    warnings, and how many targets the earlier numeric nearest-joints search put on another branch."""
    nominal, targets, q_taught, text = drilling_cell()
    sim = simulate_tracker(nominal, 120, n_smr=3, seed=seed)
    cal = rc.calibrate(nominal, sim.data).robot
    # the true robot as the controller sees it: the calibrated frame {0} is the base, tool0 the flange
    truth = sim.truth.with_frames(base=nominal.base @ invert_transform(cal.base) @ sim.truth.base,
                                  tool=nominal.tool)
    rng = np.random.default_rng(seed)
    reach = np.linalg.norm(nominal.fk(np.zeros((1, 6)))[0, :3, 3])
    touch = touch_poses(truth, DRILL, np.array([0.55, 0.1, 0.25]) * reach, 8, rng,
                        np.deg2rad([0, -90, 90, -90, -90, 0]))
    real = DRILL.copy()
    real[:3, 3] = identify_tcp(cal, nominal, touch).tcp
    path = Path(folder) / "drill_plate.script"
    path.write_text(text)
    name = _parsed([path], {}, {}).targets[0].tool
    result = filter_program(path, cal, nominal, tcp={name: real})
    filtered = Path(folder) / "drill_plate_filtered.script"
    filtered.write_bytes(result.outputs[path])
    q_f, tool, _ = ur_controller_joints(filtered, nominal)
    q_u, _, _ = ur_controller_joints(path, nominal)
    model = cal.with_frames(base=nominal.base, tool=nominal.tool @ real)
    q_model = rc.ik.solve(model, targets, q_taught).joints

    def rms_mm(q):
        err = (truth.fk(q) @ tool)[:, :3, 3] - targets[:, :3, 3]
        return float(np.sqrt(np.mean(np.sum(err**2, axis=1))) * 1e3)

    program = _parsed([path], {}, {})
    flanges = targets @ invert_transform(DRILL)
    numeric = _nearest_joints(nominal, flanges, program.targets, program, [], [])
    hops = int((branch_slot(nominal, numeric) != branch_slot(nominal, q_taught)).sum())
    return {"targets": len(targets), "taught": q_taught, "filtered_joints": q_f, "nominal": nominal,
            "own_mm": rms_mm(q_model), "filtered_mm": rms_mm(q_f), "unfiltered_mm": rms_mm(q_u),
            "warnings": result.warnings, "numeric_hops": hops, "path": path}


def drilling(seeds=(4, 5, 6)) -> None:
    _, _, taught, _ = drilling_cell()
    step = figure("drilling_step_deg", f"{np.rad2deg(np.abs(np.diff(taught, axis=0)).max()):.1f}")
    elbow = figure("drilling_elbow_deg", _span(np.rad2deg(np.abs(taught[:, 2])), ".0f"))
    rows, found = [], {"own": [], "filtered": [], "ratio": [], "unfiltered": [], "gain": []}
    hops = numeric = 0
    for seed in seeds:
        with tempfile.TemporaryDirectory() as tmp:
            r = drilling_experiment(tmp, seed)
        nominal = r["nominal"]
        slots = int((branch_slot(nominal, r["filtered_joints"]) != branch_slot(nominal, r["taught"])).sum())
        hops, numeric = hops + slots, numeric + r["numeric_hops"]
        own, fil, unf = r["own_mm"], r["filtered_mm"], r["unfiltered_mm"]
        for key, value in (("own", own), ("filtered", fil), ("unfiltered", unf), ("ratio", fil / own),
                           ("gain", unf / fil)):
            found[key].append(value)
        rows.append([seed, f"{own:.4f}", f"{fil:.4f}", f"{fil / own:.2f}", f"{unf:.3f}", f"{unf / fil:.0f}x",
                     slots,
                     f"{r['numeric_hops']} of {r['targets']}"])
    table(f"UR5 drilling, URScript (100 holes x approach / drill / retract, movel, set_tcp; joints move "
          f"at most {step} deg between targets, elbow {elbow} deg from stretched): RMS error at the drill "
          "(mm)",
          ["seed", "model's own", "filtered", "filtered / own (goal <= 1.2)", "unfiltered",
           "unfiltered / filtered (goal >= 10)", "filtered targets on another branch than the controller's",
           "numeric nearest-joints search on another branch"], rows, key="drilling")
    figure("drilling_filtered_mm", " / ".join(f"{v:.4f}" for v in found["filtered"]))
    figure("drilling_unfiltered_mm", " / ".join(f"{v:.2f}" for v in found["unfiltered"]))
    figure("drilling_ratio", _span(found["ratio"], ".2f") + "x")
    figure("drilling_gain", _span(found["gain"], ".0f") + "x")
    figure("drilling_branch_hops", str(hops))
    figure("drilling_numeric_hops", f"{numeric} of {len(seeds) * len(taught)}")


def main() -> None:
    speed()
    large()
    truth()
    drilling()


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--large-write":
        large_write(sys.argv[2], sys.argv[3], sys.argv[4])
    elif len(sys.argv) == 5 and sys.argv[1] == "--large-filter":
        print(json.dumps(large_filter(sys.argv[3], sys.argv[4])))
    else:
        main()
