"""Program filtering on a corpus of programs written the way real cells are (tests/data/programs/corpus):
every motion that reaches a Cartesian pose is corrected or named (file:line, instruction, why) in a
warning, or the run is refused; one test per construct of each dialect; only target numbers change."""

from __future__ import annotations

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
from robocal.programs.source import NUMBER_RE

CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"
FANUC_FRAMES = {"frames": {"1": "450,-150,100,0,0,-10"}, "tools": {"2": "0,0,120,0,0,0"}}

# program files, references, robot, filter options, the targets corrected, the motions named (in the
# order of the warnings)
CASES = {
    "rapid arc welding": (["arc_station.mod"], [], "abb_irb2600", {},
                          ["pApproach", "pSeam{1}", "pSeam{2}", "pSeam{3}", "pCirc1", "pCirc2", "pEnd",
                           "pStartA", "pEndA", "pDepart", "pFlip"],
                          [r":63: MoveL: .*Offs\(pCheck,0,0,nDepth\) .*run time only \(nDepth\)",
                           r":65: MoveL: .*computed at run time by CRobT\(\)",
                           r":66: MoveJ: .*robtarget pService is not declared"]),
    "rapid offsets and expressions": (["glue_offsets.mod"], [], "abb_irb2600", {}, ["pLid", "pCorner"],
                                      [r":22: MoveL: .*Offs\(pCorner, nBead\{nRow, 1\}, 0, 0\) .*run time",
                                       r":26: MoveL: .*computed at run time by CRobT\(\)",
                                       r":27: MoveJ: .*robtarget pPurge is not declared",
                                       r":33: MoveL: .*pSpot is a parameter of routine rework that no call",
                                       r":34: MoveL: .*pSpot is a parameter of routine rework that no call"]),
    "rapid multimove palletizing": (["pallet_multimove.mod"], [], "abb_irb2600", {},
                                    ["pPickUp", "pPick", "wp{1}.pos", "wp{2}.pos", "pHandOver"],
                                    [r":32: MoveL: .*Offs\(pPalletCorner, nCol\*nPitch.*run time only",
                                     r":35: MoveL: .*pLayer is modified at run time .*:34\)"]),
    "krl kss8 spline": (["deburr_cell.src", "deburr_cell.dat"], ["$config.dat"], "kuka_kr16_2", {},
                        ["XP1", "XP2", "XP3", "XP4", "XP5", "XP6", "XP7", "XHOLE[1]", "XHOLE[2]", "XHOLE[3]",
                         "XSTART", "XCHECK"],
                        [r":48: LIN_REL: .*a relative motion", r":49: LIN_REL: .*a relative motion",
                         r":58: SLIN: .*XLIFT is modified at run time .*:57\)",
                         r":61: SLIN: .*XOTHER is not declared in these files",
                         r":64: SPTP: .*XHANDOVER is declared in \$config.dat, given as a reference"]),
    "krl sealer without $config.dat": (["sealer_cell.src", "sealer_cell.dat"], [], "kuka_kr16_2",
                                       {"tools": {"3": "0,0,200,0,0,0"},
                                        "frames": {"2": "700,-300,400,90,0,0"}},
                                       ["XGLUE1", "XGLUE2", "XGLUE3", "XGLUE4", "inline@28"],
                                       [r":30: LIN: .*\$POS_ACT is a system variable",
                                        r":32: LIN: .*XAPP is not declared in these files"]),
    "fanuc arc welding": (["weld_bracket.ls"], [], "fanuc_lrmate200id", FANUC_FRAMES,
                          ["P[1:approach]", "P[2]", "P[3]", "P[4]", "P[5]", "P[6]", "P[7]", "P[8]"],
                          [r":39: L: .*PR\[5:service\] is a position reg",
                           r":40: L: .*P\[12\] is not a Cartesian position of group 1",
                           r":36: L: .*P\[6\] is shifted by Offset,PR\[2\], whose value lives in",
                           r":37: L: .*P\[7\] is shifted by Tool_Offset,PR\[3\], which robocal does not",
                           r":38: L: .*P\[9\] is an incremental move"]),  # named once all uses are known
    "fanuc near gimbal lock": (["polish_vertical.ls"], [], "fanuc_lrmate200id", FANUC_FRAMES,
                               ["P[2:above lid]", "P[3]", "P[4]", "P[5]", "P[6]"],
                               [r":34: L: .*PR\[6:retract\] is written at polish_vertical.ls:33 \(PR\[6\]=",
                                r":35: L: .*PR\[3:service\] is a position register",
                                r":31: L: .*P\[4\] is shifted by Offset,PR\[4:lift\], whose value lives in",
                                r":32: L: .*P\[7\] is an incremental move"]),
    "urscript polyscope screw station": (["screw_station.script"], [], "ur5", {}, ["p@14", "p@17", "p@19"],
                                         [r":21: movel: .*Feeder_p is not assigned a pose before this motion",
                                          r":23: movel: .*pose_add"]),
    "urscript palletizing": (["palletizing_ur5.script"], [], "ur5", {},
                             ["Pick_p", "Inspect_p", "p@40", "p@41", "p@41", "Gauge_p"],
                             [r":28: movel: .*pose_add\(Place_base_p, \.\.\.\) moves it at run time",
                              r":39: movel: .*computed at run time by get_actual_tcp_pose\(\)"]),
}


# the motion instructions to a Cartesian pose, counted by hand in each program (joint motions such
# as MoveAbsJ, SPTP $H_POS / XHOME, movej(Home_q) are not counted): (total, corrected)
HAND_COUNT = {"rapid arc welding": (13, 10),  # lines 41-66; Offs(pCheck, .., nDepth), CRobT, pService named
              "rapid offsets and expressions": (10, 5),  # 19-34 but MoveAbsJ (18, 28); Offs/RelTool with
              # constant expressions (19, 21, 23, 24) are corrected
              "rapid multimove palletizing": (7, 5),  # lines 29-44; 32 (run-time Offs) and 35 named
              "krl kss8 spline": (15, 10),  # 27-72 but 20 ($H_POS) and 66 (XHOME)
              "krl sealer without $config.dat": (7, 5),  # 25-33 but PTP XHOME (20, 34), PTP $AXIS_ACT (31)
              "fanuc arc welding": (11, 6),  # /MN lines 3-18 with a P[] or PR[]
              "fanuc near gimbal lock": (8, 4),  # /MN 4-12; J P[1] (3, 13) is a joint representation
              "urscript polyscope screw station": (5, 3),  # 14-23; movej(Home_q) (12, 25) is a joint move
              "urscript palletizing": (10, 8)}  # every movel/movep/movec; movej(Home_q) is a joint move


def _copy(names, tmp_path) -> list[Path]:
    out = []
    for n in names:
        shutil.copy(CORPUS / n, tmp_path / n)
        out.append(tmp_path / n)
    return out


def _run(case, tmp_path, robot=None, **extra):
    files, refs, name, options, *_ = CASES[case]
    nominal = rc.Robot.from_catalog(name)
    paths, ref_paths = _copy(files, tmp_path), _copy(refs, tmp_path)
    res = filter_program(paths, robot if robot is not None else perturbed(nominal, 7), nominal,
                         references=ref_paths, **options, **extra)
    return res, paths


def _outside_numbers(data: bytes) -> str:
    """The text with every number and the spaces right before it masked (a FANUC number keeps
    its width by taking or giving spaces)."""
    return re.sub(r" *" + NUMBER_RE.pattern, "#", data.decode("latin-1"))


@pytest.mark.parametrize("case", list(CASES))
def test_every_motion_is_corrected_or_named(case, tmp_path):
    """The targets the motions reach are corrected, the motions this cannot follow are named
    with file:line, instruction and why; nothing else changes."""
    *_, corrected, named = CASES[case]
    res, paths = _run(case, tmp_path)
    assert [r["name"] for r in res.rows] == corrected and all(r["filtered"] for r in res.rows)
    assert len(res.uncorrected) == len(named)
    for pattern, line in zip(named, res.uncorrected, strict=True):
        assert re.search(pattern, line), (pattern, line)
    total, corrected = HAND_COUNT[case]
    count = res.summary_dict()["motions"]
    assert count == {"total": total, "corrected": corrected, "named": total - corrected}
    assert len(res.motions) == total
    assert f"{total} motions: {corrected} corrected, {total - corrected} not corrected (each named)" \
        in res.summary()
    for m in res.motions:  # every named motion's reason is one of the warnings of its line
        assert (m.status == "corrected") == (not m.reason)
        if m.reason:
            head = f"{m.file}:{m.line}: {m.instruction}: not corrected"
            assert any(w.startswith(head) for w in res.warnings)
    for p in paths:
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(p.read_bytes())
        assert res.outputs[p].count(b"\r\n") == p.read_bytes().count(b"\r\n")


@pytest.mark.parametrize("case", list(CASES))
def test_identity_calibration_changes_no_byte(case, tmp_path):
    name = CASES[case][2]
    res, paths = _run(case, tmp_path, robot=rc.Robot.from_catalog(name))
    assert all(res.outputs[p] == p.read_bytes() for p in paths)


# ----------------------------------------------------------------------------- RAPID constructs
def test_rapid_process_instructions_carry_their_targets(tmp_path):
    """ArcLStart / ArcL (with \\Weave) / ArcC / ArcLEnd: the seam is corrected, not only the approach."""
    res, _ = _run("rapid arc welding", tmp_path)
    rows = {r["name"]: r for r in res.rows}
    assert {"pSeam{1}", "pCirc1", "pCirc2", "pEnd"} <= set(rows)
    assert all((rows[n]["tool"], rows[n]["frame"]) == ("tweldgun", "wobjfixture") for n in ("pCirc1", "pEnd"))


def test_rapid_routine_parameters_and_tool_arrays(tmp_path):
    """WeldStitch pStartA, pEndA: the PROC's parameters lead to the caller's robtargets; the tool
    is an element of a PERS tooldata array."""
    res, _ = _run("rapid arc welding", tmp_path)
    rows = {r["name"]: r for r in res.rows}
    assert rows["pStartA"]["tool"] == rows["pEndA"]["tool"] == "tguns{1}"


def test_rapid_assignment_corrects_the_source(tmp_path):
    """pTemp := pDepart; MoveL Offs(pTemp,0,0,nLift) with CONST nLift: pDepart is corrected and
    not reported as unused; the overwritten VAR is not a target."""
    res, _ = _run("rapid arc welding", tmp_path)
    assert "pDepart" in [r["name"] for r in res.rows]
    assert not any("pDepart" in w and "not used" in w for w in res.warnings)


def test_rapid_variable_index_uses_every_element(tmp_path):
    res, _ = _run("rapid arc welding", tmp_path)
    assert {"pSeam{2}", "pSeam{3}"} <= {r["name"] for r in res.rows}  # ArcL pSeam{i} in a FOR loop


def test_rapid_record_fields(tmp_path):
    """MoveL wp{k}.pos with a RECORD slotdata holding a robtarget: every element's field."""
    res, _ = _run("rapid multimove palletizing", tmp_path)
    assert {"wp{1}.pos", "wp{2}.pos"} <= {r["name"] for r in res.rows}


def test_rapid_multimove_is_named(tmp_path):
    res, _ = _run("rapid multimove palletizing", tmp_path)
    assert any(re.match(r"pallet_multimove.mod:38: MultiMove synchronized motions \(\\ID\)", w)
               for w in res.warnings)


def test_rapid_conf_off_is_honoured(tmp_path):
    """After ConfL\\Off the controller takes the solution nearest the current joints: a target
    whose confdata match no solution is not refused; its row says so."""
    path = _copy(["arc_station.mod"], tmp_path)[0]
    data = path.read_bytes()
    flip = re.search(rb"CONST robtarget pFlip:=\[\[[^]]*\],\[[^]]*\],\[(0,0,0,0)\]", data)
    path.write_bytes(data[:flip.start(1)] + b"0,0,0,4" + data[flip.end(1):])  # behind axis 1: impossible
    robot = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, perturbed(robot, 7), robot)
    row = next(r for r in res.rows if r["name"] == "pFlip")
    assert row["filtered"] and row["configuration"] == "not monitored" and row["config_before"] == "[0,0,0,4]"
    path.write_bytes(path.read_bytes().replace(b"ConfL\\Off;", b"ConfL\\On; "))
    with pytest.raises(DataError, match=r"arc_station.mod:26 \(pFlip\): configuration \[0,0,0,4\] is not"):
        filter_program(path, perturbed(robot, 7), robot)


def test_rapid_configuration_matching_no_solution_is_warned(tmp_path):
    """A cf1 quadrant no solution has: the nearest is taken, with a warning; config_before is the
    file's value."""
    path = _copy(["arc_station.mod"], tmp_path)[0]
    data = path.read_bytes()
    m = re.search(rb"CONST robtarget pEnd:=\[\[[^]]*\],\[[^]]*\],\[(0),-1,0,0\]", data)
    path.write_bytes(data[:m.start(1)] + b"2" + data[m.end(1):])
    robot = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, perturbed(robot, 7), robot)
    row = next(r for r in res.rows if r["name"] == "pEnd")
    assert row["config_before"] == "[2,-1,0,0]" and row["filtered"]
    assert any(re.match(r"arc_station.mod:22 \(pEnd\): configuration \[2,-1,0,0\] matches no solution.*"
                        r"the nearest, \[0,-1,0,0\]", w) for w in res.warnings)


def test_rapid_uncoordinated_external_values_are_arm_targets(tmp_path):
    """Robtargets with eax_a values (800, 1450, 2100: a track's mm) in wobj0 (no mechanical unit moves
    the work object) and a plain arm model: 3 targets are too few to tell a track carrying the arm
    from a positioner, so by default the 3 motions (counted by hand) are named, the reason saying
    so and what to give; declared fixed (``fixed_base``, no external axis carries the arm) they are
    corrected as arm targets, the eax_a values untouched, one warning counting them."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    path = _copy(["track_mill.mod"], tmp_path)[0]
    res = filter_program(path, perturbed(robot, 7), robot)
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 0, "named": 3}
    assert all("eax_a varies (800 .. 2100) over 3 target(s) at 3 value(s)" in m.reason and "too few to tell"
               in m.reason and "--fixed-base" in m.reason for m in res.motions)
    res = filter_program(path, perturbed(robot, 7), robot, fixed_base=True)
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 3, "named": 0}
    out = res.outputs[path].decode()
    assert re.findall(r"\],\[(\d+),9E\+09", out) == ["800", "1450", "2100"]
    said = [w for w in res.warnings if "external-axis values" in w]
    assert len(said) == 1 and said[0].startswith("3 target(s)") and "(eax_a)" in said[0]
    assert "--fixed-base" in said[0]


def test_rapid_quaternions_keep_the_files_precision(tmp_path):
    """The file writes quaternions with 6 decimals: corrected ones too (not 7 or more)."""
    res, paths = _run("rapid arc welding", tmp_path)
    text = res.outputs[paths[0]].decode()
    quats = re.findall(r"robtarget \w+(?:\{\d\})?:=\[\[[^]]*\],\[([^]]*)\]", text)
    assert quats and all(len(v.split(".")[1]) == 6 for q in quats for v in q.split(",") if "." in v)


def test_rapid_undeclared_target_is_named_not_silent(tmp_path):
    """A module whose targets live in another module: no '0 of 0 ... nothing to filter', every
    motion is named."""
    path = tmp_path / "calls_only.mod"
    path.write_bytes(b"MODULE CallsOnly\n  PROC main()\n    MoveJ pHome, v1000, z50, tool0;\n"
                     b"    MoveL pWork, v200, fine, tool0;\n  ENDPROC\nENDMODULE\n")
    robot = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, robot, robot)
    assert not res.rows and len(res.uncorrected) == 2
    assert "2 not corrected (each named)" in res.summary()
    assert re.match(r"calls_only.mod:3: MoveJ: not corrected: robtarget pHome is not declared",
                    res.uncorrected[0])


# ----------------------------------------------------------------------------- KRL constructs
def test_krl_with_clause_sets_tool_and_base(tmp_path):
    """SPTP XP1 WITH $TOOL = STOOL2(FP1), $BASE = SBASE(FP1.BASE_NO): tool 1, base 1."""
    res, _ = _run("krl kss8 spline", tmp_path)
    row = next(r for r in res.rows if r["name"] == "XP1")
    assert (row["tool"], row["frame"]) == ("1", "1")


def test_krl_spline_block_and_variable_index(tmp_path):
    res, _ = _run("krl kss8 spline", tmp_path)
    names = {r["name"] for r in res.rows}
    assert {"XP5", "XP6", "XP7"} <= names  # SPL / SLIN inside SPLINE ... ENDSPLINE
    assert {"XHOLE[1]", "XHOLE[2]", "XHOLE[3]"} <= names  # SLIN XHOLE[i] in a FOR loop


def test_krl_assignment_and_routine_parameter(tmp_path):
    """XAPPR = XSTART; SLIN XAPPR corrects XSTART; Inspect(XCHECK) with DEF Inspect(P_INSP:IN)
    corrects XCHECK (also through a constant geometric offset P_INSP : {Z -20})."""
    res, _ = _run("krl kss8 spline", tmp_path)
    assert {"XSTART", "XCHECK"} <= {r["name"] for r in res.rows}


def test_krl_config_dat_given_as_a_program_is_corrected_and_written(tmp_path, capsys):
    """$config.dat as a program file with -o a folder: its global position is corrected and
    written with the others; LOAD_DATA's nested aggregate is not a position."""
    files = _copy(["deburr_cell.src", "deburr_cell.dat", "$config.dat"], tmp_path)
    nominal = rc.Robot.from_catalog("kuka_kr16_2")
    cal = tmp_path / "cal.yaml"
    perturbed(nominal, 7).save(cal)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["filter", *map(str, files), "--calibrated", str(cal), "--nominal", "kuka_kr16_2",
                 "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "13 of 13" in text and "15 motions: 11 corrected, 4 not corrected (each named)" in text
    written = (out / "$config.dat").read_bytes()
    assert written != files[2].read_bytes()
    assert b"LOAD_DATA[1]={M 4.5,CM {X 0.0,Y 0.0,Z 90.0" in written


def test_krl_src_without_its_dat_names_every_motion(tmp_path):
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    src = _copy(["deburr_cell.src"], tmp_path)[0]
    res = filter_program(src, robot, robot)
    assert not res.rows
    undeclared = [w for w in res.uncorrected if "is not declared in these files" in w]
    assert len(undeclared) >= 12 and any(re.match(r"deburr_cell.src:27: SPTP: .*XP1 is not declared", w)
                                         for w in undeclared)
    # and the summary collapses the repeated reason per motion
    assert "not corrected (each named)" in res.summary()


def test_krl_tool_from_a_variable_is_named(tmp_path):
    path = tmp_path / "var_tool.src"
    path.write_bytes(b"DEF var_tool( )\r\n  DECL INT nT\r\n  nT = 2\r\n  $TOOL = TOOL_DATA[nT]\r\n"
                     b"  $BASE = $NULLFRAME\r\n  LIN {X 800, Y 0, Z 900, A 0, B 90, C 0}\r\nEND\r\n")
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    res = filter_program(path, robot, robot)
    assert res.uncorrected == ["var_tool.src:6: LIN: not corrected: inline@6: $TOOL is set from "
                               "TOOL_DATA[nT] (a variable index known at run time only)"]


def test_krl_uncoordinated_external_axis_values_are_arm_targets(tmp_path):
    """An E6POS with E1 1250 (the others 0) used with a base no machine carries: E1 takes two values
    over 12 targets, too few to tell a track carrying the arm from a positioner, so the motion to the
    target with E1 1250 is named (the safe side; those at 0 are where the arm is with the axis at
    zero: corrected); declared fixed (``fixed_base``): corrected as an arm target (its E1 kept),
    with the one summary warning. Motions counted by hand: 15, 9 corrected by default, 10 fixed."""
    files = _copy(["deburr_cell.src", "deburr_cell.dat"], tmp_path)
    dat = files[1].read_bytes()
    files[1].write_bytes(dat.replace(b"E1 0.0", b"E1 1250.0", 1))
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    refs = _copy(["$config.dat"], tmp_path)
    res = filter_program(files, perturbed(robot, 7), robot, references=refs)
    sptp = next(m for m in res.motions if m.line == 27)
    assert sptp.status == "named" and "external axis E1 varies (0 .. 1250)" in sptp.reason
    assert res.summary_dict()["motions"] == {"total": 15, "corrected": 9, "named": 6}
    assert [m.line for m in res.motions if "E1 varies" in m.reason] == [27]
    res = filter_program(files, perturbed(robot, 7), robot, references=refs, fixed_base=True)
    sptp = next(m for m in res.motions if m.line == 27)
    assert sptp.status == "corrected" and "XP1" in [r["name"] for r in res.rows]
    assert res.summary_dict()["motions"] == {"total": 15, "corrected": 10, "named": 5}
    assert b"E1 1250.0" in res.outputs[files[1]]
    assert sum("external-axis values (E1)" in w for w in res.warnings) == 1


# ----------------------------------------------------------------------------- FANUC constructs
def test_fanuc_offsets_are_named_and_corrected(tmp_path):
    res, _ = _run("fanuc arc welding", tmp_path)
    named = {(m.line, m.status, m.reason.split(":")[0]) for m in res.motions}
    assert (36, "named", "P[6] is shifted by Offset,PR[2], whose value lives in the controller (give its "
                         "backup POSREG.VA with --references)") in named
    assert (37, "named", "P[7] is shifted by Tool_Offset,PR[3], which robocal does not correct") in named
    assert (34, "corrected", "") in named  # the plain motion to P[6] is corrected


def test_fanuc_incremental_position_is_left_alone(tmp_path):
    res, paths = _run("fanuc arc welding", tmp_path)
    block = re.search(rb"P\[9\]\{.*?\};", res.outputs[paths[0]], re.DOTALL).group(0)
    assert block == re.search(rb"P\[9\]\{.*?\};", paths[0].read_bytes(), re.DOTALL).group(0)


def test_fanuc_position_registers_from_a_file(tmp_path, capsys):
    """--position-registers: the motion to PR[5] is corrected in the UF/UT active there, the
    register file's copy holds the corrected values (only numbers change); without the file the
    motion is named."""
    path = _copy(["weld_bracket.ls"], tmp_path)[0]
    regs = _copy(["weld_registers.csv"], tmp_path)[0]
    nominal = rc.Robot.from_catalog("fanuc_lrmate200id")
    cal = perturbed(nominal, 7)
    res = filter_program(path, cal, nominal, position_registers=regs, **FANUC_FRAMES)
    pr = next(m for m in res.motions if m.line == 39)
    assert pr.status == "corrected" and pr.target == "PR[5]"
    assert res.summary_dict()["motions"] == {"total": 11, "corrected": 7, "named": 4}
    row = next(r for r in res.rows if r["name"] == "PR[5]")
    assert row["frame"] == "1" and row["tool"] == "2" and row["correction_mm"] > 0.1
    out = res.outputs[regs]
    assert out != regs.read_bytes() and _outside_numbers(out) == _outside_numbers(regs.read_bytes())
    # the corrected register is the corrected pose of an identical /POS position
    text = path.read_bytes().replace(b"16:L P[12]", b"16:L P[13]")
    x, y, z, w, p, r = re.search(rb"\n5,([^\n]*),\"", regs.read_bytes()).group(1).decode().split(",")
    block = (f"P[13]{{\n   GP1:\n\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',\n\tX = {x} mm, Y = {y} mm, "
             f"Z = {z} mm,\n\tW = {w} deg, P = {p} deg, R = {r} deg\n}};\n").encode()
    twin = tmp_path / "twin.ls"
    twin.write_bytes(text.replace(b"/END", block + b"/END"))
    res2 = filter_program(twin, cal, nominal, position_registers=regs, **FANUC_FRAMES)
    got = re.search(rb"P\[13\]\{.*?X = (\S+) mm, Y = (\S+) mm, Z = (\S+) mm", res2.outputs[twin], re.DOTALL)
    new = re.search(rb"\n5,([^\n]*),\"", out).group(1).decode().split(",")
    assert [float(v) for v in got.groups()] == pytest.approx([float(v) for v in new[:3]], abs=1e-3)
    # without the file: named, with how to correct it
    res = filter_program(path, cal, nominal, **FANUC_FRAMES)
    assert "--position-registers" in next(m for m in res.motions if m.line == 39).reason
    # the CLI writes the corrected register file next to the program
    cal_path = tmp_path / "cal.yaml"
    cal.save(cal_path)
    assert main(["filter", str(path), "--calibrated", str(cal_path), "--nominal", "fanuc_lrmate200id",
                 "--frame", "1=450,-150,100,0,0,-10", "--tool", "2=0,0,120,0,0,0", "--position-registers",
                 str(regs), "-o", str(tmp_path / "o.ls")]) == 0
    written = (tmp_path / "o.ls.registers.csv").read_bytes()  # the corrected copy, marked (issue 47)
    assert written.startswith(b"# robocal ") and written.split(b"\n", 1)[1] == out
    assert "11 motions: 7 corrected, 4 not corrected" in capsys.readouterr().out


def test_fanuc_gimbal_lock_swing_is_named(tmp_path):
    """Positions taught at P = -90 deg: a correction that tilts the tool off the pole needs W and R
    to swing (the only triples of that orientation); each such target is named with the swing."""
    res, _ = _run("fanuc near gimbal lock", tmp_path)
    swings = [w for w in res.warnings if "from gimbal lock" in w]
    assert swings and all(re.match(r"polish_vertical.ls:\d+ \(P\[\d", w) for w in swings)
    assert all(float(re.search(r"correction of ([\d.]+) deg", w).group(1)) < 1.0 for w in swings)


def test_fanuc_position_used_plain_and_incremental(tmp_path):
    """P[2] reached by a plain L and by an L ... INC: the plain motion is corrected (so is P[2]),
    the incremental one is named: its displacement changes by that correction."""
    path = _copy(["weld_bracket.ls"], tmp_path)[0]
    path.write_bytes(path.read_bytes().replace(b"14:L P[9] 50mm", b"14:L P[2] 50mm"))
    nominal = rc.Robot.from_catalog("fanuc_lrmate200id")
    # P[9], a displacement now used by no motion, is out of reach as a pose: left unchanged
    res = filter_program(path, perturbed(nominal, 7), nominal, keep_unreached=True, **FANUC_FRAMES)
    by_line = {m.line: m for m in res.motions}
    assert by_line[27].status == "corrected" and by_line[27].target == "P[2]"
    assert by_line[38].status == "named" and "a pose in other motions, which correct it" in by_line[38].reason
    assert "P[2]" in [r["name"] for r in res.rows]
    s = res.summary_dict()["motions"]
    assert s["corrected"] + s["named"] == s["total"] == 11


def test_strict_refuses_names_declared_nowhere(tmp_path, capsys):
    """By default a motion to a name no file declares is named with the declaration it needs;
    --strict refuses the run, naming each."""
    res, _ = _run("krl sealer without $config.dat", tmp_path)
    needs = "DECL E6POS/POS/FRAME XAPP (in a .dat or $config.dat)"
    assert [m.needs for m in res.motions if m.needs] == [needs]
    with pytest.raises(DataError, match=r"1 motion\(s\) move to names declared in none of the files given: "
                                        r"sealer_cell.src:32 \(LIN\): needs " + re.escape(needs)):
        _run("krl sealer without $config.dat", tmp_path, strict=True)
    nominal = rc.Robot.from_catalog("abb_irb2600")
    cal = tmp_path / "cal.yaml"
    perturbed(nominal, 7).save(cal)
    src = _copy(["glue_offsets.mod"], tmp_path)[0]
    args = ["filter", str(src), "--calibrated", str(cal), "--nominal", "abb_irb2600",
            "-o", str(tmp_path / "o.mod")]
    assert main([*args, "--strict"]) == 2
    assert "needs robtarget pPurge" in capsys.readouterr().err
    assert main(args) == 0
    assert "10 motions: 5 corrected, 5 not corrected (each named)" in capsys.readouterr().out


def test_motion_records_in_the_table(tmp_path):
    """The table JSON carries one record per motion and the motion summary."""
    import json

    res, _ = _run("rapid arc welding", tmp_path)
    table = json.loads(res.table_json())
    assert table["summary"]["motions"] == {"total": 13, "corrected": 10, "named": 3}
    assert len(table["motions"]) == 13
    assert table["motions"][0] == {"file": "arc_station.mod", "line": 41, "instruction": "MoveJ",
                                   "target": "pApproach", "status": "corrected", "reason": "", "needs": ""}
    assert table["motions"][-1]["status"] == "named" and table["motions"][-1]["target"] == "pService"


def test_fanuc_numbers_keep_their_style(tmp_path):
    """3 decimals stay 3, a leading-dot number keeps its style, right-aligned numbers their width;
    a file written with tabs and 6 decimals keeps those."""
    res, paths = _run("fanuc arc welding", tmp_path)
    old, new = paths[0].read_bytes().decode(), res.outputs[paths[0]].decode()
    assert "P =     -.390 deg" in old and re.search(r"P = {5}-\.3\d\d deg", new)
    aligned = re.findall(r"= ( *-?\d*\.\d+) +(?:mm|deg)", new[:new.index("P[9]{")])  # P[9]: left alone
    assert aligned and all(len(v) == 9 and len(v.split(".")[1]) == 3 for v in aligned)
    tabbed = re.findall(r"=\t(-?\d+\.\d+)\t", new)
    assert tabbed and all(len(v.split(".")[1]) == 6 for v in tabbed)


def test_fanuc_track_positions_are_named(tmp_path):
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    path = _copy(["track_pick.ls"], tmp_path)[0]
    res = filter_program(path, perturbed(robot, 7), robot, **FANUC_FRAMES)
    first = res.motions[0]
    assert first.target == "P[1]" and first.status == "named"
    assert "external axes E1 = 1500.000" in first.reason


def test_fanuc_malformed_position_block_is_not_silent(tmp_path):
    """A position block that does not parse as one (here without its closing '};') is refused
    with its line (the /POS section holds position blocks and nothing else), never '0 of 0'."""
    path = tmp_path / "short.ls"
    data = (CORPUS / "weld_bracket.ls").read_bytes()
    data = data[:data.index(b"/POS")] + b"/POS\nP[1:\"approach\"]{\n   GP1:\n\tUF : 1, UT : 2,\n/END\n"
    path.write_bytes(data)
    robot = rc.Robot.from_catalog("fanuc_lrmate200id")
    with pytest.raises(DataError, match=r"short.ls:\d+: malformed position block"):
        filter_program(path, robot, robot, **FANUC_FRAMES)


# ----------------------------------------------------------------------------- URScript constructs
def test_urscript_constant_expressions_and_pose_trans(tmp_path):
    """pose_trans(Pick_p, p[0, 0, -approach_dist, 0, 0, 0]) with a constant approach_dist and
    pose_add(Pick_p, p[0, 0, approach_dist, ...]) are uses of Pick_p; move_over(Inspect_p, 0.05)
    passes Inspect_p and a constant through function parameters."""
    res, _ = _run("urscript palletizing", tmp_path)
    names = [r["name"] for r in res.rows]
    assert names.count("Pick_p") == 1 and "Inspect_p" in names
    assert not any("malformed" in w for w in res.warnings)


def test_urscript_expression_list_is_not_refused(tmp_path):
    """[2*sqrt(Kp[0]), ...] and local d = [0, 0, k * layer_height, ...]: read, not refused as
    malformed; the motion through d is named."""
    res, _ = _run("urscript palletizing", tmp_path)
    assert any("holds values known at run time only (d[0]" in w for w in res.uncorrected)


def test_urscript_feature_that_is_also_a_target_is_not_corrected(tmp_path):
    path = tmp_path / "feature.script"
    path.write_bytes(b"def f():\n  global Plane=p[0.4, -0.2, 0.1, 0, 3.1416, 0]\n  d = 0.05\n"
                     b"  movel(pose_trans(Plane, p[0.01, 0.02, 0.0, 0, 0, 0]))\n"
                     b"  movel(pose_trans(Plane, p[0, 0, -d, 0, 0, 0]))\nend\n")
    robot = rc.Robot.from_catalog("ur5")
    res = filter_program(path, perturbed(robot, 7), robot)
    assert [r["name"] for r in res.rows] == ["p@4"] and res.rows[0]["frame"] == "Plane"
    assert any("Plane serves as a feature (pose_trans) and as a target" in w for w in res.uncorrected)


# ----------------------------------------------------------------------------- messages
def test_repeated_errors_are_collapsed_one_item_a_line(tmp_path):
    robot = rc.Robot.from_catalog("abb_irb2600")
    path = tmp_path / "far.mod"
    targets = "".join(f"  CONST robtarget p{i}:=[[{4000 + i},0,500],[0,0,1,0],[0,0,0,0],"
                      "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\n" for i in range(8))
    moves = "".join(f"    MoveL p{i}, v100, fine, tool0;\n" for i in range(8))
    path.write_text(f"MODULE Far\n{targets}  PROC main()\n{moves}  ENDPROC\nENDMODULE\n")
    with pytest.raises(DataError) as err:
        filter_program(path, robot, robot)
    # one reason: one line naming the first places
    assert re.fullmatch(r"8 target\(s\) cannot be corrected: no solution of the nominal model inside the "
                        r"joint limits \(out of reach\) \(8 places: far.mod:2 \(p0\), far.mod:3 \(p1\), "
                        r"far.mod:4 \(p2\), far.mod:5 \(p3\) and 4 more\); nothing was written.*",
                        str(err.value))


def test_urscript_relative_waypoint_export(tmp_path):
    """PolyScope writes a waypoint relative to a feature point as pose_trans(F, pose_trans(
    pose_inv(A), B)): B is corrected in the frame F * A^-1; a motion to F itself then cannot be
    corrected (F is a frame) and is named; a move relative to the current pose is named."""
    path = tmp_path / "relative.script"
    path.write_bytes(b"def Prog():\n  global Feat_7=p[.40430, -.26587, .21250, .00027, 3.14144, -.00022]\n"
                     b"  movel(pose_trans(Feat_7, pose_trans(pose_inv(p[.40461, -.26488, .21343, .00025, "
                     b"3.14143, -.00010]), p[.40543, -.26239, .32808, .00052, 3.14145, -.00005])), a=2.5, "
                     b"v=0.3)\n"
                     b"  movel(Feat_7, a=2.5, v=0.3)\n"
                     b"  movel(pose_trans(get_actual_tcp_pose(), p[0, 0, 0.01, 0, 0, 0]), a=0.1, v=0.1)\n"
                     b"end\n")
    robot = rc.Robot.from_catalog("ur5")
    res = filter_program(path, perturbed(robot, 7), robot)
    assert [(r["name"], r["frame"]) for r in res.rows] == [("p@3", "Feat_7*pose@3")]
    assert re.match(r"relative.script:4: motion: not corrected: Feat_7 serves as a feature",
                    res.uncorrected[1])
    assert re.match(r"relative.script:5: movel: .*relative to a pose known at run time only",
                    res.uncorrected[0])
    text = res.outputs[path].decode()
    assert "p[.40543, -.26239, .32808" not in text
    assert re.search(r"p\[\.4\d+, -\.2\d+, \.3\d+, -?\.\d+", text)  # the leading-dot style is kept


def test_krl_literal_index_is_that_element(tmp_path):
    files = _copy(["deburr_cell.src", "deburr_cell.dat"], tmp_path)
    files[0].write_bytes(files[0].read_bytes().replace(b"SLIN XHOLE[i]", b"SLIN XHOLE[2]"))
    robot = rc.Robot.from_catalog("kuka_kr16_2")
    res = filter_program(files, perturbed(robot, 7), robot, references=_copy(["$config.dat"], tmp_path))
    names = [r["name"] for r in res.rows]
    assert "XHOLE[2]" in names and "XHOLE[1]" not in names


def test_urscript_qnear_variable_is_read():
    """get_inverse_kin(pose, qnear=q_home): the joints the controller starts from."""
    from robocal.programs.dialects.urscript.reader import URScriptDialect
    from robocal.programs.source import ProgramText

    text = (b"def f():\n  q_home = [0.1, -1.5, 1.5, -1.5, -1.5, 0.2]\n  P1 = p[0.4, -0.2, 0.3, 0, 3.1, 0]\n"
            b"  movej(get_inverse_kin(P1, qnear=q_home))\nend\n")
    prog = URScriptDialect().parse([ProgramText("f.script", text)], {}, {"default": np.eye(4)})
    assert np.allclose(prog.targets[0].qnear, [0.1, -1.5, 1.5, -1.5, -1.5, 0.2])


def test_rapid_routine_without_a_call_in_these_files(tmp_path):
    """A PROC with parameters called from a module not given: its motions to declared targets are
    corrected, the one through its parameter is named."""
    path = tmp_path / "lib.mod"
    path.write_bytes(b"MODULE Lib\n  CONST robtarget pFix:=[[900,0,900],[0,0,1,0],[0,0,0,0],"
                     b"[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\n  PROC Go(robtarget pT, num nSpeed)\n"
                     b"    MoveL pFix, v100, fine, tool0;\n    MoveL pT, v100, fine, tool0;\n  ENDPROC\n"
                     b"ENDMODULE\n")
    robot = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, perturbed(robot, 7), robot)
    assert [r["name"] for r in res.rows] == ["pFix"]
    assert res.uncorrected == ["lib.mod:5: MoveL: not corrected: pT is a parameter of routine go that no "
                               "call in these files gives"]


def test_rapid_seam_finding_and_routines_of_other_modules():
    """SeamFind's ToPoint is a target; a robtarget passed to a routine no file given defines is
    named; a robtarget whose field is changed at run time is named, not corrected."""
    from robocal.programs.dialects.rapid.reader import RapidDialect
    from robocal.programs.source import ProgramText

    rt = "[[500,-200,400],[0,0,1,0],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    text = (f"MODULE Touch\n  PERS robtarget pSearch:={rt};\n  PERS robtarget pFound:={rt};\n"
            f"  PERS robtarget pLaser:={rt};\n  PERS robtarget pCheck:={rt};\n  PROC main()\n"
            "    SeamFind 2\\FoundPoint:=pFound,pSearch,v100,js1,sched1,tGun\\WObj:=wobj0;\n"
            "    ScanSeam pLaser,v100,tLaser;\n    pCheck.trans:=pFound.trans;\n"
            "    MoveJ pCheck,v100,fine,tGun;\n  ENDPROC\nENDMODULE\n").encode()
    prog = RapidDialect().parse([ProgramText("touch.mod", text)], {}, {})
    assert [(t.name, t.tool) for t in prog.targets] == [("pSearch", "tgun")]
    assert prog.uncorrected == [
        "touch.mod:10: MoveJ: not corrected: pCheck is modified at run time (pCheck.<field> := ... at "
        "touch.mod:9)",
        "touch.mod:8: ScanSeam: not corrected: robtarget pLaser is passed to ScanSeam, a routine not in "
        "these files: if it moves there, give its module as a program file"]


def test_positions_passed_to_routines_not_given_are_named():
    """KRL UserMove(XP9) with UserMove in another file; URScript rq_move_to(Drop_p) of a URCap: the
    positions are named, not reported as unused."""
    from robocal.programs.dialects.krl.reader import KRLDialect
    from robocal.programs.dialects.urscript.reader import URScriptDialect
    from robocal.programs.source import ProgramText

    src = b"DEF cell( )\r\n  $TOOL = TOOL_DATA[1]\r\n  $BASE = BASE_DATA[1]\r\n  UserMove(XP9)\r\nEND\r\n"
    dat = b"DEFDAT cell\r\nDECL E6POS XP9={X 500,Y 0,Z 600,A 0,B 90,C 0,S 2,T 2}\r\nENDDAT\r\n"
    prog = KRLDialect().parse([ProgramText("cell.src", src), ProgramText("cell.dat", dat)], {}, {})
    assert prog.uncorrected == ["cell.src:4: UserMove: not corrected: XP9 is passed to UserMove, a routine "
                                "not in these files: if it moves there, give its file as a program file"]
    assert not any("not used" in w for w in prog.warnings)
    script = b"def f():\n  Drop_p = p[0.4, -0.2, 0.3, 0, 3.1, 0]\n  rq_move_to(Drop_p, 0.1)\nend\n"
    prog = URScriptDialect().parse([ProgramText("f.script", script)], {}, {"default": np.eye(4)})
    assert prog.uncorrected == ["f.script:3: rq_move_to: not corrected: Drop_p is passed to rq_move_to(), "
                                "which this filter does not follow: if it moves there, the pose is not "
                                "corrected"]


def test_cli_lists_refused_motions_one_a_line(tmp_path, capsys):
    """--strict on a KRL .src without its .dat: every motion named in the error, one a line."""
    path = _copy(["deburr_cell.src"], tmp_path)[0]
    cal = tmp_path / "cal.yaml"
    perturbed(rc.Robot.from_catalog("kuka_kr16_2"), 7).save(cal)
    code = main(["filter", str(path), "--calibrated", str(cal), "--nominal", "kuka_kr16_2",
                 "-o", str(tmp_path / "out.src"), "--strict"])
    err = capsys.readouterr().err.splitlines()
    assert code == 2 and err[0].startswith("robocal filter: error: ") and "declared in none" in err[0]
    assert err[1].startswith("  deburr_cell.src:27 (SPTP): needs DECL E6POS/POS/FRAME XP1")
    assert not (tmp_path / "out.src").exists()


def test_rapid_error_handler_motions_are_read():
    from robocal.programs.dialects.rapid.reader import RapidDialect
    from robocal.programs.source import ProgramText

    rt = "[[500,-200,400],[0,0,1,0],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]"
    text = (f"MODULE E\n  CONST robtarget pA:={rt};\n  CONST robtarget pB:={rt};\n  PROC main()\n"
            "    MoveL pA, v100, fine, tool0;\n  ERROR\n    MoveL pB, v100, fine, tool0;\n    RETRY;\n"
            "  ENDPROC\nENDMODULE\n").encode()
    prog = RapidDialect().parse([ProgramText("e.mod", text)], {}, {})
    assert [t.name for t in prog.targets] == ["pA", "pB"] and not prog.warnings
