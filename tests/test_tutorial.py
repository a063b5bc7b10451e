"""The tutorial and every how-to page run as written: every ``bash`` and ``python`` block of a page,
in order, in an empty folder, as a user pastes them into a fresh shell: ``bash`` blocks as one shell
script each (so a heredoc writes a file), ``python`` blocks in a fresh interpreter; a non-zero exit
fails. The shell is a fresh one: the PATH has no virtual environment on it, only what the reader
was told to do once where a reader starts (``source .venv/bin/activate``: the index and the
tutorial say it), so a page that forgets a step fails here as it would for its reader.

What each block printed is the expected output the site shows under it (``PAGE.output.json`` next to
the page, read by ``scripts/docs_tutorial.py``): the run must print the same text, numbers within a
tolerance (floating-point libraries differ in the last digits). ``ROBOCAL_RECORD_TUTORIAL=1``
records the run instead, after a change to the commands or their output (``-k track`` for one
page). The pages that calibrate large campaigns are marked slow."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_tutorial  # noqa: E402

BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```$", re.M | re.S)
# a number, with thousands separators ("1,000") but not across a comma-separated list ("49.99,0.03")
NUMBER = re.compile(r"[-+]?(?:\d{1,3}(?:,\d{3})+(?!\d)|\d+)(?:\.\d+)?(?:[eE][-+]?\d+)?")
NUMBER_RTOL, NUMBER_ATOL = 0.05, 0.002  # printed figures may differ in the last digits between machines
# what differs on every run by nature, compared as a placeholder: dates (a history's records) and
# durations in seconds ("selection 0.41 s")
VOLATILE = re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}:\d{2}(?:\.\d+)?(?:[+-]\d{2}:\d{2}|Z)?"
                      r"|\b\d+(?:\.\d+)? s\b")
BLOCK_TIMEOUT_S = 900
SHELL_TIMEOUT_S = 60  # `command -v` in a fresh shell: seconds
# pages whose blocks take more than ~15 s on a busy 2-core machine: run by `make test-slow`
# (the others, own-robot, tracker-export, flush-contacts, ur-factory-calibration: ~65 s together at load 13)
SLOW = {"tutorial/first-campaign.md", "how-to/error-model.md", "how-to/recalibrating.md",
        "how-to/track.md", "how-to/cell.md", "how-to/planes-scale-bar.md", "how-to/real-tool.md"}
# files a page's blocks must leave behind (beyond the printed outputs)
FILES = {"tutorial/first-campaign.md": ("poses.csv", "campaign.html", "Campaign.mod", "calibrated.yaml",
                                        "result.json", "report.html", "cell.mod", "cell_cal.mod",
                                        "cell_cal.mod.targets.csv")}


def blocks(text: str) -> list[tuple[str, str]]:
    """``(language, body)`` of every fenced block, in order."""
    return [(lang, body) for lang, _, body in BLOCK.findall(text)]


def same_output(recorded: str, fresh: str) -> str | None:
    """None when ``fresh`` is ``recorded`` up to the numbers' last digits, else the first difference."""
    recorded, fresh = VOLATILE.sub("<volatile>", recorded), VOLATILE.sub("<volatile>", fresh)
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


def fresh_shell() -> tuple[dict[str, str], str]:
    """The environment of a new terminal (no virtual environment on the PATH) and the activation
    line the reader was told to run in it (this interpreter's environment stands for ``.venv``)."""
    activate = Path(sys.prefix) / "bin" / "activate"
    if sys.prefix == sys.base_prefix or not activate.exists():  # robocal installed without a venv
        return dict(os.environ), ""
    venv_bins = {str(Path(sys.prefix) / "bin"), str(Path(sys.executable).parent)}
    path = [d for d in os.environ.get("PATH", "").split(os.pathsep) if d and d not in venv_bins]
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PATH")}
    return {**env, "PATH": os.pathsep.join(path)}, f'source "{activate}"\n'


def test_output_comparison():
    assert same_output("RMS 1.2797 -> 0.0206 mm", "RMS 1.2799 -> 0.0207 mm") is None
    assert same_output("RMS 1.2797 -> 0.0206 mm", "RMS 1.9 -> 0.0206 mm") is not None
    assert same_output("wrote a.csv", "wrote b.csv") is not None
    assert same_output("--tcp t=49.9983,0.0277,200.4340", "--tcp t=49.9985,0.0278,200.4341") is None
    assert same_output("--tcp t=49.9983,0.0277,200.4340", "--tcp t=49.9983,0.0277,260.4340") is not None
    assert same_output("from 1,000 candidates", "from 1,010 candidates") is None
    assert same_output("a\nb", "a") is not None
    assert same_output("#1    2026-12-06T11:17:26.214+00:00  calibration",
                       "#1    2027-01-02T08:00:00.001+00:00  calibration") is None
    assert same_output("time: selection 0.41 s, final fit 0.09 s",
                       "time: selection 1.9 s, final fit 0.2 s") is None
    page = docs_tutorial.with_outputs("x\n<!-- output -->\ny", ["line 1\nline 2"])
    assert "\n    line 2\n" in page and "<!--" not in page
    with pytest.raises(docs_tutorial.TutorialOutputError, match="markers"):
        docs_tutorial.with_outputs("x", ["one"])


def test_activation_is_said_where_a_reader_starts():
    """The index and the tutorial tell the reader to activate the environment; without it a fresh
    shell has no ``robocal`` (the harness does not put it there behind the page's back)."""
    for page in ("index.md", docs_tutorial.TUTORIAL):
        assert docs_tutorial.ACTIVATE in (docs_tutorial.DOCS / page).read_text(encoding="utf-8"), page
    env, activation = fresh_shell()
    if activation and shutil.which("robocal", path=env["PATH"]) is None:
        found = subprocess.run(["bash", "-c", "command -v robocal"], env=env, capture_output=True,
                               check=False, timeout=SHELL_TIMEOUT_S)
        assert found.returncode != 0
        found = subprocess.run(["bash", "-c", activation + "command -v robocal"], env=env,
                               capture_output=True, check=False, timeout=SHELL_TIMEOUT_S)
        assert found.returncode == 0


def test_every_runnable_block_has_its_output_marker():
    for page in docs_tutorial.runnable_pages():
        text = (docs_tutorial.DOCS / page).read_text(encoding="utf-8")
        found = [lang for lang, _ in blocks(text) if lang in docs_tutorial.RUNNABLE]
        assert text.count(docs_tutorial.OUTPUT_MARK) == len(found), f"{page}: one output marker a block"
        if found:
            assert docs_tutorial.outputs_path(page).exists(), f"{page}: record its outputs"


@pytest.mark.parametrize("page", [pytest.param(p, marks=[pytest.mark.slow] if p in SLOW else [])
                                  for p in docs_tutorial.runnable_pages()])
def test_page_runs_as_written(page, tmp_path):
    text = (docs_tutorial.DOCS / page).read_text(encoding="utf-8")
    found = [(lang, body) for lang, body in blocks(text) if lang in docs_tutorial.RUNNABLE]
    if not found:
        pytest.skip(f"{page} has no runnable block")
    pytest.importorskip("matplotlib", reason="the pages write HTML reports (report extra)")
    env, activation = fresh_shell()
    outputs = []
    for lang, body in found:
        cmd = (["bash", "-e", "-o", "pipefail", "-c", activation + body] if lang == "bash"
               else [sys.executable, "-c", body])
        proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, check=False,
                              timeout=BLOCK_TIMEOUT_S)
        assert proc.returncode == 0, f"{page}:\n{body}\n{proc.stderr[-2000:]}"
        outputs.append(proc.stdout + proc.stderr)
    for name in FILES.get(page, ()):
        assert (tmp_path / name).exists(), name
    path = docs_tutorial.outputs_path(page)
    if os.environ.get("ROBOCAL_RECORD_TUTORIAL") == "1":
        path.write_text(json.dumps({"outputs": outputs}, indent=1) + "\n", encoding="utf-8")
        return
    recorded = json.loads(path.read_text(encoding="utf-8"))["outputs"]
    assert len(recorded) == len(outputs), f"{page}: blocks added or removed: ROBOCAL_RECORD_TUTORIAL=1"
    for k, (old, new) in enumerate(zip(recorded, outputs, strict=True)):
        diff = same_output(old, new)
        assert diff is None, (f"{page}: block {k + 1} printed other than the site shows (record again with "
                              f"ROBOCAL_RECORD_TUTORIAL=1 if the change is intended):\n{diff}")


def test_a_list_rendered_as_a_paragraph_is_found():
    """scripts/docs_lists.py (a build hook) reports a paragraph holding list items; none of the pages
    the readers paste from, nor the result JSON reference, has one."""
    markdown = pytest.importorskip("markdown")
    import docs_lists

    exts = ["admonition", "attr_list", "tables", "def_list", "pymdownx.superfences"]
    broken = markdown.markdown("| a |\n|---|\n| 1 |\n- one\n- two\n", extensions=exts)
    assert docs_lists.broken_lists(markdown.markdown("text\n- one\n- two\n", extensions=exts))
    assert docs_lists.broken_lists(broken)
    assert not docs_lists.broken_lists(markdown.markdown("text\n\n- one\n- two\n", extensions=exts))
    assert not docs_lists.broken_lists("<p>a - b, 1. c</p>")
    for page in [*docs_tutorial.runnable_pages(), "index.md", "result-json.md"]:
        html = markdown.markdown((docs_tutorial.DOCS / page).read_text(encoding="utf-8"), extensions=exts)
        assert not docs_lists.broken_lists(html), page
