"""Bad inputs, every command and file type: each run exits non-zero with one line naming the
problem, no traceback, writes nothing, and leaves every existing file as it was."""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.compensate import format_csv, pose_columns

PROGRAMS = Path(__file__).parent / "data" / "programs"
MECA = rc.Robot.from_catalog("meca500")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Path:
    """Good and bad input files shared by the cases (never modified by them)."""
    d = tmp_path_factory.mktemp("inputs")
    meca = rc.simulate_tracker(MECA, 40, noise_mm=0.01, seed=1)
    meca.data.save(d / "meca.csv")
    q, p = np.rad2deg(meca.data.joints), meca.data.points
    head = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n"

    def table(joints, points):
        rows = np.hstack([joints, points])
        return head + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in rows)

    (d / "meca_m_as_mm.csv").write_text(table(q, p))  # metres under _mm headers
    (d / "meca_rad_as_deg.csv").write_text(table(np.deg2rad(q), p * 1e3))  # radians under _deg
    (d / "same_pose.csv").write_text(table(np.repeat(q[:1], 40, 0), np.repeat(p[:1] * 1e3, 40, 0)))
    (d / "nan.csv").write_text(table(q, p * 1e3).replace("\n", "\nnan,0,0,0,0,0,1,2,3\n", 1))
    (d / "colour.csv").write_text("q1_deg,colour\n1,2\n")
    (d / "empty.csv").write_text("")
    (d / "binary.csv").write_bytes(b"\x89PNG\r\n\x1a\n\x00\xff\xfe")
    irb = rc.simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 40, noise_mm=0.01, seed=2)
    irb.data.save(d / "irb2600.csv")
    (d / "irb2600_truth.yaml").write_text("")
    irb.truth.save(d / "irb2600_truth.yaml")
    gaps = "q1_deg,q3_deg\n1,2\n"
    (d / "gaps.csv").write_text(gaps)
    base = "units: {length: mm, angle: deg}\n"
    (d / "no_d.yaml").write_text(base + "joints:\n  - {alpha: 0, a: 0, theta: 0, d: 100}\n"
                                        "  - {alpha: 90, a: 50, theta: 0}\n")
    (d / "unknown_key.yaml").write_text(base + "mdh: {alpha: [0], a: [0], theta: [0], d: [0]}\ncolour: red\n")
    (d / "unsafe.yaml").write_text("!!python/object/apply:os.system ['echo hacked']\n")
    (d / "no_units.yaml").write_text("mdh: {alpha: [0], a: [0], theta: [0], d: [0]}\n")
    (d / "binary.yaml").write_bytes(b"\x00\xff\xfe\x00")
    (d / "doctype.urdf").write_text('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x "y">]><robot name="r"/>')
    (d / "not_result.json").write_text('{"format": "something else"}')
    (d / "broken.json").write_text("{not json")
    for name, cells in (("big.txt", "1e30"), ("inf.txt", "inf"), ("text.txt", "abc")):
        (d / name).write_text(f"10 20 30 40 50 60 1 2 3\n10 20 30 40 50 61 {cells} 2 3\n")
    T = MECA.fk(np.deg2rad(q[:5]))
    names, vals = pose_columns(T, {"length": "mm", "orientation": "quat"})
    vals[0, 3] = 2.0  # not a unit quaternion
    (d / "bad_quat.csv").write_text(format_csv(names, vals))
    far = T.copy()
    far[:, 0, 3] += 5.0
    names, vals = pose_columns(far, {"length": "mm", "orientation": "quat"})
    (d / "far.csv").write_text(format_csv(names, vals))
    MECA.save(d / "meca.yaml")
    shutil.copy(PROGRAMS / "weld_cell.mod", d / "weld_cell.mod")
    (d / "malformed.mod").write_text((PROGRAMS / "weld_cell.mod").read_text().replace(
        "[[392.37,421.20,120.43]", "[[392.37,421.20]", 1))
    (d / "unknown_tool.mod").write_text((PROGRAMS / "weld_cell.mod").read_text().replace(
        "tool:=tGun", "tool:=tNoSuchTool").replace("tGun", "tNoSuchTool", 1))
    rc.Robot.from_catalog("abb_irb2600").save(d / "irb2600.yaml")
    (d / "three.csv").write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,0,0,0,0,0\n10,0,0,0,0,0\n")
    ro = d / "readonly.yaml"
    ro.write_text("keep me\n")
    ro.chmod(0o444)
    return d


def _cases() -> list[tuple[str, list[str], list[str], str]]:
    """(case id, argv with {d} for the input folder and {o} for the output folder, outputs that
    must not appear (relative to {o}), a word the message must contain)."""
    cal = ["calibrate", "{d}/meca.csv", "--robot", "meca500"]
    return [
        ("m-under-mm", ["calibrate", "{d}/meca_m_as_mm.csv", "--robot", "meca500", "-o", "{o}/m.yaml"],
         ["m.yaml"], "length unit"),
        ("rad-under-deg", ["calibrate", "{d}/meca_rad_as_deg.csv", "--robot", "meca500", "-o", "{o}/m.yaml"],
         ["m.yaml"], "misses the measurements"),
        ("wrong-robot", ["calibrate", "{d}/meca.csv", "--robot", "abb_irb2600", "-o", "{o}/m.yaml"],
         ["m.yaml"], "another robot"),
        ("validation-other-robot", [*cal, "--validate", "{d}/irb2600.csv", "-o", "{o}/m.yaml"], ["m.yaml"],
         "bigger robot"),
        ("missing-output-folder", [*cal, "-o", "{o}/no/such/folder/m.yaml"], [], "does not exist"),
        ("read-only-output", [*cal, "-o", "{d}/readonly.yaml"], [], "read-only"),
        ("output-is-input", [*cal, "--json", "{d}/meca.csv"], [], "input"),
        ("same-output-twice", [*cal, "-o", "{o}/m.yaml", "--json", "{o}/m.yaml"], ["m.yaml"], "twice"),
        ("report-unwritable", [*cal, "-o", "{o}/m.yaml", "--json", "{o}/r.json", "--report",
                               "{o}/nope/r.html"], ["m.yaml", "r.json"], "does not exist"),
        ("hold-out-0", [*cal, "--hold-out", "0", "-o", "{o}/m.yaml"], ["m.yaml"], "hold-out"),
        ("hold-out-all", [*cal, "--hold-out", "40", "-o", "{o}/m.yaml"], ["m.yaml"], "hold-out"),
        ("unknown-method", [*cal, "--method", "magic", "-o", "{o}/m.yaml"], ["m.yaml"], "unknown method"),
        ("unknown-option", [*cal, "--set", "colour=1", "-o", "{o}/m.yaml"], ["m.yaml"], "no option"),
        ("unknown-term", [*cal, "--nongeometric", "friction", "-o", "{o}/m.yaml"], ["m.yaml"], "friction"),
        ("cyclic-of-joint-7", [*cal, "--nongeometric", "cyc7_50_s", "-o", "{o}/m.yaml"], ["m.yaml"],
         "6-joint"),
        ("auto-too-few-poses", [*cal, "--hold-out", "20", "--nongeometric", "auto", "-o", "{o}/m.yaml"],
         ["m.yaml"], "25 poses"),
        ("auto-two-files", ["calibrate", "{d}/meca.csv", "{d}/meca.csv", "--robot", "meca500",
                            "--nongeometric", "auto"], [], "one calibration data set"),
        ("terms-with-swarm", [*cal, "--method", "swarm", "--nongeometric", "gear"], [], "lsq, robust"),
        ("sigma-without-value", [*cal, "--sigma", "plane", "-o", "{o}/m.yaml"], ["m.yaml"], "KIND=MM"),
        ("not-converged", [*cal, "--method", "genetic", "--set", "generations=2", "-o", "{o}/m.yaml"],
         ["m.yaml"], "did not converge"),
        ("empty-csv", ["calibrate", "{d}/empty.csv", "--robot", "meca500"], [], "empty"),
        ("nan-csv", ["calibrate", "{d}/nan.csv", "--robot", "meca500"], [], "NaN"),
        ("unknown-column", ["calibrate", "{d}/colour.csv", "--robot", "meca500"], [], "colour"),
        ("binary-csv", ["calibrate", "{d}/binary.csv", "--robot", "meca500"], [], "UTF-8"),
        ("missing-csv", ["calibrate", "{d}/nothing.csv", "--robot", "meca500"], [], "cannot read"),
        ("yaml-missing-d", ["calibrate", "{d}/meca.csv", "--robot", "{d}/no_d.yaml"], [], "joint 2"),
        ("yaml-unknown-key", ["robots", "{d}/unknown_key.yaml"], [], "colour"),
        ("yaml-unsafe", ["robots", "{d}/unsafe.yaml"], [], "not valid"),
        ("yaml-no-units", ["robots", "{d}/no_units.yaml"], [], "units"),
        ("yaml-binary", ["robots", "{d}/binary.yaml"], [], "UTF-8"),
        ("unknown-catalog-robot", ["calibrate", "{d}/meca.csv", "--robot", "meca9000"], [], "unknown robot"),
        ("evaluate-m-under-mm", ["evaluate", "meca500", "{d}/meca_m_as_mm.csv", "--fit-frame", "--json",
                                 "{o}/e.json"], ["e.json"], "length unit"),
        ("evaluate-same-pose", ["evaluate", "meca500", "{d}/same_pose.csv", "--fit-frame"], [], "degenerate"),
        ("evaluate-two-frames", ["evaluate", "meca500", "{d}/meca.csv", "--fit-frame", "--frame-from",
                                 "{d}/meca.csv"], [], "not allowed"),
        ("evaluate-other-robot", ["evaluate", "{d}/meca.yaml", "{d}/irb2600.csv"], [], "bigger robot"),
        ("import-1e30", ["import", "{d}/big.txt", "--joints", "cols=0-5:deg", "--points", "cols=6-8:mm",
                         "-o", "{o}/i.csv"], ["i.csv"], "column 6"),
        ("import-inf", ["import", "{d}/inf.txt", "--joints", "cols=0-5:deg", "--points", "cols=6-8:mm",
                        "-o", "{o}/i.csv"], ["i.csv"], "infinite"),
        ("import-text", ["import", "{d}/text.txt", "--joints", "cols=0-5:deg", "--points", "cols=6-8:mm",
                         "-o", "{o}/i.csv"], ["i.csv"], "'abc'"),
        ("import-no-unit", ["import", "{d}/big.txt", "--joints", "cols=0-5", "--points", "cols=6-8:mm",
                            "-o", "{o}/i.csv"], ["i.csv"], "unit"),
        ("import-onto-input", ["import", "{d}/big.txt", "--joints", "cols=0-5:deg", "--points",
                               "cols=6-8:mm", "-o", "{d}/big.txt"], [], "input"),
        ("simulate-negative-noise", ["simulate", "--robot", "meca500", "--poses", "10", "--noise-mm", "-1",
                                     "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"], ["s.csv", "t.yaml"],
         "noise"),
        ("simulate-no-poses", ["simulate", "--robot", "meca500", "--poses", "0", "-o", "{o}/s.csv",
                               "--truth", "{o}/t.yaml"], ["s.csv", "t.yaml"], "n_poses"),
        ("report-not-a-result", ["report", "{d}/not_result.json", "-o", "{o}/r.html"], ["r.html"],
         "not a robocal result"),
        ("report-broken-json", ["report", "{d}/broken.json", "-o", "{o}/r.html"], ["r.html"], "JSON"),
        ("export-doctype", ["export", "{d}/doctype.urdf", "--yaml", "{o}/x.yaml"], ["x.yaml"], "DOCTYPE"),
        ("export-nothing", ["export", "meca500"], [], "nothing to write"),
        ("export-missing-urdf", ["export", "{d}/none.urdf", "--yaml", "{o}/x.yaml"], ["x.yaml"],
         "cannot read"),
        ("compensate-bad-quaternion", ["compensate", "{d}/meca.yaml", "{d}/bad_quat.csv", "--nominal",
                                       "meca500", "-o", "{o}/c.csv"], ["c.csv"], "unit length"),
        ("compensate-missing-model", ["compensate", "{d}/none.yaml", "{d}/far.csv", "--nominal", "meca500",
                                      "-o", "{o}/c.csv"], ["c.csv"], "cannot read"),
        ("plan-unreachable", ["plan", "--robot", "abb_irb2600", "{d}/far.csv", "-o", "{o}/p.csv"], ["p.csv"],
         "no IK solution"),
        ("analyze-joint-gaps", ["analyze", "{d}/gaps.csv", "--robot", "meca500"], [], "q1_deg"),
        ("filter-malformed-rapid", ["filter", "{d}/malformed.mod", "--calibrated",
                                    "{d}/irb2600_truth.yaml", "--nominal", "abb_irb2600", "-o", "{o}/f.mod"],
         ["f.mod"], "malformed.mod"),
        ("filter-unknown-tool", ["filter", "{d}/unknown_tool.mod", "--calibrated",
                                 "{d}/irb2600_truth.yaml", "--nominal", "abb_irb2600", "-o", "{o}/f.mod"],
         ["f.mod"], "unknown tool"),
        ("filter-onto-input", ["filter", "{d}/weld_cell.mod", "--calibrated", "{d}/irb2600_truth.yaml",
                               "--nominal", "abb_irb2600", "-o", "{d}/weld_cell.mod"], [], "input"),
        ("tool-three-poses", ["tool", "{d}/three.csv", "--calibrated", "{d}/irb2600.yaml", "--nominal",
                              "abb_irb2600"], [], "4"),
        ("bad-argument", ["calibrate", "{d}/meca.csv"], [], "--robot"),
        ("poses-too-few", ["poses", "--robot", "meca500", "-n", "3", "-o", "{o}/p.csv", "--rapid",
                           "{o}/c.mod"], ["p.csv", "c.mod"], "identif"),
        ("poses-tracker-inside", ["poses", "--robot", "abb_irb2600", "-n", "20", "--tracker-mm", "0,0,500",
                                  "-o", "{o}/p.csv"], ["p.csv"], "tracker"),
        ("poses-empty-box", ["poses", "--robot", "abb_irb2600", "-n", "20", "--box", "5000", "5000", "5000",
                             "5100", "5100", "5100", "-o", "{o}/p.csv"], ["p.csv"], "box"),
        ("poses-krl-not-src", ["poses", "--robot", "abb_irb2600", "-n", "20", "-o", "{o}/p.csv", "--krl",
                               "{o}/c.dat"], ["p.csv"], ".src"),
        ("simulate-bar-too-long", ["simulate", "--robot", "meca500", "--kind", "distance", "--poses", "4",
                                   "--bar-mm", "20000", "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"],
         ["s.csv", "t.yaml"], "scale bar"),
    ]


def _digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


CASES = _cases()


def test_the_table_is_large():
    assert len(CASES) >= 40


@pytest.mark.parametrize("argv, absent, word", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_and_writes_nothing(files, tmp_path, capsys, argv, absent, word):
    before = _digest(files)
    argv = [a.format(d=files, o=tmp_path) for a in argv]
    try:
        code = main(["--quiet", *argv])
    except SystemExit as exc:  # argparse
        code = exc.code
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code not in (0, None), f"exit 0 for {argv}: {err}"
    assert len(lines) == 1 and "Traceback" not in err and "internal error" not in err, err
    assert word.lower() in lines[0].lower(), lines[0]
    assert not [p for p in absent if (tmp_path / p).exists()], list(tmp_path.iterdir())
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".tmp")]
    assert _digest(files) == before  # no input changed, nothing written next to them
    assert os.access(files / "readonly.yaml", os.F_OK)
