"""RAPID and KRL constructs of issue 46 (real programs, round four), each written in the style of
the public programs that showed it (the programs themselves are not copied: no licence allows it):
a motion wrapper ``PROC MoveTo(robtarget ToPoint, ...\\robtarget Via)`` (optional parameters after a
backslash without a comma, as RAPID allows) resolved at its call sites (optional arguments left out,
passed on with ``\\Via?Via``, required arguments given by name; main lost the parameter before the
backslash and named ToPoint 'not declared'); one
robtarget used with two tools (work objects) whose data are identical; a system module with a
placeholder robtarget filled at run time (quaternion [0,0,0,0], as calibration user modules
declare them); KRL ``DECL CONST POS/E6POS`` and ``DECL GLOBAL CONST`` in the .dat given."""

from __future__ import annotations

import re

import numpy as np
import pytest

import robocal as rc
from robocal.data.simulate import perturbed
from robocal.programs import filter_program
from robocal.programs.dialects.krl.configuration import KUKAConfig
from robocal.programs.dialects.krl.runtime import frame_numbers
from robocal.programs.source import NUMBER_RE

ABB = rc.Robot.from_catalog("abb_irb4600")
KUKA = rc.Robot.from_catalog("kuka_kr16_2")
EAX = "[9E9,9E9,9E9,9E9,9E9,9E9]"
DOWN = "[0,0.7071068,0.7071068,0]"


def _outside_numbers(data: bytes) -> str:
    return re.sub(NUMBER_RE.pattern, "#", data.decode("latin-1"))


def _accounted(res, paths) -> dict[int, tuple[str, str]]:
    """Every motion corrected or named, every byte outside the numbers unchanged; line -> (status,
    reason)."""
    counts = res.summary_dict()["motions"]
    assert counts["corrected"] + counts["named"] == counts["total"] == len(res.motions)
    for p in paths:
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(p.read_bytes())
    return {m.line: (m.status, m.reason) for m in res.motions}


# ----------------------------------------------------------------------------- RAPID wrappers
WRAPPER = f"""MODULE MainModule
  PERS tooldata tGripper:=[TRUE,[[0,0,150],[1,0,0,0]],[2,[0,0,60],[1,0,0,0],0,0,0]];
  PERS wobjdata wTable:=[FALSE,TRUE,"",[[100,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget pApproach:=[[1200,-200,900],{DOWN},[0,0,0,0],{EAX}];
  CONST robtarget pPick:=[[1200,-200,700],{DOWN},[0,0,0,0],{EAX}];
  CONST robtarget pPlace:=[[1300,200,750],{DOWN},[0,0,0,0],{EAX}];
  CONST robtarget pVia:=[[1250,0,1000],{DOWN},[0,0,0,0],{EAX}];
  CONST robtarget pTable:=[[1100,100,800],{DOWN},[0,0,0,0],{EAX}];

  PROC main()
    MoveTo pApproach, v500, z10, tGripper;
    MoveTo pPick, v200, fine, tGripper \\Via:=pVia;
    MoveTo ToPoint:=pPlace, v500, fine, tGripper;
    PickPart pTable \\WObj:=wTable;
    PickPart pPick;
    Approach pPick;
    Approach pPlace\\Via:=pVia;
  ENDPROC

  PROC Approach(robtarget ToPoint\\robtarget Via)
    IF Present(Via) MoveJ Via, v500, z50, tGripper;
    MoveJ Offs(ToPoint,0,0,100), v500, z50, tGripper;
  ENDPROC

  PROC PickPart(robtarget pPart\\PERS wobjdata WObj\\robtarget Via)
    MoveTo pPart, v200, fine, tGripper \\WObj?WObj \\Via?Via;
  ENDPROC

  PROC MoveTo(robtarget ToPoint,speeddata Speed,zonedata Zone,PERS tooldata Tool\\PERS wobjdata WObj
              \\robtarget Via)
    IF Present(Via) THEN
      MoveJ Via, Speed, z50, Tool \\WObj?WObj;
    ENDIF
    MoveL ToPoint, Speed, Zone, Tool \\WObj?WObj;
    IF Present(WObj) MoveL Offs(ToPoint,0,0,50), Speed, z10, Tool \\WObj:=WObj;
  ENDPROC
ENDMODULE
"""


@pytest.mark.parametrize("newline", ["\n", "\r\n", "\r"])
def test_rapid_wrapper_parameters_are_resolved_at_their_calls(tmp_path, newline):
    """Every call's constant argument is corrected (ToPoint of five calls, one given by name; Via
    of the one call that gives it: the calls that leave it out do not run the MoveJ, the ones
    that pass it on with \\Via?Via from a caller that lacks it neither), pTable in the work object
    the call passes on with \\WObj?WObj, the others in wobj0; the motion under IF Present(WObj)
    reaches pTable only; every motion corrected (main named
    ToPoint and Via 'no call in these files gives', and ToPoint:=pPlace 'not a robtarget this
    filter can follow')."""
    path = tmp_path / "MainModule.mod"
    path.write_bytes(WRAPPER.replace("\n", newline).encode("latin-1"))  # as the controller saves it
    res = filter_program(path, perturbed(ABB, 7), ABB)
    status = _accounted(res, [path])
    assert status == {k: ("corrected", "") for k in (21, 22, 32, 34, 35)}
    rows = {r["name"].lower(): r for r in res.rows}
    assert set(rows) == {"papproach", "ppick", "pplace", "pvia", "ptable"}
    assert all(r["filtered"] for r in rows.values())
    assert rows["ptable"]["frame"] == "wtable" and rows["ppick"]["frame"] == "wobj0"
    assert res.motions[4].target == "pTable"  # the guarded motion runs for the call that gives WObj only


def test_rapid_wrapper_argument_not_declared_is_named_with_the_true_reason(tmp_path):
    """A call's argument declared in none of the files given (by position or by name) names the
    wrapper's motion 'not declared' (the other calls' targets are still corrected); a Via no
    call gives names the MoveJ with that reason."""
    path = tmp_path / "MainModule.mod"
    path.write_text(WRAPPER.replace("ToPoint:=pPlace", "ToPoint:=pService")
                    .replace("tGripper \\Via:=pVia;", "tGripper;").replace("pPlace\\Via:=pVia", "pPlace"))
    res = filter_program(path, perturbed(ABB, 7), ABB)
    status = _accounted(res, [path])
    assert status[34][0] == "named" and "robtarget pService is not declared in these files" in status[34][1]
    assert "not a robtarget this filter can follow" not in status[34][1]
    assert status[32][0] == "named"
    assert "Via: the motion needs an optional parameter of routine moveto that no call" in status[32][1]
    assert {r["name"].lower() for r in res.rows} == {"papproach", "ppick", "ptable", "pplace"}
    assert status[21][0] == "named" and "Via: the motion needs an optional parameter of routine approach" \
        in status[21][1]
    assert res.motions[3].needs == "robtarget pService"


# ----------------------------------------------------------------------------- identical tool data
STATION = f"""MODULE Station
  PERS tooldata tGun1:=[TRUE,[[0,0,250],[1,0,0,0]],[3,[0,0,100],[1,0,0,0],0,0,0]];
  PERS tooldata tGun2:=[TRUE,[[0,0,250],[1,0,0,0]],[3,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wFixture:=[FALSE,TRUE,"",[[300,0,200],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  PERS wobjdata wFixtureB:=[FALSE,TRUE,"",[[300,0,200],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p10:=[[1000,50,580],[0,0,1,0],[0,0,0,0],{EAX}];
  CONST robtarget p20:=[[1050,50,580],[0,0,1,0],[0,0,0,0],{EAX}];
  PROC main()
    MoveJ p10, v500, z10, tGun1 \\WObj:=wFixture;
    MoveL p20, v100, fine, tGun1 \\WObj:=wFixture;
    MoveL p10, v100, fine, tGun2 \\WObj:=wFixtureB;
    MoveL p20, v100, fine, tGun2 \\WObj:=wFixture;
  ENDPROC
ENDMODULE
"""


def test_rapid_target_with_identical_tool_and_wobj_data_is_one_target(tmp_path):
    """Two names, the same data: p10/p20 are corrected once, exactly as with one name each."""
    calibrated = perturbed(ABB, 7)
    path = tmp_path / "Station.mod"
    path.write_text(STATION)
    res = filter_program(path, calibrated, ABB)
    assert set(_accounted(res, [path]).values()) == {("corrected", "")}
    one = tmp_path / "One.mod"
    one.write_text(STATION.replace("tGun2 \\WObj:=wFixtureB", "tGun1 \\WObj:=wFixture")
                   .replace("tGun2 \\WObj", "tGun1 \\WObj"))
    ref = filter_program(one, calibrated, ABB)
    targets = lambda b: [ln for ln in b.decode().splitlines() if "robtarget" in ln]  # noqa: E731
    assert targets(res.outputs[path]) == targets(ref.outputs[one]) != targets(path.read_bytes())


def test_rapid_target_with_really_different_tools_stays_named(tmp_path):
    """Different data (10 mm longer): one corrected target cannot serve both; the same data but
    one tool changed at run time: the tool's motions name where, the others that the target is
    also moved to with it; every motion to it named."""
    for text, said in ((STATION.replace("tGun2:=[TRUE,[[0,0,250]", "tGun2:=[TRUE,[[0,0,260]"),
                        "one corrected target cannot serve both"),
                       (STATION.replace("  PROC main()\n",
                                        "  PROC main()\n    tGun2.tframe.trans.z := 260;\n"),
                        "tGun2 is assigned at run time (Station.mod:")):
        path = tmp_path / "Station.mod"
        path.write_text(text)
        res = filter_program(path, perturbed(ABB, 7), ABB)
        status = _accounted(res, [path])
        assert len(status) == 4 and all(s == "named" and said in why for s, why in status.values())


# ----------------------------------------------------------------------------- placeholders
CALIB_SYS = f"""MODULE CalibUser(SYSMODULE)
  CONST speeddata CALIB_SPEED:=v100;
  VAR robtarget pTemp:=[[0,0,0],[0,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  VAR robtarget calibPose1:=[[0,0,0],[0,0,0,0],[0,0,0,0],[0,0,0,0,0,0]];
  VAR robtarget calibPoses{{2}}:=[[[1200,0,900],[0,0,1,0],[0,0,0,0],{EAX}],
                                 [[0,0,0],[0,0,0,0],[0,0,0,0],{EAX}]];
  CONST robtarget pHome:=[[1200,0,1100],[0,0,1,0],[0,0,0,0],{EAX}];
  CONST robtarget pStart:=[[1200,100,900],[0,0,1,0],[0,0,0,0],{EAX}];
  PROC main()
    MoveJ pHome, v500, z10, tool0;
    MoveL pStart, v200, fine, tool0;
    pTemp := CRobT(\\Tool:=tool0);
    MoveL Offs(pTemp,0,0,50), v100, fine, tool0;
    MoveL calibPose1, CALIB_SPEED, fine, tool0;
    MoveL calibPoses{{1}}, CALIB_SPEED, fine, tool0;
    MoveL calibPoses{{2}}, CALIB_SPEED, fine, tool0;
    FOR i FROM 1 TO 2 DO
      MoveL calibPoses{{i}}, CALIB_SPEED, fine, tool0;
    ENDFOR
  ENDPROC
ENDMODULE
"""


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_rapid_placeholder_robtarget_is_named_and_the_module_filtered(tmp_path, newline):
    """The module is read (main refused it whole: 'a quaternion is not normalised'); the taught
    targets are corrected, the placeholder assigned at run time is named by that assignment, the
    ones no assignment fills are named as placeholders; their bytes are unchanged."""
    path = tmp_path / "CalibUser.sys"
    path.write_bytes(CALIB_SYS.replace("\n", newline).encode())
    res = filter_program(path, perturbed(ABB, 7), ABB)
    status = _accounted(res, [path])
    assert [status[k][0] for k in (10, 11, 15)] == ["corrected"] * 3
    assert status[13][0] == "named" and "computed at run time by CRobT()" in status[13][1]
    for line, name in ((14, "calibPose1"), (16, "calibPoses{2}")):
        assert status[line][0] == "named"
        assert f"{name} is a placeholder" in status[line][1] and "assigns at run time" in status[line][1]
        assert "no assignment in these files gives it a value" in status[line][1]
    assert status[18][0] == "named" and "calibPoses{...} is a placeholder" in status[18][1]  # {i}: either
    assert any("robtarget pTemp holds the quaternion [0,0,0,0]" in w for w in res.warnings)
    assert any("1 of the 2 elements of robtarget calibPoses (calibPoses{2} ...) hold" in w
               for w in res.warnings)
    out = res.outputs[path].decode().replace(newline, "\n")
    assert "VAR robtarget pTemp:=[[0,0,0],[0,0,0,0],[0,0,0,0]" in out
    assert "[[0,0,0],[0,0,0,0],[0,0,0,0],[9E9" in out.split("calibPoses{2}:=")[1]


# ----------------------------------------------------------------------------- KRL CONST positions
def _e6pos(robot, q, e6: bool) -> str:
    v = frame_numbers(robot.fk(q[None]))[0]  # mm, deg
    s, t = KUKAConfig().encode(robot, q[None])[0]
    tail = ",E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0" if e6 else ""
    return (f"{{X {v[0]:.3f},Y {v[1]:.3f},Z {v[2]:.3f},A {v[3]:.4f},B {v[4]:.4f},C {v[5]:.4f},"
            f"S {s},T {t}{tail}}}")


def test_krl_const_positions_in_the_dat_are_read(tmp_path):
    """DECL CONST E6POS, DECL CONST POS, CONST POS and DECL GLOBAL CONST E6POS (as WorkVisual and
    hand-written .dat files declare fixed positions) are read and corrected (main: 'not declared')."""
    q = np.deg2rad([[25, -85, 95, 35, 45, -40], [-25, -70, 110, -40, -35, 60], [30, -95, 85, 60, 55, 40],
                    [-30, -60, 100, -100, 25, 150], [20, -80, 100, 40, 50, 30]])
    decl = ["DECL CONST E6POS P_APPROACH", "DECL CONST POS P_PICK", "CONST POS P_TABLE",
            "DECL GLOBAL CONST E6POS XP_GLOB", "GLOBAL CONST E6POS XP_G2"]
    src = ["&ACCESS RVP", "DEF cell( )", ";FOLD INI", "  BAS(#INITMOV,0 )", ";ENDFOLD (INI)",
           "  $TOOL = TOOL_DATA[1]", "  $BASE = BASE_DATA[1]", "  PTP P_APPROACH", "  LIN P_PICK",
           "  LIN P_TABLE", "  LIN XP_GLOB", "  LIN XP_G2", "END", ""]
    dat = ["&ACCESS RVP", "DEFDAT cell",
           *[f"{d}={_e6pos(KUKA, q[k], 'E6POS' in d)}" for k, d in enumerate(decl)], "ENDDAT", ""]
    paths = [tmp_path / "cell.src", tmp_path / "cell.dat"]
    paths[0].write_text("\r\n".join(src))
    paths[1].write_text("\r\n".join(dat))
    res = filter_program(paths, perturbed(KUKA, 7), KUKA, tools={"1": "0,0,0,0,0,0"},
                         frames={"1": "0,0,0,0,0,0"})
    status = _accounted(res, paths)
    assert status == {k: ("corrected", "") for k in (8, 9, 10, 11, 12)}
    assert {r["name"] for r in res.rows} == {"P_APPROACH", "P_PICK", "P_TABLE", "XP_GLOB", "XP_G2"}
    assert res.outputs[paths[1]] != paths[1].read_bytes()


def test_rapid_placeholder_tool_and_wobj_name_their_motions(tmp_path):
    """A tooldata / wobjdata holding the quaternion [0,0,0,0] (a camera tool or a found work object
    the program measures at run time) names the motions that use it; the rest is filtered."""
    path = tmp_path / "Cam.mod"
    path.write_text(f"""MODULE Cam
  PERS tooldata tCam:=[TRUE,[[0,0,0],[0,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];
  PERS wobjdata wFound:=[FALSE,TRUE,"",[[0,0,0],[0,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget pHome:=[[1200,0,1100],[0,0,1,0],[0,0,0,0],{EAX}];
  CONST robtarget pCam:=[[1200,0,1000],[0,0,1,0],[0,0,0,0],{EAX}];
  CONST robtarget pA:=[[100,0,100],[0,0,1,0],[0,0,0,0],{EAX}];
  PROC main()
    MoveJ pHome, v500, z10, tool0;
    MoveL pCam, v500, z10, tCam;
    MoveL pA, v500, z10, tool0 \\WObj:=wFound;
  ENDPROC
ENDMODULE
""")
    res = filter_program(path, perturbed(ABB, 7), ABB)
    status = _accounted(res, [path])
    assert status[8] == ("corrected", "")
    assert "tooldata tCam holds the quaternion [0,0,0,0]" in status[9][1]
    assert "wobjdata wFound holds the quaternion [0,0,0,0]" in status[10][1]


def test_rapid_declared_copies_of_wobj0_and_tool0_are_them(tmp_path):
    """A work object declared with wobj0's own data (RobotStudio's wobj1 / DefaultFrame) and a
    tooldata equal to tool0's are the built-in ones: a target used with both is corrected once."""
    path = tmp_path / "Copies.mod"
    path.write_text(f"""MODULE Copies
  TASK PERS wobjdata DefaultFrame:=[FALSE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  PERS tooldata tFlange:=[TRUE,[[0,0,0],[1,0,0,0]],[0.001,[0,0,0.001],[1,0,0,0],0,0,0]];
  CONST robtarget pHome:=[[1200,0,1100],[0,0,1,0],[0,0,0,0],{EAX}];
  PROC main()
    MoveJ pHome, v500, z10, tool0;
    MoveL pHome, v500, fine, tFlange \\WObj:=DefaultFrame;
  ENDPROC
ENDMODULE
""")
    res = filter_program(path, perturbed(ABB, 7), ABB)
    assert set(_accounted(res, [path]).values()) == {("corrected", "")}
    assert [(r["tool"], r["frame"]) for r in res.rows] == [("tool0", "wobj0")]
