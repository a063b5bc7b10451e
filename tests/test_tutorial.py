"""The tutorial (docs/tutorial/first-campaign.md) runs as written: every code block, in order, in an
empty folder. Blocks with a ``title="FILE"`` are written to FILE, ``bash`` blocks run command by
command (non-zero exit fails), ``python`` blocks run in a fresh interpreter."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial" / "first-campaign.md"
BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```$", re.M | re.S)
TITLE = re.compile(r'title="([^"]+)"')


def blocks(text: str) -> list[tuple[str, str | None, str]]:
    """``(language, title or None, body)`` of every fenced block, in order."""
    out = []
    for lang, info, body in BLOCK.findall(text):
        title = TITLE.search(info)
        out.append((lang, title.group(1) if title else None, body))
    return out


def commands(body: str) -> list[str]:
    """Shell commands of a block: continuation lines joined, comments and blank lines dropped."""
    return [c.strip() for c in body.replace("\\\n", " ").splitlines() if c.strip() and not c.startswith("#")]


def test_block_parser_reads_titles_and_continuations():
    text = '```text title="a.mod"\nX\n```\n\n```bash\nrobocal a \\\n    --b 1\n# note\nrobocal c\n```\n'
    (l1, t1, b1), (l2, t2, b2) = blocks(text)
    assert (l1, t1, b1, l2, t2) == ("text", "a.mod", "X\n", "bash", None)
    assert commands(b2) == ["robocal a      --b 1", "robocal c"]


def test_tutorial_runs_as_written(tmp_path):
    pytest.importorskip("matplotlib", reason="the tutorial writes the HTML report (report extra)")
    env = {**os.environ, "PATH": os.pathsep.join([str(Path(sys.executable).parent), os.environ["PATH"]])}
    found = blocks(TUTORIAL.read_text(encoding="utf-8"))
    assert {lang for lang, _, _ in found} >= {"bash", "python", "text"}
    for lang, title, body in found:
        if title:
            (tmp_path / title).write_text(body, encoding="utf-8")
        elif lang == "bash":
            for cmd in commands(body):
                proc = subprocess.run(cmd, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True,
                                      check=False)
                assert proc.returncode == 0, f"{cmd}\n{proc.stderr[-2000:]}"
        elif lang == "python":
            proc = subprocess.run([sys.executable, "-c", body], cwd=tmp_path, env=env, capture_output=True,
                                  text=True, check=False)
            assert proc.returncode == 0, f"{body}\n{proc.stderr[-2000:]}"
    for name in ("poses.csv", "campaign.html", "Campaign.mod", "calibrated.yaml", "result.json",
                 "report.html", "cell_cal.mod", "cell_cal.mod.targets.csv"):
        assert (tmp_path / name).exists(), name
