"""Mutants of a vendor's URDF and xacro macro through ``robocal export --urdf-like`` (the text and
byte operators of tests/fuzzing.py, plus hostile XML: entities, a DOCTYPE, deep nesting, a huge
attribute, a processing instruction, a CDATA comment). The contract of tests/fuzzing.py: exit 0 with
every output, or exit 2 in one line with no output; never exit 3, never an input changed.
``python tests/fuzz_urdf_like.py 400`` runs any number."""

from __future__ import annotations

import random
from pathlib import Path

from fuzzing import Reader, check, mutate, run_case

DATA = Path(__file__).resolve().parent / "data" / "urdf_vendor"
HOSTILE = [b'<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa"><!ENTITY b "&a;&a;&a;">]><robot name="&b;">',
           b"<robot name='x'>" + b"<link name='l'>" * 5000, b'<?xml-stylesheet href="x"?>',
           b"<!-- ]]> --> <![CDATA[ </robot> ]]>", b'<robot name="' + b"x" * 2_000_000 + b'">',
           b'<xi:include xmlns:xi="http://www.w3.org/2001/XInclude" href="/etc/passwd"/>',
           b'<joint name="joint_1" type="revolute">', b"</joint>", b'<origin xyz="nan 0 0" rpy="0 0 0"/>',
           b'<origin xyz="1e308 0 0" rpy="0 0 0"/>', b'<origin xyz="0 0 0" rpy="inf 0 0"/>',
           b'<axis xyz="0 0 0"/>', b'<limit lower="-1e309" upper="1e309" effort="1" velocity="1"/>',
           b"\xef\xbb\xbf", b"\x00", b'<robot name="a\x1b]0;x\x07">']


def reader(name: str = "kr16_2", robot: str = "kuka_kr16_2", macro: bool = True) -> Reader:
    files = {"vendor.urdf": (DATA / f"{name}.urdf").read_bytes()}
    outputs = ["out.urdf"]
    if macro and (DATA / f"{name}_macro.xacro").exists():
        files["macro.xacro"] = (DATA / f"{name}_macro.xacro").read_bytes()
        outputs.append("out.xacro")
    def argv(d: Path) -> list[str]:
        extra = ["--xacro", str(d / "macro.xacro"), str(d / "out.xacro")] if "macro.xacro" in files else []
        return ["export", robot, "--urdf-like", str(d / "vendor.urdf"), "-o", str(d / "out.urdf"), *extra]
    return Reader("urdf_like", files, list(files), argv, outputs)


def hostile_mutant(data: bytes, rng: random.Random) -> bytes:
    """``data`` with one hostile XML piece inserted at a random line start."""
    lines = data.split(b"\n")
    at = rng.randrange(len(lines) + 1)
    return b"\n".join([*lines[:at], rng.choice(HOSTILE), *lines[at:]])


def fuzz(count: int, seed: int, folder: Path) -> list[str]:
    rng = random.Random(seed)
    r = reader()
    problems = []
    for k in range(count):
        if rng.random() < 0.3:
            target = rng.choice(r.targets)
            data = hostile_mutant(r.files[target], rng)
        else:
            target, data = mutate(r, rng, encodings=True)
        code, stderr = run_case(r, target, data, folder / "case", timeout_s=60)
        problem = check(r, target, data, folder / "case", code, stderr, no_partial=True)
        if problem:
            problems.append(f"mutant {k} of {target}: {problem}")
    return problems


if __name__ == "__main__":  # pragma: no cover
    import sys
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        args = [int(a) for a in sys.argv[1:3]]
        count, seed = (args[0] if args else 50), (args[1] if len(args) > 1 else 0)
        for line in fuzz(count, seed, Path(tmp)):
            print(line, flush=True)
