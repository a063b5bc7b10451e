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
from robocal.data.measurements import read_joints
from robocal.deploy.compensation import format_csv, pose_columns
from robocal.kinematics.transforms import make_transform
from robocal.kinematics.urdf import from_urdf, to_urdf

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
    _workflow_files(d, q, p * 1e3, table, T)
    ro = d / "readonly.yaml"
    ro.write_text("keep me\n")
    ro.chmod(0o444)
    return d


def _workflow_files(d: Path, q: np.ndarray, p_mm: np.ndarray, table, T: np.ndarray) -> None:
    """Files of the workflow mistakes (issue 24): a file copied, joint columns exchanged or
    sign-flipped, a mirrored tracker frame, two tracker stations, decimal commas, programs without
    their points or in another language, flange targets, a URDF and a xacro file."""
    shutil.copy(d / "meca.csv", d / "meca_copy.csv")
    rc.simulate_tracker(MECA, 40, noise_mm=0.01, seed=5).data.save(d / "meca_b.csv")
    swapped, flipped = q.copy(), q.copy()
    swapped[:, [1, 2]] = swapped[:, [2, 1]]
    flipped[:, 3] *= -1
    (d / "swapped.csv").write_text(table(swapped, p_mm))
    (d / "flipped.csv").write_text(table(flipped, p_mm))
    (d / "mirrored.csv").write_text(table(q, p_mm * [1, -1, 1]))
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # the tracker moved
    (d / "station1.csv").write_text(table(q[:20], p_mm[:20]))
    (d / "station2.csv").write_text(table(q[20:], p_mm[20:] @ turn.T + [800.0, 300.0, 0.0]))
    text = table(q, p_mm)
    (d / "semicolon.csv").write_text(text.replace(",", ";").replace(".", ","))
    head, *rows = text.splitlines()
    quoted = [",".join(f'"{c.replace(".", ",")}"' for c in r.split(",")) for r in rows]
    (d / "quoted.csv").write_text("\n".join([head, *quoted]) + "\n")
    (d / "comma.txt").write_text("10,5 20 30 40 50 60 1 2 3\n11,5 20 30 40 50 60 1 2 3\n")
    shutil.copy(PROGRAMS / "weld_cell.mod", d / "weld.src")
    names, vals = pose_columns(T, {"length": "mm", "orientation": "deg"})
    (d / "flange.csv").write_text(format_csv(names, vals))
    (d / "meca.urdf").write_text(to_urdf(MECA))
    (d / "meca.xacro").write_text('<?xml version="1.0"?><robot xmlns:xacro="x"/>\n')
    from_urdf(to_urdf(rc.Robot.from_catalog("abb_irb2600"))).save(d / "irb2600_from_urdf.yaml")


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
        ("auto-two-files", ["calibrate", "{d}/meca.csv", "{d}/meca_b.csv", "--robot", "meca500",
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
        *_workflow_cases(),
        ("simulate-bar-too-long", ["simulate", "--robot", "meca500", "--kind", "distance", "--poses", "4",
                                   "--bar-mm", "20000", "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"],
         ["s.csv", "t.yaml"], "scale bar"),
    ]


def _workflow_cases() -> list[tuple[str, list[str], list[str], str]]:
    """The whole workflow as a newcomer drives it (issue 24): each mistake refused, naming it."""
    cal = ["calibrate", "{d}/meca.csv", "--robot", "meca500"]
    comp = ["compensate", "{d}/meca.yaml", "{d}/flange.csv", "--nominal", "meca500", "-o", "{o}/c.csv"]
    irb = ["--calibrated", "{d}/irb2600_truth.yaml", "--nominal", "abb_irb2600"]
    weld = ["filter", "{d}/weld_cell.mod", *irb, "-o", "{o}/f.mod"]
    return [
        ("same-file-twice", ["calibrate", "{d}/meca.csv", "{d}/meca.csv", "--robot", "meca500", "-o",
                             "{o}/m.yaml"], ["m.yaml"], "given twice"),
        ("same-contents-twice", ["calibrate", "{d}/meca.csv", "{d}/meca_copy.csv", "--robot", "meca500"], [],
         "same contents"),
        ("validate-on-calibration-data", [*cal, "--validate", "{d}/meca_copy.csv"], [], "validation"),
        ("model-yaml-named-json", [*cal, "-o", "{o}/result.json"], ["result.json"], "writes YAML"),
        ("json-named-yaml", [*cal, "--json", "{o}/r.yaml"], ["r.yaml"], "writes JSON"),
        ("simulate-csv-named-yaml", ["simulate", "--robot", "meca500", "--poses", "10", "-o", "{o}/s.yaml",
                                     "--truth", "{o}/t.yaml"], ["s.yaml", "t.yaml"], "writes CSV"),
        ("export-urdf-named-yaml", ["export", "meca500", "--urdf", "{o}/x.yaml"], ["x.yaml"], "URDF"),
        ("report-html-named-json", ["report", "{d}/not_result.json", "-o", "{o}/r.json"], ["r.json"], "HTML"),
        ("import-same-raw-twice", ["import", "{d}/big.txt", "{d}/big.txt", "--joints", "cols=0-5:deg",
                                   "--points", "cols=6-8:mm", "-o", "{o}/i.csv"], ["i.csv"], "twice"),
        ("compensate-tool-in-metres", [*comp, "--tool", "0.12,0,0.18,0,45,0"], ["c.csv"], "metres"),
        ("compensate-tool-in-radians", [*comp, "--tool", "120,0,180,0,0.785,0"], ["c.csv"], "radians"),
        ("plan-tool-in-metres", ["plan", "--robot", "meca500", "{d}/flange.csv", "--tool", "0.05,0,0.1,0,0,0",
                                 "-o", "{o}/p.csv"], ["p.csv"], "metres"),
        ("poses-smr-in-metres", ["poses", "--robot", "meca500", "-n", "20", "--smr-mm", "0.03,-0.02,0.06",
                                 "-o", "{o}/p.csv"], ["p.csv"], "metres"),
        ("simulate-smr-in-metres", ["simulate", "--robot", "meca500", "--poses", "10", "--smr-mm",
                                    "0.03,-0.02,0.06", "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"],
         ["s.csv", "t.yaml"], "metres"),
        ("tool-rotation-in-radians", ["tool", "{d}/three.csv", "--calibrated", "{d}/irb2600.yaml",
                                      "--nominal", "abb_irb2600", "--rotation", "0,0.785,0"], [], "radians"),
        ("filter-tool-in-metres", [*weld, "--tool", "tX=0.1,0,0.2,1,0,0,0"], ["f.mod"], "metres"),
        ("filter-tcp-44-deg-from-tool-data", [*weld, "--tcp", "tGun=50,0,200,0,74,0"], ["f.mod"], "44.0 deg"),
        ("filter-tcp-in-radians", [*weld, "--tcp", "tGun=50,0,200,0,0.5236,0"], ["f.mod"], "radians"),
        ("filter-rapid-named-src", ["filter", "{d}/weld.src", *irb, "-o", "{o}/w.src"], ["w.src"],
         "looks like ABB RAPID"),
        ("joint-columns-exchanged", ["calibrate", "{d}/swapped.csv", "--robot", "meca500"], [],
         "q2 and q3 look exchanged"),
        ("joint-sign-flipped", ["calibrate", "{d}/flipped.csv", "--robot", "meca500"], [], "q4's sign"),
        ("tracker-frame-mirrored", ["calibrate", "{d}/mirrored.csv", "--robot", "meca500"], [], "mirrored"),
        ("two-tracker-stations", ["calibrate", "{d}/station1.csv", "{d}/station2.csv", "--robot", "meca500"],
         [], "different tracker positions"),
        ("odd-file-of-two", ["calibrate", "{d}/meca.csv", "{d}/swapped.csv", "--robot", "meca500"], [],
         "swapped.csv is the odd file"),
        ("odd-validation-file", [*cal, "--validate", "{d}/mirrored.csv"], [], "mirrored.csv is the odd file"),
        ("evaluate-nominal-without-fit-frame", ["evaluate", "meca500", "{d}/meca.csv"], [], "--fit-frame"),
        ("evaluate-exchanged-columns", ["evaluate", "meca500", "{d}/swapped.csv", "--fit-frame"], [],
         "exchanged"),
        ("decimal-comma-semicolons", ["calibrate", "{d}/semicolon.csv", "--robot", "meca500"], [], "decimal"),
        ("decimal-comma-quoted", ["calibrate", "{d}/quoted.csv", "--robot", "meca500"], [], "decimal comma"),
        ("import-decimal-comma", ["import", "{d}/comma.txt", "--joints", "cols=0-5:deg", "--points",
                                  "cols=6-8:mm", "-o", "{o}/i.csv"], ["i.csv"], "decimal commas"),
        ("simulate-tracker-in-metres", ["simulate", "--robot", "meca500", "--poses", "10", "--tracker-mm",
                                        "2.5,0.5,0.3", "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"],
         ["s.csv", "t.yaml"], "metres"),
        ("compensate-decimal-comma-targets", ["compensate", "{d}/meca.yaml", "{d}/semicolon.csv", "--nominal",
                                              "meca500", "-o", "{o}/c.csv"], ["c.csv"], "decimal-comma"),
        ("model-given-as-data", ["calibrate", "{d}/meca.yaml", "--robot", "meca500"], [], "not measurements"),
        ("model-given-as-result", ["report", "{d}/meca.yaml", "-o", "{o}/r.html"], ["r.html"],
         "robot model YAML"),
        ("xacro-as-robot", ["calibrate", "{d}/meca.csv", "--robot", "{d}/meca.xacro"], [], "xacro"),
        ("compensate-other-parametrisation", ["compensate", "{d}/irb2600_from_urdf.yaml", "{d}/flange.csv",
                                              "--nominal", "abb_irb2600", "-o", "{o}/c.csv"], ["c.csv"],
         "another parametrisation"),
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


# ---------------------------------------------------------------- handled right, or flagged
def _doubled(q_deg: np.ndarray, p_mm: np.ndarray, jitter_deg: float, rng) -> str:
    """Every reading on two consecutive rows (a tracker export), no pose_id; the second row's
    joints jittered by ``jitter_deg``, its point by 5 um."""
    rows = []
    for qi, pi in zip(q_deg, p_mm, strict=True):
        rows += [np.r_[qi, pi], np.r_[qi + rng.normal(0, jitter_deg, qi.shape) * (jitter_deg > 0),
                                      pi + rng.normal(0, 0.005, 3)]]
    head = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n"
    return head + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)


@pytest.fixture(scope="module")
def flagged(files) -> Path:
    """Inputs that may be legitimate but look wrong (a WARNING), or that are handled right."""
    d = files.parent / "flagged"
    d.mkdir()
    rng = np.random.default_rng(3)
    meca = rc.Measurements.load(files / "meca.csv")
    q, p = np.rad2deg(meca.joints), meca.points * 1e3
    (d / "repeated.csv").write_text(_doubled(q, p, 0.0, rng))
    (d / "jittered.csv").write_text(_doubled(q, p, 0.01, rng))
    sim = rc.simulate_tracker(MECA, 40, noise_mm=0.01, seed=1)
    as_nominal = MECA.with_frames(base=sim.truth.base, tool=sim.truth.tool)  # the nominal robot measured
    rc.simulate_tracker(as_nominal, 30, noise_mm=0.01, seed=8, as_is=True).data.save(d / "nominal_val.csv")
    truth = rc.Robot.load(files / "irb2600_truth.yaml")
    moved = truth.with_frames(tool=truth.tool @ make_transform(np.eye(3), [3e-3, 0.0, 0.0]))  # SMR moved
    rc.simulate_tracker(moved, 30, noise_mm=0.01, seed=9, as_is=True).data.save(d / "smr_moved.csv")
    assert main(["--quiet", "poses", "--robot", "meca500", "-n", "12", "--candidates", "600", "--starts", "1",
                 "--smr-mm", "20,-30,40", "-o", str(d / "plan.csv")]) == 0
    return d


WARNINGS = [  # (case id, argv with {d} inputs, {f} flagged inputs, {o} outputs, a word of the WARNING line)
    ("near-repeats-without-pose-id", ["calibrate", "{f}/jittered.csv", "--robot", "meca500", "--nongeometric",
                                      "none"], "pose_id"),
    ("simulate-smr-unlike-the-plan", ["simulate", "--robot", "meca500", "--joints", "{f}/plan.csv",
                                      "--smr-mm", "0,0,50", "-o", "{o}/s.csv", "--truth", "{o}/t.yaml"],
     "planned with"),
    ("evaluate-smr-moved", ["evaluate", "{d}/irb2600_truth.yaml", "{f}/smr_moved.csv"], "SMR moved"),
    ("calibrated-worse-on-validation", ["calibrate", "{d}/meca.csv", "--robot", "meca500", "--validate",
                                        "{f}/nominal_val.csv"], "worse than the nominal"),
]


@pytest.mark.parametrize("argv, word", [c[1:] for c in WARNINGS], ids=[c[0] for c in WARNINGS])
def test_what_looks_wrong_is_a_warning(files, flagged, tmp_path, capsys, argv, word):
    before = _digest(files), _digest(flagged)
    code = main([a.format(d=files, f=flagged, o=tmp_path) for a in argv])
    out = capsys.readouterr().out
    assert code == 0
    assert [ln for ln in out.splitlines() if ln.startswith("WARNING") and word in ln], out
    assert (_digest(files), _digest(flagged)) == before


def test_repeated_readings_without_pose_id_are_one_pose(files, flagged, capsys):
    """Each reading on two rows and no pose_id: the rows pair into poses (backlash directions and
    cross-validation folds by pose stay right) and the run says so."""
    data = rc.Measurements.load(flagged / "repeated.csv")
    one = rc.Measurements.load(files / "meca.csv")
    assert data.n_poses == one.n_poses == len(data) // 2
    np.testing.assert_array_equal(data.approach[1::2], data.approach[::2])
    np.testing.assert_array_equal(data.approach[::2], one.approach)
    assert main(["evaluate", "meca500", str(flagged / "repeated.csv"), "--fit-frame"]) == 0
    assert "80 rows hold 40 poses" in capsys.readouterr().out


def test_frame_fit_of_a_backlash_model_uses_the_approach_directions(tmp_path):
    """evaluate --fit-frame / --frame-from judges a model with backlash as calibrate does: the
    errors of the true model are the noise, with or without the frame fit (4x before)."""
    import yaml

    truth = rc.simulate_tracker(rc.Robot.from_catalog("kuka_kr16_2"), 10, seed=3).truth
    truth.save(tmp_path / "t.yaml")
    doc = yaml.safe_load((tmp_path / "t.yaml").read_text())
    doc["joint_errors"] = {"parameters": {"backlash2": 3e-4, "backlash3": -3e-4, "backlash5": 4e-4}}
    (tmp_path / "bl.yaml").write_text(yaml.safe_dump(doc))
    robot = rc.Robot.load(tmp_path / "bl.yaml")
    cal = rc.simulate_tracker(robot, 150, noise_mm=0.02, seed=4, as_is=True).data
    val = rc.simulate_tracker(robot, 80, noise_mm=0.02, seed=5, as_is=True).data
    plain = rc.evaluate(robot, val)["rms"]
    for kw in ({"fit_frame": True}, {"frame_from": cal}):
        assert rc.evaluate(robot, val, **kw)["rms"] < 1.2 * plain < 0.06


def test_a_rehearsal_measures_the_planned_smr(flagged, tmp_path):
    assert main(["--quiet", "simulate", "--robot", "meca500", "--joints", str(flagged / "plan.csv"), "-o",
                 str(tmp_path / "s.csv"), "--truth", str(tmp_path / "t.yaml")]) == 0
    truth = rc.Robot.load(tmp_path / "t.yaml")
    np.testing.assert_allclose(truth.tool[:3, 3], [0.02, -0.03, 0.04], atol=1e-12)


def test_a_urdf_is_a_robot(files, tmp_path):
    assert main(["--quiet", "calibrate", str(files / "meca.csv"), "--robot", str(files / "meca.urdf"),
                 "-o", str(tmp_path / "m.yaml")]) == 0
    assert rc.Robot.load(tmp_path / "m.yaml").n_joints == 6


def test_compensate_defaults_to_the_flange_in_the_robot_base(files, tmp_path, capsys):
    irb = rc.Robot.from_catalog("abb_irb2600")
    q = np.deg2rad([[10, 20, 10, 30, 40, 20], [-20, 10, 20, -30, 50, 10], [30, 0, 30, 10, 60, -20]])
    names, vals = pose_columns(irb.fk(q), {"length": "mm", "orientation": "deg"})
    (tmp_path / "flange.csv").write_text(format_csv(names, vals))
    assert main(["compensate", str(files / "irb2600_truth.yaml"), str(tmp_path / "flange.csv"), "--nominal",
                 "abb_irb2600", "-o", str(tmp_path / "c.csv")]) == 0
    out = capsys.readouterr().out
    assert "targets: the flange (tool0) in the robot's base frame" in out
    assert "corrections largest" in out and "median" in out
    # flange targets move by the robot's errors (a few mm at most), not by the SMR offset
    corrected = np.loadtxt(tmp_path / "c.csv", delimiter=",", skiprows=2, usecols=(6, 7, 8))  # marker, header
    assert np.abs(corrected - vals[:, :3]).max() < 5.0


def test_the_fanuc_campaign_program_holds_the_planned_joints(tmp_path):
    """poses --fanuc: one P[k] per pose in order, J3 in FANUC's convention (catalog J3 + J2)."""
    import re

    assert main(["--quiet", "poses", "--robot", "fanuc_lrmate200id", "-n", "10", "--candidates", "600",
                 "--starts", "1", "--smr-mm", "20,-30,40", "-o", str(tmp_path / "p.csv"), "--fanuc",
                 str(tmp_path / "campaign.ls")]) == 0
    text = (tmp_path / "campaign.ls").read_text()
    assert text.startswith("/PROG  CAMPAIGN") and text.rstrip().endswith("/END")
    values = np.array([[float(v) for v in re.findall(r"J\d= (-?[\d.]+) deg", block)]
                       for block in re.findall(r"P\[\d+\]\{(.*?)\};", text, re.S)])
    planned = np.rad2deg(read_joints(tmp_path / "p.csv"))
    planned[:, 2] += planned[:, 1]
    np.testing.assert_allclose(values, planned, atol=1e-4)
    assert len(re.findall(r"^\s*\d+:J P\[\d+\] 20% FINE", text, re.M)) == 10
