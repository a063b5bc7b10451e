"""Yaskawa INFORM jobs: the corpus (tests/data/programs/corpus/*.JBI, VAR.DAT, written for the project
in the styles pendants and offline tools save), one test per construct; every motion corrected or
named, only target numbers change, the filtered targets reach the intended poses on the calibrated
model; the form (RCONF); the campaign job of ``robocal poses --inform`` read back."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.programs import filter_program
from robocal.programs.dialects.inform.reader import InformDialect
from robocal.programs.filter import controller_joints, target_poses
from robocal.programs.registry import dialect_for
from robocal.programs.simulate import execute
from robocal.programs.source import NUMBER_RE, ProgramText

CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"
FRAMES = {"2": "1250,-300,450,0,0,15"}
TOOLS = {"1": "0,-35,410,0,-30,0", "3": "0,0,180,0,0,0"}

# files, the targets corrected, the motions named (pattern per motion), motions: (corrected, joint) by hand
CASES = {
    "welding job in user frame 2": (
        ["WELD_UF2.JBI"], ["C00001", "C00002", "C00003", "C00004", "C00005", "C00006", "C00007", "C00009"],
        [r":41: MOVL: .*C00008 is shifted at run time by SFTON P010 UF#\(2\) \(WELD_UF2.JBI:40\)",
         r":43: IMOV: .*P011 is an increment \(IMOV\)"], (7, 2)),
    "pick and place, no VAR.DAT": (
        ["PICK_PLACE.JBI"], ["C00000", "C00001", "C00002", "C00003", "C00004", "C00005"],
        [r":35: MOVL: .*P001 is not in the files given \(a global position variable: give the controller.s "
         r"VAR.DAT with --references",
         r":37: MOVL: .*P002 is assigned at run time by GETPOS \(PICK_PLACE.JBI:36\)",
         r":39: MOVL: .*LP000 is assigned at run time by SET \(PICK_PLACE.JBI:38\)",
         r":40: MOVL: .*P\[I000\]: the position number is computed at run time",
         r":42: MOVJ: .*P003 is not in the files given"], (8, 0)),
    "pick and place with VAR.DAT": (
        ["PICK_PLACE.JBI", "VAR.DAT"], ["C00000", "C00001", "C00002", "C00003", "C00004", "C00005", "P0001"],
        [r":37: MOVL: .*P002 is assigned at run time by GETPOS",
         r":39: MOVL: .*LP000 is assigned at run time by SET",
         r":40: MOVL: .*P\[I000\]: the position number is computed at run time"], (9, 1)),
    "track and station": (
        # ROBOT positions with base-axis (BC) and station (+MOVJ EC) values: arm targets (issue 45)
        ["TRACK_WELD.JBI"], ["C00000", "C00001", "C00002"],
        [r":32: MOVL: .*C00003 is in user frame 5, set at run time by MFRAME at TRACK_WELD.JBI:31",
         r":33: MOVL: .*C00004 is in user frame 5, set at run time by MFRAME"], (3, 0)),
}
NOMINAL = rc.Robot.from_catalog("yaskawa_gp25")
CALIBRATED = perturbed(NOMINAL, 7)


def _copy(names, tmp_path) -> list[Path]:
    for n in names:
        shutil.copy(CORPUS / n, tmp_path / n)
    return [tmp_path / n for n in names]


def _outside_numbers(data: bytes) -> str:
    return re.sub(NUMBER_RE.pattern, "#", data.decode("latin-1"))


def _parse(paths):
    d = InformDialect()
    return d.parse([ProgramText(p) for p in paths], {}, {})


@pytest.mark.parametrize("case", list(CASES))
def test_every_motion_is_corrected_or_named(case, tmp_path):
    files, corrected, named, (n_corrected, n_joint) = CASES[case]
    paths = _copy(files, tmp_path)
    res = filter_program(paths, CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    assert [r["name"] for r in res.rows] == corrected and all(r["filtered"] for r in res.rows)
    assert len(res.uncorrected) == len(named)
    for pattern, line in zip(named, res.uncorrected, strict=True):
        assert re.search(pattern, line), (pattern, line)
    counts = json.loads(res.table_json())["summary"]["motions"]
    # corrected + named == total == the hand count (motions to joint positions have no record)
    assert counts == {"total": n_corrected + len(named), "corrected": n_corrected, "named": len(named)}
    hand = sum(len(re.findall(r"^(?:MOVJ|MOVL|MOVC|MOVS|IMOV) ", p.read_text(), re.M)) for p in paths)
    assert counts["total"] == hand - n_joint
    lines = [int(re.match(r":(\d+)", n).group(1)) for n in named]
    assert [(r.file, r.line) for r in res.motions if r.status == "named"] == [(files[0], k) for k in lines]
    for p in paths:
        before = p.read_bytes()
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(before)
        assert res.outputs[p].count(b"\r\n") == before.count(b"\r\n")
        assert p.read_bytes() == before


@pytest.mark.parametrize("case", list(CASES))
def test_identity_calibration_changes_no_byte(case, tmp_path):
    paths = _copy(CASES[case][0], tmp_path)
    res = filter_program(paths, NOMINAL, NOMINAL, frames=FRAMES, tools=TOOLS)
    assert all(res.outputs[p] == p.read_bytes() for p in paths)


@pytest.mark.parametrize("case", ["welding job in user frame 2", "pick and place with VAR.DAT"])
def test_filtered_targets_reach_the_intended_poses(case, tmp_path):
    """The controller (nominal IK in each position's RCONF) runs the filtered job on the calibrated
    robot: the TCP lands on the pose the job meant, to the file's resolution."""
    paths = _copy(CASES[case][0], tmp_path)
    res = filter_program(paths, CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    out = []
    for p in paths:
        o = tmp_path / "out" / p.name
        o.parent.mkdir(exist_ok=True)
        o.write_bytes(res.outputs[p])
        out.append(o)
    reached, _ = execute(out, CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    before, X = execute(paths, CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    err = np.linalg.norm(reached[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    err0 = np.linalg.norm(before[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    turn = np.rad2deg(np.linalg.norm(rc.kinematics.transforms.matrix_to_rotvec(
        reached[:, :3, :3] @ np.swapaxes(X[:, :3, :3], 1, 2)), axis=1))
    assert err.max() < 0.003 and turn.max() < 0.0005 and err0.min() > 0.5


# ----------------------------------------------------------------------------- constructs
def test_frames_tools_and_forms_of_the_positions(tmp_path):
    """Each position takes the ///USER, ///TOOL, ///POSTYPE and ///RCONF set above it; PULSE
    positions are joints; BASE and ROBOT positions are in the robot frame."""
    prog = _parse(_copy(["WELD_UF2.JBI"], tmp_path))
    assert {(t.frame, t.tool) for t in prog.targets} == {("2", "1")}
    assert all(t.config.tolist() == [1, 0, 0, 0, 0, 0] for t in prog.targets)
    pick = _parse(_copy(["PICK_PLACE.JBI"], tmp_path))
    assert {(t.frame, t.tool) for t in pick.targets} == {("identity", "3")}


def test_unknown_tool_or_user_frame_is_refused(tmp_path):
    paths = _copy(["WELD_UF2.JBI"], tmp_path)
    with pytest.raises(DataError, match=r"unknown tool\(s\) or frame\(s\)"):
        filter_program(paths, CALIBRATED, NOMINAL, tools=TOOLS)
    with pytest.raises(DataError, match=r"unknown tool\(s\) or frame\(s\)"):
        filter_program(paths, CALIBRATED, NOMINAL, frames=FRAMES)


def test_tool_0_without_data_is_the_flange(tmp_path):
    path = tmp_path / "T0.JBI"
    path.write_bytes((CORPUS / "PICK_PLACE.JBI").read_bytes().replace(b"///TOOL 3", b"///TOOL 0"))
    res = filter_program([path], CALIBRATED, NOMINAL)
    assert {r["tool"] for r in res.rows} == {"0"}
    assert any("TOOL 0 has no data given: taken as the flange" in w for w in res.warnings)


def test_form_crossing_is_written_before_the_position_and_restored_after(tmp_path):
    """A correction that carries R across 180 deg needs another RCONF: a ///RCONF line goes before
    the position and the old one after it; read back, the controller lands on the target."""
    q = np.deg2rad([[10, 20, -10, 179.999, -60, 0], [12, 22, -8, 150, -60, 0], [14, 24, -6, 120, -60, 0]])
    d = InformDialect()
    values = d.from_pose(NOMINAL.fk(q), np.zeros((3, 6)))
    lines = ["/JOB", "//NAME FORM", "//POS", "///NPOS 3,0,0,0,0,0", "///TOOL 0", "///POSTYPE ROBOT",
             "///RECTAN", "///RCONF 1,0,0,0,0,0,0,0"]
    lines += [f"C{k:05d}=" + ",".join([f"{v:.3f}" for v in row[:3]] + [f"{v:.4f}" for v in row[3:]])
              for k, row in enumerate(values)]
    lines += ["//INST", "///ATTR SC,RW", "///GROUP1 RB1", "NOP", "MOVJ C00000 VJ=10.00", "MOVL C00001 V=50.0",
              "MOVL C00002 V=50.0", "END", ""]
    path = tmp_path / "FORM.JBI"
    path.write_bytes("\r\n".join(lines).encode())
    cal = perturbed(NOMINAL, 3)
    res = filter_program([path], cal, NOMINAL, tools={"0": "0,0,0,0,0,0"})
    rows = {r["name"]: r for r in res.rows}
    changed = [n for n, r in rows.items() if r["configuration"] == "changed"]
    out = res.outputs[path].decode()
    if not changed:
        pytest.skip("this perturbation does not carry R across 180 deg")
    assert changed == ["C00000"] and "///RCONF 1,0,0,1,0,0,0,0\r\nC00000=" in out
    assert re.search(r"C00000=[^\r]*\r\n///RCONF 1,0,0,0,0,0,0,0\r\nC00001=", out)
    o = tmp_path / "out.JBI"
    o.write_bytes(res.outputs[path])
    reached, X = execute([o], cal, NOMINAL, tools={"0": "0,0,0,0,0,0"})
    _, X0 = execute([path], cal, NOMINAL, tools={"0": "0,0,0,0,0,0"})
    assert np.abs(reached[:, :3, 3] - X0[:, :3, 3]).max() * 1e3 < 0.003


def test_npos_count_and_malformed_lines(tmp_path):
    text = (CORPUS / "WELD_UF2.JBI").read_bytes()
    bad = tmp_path / "BAD.JBI"
    bad.write_bytes(text.replace(b"///NPOS 10,", b"///NPOS 11,"))
    res = filter_program([bad], CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    assert any("///NPOS 11,0,0,0,0,0 but the section holds 10,0,0,0,0,0" in w for w in res.warnings)
    bad.write_bytes(text.replace(b"C00004=", b"C00004 ="[:-1] + b": "))
    with pytest.raises(DataError, match=r"BAD.JBI:16: malformed position line"):
        filter_program([bad], CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    bad.write_bytes(text.replace(b"///RCONF 1,0,0,0,0,0,0,0", b"///RCONF 1,0,2"))
    with pytest.raises(DataError, match=r"BAD.JBI:12: malformed ///RCONF"):
        filter_program([bad], CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)


def test_format_is_told_from_suffix_and_content(tmp_path):
    paths = _copy(["PICK_PLACE.JBI", "VAR.DAT"], tmp_path)
    assert dialect_for(paths).name == "Yaskawa INFORM"
    renamed = tmp_path / "pick.txt"
    shutil.copy(paths[0], renamed)
    assert dialect_for([renamed]).name == "Yaskawa INFORM"
    krl = tmp_path / "cell.dat"
    krl.write_text("&ACCESS RVP\nDEFDAT cell\nENDDAT\n")
    with pytest.raises(DataError, match="cannot tell the program format"):
        dialect_for([paths[0], krl])


def test_cli_filters_a_job(tmp_path, capsys):
    paths = _copy(["WELD_UF2.JBI"], tmp_path)
    cal = tmp_path / "cal.yaml"
    CALIBRATED.save(cal)
    out = tmp_path / "WELD_CAL.JBI"
    assert main(["filter", str(paths[0]), "--calibrated", str(cal), "--nominal", "yaskawa_gp25", "-o",
                 str(out), "--frame", "2=1250,-300,450,0,0,15", "--tool", "1=0,-35,410,0,-30,0"]) == 0
    text = capsys.readouterr().out
    assert "8 of 8 Cartesian target(s) filtered" in text
    assert "9 motions: 7 corrected, 2 not corrected (each named)" in text
    assert out.read_bytes() != paths[0].read_bytes() and (tmp_path / "WELD_CAL.JBI.targets.json").exists()
    # the provenance marker: one comment instruction after NOP, 32 characters at most; filtering the
    # filtered job again is refused
    added = [ln for ln in out.read_text(encoding="latin-1").splitlines() if ln.startswith("'robocal ")]
    assert len(added) == 1 and len(added[0]) <= 33
    assert main(["filter", str(out), "--calibrated", str(cal), "--nominal", "yaskawa_gp25", "-o",
                 str(tmp_path / "TWICE.JBI"), "--frame", "2=1250,-300,450,0,0,15", "--tool",
                 "1=0,-35,410,0,-30,0"]) == 2
    assert "already filtered" in capsys.readouterr().err and not (tmp_path / "TWICE.JBI").exists()


# ----------------------------------------------------------------------------- campaign
def test_poses_writes_a_job_the_controller_runs_at_the_planned_joints(tmp_path):
    """poses --inform: RECTAN positions with the planned joints' RCONF; the nominal controller's
    IK of each position in its form gives back the planned joints; filtering it with the nominal
    model changes no byte."""
    job = tmp_path / "CAMPAIGN.JBI"
    assert main(["--quiet", "poses", "--robot", "yaskawa_gp25", "-n", "10", "--candidates", "600", "--starts",
                 "1", "--smr-mm", "20,-30,60", "-o", str(tmp_path / "poses.csv"), "--inform", str(job),
                 "--speed-percent", "15", "--settle-s", "0.5"]) == 0
    planned = rc.data.measurements.read_joints(tmp_path / "poses.csv")
    data = job.read_bytes()
    assert data.count(b"\r\n") == data.count(b"\n") and data.startswith(b"/JOB\r\n//NAME CAMPAIGN\r\n")
    text = data.decode()
    assert "///NPOS 10,0,0,0,0,0" in text and text.count("MOVJ C") == 10 and "VJ=15.00" in text
    assert re.findall(r"SET I000 (\d+)", text) == [str(k) for k in range(1, 11)]
    d = InformDialect()
    prog = d.parse([ProgramText(job)], {}, {"0": np.eye(4)})
    assert [t.name for t in prog.targets] == [f"C{k:05d}" for k in range(10)]
    _, P, W, tool = target_poses(d, prog, prog.targets)
    problems: list = []
    q = controller_joints(d, prog, prog.targets, NOMINAL, W @ P, problems, [])
    assert not problems
    # 3 decimals in mm, 4 in deg; a T beyond +-360 deg comes back as its copy within a turn (same pose)
    turns = np.round((q - planned) / (2 * np.pi))
    assert np.all(turns[:, :5] == 0) and np.all((turns[:, 5] == 0) | (np.abs(planned[:, 5]) > 2 * np.pi))
    assert np.rad2deg(np.abs(q - planned - 2 * np.pi * turns)).max() < 2e-3
    res = filter_program([job], NOMINAL, NOMINAL, tools={"0": "0,0,0,0,0,0"})
    assert res.outputs[job] == data and len(res.rows) == 10


def test_base_positions_of_a_robot_on_base_axes_are_named(tmp_path):
    """With base axes in the job's group (RB1,BS1), a BASE position is where the track puts it:
    named; the ROBOT positions (in the robot's own frame) are still corrected."""
    path = tmp_path / "PICK_TRACK.JBI"
    path.write_bytes((CORPUS / "PICK_PLACE.JBI").read_bytes().replace(b"///GROUP1 RB1", b"///GROUP1 RB1,BS1"))
    res = filter_program([path], CALIBRATED, NOMINAL, tools=TOOLS)
    assert [r["name"] for r in res.rows] == ["C00000", "C00001", "C00002"]
    based = [r for r in res.motions if "BASE position of a robot on base axes" in r.reason]
    assert [r.target for r in based] == ["C00003", "C00004", "C00005", "C00004"]


def test_offline_generator_style(tmp_path):
    """A comment line before /JOB, a trailing blank after ///RECTAN, the 24-field RCONF of the
    YRC1000, LF line ends, 4-decimal positions: read, filtered, and unchanged by an identity
    calibration."""
    q = np.deg2rad([[0, 10, -20, 0, -70, 0], [15, 20, -15, 5, -75, 10]])
    v = InformDialect().from_pose(NOMINAL.fk(q), np.zeros((2, 6)))
    lines = ["'PP version: 3.1", "/JOB", "//NAME GEN", "//POS", "///NPOS 2,0,0,0,0,0", "///TOOL 0",
             "///POSTYPE ROBOT", "///RECTAN ", "///RCONF 1," + ",".join(["0"] * 23)]
    lines += [f"C{k:05d}=" + ",".join(f"{x:.4f}" for x in row) for k, row in enumerate(v)]
    lines += ["//INST", "///DATE 2021/01/01 00:00", "///ATTR SC,RW,RJ", "///GROUP1 RB1", "NOP",
              "MOVJ C00000 VJ=20.00", "MOVL C00001 V=100.0 PL=0", "END", ""]
    path = tmp_path / "gen.jbi"
    path.write_text("\n".join(lines))
    assert dialect_for([path]).name == "Yaskawa INFORM"
    res = filter_program([path], CALIBRATED, NOMINAL)
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 2, "corrected": 2, "named": 0}
    assert _outside_numbers(res.outputs[path]) == _outside_numbers(path.read_bytes())
    assert filter_program([path], NOMINAL, NOMINAL).outputs[path] == path.read_bytes()


def test_user_frames_from_uframe_cnd_and_p_variables_saved_in_the_job(tmp_path):
    """--references UFRAME.CND gives the user frames (////BUSER, base coordinates); a job that
    saves its P variables in //POS (///NPOS 0,0,0,n,0,0) has them corrected from there."""
    cnd = tmp_path / "UFRAME.CND"
    cnd.write_bytes(b"//UFRAME 1\r\n///NAME TABLE\r\n///TOOL 0\r\n"
                    b"////BUSER 0.000,0.000,0.000,0.0000,0.0000,0.0000\r\n"
                    b"//UFRAME 2\r\n///NAME FIXTURE\r\n///TOOL 1\r\n"
                    b"////BUSER 1250.000,-300.000,450.000,0.0000,0.0000,15.0000\r\n")
    job = tmp_path / "CUT.JBI"
    text = (CORPUS / "WELD_UF2.JBI").read_text()
    text = text.replace("///NPOS 10,0,0,0,0,0", "///NPOS 1,0,0,9,0,0")
    text = re.sub(r"^C0000([1-9])=", r"P0010\1=", text, flags=re.M)
    text = re.sub(r"^(MOV[JLC]|REFP 1) C0000([1-9])", r"\1 P10\2", text, flags=re.M)
    job.write_bytes(text.replace("\n", "\r\n").encode())
    res = filter_program([job], CALIBRATED, NOMINAL, tools=TOOLS, references=[cnd])
    ref = filter_program([CORPUS / "WELD_UF2.JBI"], CALIBRATED, NOMINAL, tools=TOOLS, frames=FRAMES)
    assert [r["name"] for r in res.rows] == [r["name"].replace("C0000", "P0010") for r in ref.rows]
    assert [r["correction_mm"] for r in res.rows] == pytest.approx([r["correction_mm"] for r in ref.rows])
    with pytest.raises(DataError, match="not a UFRAME.CND"):
        filter_program([job], CALIBRATED, NOMINAL, tools=TOOLS, references=[CORPUS / "PALLETIZE.JBI"])


def test_conveyor_station_and_external_group_motions_are_named(tmp_path):
    """SMOVL (conveyor), SYMOVL (station), EIMOVL (external group), a 7-value position (a 7-axis
    arm), a motion without a robot position: each named; the plain MOVL corrected."""
    q = np.deg2rad([[0, 10, -20, 0, -70, 0]])
    v = ",".join(f"{x:.3f}" for x in InformDialect().from_pose(NOMINAL.fk(q), np.zeros((1, 6)))[0])
    lines = ["/JOB", "//NAME SYNC", "//POS", "///NPOS 2,0,0,0,0,0", "///TOOL 0", "///POSTYPE ROBOT",
             "///RECTAN", "///RCONF 1,0,0,0,0,0,0,0", f"C00000={v}", f"C00001={v},0.000", "//INST",
             "///ATTR SC,RW", "///GROUP1 RB1", "NOP", "SMOVL C00000 V=100.0 CV#(1) CTP=0.000",
             "SYMOVL C00000 V=100.0", "EIMOVL C00000 V=100.0", "MOVL C00001 V=100.0", "MOVJ VJ=10.00",
             "MOVL C00000 V=100.0", "END", ""]
    path = tmp_path / "SYNC.JBI"
    path.write_bytes("\r\n".join(lines).encode())
    res = filter_program([path], CALIBRATED, NOMINAL)
    reasons = [r.reason for r in res.motions if r.status == "named"]
    assert len(reasons) == 5 and [r.line for r in res.motions if r.status == "corrected"] == [20]
    patterns = ["follows a conveyor", "synchronised with a station", "external axis group",
                "not a 6-value Cartesian position", "no robot position"]
    for pattern, reason in zip(patterns, reasons, strict=True):
        assert pattern in reason, (pattern, reason)
    assert any("C00001 has 7 values" in w for w in res.warnings)


def test_lone_cr_line_ends(tmp_path):
    """A job saved with lone CR line ends reads the same and keeps them."""
    path = tmp_path / "CR.JBI"
    path.write_bytes((CORPUS / "WELD_UF2.JBI").read_bytes().replace(b"\r\n", b"\r"))
    res = filter_program([path], CALIBRATED, NOMINAL, frames=FRAMES, tools=TOOLS)
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 9, "corrected": 7, "named": 2}
    assert b"\n" not in res.outputs[path] and _outside_numbers(res.outputs[path]) == _outside_numbers(
        path.read_bytes())


def test_p_variable_saved_by_another_job(tmp_path):
    """P001 used by PICK_PLACE and saved in the //POS of another job given with it: corrected
    there (VAR.DAT, when given, comes first)."""
    q = np.deg2rad([[0, 5, -30, 0, -65, 0]])
    tool = InformDialect().to_pose(np.array([[0, 0, 180, 0, 0, 0]]))[0]
    v = InformDialect().from_pose(NOMINAL.fk(q) @ tool, np.zeros((1, 6)))[0]
    text = ",".join([f"{x:.3f}" for x in v[:3]] + [f"{x:.4f}" for x in v[3:]])
    other = tmp_path / "TEACH.JBI"
    lines = ["/JOB", "//NAME TEACH", "//POS", "///NPOS 0,0,0,1,0,0", "///TOOL 3", "///POSTYPE ROBOT",
             "///RECTAN", "///RCONF 1,0,0,0,0,0,0,0", f"P00001={text}", "//INST", "///ATTR SC,RW",
             "///GROUP1 RB1", "NOP", "END", ""]
    other.write_bytes("\r\n".join(lines).encode())
    pick = _copy(["PICK_PLACE.JBI"], tmp_path)[0]
    res = filter_program([pick, other], CALIBRATED, NOMINAL, tools=TOOLS)
    assert "P00001" in [r["name"] for r in res.rows]
    assert [r.status for r in res.motions if r.line == 35 and r.file == "PICK_PLACE.JBI"] == ["corrected"]
    assert res.outputs[other] != other.read_bytes()
