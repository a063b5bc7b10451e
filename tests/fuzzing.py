"""Mutation fuzzing of every reader of the command line (shared by tests/test_fuzz_readers.py and
the long run scripts/fuzz_readers.py).

A reader is a command that reads one kind of user file; its seed files are real robocal files
(simulated measurements, a catalog model, a result JSON, the hand-written programs of
tests/data/programs). A mutant changes the seed file by one to three operators (lines deleted,
duplicated or swapped, numbers replaced by extreme or ambiguous forms, characters inserted or
deleted, the file truncated, a structure nested deeply, a JSON node given another type or shape).
The contract of the CLI on any input (:func:`check`): exit 0 with every output written, or exit 2
with one line on stderr (a warning line before it allowed); never exit 3 (internal error), never
a traceback or a stray warning line, never an input modified. ``mutate(..., encodings=True)`` adds
byte-level changes (:func:`_encoding_op`: BOM, CRLF/CR, NUL, bytes that are no UTF-8, huge numbers,
a line copied, a file named in place of another); :func:`same_whatever_the_bytes` checks that a
file with a BOM or other line ends reads as it is (tests/test_fuzz_inputs.py).
"""

from __future__ import annotations

import contextlib
import difflib
import io
import json
import os
import random
import re
import shutil
import signal
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.cli import main
from robocal.data.simulate import perturbed
from robocal.kinematics.model import Robot

PROGRAMS = Path(__file__).resolve().parent / "data" / "programs"
EXTREMES = [
    b"1e308",
    b"-1e308",
    b"1e-320",
    b"nan",
    b"NaN",
    b"inf",
    b"-inf",
    b"0",
    b"-0",
    b"0135",
    b"0x1F",
    b"1:30",
    b"1_000",
    b"2e9",
    b"12",
    b"-7",
    b"720",
    b"99999999",
    b"3.5",
    b'""',
    b"$x$",
    b"$\\frac{",
    b"[]",
    b"{}",
    b"null",
    b"true",
    b"~",
    b"1" * 5000,
    b"1e",
    b"--1",
    b"1..2",
    b"",
    b"*a",
    b"&a",
]
CHARS = b" ,;:[]{}()\"'$-+.0123456789eE\n\t#*&!xX\\/<>=%@|\x00\xff\xe9"
MAX_MUTANT = 20_000_000  # bytes: a mutant larger than this is not grown further
NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
WORD = re.compile(rb"[A-Za-z_][A-Za-z0-9_]*")


@dataclass
class Reader:
    """A command reading ``targets`` (one is mutated per case) among ``files`` in a case folder."""

    name: str
    files: dict[str, bytes]
    targets: list[str]
    argv: Callable[[Path], list[str]]
    outputs: list[str]
    kind: str = "text"  # 'json' adds structural mutations
    extra: dict = field(default_factory=dict)


# ----------------------------------------------------------------- seeds
def _run(argv: list[str]) -> None:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(["--quiet", *argv])
    assert code == 0, argv


def _trim_result(data: dict, rows: int = 25) -> dict:
    """A smaller result (fewer observation rows): the report renders it faster."""
    for key in ("observations", "validation_observations"):
        obs = data.get(key)
        if isinstance(obs, dict):
            for k, v in obs.items():
                if isinstance(v, list):
                    obs[k] = v[:rows]
    return data


def build_readers(folder: Path) -> dict[str, Reader]:
    """Every reader with its seed files (made in ``folder`` by simulate/calibrate/export)."""
    folder.mkdir(parents=True, exist_ok=True)
    readers: dict[str, Reader] = {}
    truth = folder / "truth.yaml"
    for kind in ("point", "pose", "plane", "distance"):
        data = folder / f"{kind}.csv"
        _run(
            [
                "simulate",
                "--robot",
                "abb_irb2600",
                "--poses",
                "12",
                "--kind",
                kind,
                "--seed",
                "1",
                "-o",
                str(data),
                "--truth",
                str(folder / f"truth_{kind}.yaml"),
            ]
        )
        files = {"data.csv": data.read_bytes(), "truth.yaml": (folder / f"truth_{kind}.yaml").read_bytes()}
        readers[f"csv_{kind}"] = Reader(
            f"csv_{kind}",
            files,
            ["data.csv"],
            lambda d: ["evaluate", str(d / "truth.yaml"), str(d / "data.csv"), "--json", str(d / "out.json")],
            ["out.json"],
        )
    shutil.copy(folder / "truth_point.yaml", truth)
    # import, layout 1: one file per pose reading, joints and points on each row (Meca500 style)
    rng = np.random.default_rng(0)
    q = rng.uniform(-90, 90, (6, 6))
    p = rng.uniform(-1, 1, (6, 3))
    rows = [
        ",".join(f"{v:.6f}" for v in (*qq, *(pp + rng.normal(0, 1e-5, 3))))
        for qq, pp in zip(q, p, strict=True)
        for _ in range(3)
    ]
    readers["import_rows"] = Reader(
        "import_rows",
        {"raw.csv": ("\n".join(rows) + "\n").encode()},
        ["raw.csv"],
        lambda d: [
            "import",
            str(d / "raw.csv"),
            "--joints",
            "cols=0-5:deg",
            "--points",
            "cols=6-8:m",
            "-o",
            str(d / "out.csv"),
        ],
        ["out.csv"],
    )
    # import, layout 2: a joints file, one file per SMR (mm) and a base drift monitor (IRB 120 style)
    joints = "\n".join(" ".join(f"{v:.4f}" for v in qq) for qq in q) + "\n"
    smr = ["\n".join(" ".join(f"{v:.4f}" for v in pp * 1000 + k * 50) for pp in p) + "\n" for k in range(2)]
    base = (
        "\n".join(
            " ".join(f"{v:.4f}" for v in np.array([100.0, 200, 300]) + rng.normal(0, 0.005, 3))
            for _ in range(6)
        )
        + "\n"
    )
    readers["import_files"] = Reader(
        "import_files",
        {
            "joints.txt": joints.encode(),
            "smr1.txt": smr[0].encode(),
            "smr2.txt": smr[1].encode(),
            "base.txt": base.encode(),
        },
        ["joints.txt", "smr1.txt", "smr2.txt", "base.txt"],
        lambda d: [
            "import",
            "--joints",
            f"{d / 'joints.txt'}:cols=0-5:deg",
            "--points",
            f"{d / 'smr1.txt'}:mm",
            "--points",
            f"{d / 'smr2.txt'}:mm",
            "--base",
            f"{d / 'base.txt'}:mm",
            "-o",
            str(d / "out.csv"),
        ],
        ["out.csv"],
    )
    catalog = Path(__import__("robocal").__file__).parent / "catalog"
    for name in ("abb_irb2600", "ur5", "puma560"):  # an OPW set, a UR DH table, a modified DH table
        readers[f"model_{name}"] = Reader(
            f"model_{name}",
            {"m.yaml": (catalog / f"{name}.yaml").read_bytes()},
            ["m.yaml"],
            lambda d: ["export", str(d / "m.yaml"), "--urdf", str(d / "out.urdf")],
            ["out.urdf"],
        )
    readers["model_saved"] = Reader(
        "model_saved",
        {"m.yaml": truth.read_bytes()},
        ["m.yaml"],
        lambda d: ["export", str(d / "m.yaml"), "--urdf", str(d / "out.urdf")],
        ["out.urdf"],
    )
    _run(["export", "abb_irb2600", "--urdf", str(folder / "r.urdf")])
    readers["urdf"] = Reader(
        "urdf",
        {"r.urdf": (folder / "r.urdf").read_bytes()},
        ["r.urdf"],
        lambda d: ["export", str(d / "r.urdf"), "--yaml", str(d / "out.yaml")],
        ["out.yaml"],
    )
    # a validation file of the same simulated robot at other poses (a validation repeating the
    # calibration poses is judged on none of them: refused)
    _run(["simulate", "--robot", str(folder / "truth_point.yaml"), "--as-is", "--poses", "12", "--seed", "2",
          "-o", str(folder / "point_val.csv"), "--truth", str(folder / "truth_point_val.yaml")])
    _run(
        [
            "calibrate",
            str(folder / "point.csv"),
            "--robot",
            "abb_irb2600",
            "--params",
            "auto",
            "--validate",
            str(folder / "point_val.csv"),
            "--method",
            "robust",
            "--json",
            str(folder / "result.json"),
            "-o",
            str(folder / "cal.yaml"),
        ]
    )
    result = _trim_result(json.loads((folder / "result.json").read_text()))
    readers["result_json"] = Reader(
        "result_json",
        {"result.json": json.dumps(result, indent=1).encode()},
        ["result.json"],
        lambda d: ["report", str(d / "result.json"), "-o", str(d / "out.html")],
        ["out.html"],
        kind="json",
    )
    readers.update(program_readers(folder))
    readers.update(cell_file_readers(folder))
    return readers


def program_readers(folder: Path) -> dict[str, Reader]:
    """The `filter` readers of every program dialect (RAPID, KRL, FANUC, URScript, INFORM with its
    TOOL.CND, and issue 46's: POSREG.VA, VAR.DAT, VAL3 s6, runtime correction, a cell's INFORM job),
    their seeds the hand-written programs of tests/data/programs."""
    folder.mkdir(parents=True, exist_ok=True)
    readers: dict[str, Reader] = {}
    for name, robot, files, extra in (
        ("rapid", "abb_irb2600", ["weld_cell.mod"], []),
        ("krl", "kuka_kr16_2", ["palletize.src", "palletize.dat", "config.dat"], []),
        (
            "fanuc",
            "fanuc_lrmate200id",
            ["sealing.ls"],
            ["--frame", "1=450,-150,100,0,0,-10", "--tool", "2=0,0,120,0,0,0"],
        ),
        ("urscript", "ur5", ["pick_place.script"], []),
    ):
        content = {f: (PROGRAMS / f).read_bytes() for f in files}
        out = "out" + Path(files[0]).suffix
        programs, references = files[:2] if name == "krl" else files, files[2:]
        perturbed(Robot.from_catalog(robot), 7).save(folder / f"cal_{robot}.yaml")
        cal = (folder / f"cal_{robot}.yaml").read_bytes()

        def argv(d, programs=programs, references=references, robot=robot, extra=extra, out=out):
            refs = ["--references", *(str(d / f) for f in references)] if references else []
            return [
                "filter",
                *(str(d / f) for f in programs),
                *refs,
                "--calibrated",
                str(d / "cal.yaml"),
                "--nominal",
                robot,
                *extra,
                "-o",
                str(d / (out if len(programs) == 1 else "outdir")),
            ]

        readers[name] = Reader(
            name,
            {**content, "cal.yaml": cal},
            files,
            argv,
            [out] if len(programs) == 1 else ["outdir"],
            extra={"outdir": len(programs) > 1, "programs": programs},
        )
    # a Yaskawa job with the controller's tool file, filtered with a payload model (the loads read)
    corpus = PROGRAMS / "corpus"
    files = ["PALLETIZE.JBI", "TOOL.CND"]
    terms = {"payload2": 4e-6, "payload3": 5e-6}
    path = folder / "cal_yaskawa_gp180.yaml"
    gp180 = perturbed(Robot.from_catalog("yaskawa_gp180"), 7)
    gp180.with_joint_errors(list(terms)).with_values(terms).save(path)

    def inform_argv(d):
        return ["filter", str(d / files[0]), "--references", str(d / files[1]), "--calibrated",
                str(d / "cal.yaml"), "--nominal", "yaskawa_gp180", "-o", str(d / "out.JBI")]

    readers["inform"] = Reader("inform", {**{f: (corpus / f).read_bytes() for f in files},
                                          "cal.yaml": path.read_bytes()}, files, inform_argv, ["out.JBI"],
                               extra={"programs": files[:1]})
    readers.update(_issue46_readers(folder, gp180_cal=path.read_bytes()))
    # the job and the controller's VAR.DAT both given as programs (told apart by their contents)
    import test_inform_variables as iv

    both = ["PICK_PLACE.JBI", "VAR.DAT"]  # (not `files`: inform_argv above reads that name when run)
    tools = tuple(a for k, v in iv.TOOLS.items() for a in ("--tool", f"{k}={v}"))
    readers["inform_var_program"] = _filter_reader(
        "inform_var_program", {f: (corpus / f).read_bytes() for f in both}, both, [],
        str(folder / "gp_nominal.yaml"), (folder / "gp_cal.yaml").read_bytes(), "outdir", tools)
    return readers


def _filter_reader(name: str, files: dict[str, bytes], programs: list[str], references: list[str],
                   robot: str, cal: bytes, output: str, extra: tuple = ()) -> Reader:
    """A `filter` command on ``programs`` with ``references``; every file but the model mutated."""

    def argv(d):
        refs = ["--references", *(str(d / f) for f in references)] if references else []
        return ["filter", *(str(d / f) for f in programs), *refs, "--calibrated", str(d / "cal.yaml"),
                "--nominal", robot, *extra, "-o", str(d / output)]

    edits_only = "--runtime-correction" not in extra  # the routine adds and reroutes lines
    return Reader(name, {**files, "cal.yaml": cal}, [*programs, *references], argv, [output],
                  extra={"outdir": len(programs) > 1, "programs": programs if edits_only else []})


def _issue46_readers(folder: Path, gp180_cal: bytes) -> dict[str, Reader]:
    """The inputs issue 46 added: FANUC POSREG.VA and SYSFRAME.VA, INFORM VAR.DAT (job layout and a
    controller backup's), a VAL3 s6.x XML application, RAPID and KRL with --runtime-correction."""
    import test_fanuc_posreg as fp
    import test_inform_variables as iv
    import test_val3_layouts as vl

    corpus, backup = PROGRAMS / "corpus", PROGRAMS.parent / "fanuc_backup"
    cals = {}
    for robot in ("fanuc_m20ia", "abb_irb2600", "kuka_kr16_2", "staubli_tx2_140"):
        perturbed(Robot.from_catalog(robot), 7).save(folder / f"cal46_{robot}.yaml")
        cals[robot] = (folder / f"cal46_{robot}.yaml").read_bytes()
    readers = {}
    crlf = fp.PALLET.replace("\n", "\r\n").encode()
    readers["fanuc_posreg"] = _filter_reader(
        "fanuc_posreg", {"PALLET.ls": crlf, "POSREG.VA": (backup / "POSREG.VA").read_bytes(),
                         "SYSFRAME.VA": (backup / "SYSFRAME.VA").read_bytes()},
        ["PALLET.ls"], ["POSREG.VA", "SYSFRAME.VA"], "fanuc_m20ia", cals["fanuc_m20ia"], "out.ls")
    iv.NOMINAL.save(folder / "gp_nominal.yaml")
    iv.CALIBRATED.save(folder / "gp_cal.yaml")
    files = ["PICK_PLACE.JBI", "VAR.DAT"]
    tools = tuple(a for k, v in iv.TOOLS.items() for a in ("--tool", f"{k}={v}"))
    readers["inform_var"] = _filter_reader(
        "inform_var", {f: (corpus / f).read_bytes() for f in files}, files[:1], files[1:],
        str(folder / "gp_nominal.yaml"), (folder / "gp_cal.yaml").read_bytes(), "out.JBI", tools)
    sub = folder / "inform_backup"
    sub.mkdir(exist_ok=True)
    forms = ["".join(map(str, iv.InformDialect().scheme.encode(iv.NOMINAL, iv.Q[k]).clip(0, 1))) + "0" * 18
             for k in range(2)]
    var = iv._backup_var(sub, forms).read_bytes()
    job = iv._job(["///NPOS 0,0,0,0,0,0"], [f"MOVL P{k:03d} V=100.0" for k in range(1, 6)])
    readers["inform_var_backup"] = _filter_reader(
        "inform_var_backup", {"B.JBI": job, "VAR.DAT": var}, ["B.JBI"], ["VAR.DAT"],
        str(folder / "gp_nominal.yaml"), (folder / "gp_cal.yaml").read_bytes(), "out.JBI")
    shutil.rmtree(folder / "val3_s6", ignore_errors=True)
    sub = vl._s6_application(folder / "val3_s6")
    names = ["start.pgx", "place.pgx", "cell.dtx"]
    vl.CALIBRATED.save(folder / "tx2_cal.yaml")
    readers["val3_s6"] = _filter_reader(
        "val3_s6", {n: (sub / n).read_bytes() for n in names}, names, [], "staubli_tx2_140",
        (folder / "tx2_cal.yaml").read_bytes(), "outdir")
    readers["rapid_rt"] = _filter_reader(
        "rapid_rt", {"arc_station.mod": (corpus / "arc_station.mod").read_bytes()}, ["arc_station.mod"], [],
        "abb_irb2600", cals["abb_irb2600"], "out.mod", ("--runtime-correction",))
    files = ["deburr_cell.src", "deburr_cell.dat", "$config.dat"]
    readers["krl_rt"] = _filter_reader(
        "krl_rt", {f: (corpus / f).read_bytes() for f in files}, files[:2], files[2:], "kuka_kr16_2",
        cals["kuka_kr16_2"], "outdir", ("--runtime-correction",))
    readers["inform_cell"] = _cell_reader(folder)
    return readers


def _cell_reader(folder: Path) -> Reader:
    """A station-coordinated INFORM job filtered with a cell (nominal and calibrated cell files):
    the job and the nominal cell file are mutated."""
    import cell_programs as cp
    import test_coordinated_programs as tc

    nominal, _, calibrated = cp.cells(5, arm="yaskawa_gp25", unit="ST1", external_axes=(1, 2))
    q, e, _ = cp.poses(nominal, 5)
    sub = folder / "inform_cell"
    sub.mkdir(exist_ok=True)
    job = tc._inform_cell_job(sub, nominal.arms["arm"], q, e, cp.TOOL)
    nominal.save(sub / "cell.yaml")
    calibrated.save(sub / "calibrated_cell.yaml")

    def argv(d):
        return ["filter", str(d / job.name), "--calibrated", str(d / "calibrated_cell.yaml"), "--nominal",
                str(d / "cell.yaml"), "--tool", "1=0,0,250,0,20,0", "-o", str(d / "out.JBI")]

    files = {n: (sub / n).read_bytes() for n in (job.name, "cell.yaml", "calibrated_cell.yaml")}
    return Reader("inform_cell", files, [job.name, "cell.yaml"], argv, ["out.JBI"],
                  extra={"programs": [job.name]})


CELLS = PROGRAMS.parent / "cells"


def cell_file_readers(folder: Path) -> dict[str, Reader]:
    """The cell files' readers, their seeds tests/data/cells: a work cell (two arms, one a model file
    beside it, and a positioner) read by ``simulate --model``, and a robot on a track read by
    ``export``. ``extra['names']``: the file names a mutant may put where another is named (a cell
    naming itself or a file naming the cell)."""
    folder.mkdir(parents=True, exist_ok=True)
    work = {n: (CELLS / n).read_bytes() for n in ("weld_cell.yaml", "irb2600.yaml")}
    track = {"track_cell.yaml": (CELLS / "track_cell.yaml").read_bytes(),
             "irb2600.yaml": work["irb2600.yaml"]}
    names = [b"weld_cell.yaml", b"irb2600.yaml", b"track_cell.yaml", b"abb_irb2600", b"kuka_kr210_r2700"]
    return {
        "cell_work": Reader(
            "cell_work", work, ["weld_cell.yaml", "irb2600.yaml"],
            lambda d: ["simulate", "--model", str(d / "weld_cell.yaml"), "--as-is", "--poses", "4",
                       "--table-poses", "4", "--seed", "1", "-o", str(d / "out.csv"), "--truth",
                       str(d / "truth.yaml")],
            ["out.csv", "truth.yaml"], extra={"names": names}),
        "cell_track": Reader(
            "cell_track", track, ["track_cell.yaml"],
            lambda d: ["export", str(d / "track_cell.yaml"), "--urdf", str(d / "out.urdf")],
            ["out.urdf"], extra={"names": names}),
    }


# ----------------------------------------------------------------- mutations
def _lines(data: bytes) -> list[bytes]:
    return data.splitlines(keepends=True) or [b""]


def _text_op(data: bytes, rng: random.Random) -> bytes:
    lines = _lines(data)
    op = rng.randrange(14)
    i, j = rng.randrange(len(lines)), rng.randrange(len(lines))
    if op == 0:
        del lines[i]
    elif op == 1:
        lines.insert(i, lines[j])
    elif op == 2:
        lines[i], lines[j] = lines[j], lines[i]
    elif op == 3:
        return data[: rng.randrange(len(data) + 1)]
    elif op in (4, 5, 6):  # a number replaced by an extreme or ambiguous form
        found = list(NUMBER.finditer(data))
        if found:
            m = rng.choice(found)
            return data[: m.start()] + rng.choice(EXTREMES) + data[m.end() :]
    elif op == 7 and data:
        k = rng.randrange(len(data))
        return data[:k] + data[k + 1 :]
    elif op == 8:
        k = rng.randrange(len(data) + 1)
        return data[:k] + bytes([rng.choice(CHARS)]) + data[k:]
    elif op == 9:  # an identifier replaced by another one of the file (or a new one)
        words = list(WORD.finditer(data))
        if words:
            m = rng.choice(words)
            new = (
                rng.choice(words).group() if rng.random() < 0.7 else b"Xyz" + str(rng.randrange(99)).encode()
            )
            return data[: m.start()] + new + data[m.end() :]
    elif op == 10:
        lines[i:i] = [lines[j]] * min(rng.choice((50, 500)), MAX_MUTANT // (len(lines[j]) + 1))
    elif op == 11:
        k, depth = rng.randrange(len(data) + 1), rng.choice((40, 2000))
        return data[:k] + b"[" * depth + b"1" + b"]" * depth + data[k:]
    elif op == 12:  # a punctuation character deleted (separators, brackets, semicolons)
        found = [m.start() for m in re.finditer(rb"[,;:\[\]{}()=]", data)]
        if found:
            k = rng.choice(found)
            return data[:k] + data[k + 1 :]
    else:
        lines[i] = lines[i].swapcase()
    return b"".join(lines)


_SHAPES = [
    1e308,
    -1e308,
    0,
    -1,
    1e15,
    10**20,
    True,
    None,
    "",
    "$x^$",
    "$\\frac{a$",
    "a" * 10,
    [],
    {},
    [1, 2],
    [[1, 2], [3]],
    {"a": 1},
    [[[[1]]]],
    0.5,
    "1.5",
    -5,
]


def _json_op(data: bytes, rng: random.Random) -> bytes:
    """A node of the JSON document replaced, removed or reshaped."""
    try:
        doc = json.loads(data)
    except (ValueError, RecursionError):
        return _text_op(data, rng)
    nodes = []
    stack = [(doc, None, None)]
    while stack:
        node, parent, key = stack.pop()
        nodes.append((node, parent, key))
        if isinstance(node, dict):
            stack.extend((v, node, k) for k, v in node.items())
        elif isinstance(node, list) and len(nodes) < 20000:
            stack.extend((v, node, k) for k, v in enumerate(node[:50]))
    node, parent, key = rng.choice(nodes[1:] or nodes)
    if parent is None:
        return _text_op(data, rng)
    op = rng.randrange(5)
    if op == 0:
        new = rng.choice(_SHAPES)
    elif op == 1 and isinstance(node, list) and node:  # ragged or shorter
        new = node[:-1] if rng.random() < 0.5 else [*node, node[0]]
    elif op == 2:
        new = [node] if rng.random() < 0.5 else {"x": node}
    elif op == 3 and isinstance(parent, dict):
        del parent[key]
        return json.dumps(doc).encode()
    else:
        new = "HUGE" if rng.random() < 0.5 else "DEEP"
    parent[key] = new
    text = json.dumps(doc).encode()
    return text.replace(b'"HUGE"', b"1" * 5000).replace(b'"DEEP"', b"[" * 5000 + b"]" * 5000)


BOM = b"\xef\xbb\xbf"
NOT_UTF8 = [b"\xff", b"\xfe\xff", b"\xc3(", b"\xe9", b"\xed\xa0\x80", b"\x80\x80", BOM]
HUGE = [b"9" * 400, b"1e999", b"-1e400", b"9" * 20 + b"." + b"9" * 20, b"1" * 999 + b".5"]


def _encoding_op(data: bytes, rng: random.Random, names: list[bytes] = ()) -> bytes:
    """What editors, transfers and controllers do to a file's bytes: a UTF-8 byte-order mark put
    first (or in the middle), every line end made CRLF or a lone CR, a NUL byte or bytes that are no
    UTF-8 inserted, a huge number, a line copied many times, a file name put where another is named
    (a cell naming itself)."""
    op = rng.randrange(9)
    k = rng.randrange(len(data) + 1)
    if op == 0:
        return BOM + data
    if op == 1:
        return data[:k] + BOM + data[k:]
    if op in (2, 3):
        lf = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
        return lf.replace(b"\n", b"\r\n" if op == 2 else b"\r")
    if op == 4:
        return data[:k] + b"\x00" * rng.choice((1, 1, 8)) + data[k:]
    if op == 5:
        return data[:k] + rng.choice(NOT_UTF8) + data[k:]
    if op == 6:
        found = list(NUMBER.finditer(data))
        if found:
            m = rng.choice(found)
            return data[: m.start()] + rng.choice(HUGE) + data[m.end():]
    if op == 7 and names:
        present = [n for n in names if n in data]
        if present:
            old = rng.choice(present)
            return data.replace(old, rng.choice(names), 1)
    lines = _lines(data)
    i = rng.randrange(len(lines))
    lines[i:i] = [lines[i]] * rng.choice((2, 40))
    return b"".join(lines)


def mutate(reader: Reader, rng: random.Random, encodings: bool = False) -> tuple[str, bytes]:
    """A mutant of one of the reader's target files: (file name, content). ``encodings``: half of
    the mutants get one of :func:`_encoding_op`'s byte-level changes too."""
    target = rng.choice(reader.targets)
    data = reader.files[target]
    for _ in range(rng.choice((1, 1, 2, 3))):
        new = _json_op(data, rng) if reader.kind == "json" and rng.random() < 0.6 else _text_op(data, rng)
        data = new if len(new) <= MAX_MUTANT else data  # repeated blocks of repeated blocks stay bounded
    if encodings and rng.random() < 0.5:
        data = _encoding_op(data, rng, reader.extra.get("names", ()))
    return target, data


# ----------------------------------------------------------------- the same file in other bytes
VARIANTS = {"bom": lambda b: BOM + b.removeprefix(BOM),
            "crlf": lambda b: b.replace(b"\r\n", b"\n").replace(b"\r", b"\n").replace(b"\n", b"\r\n"),
            "cr": lambda b: b.replace(b"\r\n", b"\n").replace(b"\n", b"\r")}


def _normal(data: bytes) -> bytes:
    """An output as compared across variants: no BOM, LF line ends, no provenance marker line."""
    lines = data.removeprefix(BOM).replace(b"\r\n", b"\n").replace(b"\r", b"\n").split(b"\n")
    return b"\n".join(ln for ln in lines if b"robocal" not in ln)


def _outputs(reader: Reader, folder: Path) -> dict[str, bytes]:
    out = {}
    for name in reader.outputs:
        path = folder / name
        files = sorted(path.iterdir()) if path.is_dir() else [path] if path.exists() else []
        out.update({f.name: _normal(f.read_bytes()) for f in files})
    return out


def same_whatever_the_bytes(reader: Reader, folder: Path) -> list[str]:
    """A reader given one of its files with a BOM, CRLF or lone-CR line ends must give what it gives
    for the file as it is (exit code and outputs, compared without BOM, line ends and marker): a
    BOM read as another format, or a line end that hides a line, reads 'fine' and wrongly."""
    code, stderr = run_case(reader, reader.targets[0], reader.files[reader.targets[0]], folder / "case")
    expected = (code, _outputs(reader, folder / "case"))
    if code != 0:  # a seed the reader refuses makes every mutant a refusal: a vacuous fuzz
        return [f"{reader.name}: its seed files are refused: {stderr.strip()[-200:]}"]
    problems = []
    for target in reader.targets:
        for name, variant in VARIANTS.items():
            data = variant(reader.files[target])
            code, stderr = run_case(reader, target, data, folder / "case")
            got = (code, _outputs(reader, folder / "case"))
            if got != expected:
                differ = sorted(k for k in {*got[1], *expected[1]} if got[1].get(k) != expected[1].get(k))
                problems.append(f"{reader.name}: {target} with {name}: exit {got[0]} (as is: {expected[0]}), "
                                f"outputs differing {differ} {stderr.strip()[-160:]}")
    return problems


# ----------------------------------------------------------------- one case
class _Timeout(BaseException):
    pass


def _alarm(signum, frame):
    raise _Timeout


def run_case(reader: Reader, target: str, data: bytes, folder: Path, timeout_s: int = 60) -> tuple[int, str]:
    """Write the case into an empty ``folder`` and run the reader's command in this process:
    (exit code, stderr). Exit code -1 is a timeout, -2 an exception escaping main."""
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    for name, content in reader.files.items():
        (folder / name).write_bytes(data if name == target else content)
    if reader.extra.get("outdir"):
        (folder / "outdir").mkdir()
    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(timeout_s)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            os.environ["ROBOCAL_DEBUG"] = "1"
            code = main(["--quiet", *reader.argv(folder)])
    except _Timeout:
        code = -1
    except BaseException:  # noqa: BLE001 - anything escaping main breaks the contract
        code = -2
        err.write(traceback.format_exc())
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
        os.environ.pop("ROBOCAL_DEBUG", None)
    return code, err.getvalue()


def check(reader: Reader, target: str, data: bytes, folder: Path, code: int, stderr: str,
          no_partial: bool = False) -> str | None:
    """None when the case kept the contract, else what broke it (one line, with the site);
    ``no_partial``: a refusal (exit 2) must also leave no output behind."""
    for name, content in reader.files.items():
        if (folder / name).read_bytes() != (data if name == target else content):
            return f"input {name} modified"
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    if code == 0:
        missing = [o for o in reader.outputs if not (folder / o).exists()]
        if reader.extra.get("outdir") and not any((folder / "outdir").iterdir()):
            missing.append("outdir/*")
        return f"exit 0 without {missing}" if missing else _edit_outside_numbers(reader, target, data, folder)
    if code == 2:
        # the error: one line, or a headline and one indented item a line (a list of places)
        while len(lines) > 1 and lines[-1].startswith("  ") and ": error: " not in lines[-1]:
            lines.pop()
        noise = [ln for ln in lines[:-1] if not ln.lower().startswith(("warning", "robocal"))]
        if not lines or not lines[-1].startswith("robocal ") or noise:
            return f"exit 2 with stray output: {(noise or lines or [''])[0][:160]}"
        written = [o for o in reader.outputs if (folder / o).is_file()]
        if reader.extra.get("outdir"):
            written += [f"outdir/{f.name}" for f in (folder / "outdir").iterdir()]
        return f"exit 2 with partial output {written}" if no_partial and written else None
    if code == 3:
        return f"internal error: {_site(stderr)}"
    if code == -1:
        return "timeout"
    return f"exit {code}: {_site(stderr)}"


_MASK = re.compile(rb"[ \t]*" + NUMBER.pattern)
# VAL3 writes an absent coordinate as a new attribute of the element holding the others: a line's
# coordinate attributes compare as one mark (so one added to an element that had none still shows)
_COORD = re.compile(rb'\s+(?:x|y|z|rx|ry|rz)="#"', re.I)


def _coords_as_one(line: bytes) -> bytes:
    new = _COORD.sub(b"", line)
    return new + b" @" if new != line else line


def _edit_outside_numbers(reader: Reader, target: str, data: bytes, folder: Path) -> str | None:
    """For a program reader (``extra['programs']``, no routine added): what changed in an output
    beyond its numbers (lines may be added: the provenance marker), or None. A filter edits pose
    numbers only; any other change is an unsafe edit."""
    for name in reader.extra.get("programs", ()):
        out = folder / (reader.outputs[0] if not reader.extra.get("outdir") else f"outdir/{name}")
        if not out.is_file():
            continue
        source, written = data if name == target else reader.files[name], out.read_bytes()
        if source.startswith(BOM):  # it stays first, the marker after it (test_fuzz_readers)
            if not written.startswith(BOM):
                return f"the byte-order mark of {name} not kept first"
            source, written = source[len(BOM):], written[len(BOM):]
        old, new = ([_coords_as_one(ln) for ln in _MASK.sub(b"#", b).splitlines()] for b in (source, written))
        changed = [op for op in difflib.SequenceMatcher(None, old, new, autojunk=False).get_opcodes()
                   if op[0] in ("replace", "delete")]
        if changed:
            _, i, _, j, _ = changed[0]
            got = new[j][:80] if j < len(new) else b"(deleted)"
            return f"edit outside a number in {name}:{i + 1}: {old[i][:80]!r} -> {got!r}"
    return None


def _site(stderr: str) -> str:
    """The innermost robocal frame of a traceback and the exception line."""
    frames = re.findall(r'File "([^"]*robocal[^"]*)", line (\d+), in (\w+)', stderr)
    last = [ln for ln in stderr.splitlines() if ln.strip()]
    where = f"{Path(frames[-1][0]).name}:{frames[-1][1]} {frames[-1][2]}" if frames else "?"
    exc = next(
        (ln for ln in reversed(last) if re.match(r"\w+(Error|Exception|Warning)\b", ln)),
        last[-1] if last else "",
    )
    return f"{where}: {exc[:200]}"
