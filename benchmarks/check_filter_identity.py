"""Byte identity of ``robocal filter`` against another source tree (e.g. the main branch before a
speed change): every program of tests/data/programs (with the options the tests give them) and a
``N``-target program of each format bench_filter writes (10,000 by default) are filtered by each
tree in its own interpreter, and the filtered files and the target table (CSV and JSON) compared
byte for byte. Exit 0 when every output is the same; one line per case either way.

``python benchmarks/check_filter_identity.py REFERENCE_SRC [N]`` (REFERENCE_SRC: the ``src``
folder of the other tree, e.g. a worktree of main). benchmarks/check_output_identity.py runs this
check after comparing the outputs of every other command.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SRC = HERE.parent / "src"
DATA = HERE.parent / "tests" / "data" / "programs"
# (files, nominal, options): the programs the tests filter, with the tools / frames they give
CORPUS = [(["weld_cell.mod"], "abb_irb2600", {}),
          (["palletize.src", "palletize.dat"], "kuka_kr16_2", {"references": ["config.dat"]}),
          (["sealing.ls"], "fanuc_lrmate200id", {"frames": {"1": "450,-150,100,0,0,-10"},
                                                 "tools": {"2": "0,0,120,0,0,0"}}),
          (["pick_place.script"], "ur5", {}),
          (["corpus/arc_station.mod"], "abb_irb2600", {}),
          (["corpus/glue_offsets.mod"], "abb_irb2600", {}),
          (["corpus/machine_tending.mod"], "abb_irb2600", {}),
          (["corpus/pallet_multimove.mod"], "abb_irb2600", {}),
          (["corpus/deburr_cell.src", "corpus/deburr_cell.dat"], "kuka_kr16_2",
           {"references": ["corpus/$config.dat"]}),
          (["corpus/sealer_cell.src", "corpus/sealer_cell.dat"], "kuka_kr16_2",
           {"references": ["corpus/$config.dat"]}),
          (["corpus/weld_bracket.ls"], "fanuc_lrmate200id", {"frames": {"1": "450,-150,100,0,0,-10"},
                                                             "tools": {"2": "0,0,120,0,0,0"}}),
          (["corpus/palletizing_ur5.script"], "ur5", {}),
          (["corpus/screw_station.script"], "ur5", {}),
          (["corpus/WELD_UF2.JBI", "corpus/VAR.DAT"], "yaskawa_gp25", {}),
          (["corpus/PICK_PLACE.JBI", "corpus/VAR.DAT"], "yaskawa_gp25", {})]

# run by each tree: filter the case in options.json, write the outputs into a folder
_RUNNER = """
import json, sys, time
from pathlib import Path
from robocal.data.simulate import perturbed
import robocal as rc
case = json.loads(Path(sys.argv[1]).read_text())
out = Path(sys.argv[2])
nominal = rc.Robot.from_catalog(case["nominal"])
paths = [Path(p) for p in case["paths"]]
t = time.perf_counter()
try:
    res = rc.filter_program(paths, perturbed(nominal, 0), nominal, keep_unreached=True,
                            **case["options"])
except Exception as exc:  # the same refusal is the same result
    (out / "error.txt").write_text(f"{type(exc).__name__}: {exc}")
else:
    res.write({p: out / p.name for p in paths}, out / "table")
print(time.perf_counter() - t)
"""


def run(src: Path, case: Path, out: Path) -> float:
    """Filter the case with the tree ``src`` in a fresh interpreter; its filter time (s)."""
    out.mkdir()
    done = subprocess.run([sys.executable, "-c", _RUNNER, str(case), str(out)], capture_output=True,
                          text=True, env={**os.environ, "PYTHONPATH": str(src)}, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def compare(a: Path, b: Path) -> list[str]:
    """Names of the files that differ (or exist on one side only) between two output folders."""
    names = sorted({p.name for p in a.iterdir()} | {p.name for p in b.iterdir()})
    return [n for n in names if not ((a / n).exists() and (b / n).exists()
                                     and (a / n).read_bytes() == (b / n).read_bytes())]


def cases(folder: Path, n: int) -> list[tuple[str, dict]]:
    """(label, case) of the test programs and of an ``n``-target program of each format."""
    out = []
    for files, nominal, options in CORPUS:
        opts = dict(options)
        if "references" in opts:
            opts["references"] = [str(DATA / r) for r in opts["references"]]
        out.append((files[0], {"paths": [str(DATA / f) for f in files], "nominal": nominal, "options": opts}))
    sys.path.insert(0, str(HERE))
    import numpy as np
    from bench_filter import SPEED_CASES, _joints

    import robocal as rc
    from robocal.kinematics.transforms import make_transform
    from robocal.programs.simulate import write_program

    tool = make_transform(np.eye(3), np.array([0.03, 0.0, 0.12]))
    frame = make_transform(np.eye(3), np.array([0.4, -0.1, 0.05]))
    for dialect, name, variables in SPEED_CASES:
        sub = folder / f"{dialect}{'_variables' if variables else ''}"
        sub.mkdir()
        nominal = rc.Robot.from_catalog(name)
        q = _joints(nominal, min(n, 99_999) if dialect == "fanuc" else n, np.random.default_rng(1), dialect)
        paths, tools, frames = write_program(dialect, sub, nominal, q, tool, frame, variables=variables)
        out.append((f"{dialect} {len(q)} targets" + (" (variables)" if variables else ""),
                    {"paths": [str(p) for p in paths], "nominal": name,
                     "options": {"tools": tools, "frames": frames}}))
    return out


def main(reference: Path, n: int = 10_000, tree: Path = SRC) -> int:
    """Filter every case with the trees ``reference`` and ``tree`` (``src`` folders) and print one
    line per case; 1 when any output differs."""
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, case) in enumerate(cases(Path(tmp), n)):
            spec = Path(tmp) / f"case{k}.json"
            spec.write_text(json.dumps(case))
            t_ref = run(reference, spec, Path(tmp) / f"ref{k}")
            t_new = run(tree, spec, Path(tmp) / f"new{k}")
            differ = compare(Path(tmp) / f"ref{k}", Path(tmp) / f"new{k}")
            failed += bool(differ)
            files = len(list((Path(tmp) / f"new{k}").iterdir()))
            print(f"{label:40s} {'DIFFERENT: ' + ', '.join(differ) if differ else f'same ({files} files)'}"
                  f"  filter {t_ref:.2f} s -> {t_new:.2f} s", flush=True)
    print(f"{time.strftime('%H:%M')} {'all the same' if not failed else f'{failed} case(s) differ'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]).resolve(), *(int(a) for a in sys.argv[2:3])))
