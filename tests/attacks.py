"""Injection attacks on every writer: a model name (and description) or an input file name holding
newlines, quotes, ``]]>``, ``-->``, ``<script>``, control and Unicode line-break characters, run
through the commands that embed them (poses with every program dialect and its HTML/JSON, export
to URDF and YAML, calibrate's model, JSON and report). Oracle (differential): each output, made
with the hostile text, has the structure of the one made with a harmless name of the same length
(the same count of lines in a program, of elements in an XML file, of ``<script>`` elements in an
HTML page; JSON and YAML reading back the text as given), or the command refuses in one line
(exit 2) with nothing written (shared by tests/test_attacks.py; ``python tests/attacks.py``).
"""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

HOSTILE = ["a\nb", "a\rb", "a\r\nEND", 'q"u\'ote', "a]]>b", "a-->b", "<script>alert(1)</script>", "a\x00b",
           "a\x1b[31mb", "a\u2028b", "a\x85b", "a\x0bb\x0cc", "x;y", "*/ z /*", "{{x}}", "&amp;&lt;", "a\tb",
           "!x", "'x", "% x", "; x", "// x", "# x", "\\", "a" * 200, "é中😀", "\ufeffname", "a\u202eb"]
PROGRAMS = {"--rapid": "p.mod", "--krl": "p.src", "--fanuc": "p.ls", "--urscript": "p.script",
            "--inform": "p.jbi", "--val3": "val3"}


def cli(argv: list[str]) -> tuple[int, str, str]:
    from robocal.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except BaseException as exc:  # noqa: BLE001 - anything escaping main breaks the contract
            return -2, out.getvalue(), f"{type(exc).__name__}: {exc}"
    return code, out.getvalue(), err.getvalue()


def model_with_name(folder: Path, name: str, base: str = "abb_irb2600") -> Path:
    """A catalog model saved with ``name`` as its name and description."""
    import robocal as rc

    robot = rc.Robot.from_catalog(base)
    text = robot.save  # noqa: F841 - the API's writer, used below through the dict
    from robocal.core.yaml_load import dump_yaml
    from robocal.kinematics.model_file import robot_to_dict

    data = robot_to_dict(robot)
    data["name"], data["description"] = name, name
    path = folder / "model.yaml"
    path.write_text(dump_yaml(data), encoding="utf-8")
    return path


def _structure(path: Path) -> tuple:
    """What an output's structure is, whatever the text it embeds."""
    data = path.read_bytes()
    if path.suffix in (".urdf", ".xml", ".dtx", ".pjx", ".pgx"):
        root = ET.fromstring(data)
        return ("xml", sorted(e.tag for e in root.iter()))
    if path.suffix in (".html",):
        text = data.decode("utf-8")
        return ("html", len(re.findall(r"<script\b", text, re.I)), len(re.findall(r"<!--", text)),
                len(re.findall(r"-->", text)))
    if path.suffix == ".json":
        json.loads(data)
        return ("json",)
    if path.suffix in (".yaml", ".csv"):
        return ("text", data.count(b"\n") if path.suffix == ".csv" else 0)
    text = data.decode("utf-8", errors="replace")
    return ("program", len(text.splitlines()), data.count(b"\n"), data.count(b"\r"))


def outputs(folder: Path) -> dict[str, tuple]:
    found = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != "model.yaml" and not p.name.endswith(".csv.in"):
            try:
                found[str(p.relative_to(folder))] = _structure(p)
            except (ET.ParseError, json.JSONDecodeError, UnicodeDecodeError) as exc:
                found[str(p.relative_to(folder))] = ("broken", str(exc)[:80])
    return found


def scenarios(folder: Path, model: Path) -> dict[str, list]:
    """The commands that embed the model's name, each writing into ``folder``."""
    progs = [x for flag, out in PROGRAMS.items() for x in (flag, folder / out)]
    return {
        "poses": ["poses", "--robot", model, "-n", "12", "--candidates", "200", "--starts", "1", "--seed",
                  "1", "-o", folder / "poses.csv", "--json", folder / "c.json", "--html", folder / "c.html",
                  *progs],
        "export": ["export", model, "--urdf", folder / "m.urdf", "--yaml", folder / "m.yaml"],
        "export_model_frames": ["export", model, "--urdf", folder / "w.urdf", "--frames", "model"],
        "calibrate": ["calibrate", _data(folder), "--robot", model, "--nongeometric", "none", "-o",
                      folder / "cal.yaml", "--json", folder / "cal.json", "--report", folder / "cal.html"],
    }


def _data(folder: Path) -> Path:
    """Simulated tracker data of the model (the name is not in it)."""
    import robocal as rc
    from robocal.data.simulate import simulate_tracker

    path = folder / "data.csv.in"
    if not path.exists():
        simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 30, seed=5).data.save(path)
    return path


def attack(folder: Path, name: str) -> list[str]:
    """The contract breaks of one hostile ``name`` against a harmless one of the same length."""
    problems = []
    runs = {}
    harmless = "".join(" " if ch == " " else "n" for ch in name)  # wrapped at the same places
    for label, text in (("benign", harmless), ("hostile", name)):
        where = folder / label
        shutil.rmtree(where, ignore_errors=True)
        where.mkdir(parents=True)
        model = model_with_name(where, text)
        runs[label] = {}
        for scenario, argv in scenarios(where, model).items():
            out = where / scenario
            out.mkdir()
            argv = [str(a) if Path(str(a)).exists() else str(a).replace(str(where), str(out)) for a in argv]
            before = model.read_bytes()
            code, stdout, err = cli(["--quiet", *argv])
            if model.read_bytes() != before:
                problems.append(f"{scenario}: the model file changed")
            runs[label][scenario] = (code, err, outputs(out))
    for scenario, (code, err, found) in runs["hostile"].items():
        bcode, berr, bfound = runs["benign"][scenario]
        lines = [ln for ln in err.splitlines() if ln.strip()]
        if code == 2 and lines and lines[-1].startswith("robocal ") and not found:
            continue  # refused in one line, nothing written
        if code != bcode:
            problems.append(f"{scenario} with name {name!r}: exit {code} (harmless name: {bcode}): "
                            f"{(lines or [''])[-1][:200]}")
            continue
        for path, shape in found.items():
            if shape != bfound.get(path):
                problems.append(f"{scenario} with name {name!r}: {path} is {shape} (harmless name: "
                                f"{bfound.get(path)})")
        if set(bfound) - set(found):
            problems.append(f"{scenario} with name {name!r}: missing {sorted(set(bfound) - set(found))}")
    return problems


if __name__ == "__main__":  # pragma: no cover - the full round
    import tempfile

    np.seterr(all="ignore")
    with tempfile.TemporaryDirectory() as tmp:
        for hostile in HOSTILE:
            for line in attack(Path(tmp), hostile):
                print(line, flush=True)
