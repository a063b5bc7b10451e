"""Byte identity of every ``robocal`` command's outputs against another source tree (e.g. the main
branch before a restructuring): each tree runs the same command lines, each command in its own
interpreter with ``PYTHONPATH`` set to that tree, and every file written, every stdout and stderr
text and every exit code are compared. Exit 0 when everything is the same; one line per step.

``python benchmarks/check_output_identity.py REFERENCE_SRC`` (REFERENCE_SRC: the ``src`` folder of
the other tree, e.g. /work/ref/src), from the tree to check (its ``src`` is this file's
``../src``; ``--tree OTHER_SRC`` checks another one). Options: ``--only commands|filter``
(default both), ``--targets N`` (the size of the generated programs of the filter part, default
2000), ``--keep DIR`` (keep both trees' outputs and logs there to look at a difference). On 2
cores with a load average of about 4, the commands part took 3.5 minutes (its 72 steps' own times:
119 s with the reference, 88 s with this tree), the filter part 1.5 minutes with 2000 targets.

What runs (the README's and the tutorial's command lines, on the data shipped in the package and
in tests/data): ``robots``; ``poses`` with its CSV, JSON and HTML and the program of every language
(--rapid --krl --fanuc --urscript --inform --val3, each on a robot of that maker); ``simulate``;
``calibrate`` (model YAML, result JSON, HTML report, with and without a history, robust and
--hold-out, genetic, swarm, neural, payload and thermal terms, a robot on a linear track, a
refusal); ``report``; ``evaluate``; ``check``; ``history``; ``analyze``; ``plan``;
``compensate``; ``export`` (URDF both frames, YAML, ur_calibration, URDF back to YAML);
``import`` (a headerless file made from the shipped demo campaign); ``import-calibration``;
``filter`` on the command line on every program of tests/data/programs (its warnings included;
the corpus's track programs too) and on the campaign programs; ``demo`` (what ``make demo`` writes). The
filter part (``--only filter``) is benchmarks/check_filter_identity.py: the API's filtered programs
and target tables of tests/data/programs and of an N-target program of each format.

Both trees run in the same absolute working folder one after the other (the first one's folder is
moved away before the second starts), so absolute paths written into outputs are equal and need no
mask. What legitimately varies is masked before comparing, in text files and in stdout/stderr:

- dates and times (ISO 8601 ``2026-12-06T03:10:03...``, ``2026-12-06 03:10``, ``Sun Dec  6 ...``),
- durations (``12.3 s``, ``"duration_s": 1.23``, ``elapsed``/``seconds`` fields, ``in 2.1 s``),
- robocal's version string and the two source folders' paths (``REFERENCE_SRC``, this tree's src),
- the figures of ``history*.html`` (the timeline's x axis is the records' write times),
- the result JSON's ``time_s`` (the stage times of a calibration),
- SQLite history files are compared through ``robocal history --json`` (the database file holds
  its write times), not byte for byte.

A difference is printed with the first differing lines of the (masked) file.
"""

from __future__ import annotations

import argparse
import difflib
import math
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
PROGRAMS = HERE.parent / "tests" / "data" / "programs"
TEST_DATA = HERE.parent / "tests" / "data"
STEP_TIMEOUT_S = 900  # one command; a hung child is killed and the step reported as such

# the command line in a fresh interpreter: the `robocal` script's entry point, from PYTHONPATH's tree
_CLI = "import sys; from robocal.cli import main; sys.exit(main(sys.argv[1:]))"

# a few targets (flange, robot base frame, mm and deg) inside the IRB 2600's reach
TARGETS_CSV = """x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg
900,0,1200,180,0,180
950,150,1100,175,5,170
850,-200,1000,180,-10,185
1000,100,900,170,0,180
"""
WAYPOINTS_CSV = TARGETS_CSV
# a KUKA KR 210 on a 6 m linear track (a prismatic first joint: e1 columns in mm)
TRACK_YAML = """units: {length: mm, angle: deg}
name: kr210 on a 6 m track
robot: kuka_kr210_r2700
track: {direction: [1, 0, 0], limits: [0, 6000]}
mount: {xyz: [0, 0, 0], rpy: [0, 0, 0]}
"""
# an LR Mate on a 3 m track, its base near the targets of tests/data/programs/corpus/track_pick.ls
FANUC_TRACK_YAML = """units: {length: mm, angle: deg}
name: lrmate on a 3 m track
robot: fanuc_lrmate200id
track: {direction: [1, 0, 0], limits: [0, 3000]}
mount: {xyz: [-1650, 0, 0], rpy: [0, 0, 0]}
"""
TARGETS_M_CSV = "x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg\n0.9,0,1.2,180,0,180\n0.95,0.15,1.1,175,5,170\n"

CAMPAIGN = "--smr-mm 20,-30,80 --tracker-mm 2500,500,300"

# (label, command line after `robocal`): run in order in one working folder per tree; `{programs}`
# is a copy of tests/data/programs, `{data}` one of tests/data
STEPS: list[tuple[str, str]] = [
    ("robots",
     "robots"),
    ("robots abb_irb2600",
     "robots abb_irb2600"),
    ("poses (tutorial)",
     "poses --robot abb_irb2600 -n 20 {campaign} --candidates 1000 -o poses.csv --html "
     "campaign.html --json campaign.json --rapid Campaign.mod"),
    ("poses --krl",
     "poses --robot kuka_kr16_2 -n 12 --candidates 600 --starts 1 --smr-mm 20,-30,60 -o "
     "poses_kuka.csv --krl Campaign.src"),
    ("poses --fanuc",
     "poses --robot fanuc_lrmate200id -n 12 --candidates 600 --starts 1 --smr-mm 20,-30,60 "
     "-o poses_fanuc.csv --fanuc CAMPAIGN.ls"),
    ("poses --urscript",
     "poses --robot ur5 -n 12 --candidates 600 --starts 1 --smr-mm 20,-30,60 -o "
     "poses_ur5.csv --urscript campaign.script"),
    ("poses --inform",
     "poses --robot yaskawa_gp25 -n 12 --candidates 600 --starts 1 --smr-mm 20,-30,60 -o "
     "poses_gp25.csv --inform CAMPAIGN.JBI"),
    ("poses --val3",
     "poses --robot staubli_tx2_140 -n 10 --candidates 600 --starts 1 --smr-mm 20,-30,60 "
     "-o poses_tx2.csv --val3 val3_campaign"),
    ("poses --check",
     "poses --robot abb_irb2600 -n 12 --check --candidates 600 --starts 1 {campaign} -o "
     "poses_check.csv"),
    ("simulate measured",
     "simulate --robot abb_irb2600 --joints poses.csv {campaign} --seed 7 -o measured.csv "
     "--truth truth.yaml"),
    ("simulate check",
     "simulate --robot truth.yaml --as-is --poses 100 --tracker-mm 2500,500,300 --seed 8 "
     "-o check.csv --truth truth_check.yaml"),
    ("simulate pose kind",
     "simulate --robot kuka_kr16_2 --poses 40 --kind pose --seed 3 -o kuka_pose.csv "
     "--truth truth_kuka.yaml"),
    ("simulate fanuc",
     "simulate --robot fanuc_lrmate200id --poses 30 --seed 4 -o fanuc.csv --truth "
     "truth_fanuc.yaml"),
    ("simulate ur5",
     "simulate --robot ur5 --poses 30 --seed 5 -o ur5.csv --truth truth_ur5.yaml"),
    ("simulate gp25",
     "simulate --robot yaskawa_gp25 --poses 30 --seed 6 -o gp25.csv --truth "
     "truth_gp25.yaml"),
    ("simulate tx2",
     "simulate --robot staubli_tx2_140 --poses 30 --seed 9 -o tx2.csv --truth "
     "truth_tx2.yaml"),
    ("calibrate (tutorial)",
     "calibrate measured.csv --robot abb_irb2600 --validate check.csv -o calibrated.yaml "
     "--json result.json --report report.html"),
    ("calibrate history",
     "calibrate measured.csv --robot abb_irb2600 --validate check.csv -o calibrated_h.yaml "
     "--json result_h.json --history robots.sqlite --robot-id IRB-1"),
    ("calibrate robust hold-out",
     "calibrate check.csv --robot abb_irb2600 --method robust --hold-out 30 -o "
     "calibrated_robust.yaml --json result_robust.json"),
    ("calibrate pose kind",
     "calibrate kuka_pose.csv --robot kuka_kr16_2 -o calibrated_kuka.yaml --json "
     "result_kuka.json"),
    ("calibrate refused",
     "calibrate missing.csv --robot abb_irb2600 -o never.yaml"),
    ("import",
     "import raw.txt --joints cols=0-5:deg --points cols=6-8:mm -o imported.csv"),
    ("evaluate imported",
     "evaluate abb_irb2600 imported.csv --fit-frame"),
    ("calibrate genetic",
     "calibrate measured.csv --robot abb_irb2600 --method genetic --seed 1 --force "
     "-o calibrated_genetic.yaml --json result_genetic.json"),
    ("calibrate swarm",
     "calibrate measured.csv --robot abb_irb2600 --method swarm --seed 1 -o calibrated_swarm.yaml "
     "--json result_swarm.json"),
    ("calibrate neural",
     "calibrate measured.csv --robot abb_irb2600 --method neural --seed 1 -o calibrated_neural.yaml "
     "--json result_neural.json"),
    ("simulate payloads and temperatures",
     "simulate --robot abb_irb2600 --poses 80 --payloads 0,6,12 --payload-com-mm 0,0,80 --temperatures 20:35 "
     "--seed 11 -o loaded.csv --truth truth_loaded.yaml"),
    ("calibrate payload thermal",
     "calibrate loaded.csv --robot abb_irb2600 --nongeometric payload,thermal -o calibrated_loaded.yaml "
     "--json result_loaded.json --report report_loaded.html"),
    ("compensate with payload and temperature",
     "compensate calibrated_loaded.yaml targets.csv --nominal abb_irb2600 --payload 8,0,0,80 "
     "--temperature 30 -o commands_loaded.csv"),
    ("filter with payload and temperature",
     "filter {programs}/weld_cell.mod --calibrated calibrated_loaded.yaml --nominal abb_irb2600 "
     "--payload 8,0,0,80 --temperature 30 -o weld_loaded.mod"),
    ("poses along a track",
     "poses --robot track.yaml -n 20 -o track_poses.csv --json track_poses.json --candidates 800 --starts 1 "
     "--region-size 300"),
    ("simulate track",
     "simulate --robot track.yaml --poses 120 --seed 5 -o track_all.csv --truth track_truth.yaml"),
    ("calibrate track",
     "calibrate track_all.csv --robot track.yaml --nongeometric none --hold-out 30 -o track_cal.yaml "
     "--json track_result.json"),
    ("evaluate track",
     "evaluate track_cal.yaml track_all.csv --json track_evaluate.json"),
    ("export track urdf",
     "export track_cal.yaml --urdf track.urdf"),
    ("simulate fanuc track",
     "simulate --robot fanuc_track.yaml --poses 30 --seed 2 -o fanuc_track.csv "
     "--truth fanuc_track_truth.yaml"),
    ("filter fanuc track",
     "filter {programs}/corpus/track_pick.ls --frame 1=450,-150,100,0,0,-10 --tool 2=0,0,120,0,0,0 "
     "--calibrated fanuc_track_truth.yaml --nominal fanuc_track.yaml -o track_pick_cal.ls --keep-unreached"),
    ("filter rapid track targets named",
     "filter {programs}/corpus/track_mill.mod --calibrated calibrated.yaml --nominal abb_irb2600 "
     "-o track_mill_cal.mod"),
    ("filter inform track",
     "filter {programs}/corpus/TRACK_WELD.JBI --tool 1=0,-35,410,0,-30,0 --tool 3=0,0,180,0,0,0 "
     "--frame 2=1250,-300,450,0,0,15 --calibrated truth_gp25.yaml --nominal yaskawa_gp25 "
     "-o TRACK_WELD_CAL.JBI --keep-unreached"),
    ("report",
     "report result.json -o report_again.html --title 'IRB 2600, cell 4'"),
    ("evaluate",
     "evaluate calibrated.yaml check.csv --json evaluate.json"),
    ("evaluate --fit-frame",
     "evaluate abb_irb2600 check.csv --fit-frame"),
    ("check",
     "check calibrated.yaml check.csv --fit-frame --result result.json --noise-mm 0.02 "
     "--json check.json"),
    ("check history",
     "check calibrated_h.yaml check.csv --fit-frame --noise-mm 0.02 --history "
     "robots.sqlite --robot-id IRB-1 --json check_h.json"),
    ("history",
     "history robots.sqlite --robot-id IRB-1 --json history.json --report history.html"),
    ("analyze",
     "analyze poses.csv --robot abb_irb2600"),
    ("plan",
     "plan waypoints.csv --robot abb_irb2600 -o joints.csv"),
    ("plan calibrated",
     "plan waypoints.csv --robot calibrated.yaml --nominal abb_irb2600 -o joints_cal.csv"),
    ("compensate",
     "compensate calibrated.yaml targets.csv --nominal abb_irb2600 --parameters params.csv "
     "--result result.json -o commands.csv"),
    ("compensate again refused",
     "compensate calibrated.yaml commands.csv --nominal abb_irb2600 -o twice.csv"),
    ("export urdf",
     "export calibrated.yaml --urdf calibrated.urdf"),
    ("export urdf model frames",
     "export calibrated.yaml --urdf measured.urdf --frames model"),
    ("export yaml",
     "export calibrated.yaml --yaml exported.yaml"),
    ("export urdf to yaml",
     "export calibrated.urdf --yaml from_urdf.yaml"),
    ("export ur-calibration",
     "export truth_ur5.yaml --nominal ur5 --ur-calibration ur5_calibration.yaml"),
    ("import-calibration conf",
     "import-calibration {data}/ur5e_calibration.conf --robot ur5e -o ur5e_factory.yaml"),
    ("import-calibration yaml",
     "import-calibration {data}/ur10e_calibration.yaml --robot ur10e -o ur10e_ros.yaml"),
    ("filter (README)",
     "filter {programs}/weld_cell.mod --calibrated calibrated.yaml --nominal abb_irb2600 "
     "-o cell_cal.mod --table cell_cal_table.csv"),
    ("filter rapid corpus",
     "filter {programs}/corpus/arc_station.mod {programs}/corpus/glue_offsets.mod "
     "{programs}/corpus/machine_tending.mod {programs}/corpus/pallet_multimove.mod "
     "--calibrated calibrated.yaml --nominal abb_irb2600 -o filtered_rapid "
     "--keep-unreached"),
    ("filter krl",
     "filter {programs}/palletize.src {programs}/palletize.dat --references "
     "{programs}/config.dat --calibrated truth_kuka.yaml --nominal kuka_kr16_2 -o "
     "filtered_krl --keep-unreached"),
    ("filter krl corpus",
     "filter {programs}/corpus/deburr_cell.src {programs}/corpus/deburr_cell.dat "
     "--references '{programs}/corpus/$config.dat' --calibrated truth_kuka.yaml --nominal "
     "kuka_kr16_2 -o filtered_krl_corpus --keep-unreached"),
    ("filter fanuc",
     "filter {programs}/sealing.ls --frame 1=450,-150,100,0,0,-10 --tool 2=0,0,120,0,0,0 "
     "--calibrated truth_fanuc.yaml --nominal fanuc_lrmate200id -o sealing_cal.ls "
     "--keep-unreached"),
    ("filter fanuc registers",
     "filter {programs}/corpus/weld_bracket.ls --position-registers "
     "{programs}/corpus/weld_registers.csv --frame 1=450,-150,100,0,0,-10 --tool "
     "2=0,0,120,0,0,0 --calibrated truth_fanuc.yaml --nominal fanuc_lrmate200id -o "
     "weld_bracket_cal.ls --keep-unreached"),
    ("filter urscript",
     "filter {programs}/pick_place.script --calibrated truth_ur5.yaml --nominal ur5 -o "
     "pick_place_cal.script --keep-unreached"),
    ("filter inform",
     "filter {programs}/corpus/WELD_UF2.JBI {programs}/corpus/PICK_PLACE.JBI "
     "{programs}/corpus/VAR.DAT --tool 1=0,-35,410,0,-30,0 --tool 3=0,0,180,0,0,0 --frame "
     "2=1250,-300,450,0,0,15 --calibrated truth_gp25.yaml --nominal yaskawa_gp25 -o "
     "filtered_inform --keep-unreached"),
    ("filter val3",
     "filter {programs}/val3/pick_place --calibrated truth_tx2.yaml --nominal "
     "staubli_tx2_140 -o filtered_val3 --keep-unreached"),
    ("filter campaign program (joint targets)",
     "filter Campaign.mod --calibrated calibrated.yaml --nominal abb_irb2600 -o "
     "Campaign_cal.mod"),
    ("filter unused payload warned",
     "filter {programs}/weld_cell.mod --calibrated calibrated.yaml --nominal abb_irb2600 "
     "--payload 5000 -o never.mod"),
    ("filter frame in metres refused",
     "filter {programs}/sealing.ls --frame 1=0.45,-0.15,0.1,0,0,-10 --tool 2=0,0,120,0,0,0 "
     "--calibrated truth_fanuc.yaml --nominal fanuc_lrmate200id -o never.ls"),
    ("filter robot base in metres refused",
     "filter {programs}/weld_cell.mod --calibrated calibrated.yaml --nominal abb_irb2600 "
     "--robot-base 1.2,0.3,0,0,0,0 -o never2.mod"),
    ("compensate targets in metres refused",
     "compensate calibrated.yaml targets_m.csv --nominal abb_irb2600 -o never.csv"),
    ("demo (make demo)",
     "demo"),
]

# the folders the steps write into before they run (filter -o FOLDER needs an existing folder)
FOLDERS = ["filtered_rapid", "filtered_krl", "filtered_krl_corpus", "filtered_inform", "filtered_val3"]

# what legitimately varies between two runs of the same tree (see the module docstring)
MASKS: list[tuple[re.Pattern, str]] = [
    (re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}:?\d{2})?"), "<TIME>"),
    (re.compile(r"\b(Mon|Tue|Wed|Thu|Fri|Sat|Sun) (Jan|Feb|Mar|Apr|May|Jun|Jul|Aug|Sep|Oct|Nov|Dec) "
                r"+\d+ \d{2}:\d{2}:\d{2} \d{4}\b"), "<TIME>"),
    (re.compile(r"(\"[a-z_]*(duration|elapsed|seconds|time_s|_s)\"\s*:\s*)[-+0-9.eE]+"), r"\1<DURATION>"),
    (re.compile(r"\b\d+(\.\d+)?\s?(s|ms|min)\b(?=[^a-zA-Z0-9]|$)"), "<DURATION>"),
    (re.compile(r'("time_s"\s*:\s*\{)[^}]*\}'), r"\1<DURATIONS>}"),  # the result JSON's stage times
]
# files whose figures plot against the write time (the history's timeline): the inline SVG masked
FIGURES_MASKED = re.compile(r"history[^/]*\.html$")
FIGURE = re.compile(r"<svg.*?</svg>", re.DOTALL)


def masked(text: str, fixed: list[str], name: str = "") -> str:
    """``text`` (of the file ``name``) with what legitimately varies replaced by a placeholder
    (see MASKS and FIGURES_MASKED)."""
    if FIGURES_MASKED.search(name):
        text = FIGURE.sub("<FIGURE>", text)
    for value in fixed:
        text = text.replace(value, "<FIXED>")
    for pattern, repl in MASKS:
        text = pattern.sub(repl, text)
    return text


def raw_tracker_file(src: Path, rows: int = 40) -> str:
    """A headerless tracker/controller file for ``robocal import``: the first ``rows`` rows of the
    demo campaign shipped with the package in the tree ``src`` (joints in deg, then the point in
    mm, space-separated)."""
    demo = src / "robocal" / "demo_data" / "calibration.csv"
    lines = [line.split(",") for line in demo.read_text().splitlines()[2:2 + rows]]
    return "".join(" ".join([*(f"{float(v) * 180 / math.pi:.6f}" for v in cells[2:8]),
                             *(f"{float(v) * 1000:.4f}" for v in cells[8:11])]) + "\n" for cells in lines)


def run_steps(src: Path, work: Path, log: Path, steps: list[tuple[str, str]], raw: str) -> dict[str, float]:
    """Run the steps with the tree ``src`` in ``work`` (``raw``: the text of raw.txt); stdout,
    stderr and exit code of step k in ``log/k.out``, ``k.err``, ``k.rc``. Returns each step's wall
    time (s)."""
    shutil.copytree(PROGRAMS, work / "programs")
    shutil.copytree(TEST_DATA, work / "data", ignore=shutil.ignore_patterns("programs"))
    (work / "targets.csv").write_text(TARGETS_CSV)
    (work / "waypoints.csv").write_text(WAYPOINTS_CSV)
    (work / "targets_m.csv").write_text(TARGETS_M_CSV)
    (work / "raw.txt").write_text(raw)
    (work / "track.yaml").write_text(TRACK_YAML)
    (work / "fanuc_track.yaml").write_text(FANUC_TRACK_YAML)
    for name in FOLDERS:
        (work / name).mkdir()
    log.mkdir()
    env = {**os.environ, "PYTHONPATH": str(src), "ROBOCAL_DEBUG": "1"}
    env.pop("COLUMNS", None)
    times = {}
    for k, (label, line) in enumerate(steps):
        argv = shlex.split(line.format(programs="programs", data="data", campaign=CAMPAIGN))
        t = time.perf_counter()
        child = subprocess.Popen([sys.executable, "-c", _CLI, *argv], cwd=work, env=env, text=True,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
        try:
            out, err = child.communicate(timeout=STEP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            os.killpg(child.pid, signal.SIGKILL)
            out, err = child.communicate()
            err += f"\n<KILLED after {STEP_TIMEOUT_S} s>"
        times[label] = time.perf_counter() - t
        (log / f"{k:02d}.out").write_text(out)
        (log / f"{k:02d}.err").write_text(err)
        (log / f"{k:02d}.rc").write_text(f"{child.returncode}\n")
    return times


def first_difference(a: bytes, b: bytes, fixed: list[str], name: str = "") -> tuple[bool, str]:
    """(same, a few lines showing the first difference) of the two contents of the file ``name``,
    masked if text."""
    if a == b:
        return True, ""
    try:
        ta, tb = masked(a.decode(), fixed, name), masked(b.decode(), fixed, name)
    except UnicodeDecodeError:
        return False, "    (binary files differ)"
    if ta == tb:
        return True, ""
    diff = difflib.unified_diff(ta.splitlines(), tb.splitlines(), "reference", "this tree", n=0, lineterm="")
    lines = [line[:200] for line in diff][2:8]
    return False, "\n".join(f"    {line}" for line in lines)


def compare_trees(ref: Path, new: Path, fixed: list[str]) -> list[tuple[str, str]]:
    """(relative path, first difference) of every file that differs or exists on one side only."""
    files = {p.relative_to(ref) for p in ref.rglob("*") if p.is_file()}
    files |= {p.relative_to(new) for p in new.rglob("*") if p.is_file()}
    out = []
    for rel in sorted(files):
        if rel.suffix == ".sqlite" or rel.parts[0] in ("programs", "data"):
            continue  # write times inside (compared via `history --json`); the inputs
        a, b = ref / rel, new / rel
        if not (a.is_file() and b.is_file()):
            out.append((str(rel), f"    only in {'the reference' if a.is_file() else 'this tree'}"))
            continue
        same, shown = first_difference(a.read_bytes(), b.read_bytes(), fixed, str(rel))
        if not same:
            out.append((str(rel), shown))
    return out


def written_by(step: int, steps: list[tuple[str, str]], rel: str) -> bool:
    """Whether the output file ``rel`` is named in step ``step``'s command line."""
    words = shlex.split(steps[step][1])
    return any(w and (rel == w or rel.startswith(w.rstrip("/") + "/")) for w in words)


def check_commands(reference: Path, tree: Path, keep: Path | None) -> int:
    """Run every step with both trees (their ``src`` folders) and print one line per step; the
    number of steps that differ."""
    steps = STEPS
    fixed = sorted({str(reference), str(tree)}, key=len, reverse=True)
    base = Path(tempfile.mkdtemp(prefix="robocal-identity-"))
    try:
        work = base / "work"
        trees = {}
        for name, src in (("reference", reference), ("this tree", tree)):
            work.mkdir()
            times = run_steps(src, work, base / f"log {name}", steps, raw_tracker_file(reference))
            trees[name] = times
            work.rename(base / name)
        ref_dir, new_dir = base / "reference", base / "this tree"
        differing = compare_trees(ref_dir, new_dir, fixed)
        failed = 0
        claimed: set[str] = set()
        for k, (label, _) in enumerate(steps):
            problems = []
            for stream in ("out", "err", "rc"):
                a = (base / "log reference" / f"{k:02d}.{stream}").read_bytes()
                b = (base / "log this tree" / f"{k:02d}.{stream}").read_bytes()
                same, shown = first_difference(a, b, fixed)
                if not same:
                    problems.append(f"  std{stream}:\n{shown}" if stream != "rc" else
                                    f"  exit code {a.decode().strip()} -> {b.decode().strip()}")
            for rel, shown in differing:
                if rel not in claimed and written_by(k, steps, rel):
                    claimed.add(rel)
                    problems.append(f"  {rel}:\n{shown}")
            failed += bool(problems)
            rc = (base / "log this tree" / f"{k:02d}.rc").read_text().strip()
            verdict = "DIFFERENT" if problems else "same"
            print(f"{label:40s} {verdict} (exit {rc})  {trees['reference'][label]:.1f} s -> "
                  f"{trees['this tree'][label]:.1f} s", flush=True)
            for p in problems:
                print(p)
        rest = [(rel, shown) for rel, shown in differing if rel not in claimed]
        for rel, shown in rest:  # files no command line names (e.g. the demo's folder)
            print(f"{'file ' + rel:40s} DIFFERENT\n{shown}")
        failed += bool(rest)
        n_files = sum(1 for p in new_dir.rglob("*") if p.is_file())
        print(f"commands: {len(steps)} steps, {n_files} files compared: "
              f"{'all the same' if not failed else f'{failed} difference(s)'}", flush=True)
        return failed
    finally:
        if keep is not None:
            shutil.rmtree(keep, ignore_errors=True)
            shutil.copytree(base, keep)
            print(f"outputs kept in {keep}")
        shutil.rmtree(base, ignore_errors=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("reference", type=Path, help="the src folder of the reference tree")
    parser.add_argument("--tree", type=Path, default=SRC,
                        help="the src folder of the tree to check (default: this script's ../src)")
    parser.add_argument("--only", choices=["commands", "filter"], help="run one part (default both)")
    parser.add_argument("--targets", type=int, default=2000, help="targets of the filter part's programs")
    parser.add_argument("--keep", type=Path, help="copy both trees' outputs and logs here")
    args = parser.parse_args(argv)
    reference, tree = args.reference.resolve(), args.tree.resolve()
    failed = 0
    if args.only in (None, "commands"):
        failed += check_commands(reference, tree, args.keep)
    if args.only in (None, "filter"):
        sys.path.insert(0, str(HERE))
        import check_filter_identity

        failed += check_filter_identity.main(reference, args.targets, tree)
    verdict = "all the same" if not failed else "DIFFERENCES (see above)"
    print(f"{time.strftime('%H:%M')} output identity: {verdict}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
