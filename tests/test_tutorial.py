"""The tutorial (docs/tutorial/first-campaign.md) runs as written: every code block, in order, in an
empty folder, as a user pastes it: ``bash`` blocks as one shell script each (so a heredoc writes a
file), ``python`` blocks in a fresh interpreter; a non-zero exit fails. What each block printed is
the expected output the site shows under it (``docs/tutorial/first-campaign.output.json``, read by
``scripts/docs_tutorial.py``): the run must print the same text, numbers within a tolerance
(floating-point libraries differ in the last digits). ``ROBOCAL_RECORD_TUTORIAL=1`` records the
run instead, after a change to the commands or their output."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_tutorial  # noqa: E402

TUTORIAL = ROOT / "docs" / "tutorial" / "first-campaign.md"
BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```$", re.M | re.S)
NUMBER = re.compile(r"[-+]?\d+(?:[.,]\d+)*(?:[eE][-+]?\d+)?")
RUNNABLE = ("bash", "python")
NUMBER_RTOL, NUMBER_ATOL = 0.05, 0.002  # printed figures may differ in the last digits between machines


def blocks(text: str) -> list[tuple[str, str]]:
    """``(language, body)`` of every fenced block, in order."""
    return [(lang, body) for lang, _, body in BLOCK.findall(text)]


def same_output(recorded: str, fresh: str) -> str | None:
    """None when ``fresh`` is ``recorded`` up to the numbers' last digits, else the first difference."""
    rec_lines, new_lines = recorded.strip().splitlines(), fresh.strip().splitlines()
    if len(rec_lines) != len(new_lines):
        return f"{len(new_lines)} lines printed, {len(rec_lines)} recorded"
    for a, b in zip(rec_lines, new_lines, strict=True):
        if NUMBER.sub("#", a) != NUMBER.sub("#", b):
            return f"recorded {a!r}\n   printed {b!r}"
        for x, y in zip(NUMBER.findall(a), NUMBER.findall(b), strict=True):
            u, v = float(x.replace(",", "")), float(y.replace(",", ""))
            if abs(u - v) > NUMBER_ATOL + NUMBER_RTOL * abs(u):
                return f"recorded {a!r}\n   printed {b!r}"
    return None


def test_output_comparison():
    assert same_output("RMS 1.2797 -> 0.0206 mm", "RMS 1.2799 -> 0.0207 mm") is None
    assert same_output("RMS 1.2797 -> 0.0206 mm", "RMS 1.9 -> 0.0206 mm") is not None
    assert same_output("wrote a.csv", "wrote b.csv") is not None
    assert same_output("a\nb", "a") is not None
    page = docs_tutorial.with_outputs("x\n<!-- output -->\ny", ["line 1\nline 2"])
    assert "        line 2" in page and "<!--" not in page
    with pytest.raises(docs_tutorial.TutorialOutputError, match="markers"):
        docs_tutorial.with_outputs("x", ["one"])


@pytest.mark.slow
def test_tutorial_runs_as_written(tmp_path):
    pytest.importorskip("matplotlib", reason="the tutorial writes the HTML report (report extra)")
    env = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])}
    text = TUTORIAL.read_text(encoding="utf-8")
    found = [(lang, body) for lang, body in blocks(text) if lang in RUNNABLE]
    assert {lang for lang, _ in found} == set(RUNNABLE)
    assert text.count(docs_tutorial.OUTPUT_MARK) == len(found), "one output marker under each block"
    outputs = []
    for lang, body in found:
        cmd = ["bash", "-e", "-o", "pipefail", "-c", body] if lang == "bash" else [sys.executable, "-c", body]
        proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, check=False,
                              timeout=900)
        assert proc.returncode == 0, f"{body}\n{proc.stderr[-2000:]}"
        outputs.append(proc.stdout + proc.stderr)
    for name in ("poses.csv", "campaign.html", "Campaign.mod", "calibrated.yaml", "result.json",
                 "report.html", "cell.mod", "cell_cal.mod", "cell_cal.mod.targets.csv"):
        assert (tmp_path / name).exists(), name
    if os.environ.get("ROBOCAL_RECORD_TUTORIAL") == "1":
        docs_tutorial.OUTPUTS.write_text(json.dumps({"outputs": outputs}, indent=1) + "\n", encoding="utf-8")
        return
    recorded = json.loads(docs_tutorial.OUTPUTS.read_text(encoding="utf-8"))["outputs"]
    assert len(recorded) == len(outputs), "blocks added or removed: record again (ROBOCAL_RECORD_TUTORIAL=1)"
    for k, (old, new) in enumerate(zip(recorded, outputs, strict=True)):
        diff = same_output(old, new)
        assert diff is None, (f"block {k + 1} printed other than the site shows (record again with "
                              f"ROBOCAL_RECORD_TUTORIAL=1 if the change is intended):\n{diff}")
