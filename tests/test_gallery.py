"""The gallery of worked examples (examples/gallery, issue 48): every script runs as a reader runs it
(in an empty folder, by the gallery's runner, which fills the cache the site is built from), writes
its figures, and prints figures within tolerance of the truth it simulated; the pages and thumbnails
the hook makes hold every section, output, figure and the download."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

import docs_gallery as dg  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
NOISE_FLOOR_RATIO = 1.3  # a calibration that is right reaches the noise floor within this factor
TRUTH_MM = 0.03  # a calibrated model against the true robot, 0.02 mm tracker noise, mm RMS
SIGMAS = 3.0  # an estimate against its true value, in its own 1-sigma


def _numbers(pattern: str, text: str) -> list[float]:
    match = re.search(pattern, text)
    assert match, f"not printed: {pattern!r}\n{text}"
    return [float(v) for v in match.groups()]


def check_tracker_export(text: str) -> None:
    assert "dropped 1 failed reading(s)" in text and "90 poses with 2-3 readings" in text
    gross, = _numbers(r"(\d+) poses got a gross error", text)
    rejected, = _numbers(r"without the (\d+) rejected observations", text)
    assert rejected == gross > 0  # every gross error left out (all fell in the calibration set)
    gap, _ = _numbers(r"vs true robot: RMS ([\d.]+) mm, max ([\d.]+) mm", text)
    before, after = _numbers(r"validation  RMS ([\d.]+) mm -> ([\d.]+) mm", text)
    assert gap < TRUTH_MM and after < before / 20


def check_track_cell(text: str) -> None:
    found, true = _numbers(r"found ([-+\d.]+) ppm, true ([-+\d.]+) ppm", text)
    assert abs(found - true) < 5.0  # ppm of a 200 ppm scale error
    nominal, calibrated, floor = _numbers(
        r"nominal ([\d.]+) mm, calibrated ([\d.]+) mm \(noise floor ([\d.]+)", text)
    assert calibrated <= NOISE_FLOOR_RATIO * floor < nominal


def check_payload_campaign(text: str) -> None:
    geometric, = _numbers(r"geometric +held-out RMS [\d.]+ mm = ([\d.]+) x", text)
    modelled, = _numbers(r"payload, thermal +held-out RMS [\d.]+ mm = ([\d.]+) x", text)
    assert modelled <= 1.15 < NOISE_FLOOR_RATIO < geometric
    for name in ("payload2", "payload3", "thermal"):
        found, sigma, true = _numbers(rf"{name} +found ([\d.]+) \+- ([\d.]+) [^,]+, true ([\d.]+)", text)
        assert abs(found - true) < SIGMAS * sigma, name


def check_ur_factory_to_ros(text: str) -> None:
    gap, = _numbers(r"refined model vs the true arm over the whole joint space: RMS ([\d.]+) mm", text)
    factory, refined, floor = _numbers(
        r"factory model ([\d.]+) mm, refined ([\d.]+) mm \(noise floor ([\d.]+)", text)
    fk, = _numbers(r"the calibrated model's within ([\d.e+-]+) mm", text)
    assert gap < TRUTH_MM and refined <= NOISE_FLOOR_RATIO * floor < factory and fk < 1e-6
    assert "only the 6 moving joints' origins changed" in text


def check_over_life(text: str) -> None:
    verdicts = dict(re.findall(r"month +(\d+): check of 20 poses: (holds|changed)", text))
    assert verdicts == {"3": "holds", "6": "changed", "9": "holds", "12": "holds"}
    shift, sigma = _numbers(r"most likely moved: theta3 ([-+\d.]+) \+- ([\d.]+) deg", text)
    assert abs(shift - 0.02) < SIGMAS * sigma
    refit, = _numbers(r"offsets-only recalibration: theta3 ([-+\d.]+) deg", text)
    assert abs(refit - 0.02) < 0.002  # deg: 20 poses, 0.02 mm noise
    timeline = re.findall(r"#\d (calibration|check) +(full|holds|changed|offsets only) ", text)
    assert timeline == [("calibration", "full"), ("check", "holds"), ("check", "changed"),
                        ("calibration", "offsets only"), ("check", "holds"), ("check", "holds")]


def check_filter_languages(text: str) -> None:
    languages = ["ABB RAPID", "KUKA KRL", "FANUC TP", "URScript", "Yaskawa INFORM", "Staubli VAL3"]
    for language in languages:
        done, total = _numbers(rf"{language}: (\d+) of (\d+) Cartesian target", text)
        assert done == total > 0, language
    assert "14 motions: 9 corrected, 5 not corrected (each named)" in text  # VAL3's run-time targets
    before, after = re.findall(r"(?:before|after) +CONST robtarget pApproach:=\[\[([-\d.,]+)\]", text)
    assert before != after


CHECKS = {"01_tracker_export": check_tracker_export, "02_track_cell": check_track_cell,
          "03_payload_campaign": check_payload_campaign, "04_ur_factory_to_ros": check_ur_factory_to_ros,
          "05_check_over_life": check_over_life, "06_filter_languages": check_filter_languages}
SLOW: set[str] = set()  # examples running longer than ~20 s (none today: the six take ~30 s together)
EXAMPLES = {example.stem: example for example in dg.examples()}


def test_every_example_is_checked_and_in_the_nav():
    assert set(EXAMPLES) == set(CHECKS)
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for stem in EXAMPLES:
        assert f"gallery/{stem}.md" in nav, stem


@pytest.mark.parametrize("stem", [pytest.param(s, marks=pytest.mark.slow) if s in SLOW else s
                                  for s in CHECKS])
def test_the_example_runs_writes_its_figures_and_finds_the_truth(stem):
    example = EXAMPLES[stem]
    out = dg.run_example(example)
    assert dg.cached(example) == out  # what the site build will read, without running it again
    figures = [f for section in out["sections"] for f in section["figures"]]
    assert figures, f"{stem} draws no figure"
    for name in figures:
        assert (dg.cache_dir(example) / name).read_bytes().startswith(PNG_MAGIC)
    CHECKS[stem]("".join(section["output"] for section in out["sections"]))
    page = dg.page_markdown(example, out)
    assert f"\n# {example.title}\n" in page and f"]({example.path.name}){{ download=" in page
    for section in example.sections:
        assert section.code in page and (not section.heading or f"## {section.heading}\n" in page)
    for k in range(1, len(figures) + 1):
        assert f"]({stem}_{k}.png)" in page


def test_the_downloaded_script_prints_what_its_page_shows(tmp_path):
    """Run as a reader runs it (``python NN_name.py``), an example prints exactly the sections'
    outputs the runner recorded for its page (the fastest example stands for all)."""
    example = EXAMPLES["02_track_cell"]
    out = dg.outputs(example)
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, str(example.path)], cwd=tmp_path, capture_output=True,
                          text=True, env=env, timeout=dg.RUN_TIMEOUT_S)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == "".join(section["output"] for section in out["sections"])
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["02_track_cell.png"]


def test_sections_keep_their_line_numbers_and_a_failure_names_the_script(tmp_path, monkeypatch):
    script = tmp_path / "99_broken.py"
    script.write_text('"""A broken example\n==================\n\nIt fails.\n"""\n\nx = 1\n\n'
                      '# %% A section\nprint(x)\n\n# %% Another\n\nraise ValueError("on purpose")\n')
    example = dg.parse_example(script)
    assert [(s.heading, s.first_line) for s in example.sections] == [("", 7), ("A section", 10),
                                                                      ("Another", 14)]
    monkeypatch.setattr(dg, "CACHE", tmp_path / "cache")
    with pytest.raises(dg.GalleryError, match=r'(?s)99_broken.py failed.*line 14.*on purpose'):
        dg.run_example(example)
    assert dg.cached(example) is None
    script.write_text(script.read_text().replace('raise ValueError("on purpose")', "print(2 * x)"))
    example = dg.parse_example(script)
    out = dg.run_example(example)
    assert [s["output"] for s in out["sections"]] == ["", "1\n", "2\n"]
    assert dg.cached(example) == out and out["digest"] == example.digest
    shutil.copy(script, tmp_path / "99_copy.py")  # the same text elsewhere: the same key
    assert dg.parse_example(tmp_path / "99_copy.py").digest == example.digest
    bad = tmp_path / "98_bad.py"
    bad.write_text('"""No underline"""\nx = 1\n')
    with pytest.raises(dg.GalleryError, match="underlined"):
        dg.parse_example(bad)


def test_the_index_has_a_card_per_example_with_its_thumbnail():
    items = [(e, out) for e in EXAMPLES.values() if (out := dg.cached(e)) is not None]
    if not items:
        pytest.skip("no example cached yet (run make gallery or the tests above)")
    index = dg.index_markdown(items)
    for example, _ in items:
        assert f'<a href="{example.stem}.html"><img src="{example.stem}_1.png"' in index
    assert "``" not in index
