"""Filtering programs written the way public real programs with external axes are (issue 45: the
measurement on public RAPID / KRL / INFORM / FANUC programs, its defects each tested here in the
style of the program that showed it; the programs themselves are not copied: no licence allows it)."""

from __future__ import annotations

import numpy as np
import pytest

import robocal as rc
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.programs import filter_program
from robocal.programs.source import ProgramText

ABB = rc.Robot.from_catalog("abb_irb4600")

# a MultiMove task of an arm on a track (eax_a, mm): targets in a world work object, x + eax_a the
# same along the path (the track carries the arm); the last target is reachable from the arm's
# base at the track's zero, the others are not (written as an exported COMPAS RRC program is)
TOOL = "[TRUE,[[0,0,120],[1,0,0,0]],[2.5,[0,0,50],[1,0,0,0],0,0,0]]"
WOBJ = '[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]]'
TAIL = "Speed000,fine,HeatGun \\WObj:=DefaultFrame;"
TRACK_TASK = "\n".join([
    "MODULE Track_T_ROB1", f"PERS tooldata HeatGun:={TOOL};", f"TASK PERS wobjdata DefaultFrame:={WOBJ};",
    "TASK PERS speeddata Speed000:=[100.00,180.00,5000.00,1080.00];", "PROC Main()", "ConfL \\Off;",
    "MoveJ [[3613.91,2326.15,1040.68],[0.5000,0.5000,0.5000,0.5000],[0,0,-2,0],"
    f"[3079.80,9E9,9E9,9E9,9E9,9E9]]\\ID:=1,{TAIL}",
    "MoveJ [[3943.83,2265.39,1040.68],[0.5000,0.5000,0.5000,0.5000],[0,0,-2,0],"
    f"[2749.92,9E9,9E9,9E9,9E9,9E9]]\\ID:=2,{TAIL}",
    "MoveL [[1200.00,300.00,900.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    f"[0.00,9E9,9E9,9E9,9E9,9E9]]\\ID:=3,{TAIL}",
    "ENDPROC", "ENDMODULE", ""])


def test_track_targets_out_of_the_fixed_arms_reach_name_their_axes(tmp_path):
    """Targets with eax_a values (three, one at the axis' zero: too few to judge the axis) in a work
    object no unit moves are named, the axis possibly carrying the arm, but the one at the axis' zero
    (the arm where its model has it); held at one value (no evidence) they
    are corrected as arm targets, and those the arm at a fixed base cannot reach were named 'no
    solution ... (out of reach)' alone, which blames the target: their eax_a may carry the arm (here
    a track), and the reason says so with the values and the cell file to give; the reachable one is
    corrected; every motion accounted."""
    path = tmp_path / "Track_T_ROB1.mod"
    path.write_text(TRACK_TASK)
    res = filter_program(path, perturbed(ABB, 7), ABB, keep_unreached=True)
    status = {m.line: (m.status, m.reason) for m in res.motions}
    assert len(res.motions) == 3 and status[9][0] == "corrected"
    assert all(status[k][0] == "named" and "eax_a varies (0 .. 3079.8) over 3 target(s)" in status[k][1]
               for k in (7, 8))
    path.write_text(TRACK_TASK.replace("[2749.92,9E9", "[3079.80,9E9").replace("[0.00,9E9", "[9E9,9E9"))
    res = filter_program(path, perturbed(ABB, 7), ABB, keep_unreached=True)
    status = {m.line: (m.status, m.reason) for m in res.motions}
    assert len(res.motions) == 3 and status[9][0] == "corrected"
    for line, value in ((7, "3079.80"), (8, "3079.80")):
        assert status[line][0] == "named"
        assert "out of reach" in status[line][1] and f"eax_a = {value}" in status[line][1]
        assert "if those axes move the arm" in status[line][1] and "--model CELL.yaml" in status[line][1]
    with pytest.raises(DataError, match=r"(?s)if those axes move the arm.*nothing was written"):
        filter_program(path, perturbed(ABB, 7), ABB)


def test_unreached_target_without_external_values_keeps_its_reason(tmp_path):
    """A target with no external-axis value out of reach: the reason names no track."""
    path = tmp_path / "far.mod"
    path.write_text(TRACK_TASK.replace("[3079.80,9E9", "[9E9,9E9").replace("[2749.92,9E9", "[9E9,9E9"))
    res = filter_program(path, perturbed(ABB, 7), ABB, keep_unreached=True)
    named = [m.reason for m in res.motions if m.status == "named"]
    assert len(named) == 2 and all("out of reach" in r and "track" not in r for r in named)


# a touch-sensing (SmarTac) search written as the public program that showed it: one robtarget taught
# once and run in the reference work object and in the one the search found
SEARCH = """MODULE SearchCell
  PERS tooldata toolWeldGun:=[TRUE,[[0,0,400],[1,0,0,0]],[3,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata obRef:=[FALSE,TRUE,"",[[1000,0,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  PERS wobjdata obNew:=[FALSE,TRUE,"",[[1000,0,300],[1,0,0,0]],[[1.2,-0.8,0.5],[1,0,0,0]]];
  PERS robtarget pOframeHome:=[[0,0,150],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  PERS robtarget pSearch:=[[50,0,20],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  PROC main()
    MoveJ pOframeHome, v200, fine, toolWeldGun\\WObj:=obRef;
    MoveL pSearch, v200, fine, toolWeldGun\\WObj:=obRef;
    MoveJ pOframeHome, v200, fine, toolWeldGun\\WObj:=obNew;
  ENDPROC
ENDMODULE
"""


def test_target_used_in_two_work_objects_is_named_not_refused(tmp_path):
    """A valid program whose robtarget is run in two work objects was refused whole (nothing
    filtered); one correction cannot serve both, so that target is left as written and both of
    its motions are named; the rest is corrected; the file's other bytes unchanged."""
    path = tmp_path / "SearchCell.mod"
    path.write_text(SEARCH)
    robot = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, perturbed(robot, 7), robot)
    by_line = {m.line: m for m in res.motions}
    assert sorted(by_line) == [8, 9, 10] and by_line[9].status == "corrected"
    for line in (8, 10):
        assert by_line[line].status == "named" and "cannot serve both" in by_line[line].reason
        assert "obref" in by_line[line].reason and "obnew" in by_line[line].reason
    out = res.outputs[path].decode()
    assert "pOframeHome:=[[0,0,150],[0,0,1,0]" in out and "pSearch:=[[50,0,20]" not in out


# a sealing program on a pedestal nozzle (remote TCP), written as the public plant backups that showed
# it: positions in RX .. RR, motions with RTCP, the servo gun / track groups GP2-GP3 in every position
REMOTE_LS = """/PROG  UP022
/ATTR
DEFAULT_GROUP\t= 1,1,1,*,*;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=2 ;
   3:J P[1] 100% CNT0 ACC100    ;
   4:L P[2] 200mm/sec CD5 ACC100 DB    0.0mm,P-SPS RTCP    ;
   5:L P[3] 200mm/sec FINE    ;
/POS
P[1]{
   GP1:
\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',
\tRX =   341.681  mm,\tRY =  -170.477  mm,\tRZ =  -671.251  mm,
\tRW =    55.263 deg,\tRP =     4.579 deg,\tRR =  -173.433 deg
   GP2:
\tUF : 1, UT : 2,\t
\tJ1=   100.000  mm
   GP3:
\tUF : 1, UT : 2,\t
\tJ1=     0.000  mm
};
P[2]{
   GP1:
\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 1',
\tRX =   810.218  mm,\tRY =  -319.330  mm,\tRZ =  -184.077  mm,
\tRW =    60.000 deg,\tRP =     4.000 deg,\tRR =  -170.000 deg
   GP2:
\tUF : 1, UT : 2,\t
\tJ1=   100.000  mm
   GP3:
\tUF : 1, UT : 2,\t
\tJ1=     0.000  mm
};
P[3]{
   GP1:
\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =   300.000  mm,\tY =     0.000  mm,\tZ =   -50.000  mm,
\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg
   GP2:
\tUF : 1, UT : 2,\t
\tJ1=   300.000  mm
   GP3:
\tUF : 1, UT : 2,\t
\tJ1=     0.000  mm
};
/END
"""


def test_fanuc_remote_tcp_positions_are_named_not_refused(tmp_path):
    """Remote-TCP positions (RX .. RR) made the whole program refused as 'malformed position P[1]:
    no X = ... mm'; they are read and every motion to them named (the fixed tool is not on the
    arm's model); the other position (its GP2 servo-gun value in no coordinated frame) is
    corrected as an arm target; every motion accounted; the RX numbers unchanged."""
    path = tmp_path / "UP022.LS"
    path.write_text(REMOTE_LS)
    robot = rc.Robot.from_catalog("fanuc_r2000ic_165f")
    res = filter_program(path, perturbed(robot, 7), robot, frames={"1": "1200,0,800,0,0,0"},
                         tools={"2": "0,0,250,0,0,0"})
    status = [(m.status, m.reason) for m in res.motions]
    assert [s for s, _ in status] == ["named", "named", "corrected"]
    assert all("remote-TCP position" in why for _, why in status[:2])
    out = res.outputs[path].decode()
    assert "RX =   341.681  mm" in out and "RX =   810.218  mm" in out and "X =   300.000  mm" not in out


def test_inform_station_only_job_moves_no_arm(tmp_path):
    """A job of the station group alone (///GROUP1 ST1, MOVJ EC00000: turn the positioner, as the
    public welding cell's jobs do) was counted as a Cartesian motion and named 'no robot position';
    the arm does not move: no motion to a Cartesian pose, nothing named, nothing refused."""
    path = tmp_path / "TURN.JBI"
    lines = ["/JOB", "//NAME TURN", "//POS", "///NPOS 0,0,1,0,0,0", "///TOOL 12", "///POSTYPE PULSE",
             "///PULSE", "EC00000=-29914,0", "//INST", "///DATE 2023/11/10 10:40", "///ATTR SC,RW",
             "///GROUP1 ST1", "NOP", "MOVJ EC00000 VJ=90.0", "END", ""]
    path.write_bytes("\r\n".join(lines).encode())
    robot = rc.Robot.from_catalog("yaskawa_gp25")
    res = filter_program(path, perturbed(robot, 7), robot)
    assert res.motions == [] and res.uncorrected == []
    assert res.outputs[path] == path.read_bytes()


def test_binary_module_is_said_binary_and_utf16_still_named(tmp_path):
    """A module stored encrypted (random bytes, a NUL among them) was refused as 'looks UTF-16'
    (the public repository's other modules were so); it is said binary; a UTF-16 module is still
    said UTF-16, with or without its byte-order mark."""
    rng = np.random.default_rng(3)
    binary = tmp_path / "GeneralModule.mod"
    binary.write_bytes(b"\xfc\xc8\xa4v\x00\x01" + rng.integers(0, 256, 3000, dtype=np.uint8).tobytes())
    with pytest.raises(DataError, match="not a program text .binary data"):
        ProgramText(binary)
    for codec in ("utf-16", "utf-16-le", "utf-16-be"):
        wide = tmp_path / f"{codec}.mod"
        wide.write_bytes("MODULE A ! 注释\nENDMODULE\n".encode(codec))
        with pytest.raises(DataError, match="looks UTF-16 encoded"):
            ProgramText(wide)


# --------------------------------------------------------- does an external axis carry the arm?
# (the data decide what the RAPID / KRL text cannot: robocal.programs.carrier)
QUAT = "[0,0.7071068,0.7071068,0]"


def _task(rows: list[tuple[tuple[float, float, float], str]], name: str = "Cell_T_ROB1") -> str:
    """A RAPID task of inline robtargets ``(x, y, z) mm, extax text`` in a world work object, written
    as an exported COMPAS RRC program is."""
    moves = [f"MoveL [[{x:.2f},{y:.2f},{z:.2f}],{QUAT},[0,0,0,0],[{ext}]]\\ID:={k},{TAIL}"
             for k, ((x, y, z), ext) in enumerate(rows, 1)]
    return "\n".join(["MODULE " + name, f"PERS tooldata HeatGun:={TOOL};",
                      f"TASK PERS wobjdata DefaultFrame:={WOBJ};",
                      "TASK PERS speeddata Speed000:=[100.00,180.00,5000.00,1080.00];", "PROC Main()",
                      *moves, "ENDPROC", "ENDMODULE", ""])


def _filtered(tmp_path, text: str, **kw):
    path = tmp_path / "Cell_T_ROB1.mod"
    path.write_text(text)
    return path, filter_program(path, perturbed(ABB, 7), ABB, keep_unreached=True, **kw)


def test_a_track_the_targets_follow_carries_the_arm(tmp_path):
    """A task along a track (the ECL cell's: 10 targets, x = 3693.7 - eax_a, y drifting 100 mm): the
    targets follow eax_a at 1 mm per mm, so the axis carries the arm: all 10 motions named with
    the slope and direction measured (independent truth: the written relation), the cell file or
    --fixed-base to give; with fixed_base they are corrected as arm targets (or named out of
    reach with no word of a track); every motion accounted either way."""
    e = np.linspace(72.81, 3079.80, 10)
    rows = [((3693.7 - v, 326.2 - 0.03 * (3079.8 - v), 1040.7), f"{v:.2f},9E9,9E9,9E9,9E9,9E9") for v in e]
    path, res = _filtered(tmp_path, _task(rows))
    assert res.summary_dict()["motions"] == {"total": 10, "corrected": 0, "named": 10}
    slope = np.hypot(1.0, 0.03)
    u = np.array([-1.0, 0.03, 0.0]) / slope
    want = f"{slope:.2f} mm per mm along ({', '.join(f'{c:.2f}' for c in u)}), correlation 1.00"
    for m in res.motions:
        assert "external axis eax_a carries the arm (a track or gantry)" in m.reason and want in m.reason
        assert "--model CELL.yaml" in m.reason and "--fixed-base" in m.reason
    _, res = _filtered(tmp_path, _task(rows), fixed_base=True)
    assert res.summary_dict()["motions"]["total"] == 10
    assert not any("carries the arm" in m.reason or "if those axes" in m.reason for m in res.motions)
    assert {m.status for m in res.motions} == {"corrected", "named"}  # x 600..3600 mm: some out of reach


def test_a_gantry_carrying_the_arm_is_named_on_each_axis(tmp_path):
    """A 3-axis gantry (the ZhongXun cell's eax_a, eax_b, eax_c in mm) with the arm hanging from it: the
    targets follow the gantry's x axis with the arm's own reach added: named, not corrected at a
    fixed base far from where the arm is (-8000 mm)."""
    rng = np.random.default_rng(3)
    a = np.array([-8175.6, -6200.0, -4100.0, -2500.0, -800.0, 0.0, 859.8, 2643.7])
    b = rng.uniform(-600, 500, a.size)
    c = rng.uniform(-500, 450, a.size)
    reach = rng.uniform(-300, 300, (a.size, 3))
    rows = [((1200 + a[k] + reach[k, 0], 200 + reach[k, 1], 900 + reach[k, 2]),
             f"{a[k]:.2f},{b[k]:.2f},{c[k]:.2f},9E9,9E9,9E9") for k in range(a.size)]
    _, res = _filtered(tmp_path, _task(rows))
    assert res.summary_dict()["motions"] == {"total": 8, "corrected": 0, "named": 8}
    carried = sum("external axis eax_a carries the arm" in m.reason for m in res.motions)
    assert carried == 7  # the eighth is at eax_a = 0: named for eax_b / eax_c
    assert all("eax_b" in m.reason or "eax_c" in m.reason for m in res.motions if "eax_a" not in m.reason)


def test_a_linear_axis_the_targets_do_not_follow_may_carry_the_arm(tmp_path):
    """The ECL sheet-forming task: eax_a 979 .. 1189 mm (no positioner turn reads that: a linear
    axis) while the heat gun stays on one point: the arm reaches back as the track moves, which the
    data cannot tell from a linear work slide: named, the reason says why; 6 motions."""
    e = [1054.42, 1084.45, 1056.57, 1078.07, 1108.62, 1189.48]
    _, res = _filtered(tmp_path, _task([((1640.5, 446.2, 856.1), f"{v},9E9,9E9,9E9,9E9,9E9") for v in e]))
    assert res.summary_dict()["motions"] == {"total": 6, "corrected": 0, "named": 6}
    assert all("external axis eax_a varies (1054.42 .. 1189.48) beyond any positioner turn" in m.reason
               for m in res.motions)


def test_an_uncoordinated_positioner_stays_corrected(tmp_path):
    """Issue 45's goal kept: a positioner the work object does not follow, turning (eax_b -90 .. 90 deg)
    under targets all over the arm's reach (no line in its values), and a constant track value:
    the 7 motions are corrected as arm targets, one warning counting them; nothing named."""
    pts = [(1100, -300, 800), (1300, 250, 950), (1150, 100, 1000), (1250, -200, 850), (1200, 300, 900),
           (1100, 0, 950), (1300, -100, 800)]
    ang = [-90, 45, 0, 90, -45, 30, 60]
    rows = [(p, f"500,{v},9E9,9E9,9E9,9E9") for p, v in zip(pts, ang, strict=True)]
    _, res = _filtered(tmp_path, _task(rows))
    assert res.summary_dict()["motions"] == {"total": 7, "corrected": 7, "named": 0}
    said = [w for w in res.warnings if "external-axis values" in w]
    assert len(said) == 1 and said[0].startswith("7 target(s) carry external-axis values (eax_a, eax_b)")


def test_the_filter_command_takes_fixed_base(tmp_path, capsys):
    """robocal filter --fixed-base: the short track task's targets, named by default, are corrected
    as arm targets; the output is what the API gives with fixed_base=True."""
    from robocal.cli import main

    rows = [((1200, -200, 900), "800,9E9,9E9,9E9,9E9,9E9"), ((1250, 0, 950), "1450,9E9,9E9,9E9,9E9,9E9"),
            ((1300, 200, 900), "2100,9E9,9E9,9E9,9E9,9E9")]
    path, _ = _filtered(tmp_path, _task(rows))
    cal = perturbed(ABB, 7)
    cal.save(tmp_path / "cal.yaml")
    args = ["filter", str(path), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal", "abb_irb4600",
            "-o", str(tmp_path / "out.mod")]
    assert main(args) == 0
    assert "3 motions: 0 corrected" in capsys.readouterr().out
    assert main([*args, "--fixed-base", "--force"]) == 0
    assert "3 motions: 3 corrected" in capsys.readouterr().out
    api = tmp_path / "api.mod"
    filter_program(path, cal, ABB, fixed_base=True).write(api)
    assert (tmp_path / "out.mod").read_bytes() == api.read_bytes()


def test_a_cells_positioner_axes_are_not_weighed(tmp_path):
    """With a cell whose positioner is eax_b / eax_c (logical axes 2, 3), targets in a world work object
    carrying varying eax_b values (3 targets, too few to judge with a plain arm: named) are not
    suspected of carrying the arm: the cell file says that axis is the positioner's, which the
    work object does not follow: corrected as arm targets."""
    import cell_programs as cp

    nominal, _, calibrated = cp.cells(0)
    arm = nominal.arms["arm"]
    rows = [((1000, -200, 900), "9E9,-30,10,9E9,9E9,9E9"), ((1050, 0, 950), "9E9,15,10,9E9,9E9,9E9"),
            ((1100, 200, 900), "9E9,60,10,9E9,9E9,9E9")]
    path = tmp_path / "Cell_T_ROB1.mod"
    path.write_text(_task(rows))
    res = filter_program(path, calibrated, nominal, keep_unreached=True)
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 3, "named": 0}
    res = filter_program(path, perturbed(arm, 7), arm, keep_unreached=True)
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 0, "named": 3}
    assert all("eax_b varies (-30 .. 60) over 3 target(s)" in m.reason for m in res.motions)


# a weld task's module with a calibration module given as --references (written the way the
# zhongxun RAPID application is: the reference holds its own CRobT/RelTool motions and a routine
# moving to its parameter; the task calls it with one of its own constant targets)
CALIB_MODULE = "\n".join([
    "MODULE CalibData", f"PERS tooldata toolWeldGun:={TOOL};", "VAR robtarget pTCP;",
    "PROC rCheckTcp()", "pTCP:=CRobT(\\Tool:=toolWeldGun);",
    "MoveL RelTool(pTCP,0,0,-30),v100,fine,toolWeldGun;", "MoveL RelTool(pTCP,0,0,30),v100,fine,toolWeldGun;",
    "ENDPROC", "PROC rGoTo(robtarget ToPoint)", "MoveJ ToPoint,v200,z10,toolWeldGun;", "ENDPROC",
    "ENDMODULE", ""])
WELD_MODULE = "\n".join([
    "MODULE WeldTest",
    "CONST robtarget pHome:=[[1200.00,300.00,900.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    "[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "CONST robtarget pApp:=[[1250.00,250.00,850.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    "[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "PROC main()", "rCheckTcp;", "MoveL pHome,v200,fine,toolWeldGun;", "rGoTo pApp;", "ENDPROC",
    "ENDMODULE", ""])


def test_a_reference_modules_motions_are_not_the_programs(tmp_path):
    """The motions of a module given as a reference are not the program's (it is never written):
    the program's account holds its own motion instructions only (total == its hand count, 1),
    the reference's run-time motions are not named in it, and a constant target of the program
    the reference's routine moves to is still corrected."""
    prog, ref = tmp_path / "WeldTest.mod", tmp_path / "CalibData.mod"
    prog.write_text(WELD_MODULE)
    ref.write_text(CALIB_MODULE)
    res = filter_program(prog, perturbed(ABB, 3), ABB, references=[ref])
    records = [m.as_dict() for m in res.motions]
    assert [(r["file"], r["status"]) for r in records] == [("WeldTest.mod", "corrected")]
    assert not any("CRobT" in w for w in res.warnings)
    assert {r["name"].lower() for r in res.rows} == {"phome", "papp"}
    assert res.outputs[prog] != prog.read_bytes()
    assert ref not in res.outputs


# a seam found by touch sensing (written the way the zhongxun SmarTac module is): the work object
# obNEW is recomputed from three searched points (OFrameChange) before the weld runs in it, and a
# touch-up shifts it by a field; the declaration holds only the last run's value
SMARTAC_MODULE = "\n".join([
    "MODULE SmarTacTest", f"PERS tooldata toolWeldGun:={TOOL};",
    'PERS wobjdata obREF:=[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];',
    'PERS wobjdata obNEW:=[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[-7.29398,-15.2142,-3.66034],'
    '[0.999905,-3.29978E-05,0.0025619,-0.0135815]]];',
    'PERS wobjdata obTouch:=[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];',
    "CONST robtarget pOFrame1:=[[1200.00,300.00,900.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    "[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "CONST robtarget pOFrameWeld1:=[[1250.00,250.00,850.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    "[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "CONST robtarget pOFrameHome:=[[1150.00,200.00,950.00],[0,0.7071068,0.7071068,0],[0,0,0,0],"
    "[9E9,9E9,9E9,9E9,9E9,9E9]];",
    "PROC WeldByWobjOFrame()", "MoveL pOFrameHome,v200,fine,toolWeldGun\\WObj:=obREF;",
    "MoveL pOFrame1,v200,fine,toolWeldGun\\WObj:=obREF;",
    "obNEW:=OFrameChange(obREF,pOFrame1,pOFrame1,pOFrame1,pOFrame1,pOFrame1,pOFrame1);",
    "MoveL pOFrameWeld1,v200,fine,toolWeldGun\\WObj:=obNEW;",
    "obTouch.oframe.trans.x:=obTouch.oframe.trans.x+5;", "toolWeldGun.tload.mass:=4.5;",
    "MoveL pOFrame1,v20,fine,toolWeldGun\\WObj:=obTouch;", "ENDPROC", "ENDMODULE", ""])


def test_a_work_object_the_program_computes_names_its_motions(tmp_path):
    """A motion in a work object the program assigns (whole or a field) moves to a place in the
    world known only at run time: it is named with where the work object is written, not
    corrected with the declaration's stale value; a target also moved to in the fixed obREF is
    corrected for neither (its corrected numbers would move the run-time motion too); a target
    moved to in obREF only is corrected (a change of the tool's load, toolWeldGun.tload, moves no
    target)."""
    prog = tmp_path / "SmarTacTest.mod"
    prog.write_text(SMARTAC_MODULE)
    res = filter_program(prog, perturbed(ABB, 3), ABB)
    records = [m.as_dict() for m in res.motions]
    assert [r["status"] for r in records] == ["corrected", "named", "named", "named"]
    assert "pOFrame1 is also moved to at SmarTacTest.mod:16, where the work object obTouch is " \
           "assigned at run time (SmarTacTest.mod:14)" in records[1]["reason"]
    assert "work object obNEW is assigned at run time (SmarTacTest.mod:12)" in records[2]["reason"]
    assert "work object obTouch is assigned at run time (SmarTacTest.mod:14)" in records[3]["reason"]
    assert [r["name"] for r in res.rows] == ["pOFrameHome"]
    lines = zip(SMARTAC_MODULE.splitlines(), res.outputs[prog].decode().splitlines(), strict=True)
    changed = [a for a, b in lines if a != b]
    assert len(changed) == 1 and changed[0].startswith("CONST robtarget pOFrameHome")


# a palletizing program written the way the errekaSmartPal KRC backup's are (KRC 4.1 inline forms):
# the pallet's base is shifted layer by layer by a field of BASE_DATA[3] before the place motions;
# the conveyor's motions run in BASE_DATA[1], which no routine writes ($config.dat holds both)
KR = rc.Robot.from_catalog("kuka_kr120_r2500")
PALLET_SRC = "\n".join([
    "&ACCESS RVP", "&REL 7", "DEF paletizado( )", ";FOLD INI", "  BAS (#INITMOV,0 )", ";ENDFOLD (INI)",
    "INT capa", "FOR capa=1 TO 3",
    ";FOLD LIN FrenteCinta CONT Vel= 2 m/s CPDAT1 Tool[1] Base[1];%{PE}%R 4.1.16,%MKUKATPBASIS,%CMOVE,"
    "%VLIN,%P 1:LIN, 2:FrenteCinta, 3:C_DIS, 5:2, 7:CPDAT1",
    "$BWDSTART=FALSE", "LDAT_ACT=LCPDAT1", "FDAT_ACT=FFrenteCinta", "BAS(#CP_PARAMS,2)",
    "LIN XFrenteCinta C_DIS",
    ";ENDFOLD",
    "BASE_DATA[3].Z=BASE_DATA[3].Z+120",
    ";FOLD LIN Dejar CONT Vel= 2 m/s CPDAT1 Tool[1] Base[3];%{PE}%R 4.1.16,%MKUKATPBASIS,%CMOVE,%VLIN,"
    "%P 1:LIN, 2:Dejar, 3:C_DIS, 5:2, 7:CPDAT1",
    "$BWDSTART=FALSE", "LDAT_ACT=LCPDAT1", "FDAT_ACT=FDejar", "BAS(#CP_PARAMS,2)", "LIN XDejar C_DIS",
    ";ENDFOLD", "ENDFOR", "END", ""])
PALLET_DAT = "\n".join([
    "&ACCESS RVP", "&REL 7", "DEFDAT  PALETIZADO",
    "DECL E6POS XFrenteCinta={x 1586.7,y 475.2,z 1277.2,a 88.45,b -44.99,c -179.53,s 2,t 43,e1 0.0,e2 0.0,"
    "e3 0.0,e4 0.0,e5 0.0,e6 0.0}",
    "DECL FDAT FFrenteCinta={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}",
    "DECL E6POS XDejar={x 200.7,y 356.5,z 302.6,a -0.09,b 1.01,c -178.34,s 6,t 50,e1 0.0,e2 0.0,e3 0.0,"
    "e4 0.0,e5 0.0,e6 0.0}",
    "DECL FDAT FDejar={TOOL_NO 1,BASE_NO 3,IPO_FRAME #BASE}",
    "DECL LDAT LCPDAT1={VEL 2.0,ACC 100.0,APO_DIST 100.0}", "ENDDAT", ""])
PALLET_CONFIG = "\n".join([
    "DEFDAT  $CONFIG", "DECL FRAME TOOL_DATA[16]", "TOOL_DATA[1]={x 0.0,y 0.0,z 540.0,a 0.0,b 0.0,c 0.0}",
    "DECL FRAME BASE_DATA[32]", "BASE_DATA[1]={x 0.0,y 0.0,z 0.0,a 0.0,b 0.0,c 0.0}",
    "BASE_DATA[3]={x 1200.0,y -1400.0,z 300.0,a 0.0,b 0.0,c 0.0}", "ENDDAT", ""])


def test_a_base_the_program_shifts_names_its_motions(tmp_path):
    """A motion in BASE_DATA[3], which the program shifts by a field at run time, is named with
    where (not corrected with $config.dat's stale value); the motion in BASE_DATA[1] is corrected."""
    src, dat, config = tmp_path / "paletizado.src", tmp_path / "paletizado.dat", tmp_path / "$config.dat"
    src.write_text(PALLET_SRC)
    dat.write_text(PALLET_DAT)
    config.write_text(PALLET_CONFIG)
    res = filter_program([src, dat], perturbed(KR, 3), KR, references=[config])
    records = [m.as_dict() for m in res.motions]
    assert [r["status"] for r in records] == ["corrected", "named"]
    assert "BASE_DATA[3] is written by the program at run time (paletizado.src:16)" in records[1]["reason"]
    assert [r["name"] for r in res.rows] == ["XFrenteCinta"]


# a FANUC pick program written the way the VASC cells' are (R-30iB, TC_ONLINE, ACC, TB): user frame 2
# is taught again at run time from a searched register (UFRAME[2]=PR[20]) before the picks in it;
# the approach position is taught in user frame 1, which no line writes
FANUC = rc.Robot.from_catalog("fanuc_m20ia")


def _fanuc_position(n: int, uf: int, xyz: tuple[float, float, float]) -> str:
    return "\n".join([
        f"P[{n}]{{", "   GP1:", f"\tUF : {uf}, UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',",
        f"\tX =  {xyz[0]:.3f}  mm,\tY =  {xyz[1]:.3f}  mm,\tZ =  {xyz[2]:.3f}  mm,",
        "\tW =   180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg", "};"])


PICK_LS = "\n".join([
    "/PROG  UP021", "/ATTR", "OWNER\t\t= MNEDITOR;", 'COMMENT\t\t= "Tomar en ST1540";',
    "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN", "   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=1 ;",
    "   3:J P[1] 100% CNT0 ACC100 TB    .10sec,P-SPS    ;", "   4:  UFRAME[2]=PR[20] ;",
    "   5:  UFRAME_NUM=2 ;", "   6:L P[2] 2000mm/sec CNT100 ACC100    ;", "   7:L P[3] 500mm/sec FINE    ;",
    "/POS", _fanuc_position(1, 1, (1200.0, 0.0, 600.0)), _fanuc_position(2, 2, (150.0, 80.0, 120.0)),
    _fanuc_position(3, 2, (150.0, 80.0, 20.0)), "/END", ""])


def test_a_user_frame_the_program_writes_names_its_motions(tmp_path):
    """Positions taught in user frame 2, which the program writes at run time (UFRAME[2]=PR[20]),
    are named with the line that writes it (not corrected with the frame given, a stale value);
    the position in user frame 1 is corrected."""
    prog = tmp_path / "UP021.LS"
    prog.write_text(PICK_LS)
    res = filter_program(prog, perturbed(FANUC, 3), FANUC, tools={"1": "0,0,150,0,0,0"},
                         frames={"1": "0,0,0,0,0,0", "2": "900,-300,400,0,0,0"})
    records = [m.as_dict() for m in res.motions]
    assert [r["status"] for r in records] == ["corrected", "named", "named"]
    assert all("user frame UFRAME[2] is written by the program at run time (UP021.LS:10)" in r["reason"]
               for r in records[1:])
    assert [r["name"] for r in res.rows] == ["P[1]"]
