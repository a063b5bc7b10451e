"""The how-to pages of the program languages run as a reader pastes them: each page's ``bash``
blocks, in order, in an empty folder, with ``robocal`` on PATH; the output a page shows after a
block is what the block prints (its lines without a measured figure, which a platform's rounding
may move: the motion accounting, the warnings, the files written)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs" / "how-to" / "programs").glob("*.md"))
BLOCK = re.compile(r"```bash\n(.*?)```(?:\n\n```text\n(.*?)```)?", re.DOTALL)
FIGURE = re.compile(r"\d\.\d")  # a measured figure: checked by the benchmarks, not here
LANGUAGE_PAGES = {"rapid", "krl", "inform", "fanuc", "val3", "urscript"}


def test_a_page_per_language():
    assert {p.stem for p in PAGES} >= LANGUAGE_PAGES
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert all(f"how-to/programs/{name}.md" in nav for name in LANGUAGE_PAGES)


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if p.stem in LANGUAGE_PAGES], ids=lambda p: p.stem)
def test_the_page_runs_as_pasted(page, tmp_path):
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
           "PYTHONPATH": str(ROOT / "src")}
    blocks = BLOCK.findall(page.read_text(encoding="utf-8"))
    assert len(blocks) >= 2
    for script, shown in blocks:
        proc = subprocess.run(["bash", "-e", "-c", script], cwd=tmp_path, env=env, capture_output=True,
                              text=True, timeout=600, check=False)
        assert proc.returncode == 0, f"{page.name}: {script.splitlines()[-1]}\n{proc.stderr[-2000:]}"
        printed = proc.stdout.splitlines()
        for line in shown.splitlines():
            if not FIGURE.search(line):
                assert line in printed, f"{page.name} shows {line!r}; the block printed:\n{proc.stdout}"
