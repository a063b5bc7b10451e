"""Filtering a program in each robot language
===========================================

A calibrated model is of use to the robot only through its programs: every Cartesian target in
them is moved so that the real robot reaches the point the programmer meant, and the program keeps
its text, comments, line ends and structure. This example filters one sample program of each
family robocal reads -- ABB RAPID, KUKA KRL, FANUC TP, URScript, Yaskawa INFORM and a Staubli VAL3
application -- each through a calibrated copy of its robot (simulated: the catalog robot with
known random errors, fixed seed). Motions robocal cannot correct (a target computed at run time)
are named, never silently skipped.
"""

import shutil
from importlib.resources import files
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import robocal as rc
from robocal.data.simulate import perturbed

demo = files("robocal") / "demo_data"  # sample programs shipped with robocal (`robocal sample`)


def copy(*names: str) -> list[Path]:
    """Sample files copied into the working folder (the filter never writes its inputs)."""
    return [Path(shutil.copyfile(str(demo / n), n)) for n in names]


# %% One program per language: its files, files read for declarations only, robot, options
val3_app = shutil.copytree(str(demo / "val3_pick_place"), "pick_place", dirs_exist_ok=True)
cases = {
    "ABB RAPID": (copy("weld_cell.mod"), [], "abb_irb2600", {}),
    "KUKA KRL": (copy("palletize.src", "palletize.dat"), copy("config.dat"),
                 "kuka_kr16_2", {}),
    "FANUC TP": (copy("sealing.ls"), [], "fanuc_lrmate200id",  # its frame and tool
                 {"frames": {"1": "450,-150,100,0,0,-10"},
                  "tools": {"2": "0,0,120,0,0,0"}}),
    "URScript": (copy("pick_place.script"), [], "ur5", {}),
    "Yaskawa INFORM": (copy("PALLETIZE.JBI"), copy("TOOL.CND"), "yaskawa_gp180", {}),
    "Staubli VAL3": ([Path(val3_app)], [], "staubli_tx2_140", {}),  # an application folder
}

# %% Filter each through its calibrated robot; the corrected copies go under filtered/
corrections = {}
for language, (programs, references, robot, options) in cases.items():
    nominal = rc.Robot.from_catalog(robot)
    calibrated = perturbed(nominal, 7)  # stands for `rc.calibrate(...).robot`
    result = rc.filter_program(programs, calibrated, nominal, references=references,
                               **options)
    targets = {src: Path("filtered") / src for src in result.outputs}  # the same names
    for dst in targets.values():
        dst.parent.mkdir(parents=True, exist_ok=True)
    written = result.write(targets)
    print(result.summary().splitlines()[0])
    print("   " + result.summary().splitlines()[1].strip())
    print(f"   written: {', '.join(Path(p).name for p in written)}")
    corrections[language] = [r["correction_mm"] for r in result.rows if r["filtered"]]

# %% What changed in the RAPID module: its targets' numbers (and a marker line on top)
before, after = ([t.strip() for t in Path(f).read_text().splitlines()
                  if t.lstrip().startswith("CONST robtarget")]
                 for f in ("weld_cell.mod", "filtered/weld_cell.mod"))
print(f"weld_cell.mod, first target:\n  before {before[0]}\n  after  {after[0]}")

# %% Figure: how far the calibration moved each program's targets
fig, ax = plt.subplots(figsize=(5, 3.2), layout="constrained")
rng = np.random.default_rng(0)
for k, mm in enumerate(corrections.values()):
    ax.scatter(k + rng.uniform(-0.15, 0.15, len(mm)), mm, s=14)  # jittered: every target
ax.set_xticks(range(len(corrections)), [name.replace(" ", "\n") for name in corrections])
ax.set(ylabel="target correction, mm", title="Each language's targets, filtered")
fig.savefig("06_filter_languages.png", dpi=120)
