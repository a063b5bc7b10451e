"""VAL3 applications as real cells write them (in the style of public applications: a CS8 s6.8
assembly cell, s7 chess and ROS-server applications): the s6.x XML layout (programList / dataList,
code as XML text), motions counted as a hand counts them (joint moves to joints however declared
are no Cartesian motion; files the project does not list are not loaded), every motion corrected
or named with a true reason, only the pose numbers changed; --tool / --frame read as the code
names the data and compared with the .dtx's own."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from val3_tools import reached_before_after

import robocal as rc
from robocal.cli import main
from robocal.data.simulate import perturbed
from robocal.kinematics.transforms import invert_transform
from robocal.programs import filter_program
from robocal.programs.dialects.val3.reader import Val3Dialect, application_files
from robocal.programs.source import NUMBER_RE

NOMINAL = rc.Robot.from_catalog("staubli_tx2_140")
CALIBRATED = perturbed(NOMINAL, 7)
D = Val3Dialect()
Q = np.deg2rad([[10, 20, 80, 5, 60, 0], [-15, 30, 70, 0, 50, 20], [5, 10, 95, -10, 65, -30],
                [20, 25, 85, 15, 55, 10], [-5, 35, 75, -5, 60, 40]])
TOOL_GRIP = [30, 30, 170, -90, 44, -90]
TABLE = [600, -100, 50, 0, 0, 15]
PALLET = [20, 0, 5, 0, 0, 0]


def _coords(values, names=("x", "y", "z", "rx", "ry", "rz"), skip=()) -> str:
    return " ".join(f'{k}="{v:.3f}"' for k, v in zip(names, values, strict=True) if k not in skip)


def _in_frame(q, frame_chain) -> np.ndarray:
    """The xyz/rx,ry,rz of the TCP (tool tGrip) at joints q in the frame chain (world first)."""
    F = np.eye(4)
    for f in frame_chain:
        F = F @ D.to_pose(np.array([f], float))[0]
    T = invert_transform(F) @ NOMINAL.fk(q) @ D.to_pose(np.array([TOOL_GRIP], float))[0]
    return D.from_pose(T.reshape(1, 4, 4), np.zeros((1, 6)))[0]


def _s6_point(name, values, father, skip=()):
    vals = "".join(f"""
      <valuePoint index="{k}">
        <tpValue {_coords(v, skip=skip)} />
        <cpValue shoulder="ssame" elbow="esame" wrist="wsame" />
      </valuePoint>""" for k, v in enumerate(values))
    return f"""
    <point name="{name}" public="false">
      <pFather alias="" name="{father}" fatherIndex="0" />{vals}
    </point>"""


def _s6_application(folder: Path) -> Path:
    """An s6.8 application: tools on tools, frames on frames, points in them, a point array with a
    run-time index, appro by constant and by run-time amounts, a program parameter, XML entities
    in the code, a motion in a comment and one in a string, and a stale program the project does
    not list."""
    folder.mkdir()
    p1 = _in_frame(Q[0], [])
    p2 = _in_frame(Q[1], [TABLE, PALLET])
    p3 = _in_frame(Q[2], [TABLE])
    arr = [_in_frame(Q[3], [TABLE]), _in_frame(Q[4], [TABLE])]
    points = (_s6_point("p1", [p1], "world") + _s6_point("p2", [p2], "fPallet", skip=("y", "ry"))
              + _s6_point("p3", [p3], "fTable") + _s6_point("pArr", arr, "fTable"))
    dtx = f"""\ufeff<?xml version="1.0" encoding="utf-8"?>
<dataList xmlns="DataNameSpace">
  <aioSection />
  <frameSection>
    <frame name="world" public="false">
      <fFather alias="" name="" fatherIndex="0" />
      <valueFrame index="0">
        <tfValue x="0" y="0" z="0" rx="0" ry="0" rz="0" />
      </valueFrame>
    </frame>
    <frame name="fTable" public="false">
      <fFather alias="" name="world" fatherIndex="0" />
      <valueFrame index="0">
        <tfValue {_coords(TABLE)} />
      </valueFrame>
    </frame>
    <frame name="fPallet" public="false">
      <fFather alias="" name="fTable" fatherIndex="0" />
      <valueFrame index="0">
        <tfValue {_coords(PALLET)} />
      </valueFrame>
    </frame>
  </frameSection>
  <jointSection>
    <joint name="jHome" public="false">
      <valueJoint index="0">
        <jointValue j1="0" j2="0" j3="90" j4="0" j5="45" j6="0" />
      </valueJoint>
    </joint>
  </jointSection>
  <numSection>
    <num name="nStep" public="false">
      <valueNum value="30" index="0" />
    </num>
  </numSection>
  <pointSection>{points}
  </pointSection>
  <toolSection>
    <tool name="flange" public="false">
      <tFather alias="" name="" fatherIndex="0" />
      <valueTool index="0">
        <ttValue x="0" y="0" z="0" rx="0" ry="0" rz="0" />
        <io alias="io" name="valve1" ioIndex="0" open="0" close="0" />
      </valueTool>
    </tool>
    <tool name="tGrip" public="false">
      <tFather alias="" name="flange" fatherIndex="0" />
      <valueTool index="0">
        <ttValue {_coords(TOOL_GRIP)} />
        <io alias="io" name="valve1" ioIndex="0" open="1" close="1" />
      </valueTool>
    </tool>
  </toolSection>
  <trsfSection />
</dataList>"""
    start = """\ufeff<?xml version="1.0" encoding="utf-8"?>
<programList xmlns="ProgramNameSpace">
  <program name="start" public="false">
    <description />
    <paramSection />
    <localSection>
      <local name="i" type="num" size="1" />
    </localSection>
    <source>
      <code>
begin
  movej(jHome, tGrip, mFast)
  movej(appro(p1,{0,0,-100,0,0,0}), tGrip, mFast)
  movel(p1, tGrip, mSlow)
  // movel(p1, tGrip, mSlow)
  putln(&quot;movel(p9, tGrip, mSlow)&quot;)
  for i=0 to 1
    movel(pArr[i], tGrip, mSlow)
    movel(appro(p3,{i*nStep,0,-50,0,0,0}), tGrip, mSlow)
  endFor
  if nStep &lt; 40 and nStep &gt; 0
    movec(p1, p2, tGrip, mSlow)
  endIf
  movej(herej(), tGrip, mFast)
  call place(p2)
end
            </code>
    </source>
  </program>
</programList>"""
    place = """\ufeff<?xml version="1.0" encoding="utf-8"?>
<programList xmlns="ProgramNameSpace">
  <program name="place" public="false">
    <description />
    <paramSection>
      <param name="x_pTarget" type="pointRx" byVal="false" />
    </paramSection>
    <localSection />
    <source>
      <code>begin
  movel(x_pTarget, tGrip, mSlow)
end
      </code>
    </source>
  </program>
</programList>"""
    pjx = """\ufeff<?xml version="1.0" encoding="utf-8"?>
<project xmlns="ProjectNameSpace">
  <parameters version="s6.8" stackSize="5000" millimeterUnit="true" />
  <programSection>
    <program file="start.pgx" />
    <program file="place.pgx" />
  </programSection>
  <dataSection>
    <data file="cell.dtx" />
  </dataSection>
</project>"""
    for name, text in (("cell.dtx", dtx), ("start.pgx", start), ("place.pgx", place), ("cell.pjx", pjx),
                       ("old.pgx", place.replace('name="place"', 'name="old"'))):
        (folder / name).write_bytes(text.replace("\n", "\r\n").encode("utf-8"))
    return folder


def _outside_numbers(data: bytes) -> str:
    text = re.sub(NUMBER_RE.pattern, "#", data.decode("utf-8-sig"))
    return re.sub(r' (?:x|y|z|rx|ry|rz)="#"', "", text)


def test_s6_application_read_counted_corrected(tmp_path):
    folder = _s6_application(tmp_path / "cell")
    res = filter_program([folder], CALIBRATED, NOMINAL)
    # hand count: start.pgx 5 Cartesian (movej appro p1, movel p1, movel pArr[i], movel appro p3, movec
    # p1 p2) + place.pgx 1; not motions: movej(jHome), movej(herej()), the comment, the string, old.pgx
    hand = {"total": 6, "corrected": 5, "named": 1}
    assert json.loads(res.table_json())["summary"]["motions"] == hand
    named = [(m.file, m.line, m.reason) for m in res.motions if m.status == "named"]
    assert len(named) == 1 and named[0][:2] == ("start.pgx", 19)
    assert named[0][2] == "appro(...) with a trsf computed at run time ({i*nStep,0,-50,0,0,0})"
    assert any("old.pgx is not in the project (cell.pjx)" in w for w in res.warnings)
    assert sorted(r["name"] for r in res.rows) == ["p1[0]", "p2[0]", "pArr[0]", "pArr[1]"]
    assert {r["frame"] for r in res.rows if r["name"] == "p2[0]"} == {"fPallet[0]"}
    for p in application_files(folder):
        before = p.read_bytes()
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(before), p.name
        assert res.outputs[p].count(b"\r\n") == before.count(b"\r\n")
    dtx = res.outputs[folder / "cell.dtx"].decode("utf-8-sig")
    # p2's absent y and ry are each added on its tpValue, named as what they are
    p2 = re.search(r'<point name="p2".*?<tpValue ([^/]*)/>', dtx, re.DOTALL).group(1)
    assert re.findall(r"(\w+)=", p2) == ["x", "y", "z", "rx", "ry", "rz"]
    assert all(res.outputs[p] == p.read_bytes() for p in folder.glob("*.pgx"))
    assert all(filter_program([folder], NOMINAL, NOMINAL).outputs[p] == p.read_bytes()
               for p in application_files(folder))


def test_s6_filtered_points_reach_the_intended_poses(tmp_path):
    folder = _s6_application(tmp_path / "cell")
    reached, before, X0 = reached_before_after(folder, tmp_path / "out", CALIBRATED, NOMINAL)
    err = np.linalg.norm(reached[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    err0 = np.linalg.norm(before[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    assert len(X0) == 4 and err.max() < 0.003 and err0.min() > 0.5


def test_s6_files_with_format_val3_are_read_not_refused(tmp_path, capsys):
    """The .pgx of s6.x matches URScript's signature too (movel( ...): --format val3 is never
    overridden, and the files are recognised as VAL3 by their root elements."""
    folder = _s6_application(tmp_path / "cell")
    cal = tmp_path / "cal.yaml"
    CALIBRATED.save(cal)
    files = [str(folder / n) for n in ("start.pgx", "place.pgx", "cell.dtx")]
    for extra in (["--format", "val3"], []):
        out = tmp_path / f"out{len(extra)}"
        out.mkdir()
        assert main(["filter", *files, *extra, "--calibrated", str(cal), "--nominal", "staubli_tx2_140",
                     "-o", str(out)]) == 0
        assert "6 motions: 5 corrected, 1 not corrected (each named)" in capsys.readouterr().out


def _s7(folder: Path, name: str, text: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text, encoding="utf-8")


S7_PGX = """<?xml version="1.0" encoding="utf-8"?>
<Programs xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3/Program/2">
  <Program name="{name}">{decl}
    <Code><![CDATA[begin
{code}
end]]></Code>
  </Program>
</Programs>
"""


def _s7_cell(usrapp: Path) -> Path:
    """An s7 application whose joint moves go to a jointRx with no values (<Data .../>), a local of
    type joint, herej() and a field of a user type declared on the controller disk (Disk://)."""
    app = usrapp / "chess"
    v = _coords(_in_frame(Q[0], []))
    _s7(app, "chess.dtx", f"""<?xml version="1.0" encoding="utf-8"?>
<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3/Data/2">
  <Datas>
    <Data name="jInitial" access="private" xsi:type="array" type="jointRx" size="1" />
    <Data name="tGrip" access="private" xsi:type="array" type="tool" size="1">
      <Value key="0" {_coords(TOOL_GRIP)} fatherId="flange[0]" />
    </Data>
    <Data name="pA" access="private" xsi:type="array" type="pointRx" size="1">
      <Value key="0" {v} shoulder="lefty" elbow="epositive" wrist="wpositive" fatherId="world[0]" />
    </Data>
  </Datas>
</Database>
""")
    _s7(app, "chess.pjx", """<?xml version="1.0" encoding="utf-8"?>
<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">
  <Parameters version="s7.9" stackSize="5000" millimeterUnit="true" />
  <Programs>
    <Program file="start.pgx" />
    <Program file="moveJoint.pgx" />
  </Programs>
  <Database>
    <Data file="chess.dtx" />
  </Database>
  <Libraries />
  <Types>
    <Type name="MoveCmd" path="Disk://libs/MoveCmd/MoveCmd.pjx" />
  </Types>
</Project>
""")
    locals_ = """
    <Locals>
      <Local name="l_cmd" type="MoveCmd" xsi:type="array" size="1" />
    </Locals>"""
    _s7(app, "start.pgx", S7_PGX.format(name="start", decl=locals_, code="""\
  movej(jInitial, tGrip, mNomSpeed)
  movel(pA, tGrip, mNomSpeed)
  nId = movej(l_cmd.jTarget, tGrip, l_cmd.mDesc)
  movel(l_cmd.pTarget, tGrip, mNomSpeed)
  movej(herej(), tGrip, mNomSpeed)
  call moveJoint(0, 10, 90, 0, 45, 0)"""))
    params = """
    <Parameters xmlns="http://www.staubli.com/robotics/VAL3/Param/1">
      <Parameter name="x_nJ1" type="num" xsi:type="element" />
    </Parameters>
    <Locals>
      <Local name="l_jJoint" type="joint" xsi:type="array" size="1" />
    </Locals>"""
    _s7(app, "moveJoint.pgx", S7_PGX.format(name="moveJoint", decl=params, code="""  l_jJoint.j1 = x_nJ1
  movej(l_jJoint, tGrip, mNomSpeed)"""))
    _s7(app, "Data_acqu.pgx", S7_PGX.format(name="Data_acqu", decl="", code="  movel(pA, tGrip, mNomSpeed)"))
    lib = usrapp / "libs" / "MoveCmd"
    _s7(lib, "MoveCmd.pjx", """<?xml version="1.0" encoding="utf-8"?>
<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">
  <Programs />
  <Database>
    <Data file="MoveCmd.dtx" />
  </Database>
</Project>
""")
    _s7(lib, "MoveCmd.dtx", """<?xml version="1.0" encoding="utf-8"?>
<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3/Data/2">
  <Datas>
    <Data name="mDesc" access="public" xsi:type="array" type="mdesc" size="1" />
    <Data name="jTarget" access="public" xsi:type="array" type="jointRx" size="1" />
    <Data name="pTarget" access="public" xsi:type="array" type="pointRx" size="1" />
  </Datas>
</Database>
""")
    return app


def test_joint_moves_are_no_cartesian_motion_however_the_joints_are_declared(tmp_path):
    app = _s7_cell(tmp_path / "usrapp")
    res = filter_program([app], CALIBRATED, NOMINAL)
    # hand count: movel(pA) and movel(l_cmd.pTarget); movej to jInitial (no values), to l_cmd.jTarget
    # (jointRx in MoveCmd.dtx), to herej() and to the joint local are joint moves; Data_acqu.pgx is
    # not in the project
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 2, "corrected": 1, "named": 1}
    named = next(m for m in res.motions if m.status == "named")
    assert named.line == 11 and named.reason == "l_cmd.pTarget is a field of l_cmd (MoveCmd): set at run time"
    # without the type's data on the disk the field is named for what it is, and counted
    (tmp_path / "usrapp" / "libs" / "MoveCmd" / "MoveCmd.pjx").unlink()
    res = filter_program([app], CALIBRATED, NOMINAL)
    reasons = [m.reason for m in res.motions if m.status == "named"]
    assert len(reasons) == 2 and all("whose type data are not in the files given" in r for r in reasons)


def test_tool_and_frame_options_name_the_data_as_the_code_does_and_are_compared(tmp_path):
    folder = _s6_application(tmp_path / "cell")
    grip = ",".join(str(v) for v in [30, 30, 172, -90, 44, -90])
    for name in ("tGrip", "tGrip[0]"):
        res = filter_program([folder], CALIBRATED, NOMINAL, tools={name: grip})
        assert any(w.startswith(f"--tool {name}=") and "differs from it by 2 mm" in w for w in res.warnings)
    base = filter_program([folder], CALIBRATED, NOMINAL)
    res = filter_program([folder], CALIBRATED, NOMINAL, tools={"tGrip": grip})
    assert [r["correction_mm"] for r in res.rows] != [r["correction_mm"] for r in base.rows]  # it is used
    table = ",".join(str(v) for v in [600, -100, 51, 0, 0, 15])
    res = filter_program([folder], CALIBRATED, NOMINAL, frames={"fTable": table})
    assert any(w.startswith(f"--frame fTable={table} replaces the program's own frame fTable")
               and "by 1 mm" in w for w in res.warnings)
    same = ",".join(str(v) for v in TABLE)
    assert not any("--frame" in w for w in filter_program([folder], CALIBRATED, NOMINAL,
                                                          frames={"fTable": same}).warnings)


@pytest.mark.parametrize("entity, char", [("&lt;", "<"), ("&quot;", '"'), ("&#34;", '"'), ("&#x3C;", "<")])
def test_s6_code_is_read_as_the_controller_reads_it(entity, char):
    from robocal.programs.dialects.val3.s6 import decoded
    text = f"if a{entity}b"
    assert decoded(text) == f"if a{char}" + " " * (len(entity) - 1) + "b"


def test_a_task_passes_its_arguments_and_library_data_are_named_for_what_they_are(tmp_path):
    folder = _s6_application(tmp_path / "cell")
    start = folder / "start.pgx"
    start.write_bytes(start.read_bytes().replace(
        b"  call place(p2)", b'  taskCreate "placing", 10, place(p2)\r\n  movel(lib:pDrop, tGrip, mSlow)\r\n'
                             b"  movel(p1, lib:tLong, mSlow)"))
    res = filter_program([folder], CALIBRATED, NOMINAL)
    # hand count: the 6 motions of the application, and 2 more to library data
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 8, "corrected": 5, "named": 3}
    reasons = {m.target: m.reason for m in res.motions if m.status == "named"}
    assert reasons["lib:pDrop"] == "lib:pDrop is data of library lib, not in these files"
    assert reasons["p1"] == "the tool lib:tLong is data of library lib, not in these files"
    assert [m.status for m in res.motions if m.file == "place.pgx"] == ["corrected"]


def test_appro_by_a_local_set_once_to_numbers_is_a_use_of_the_point(tmp_path):
    """A local trsf only ever set to a literal of numbers is a constant offset (the point is
    corrected); one whose field the code changes is a run-time amount (named, where it is set)."""
    folder = _s6_application(tmp_path / "cell")
    start = folder / "start.pgx"
    text = start.read_bytes().replace(b'<local name="i" type="num" size="1" />', (
        b'<local name="i" type="num" size="1" />\r\n      <local name="trOff" type="trsf" size="1" />\r\n'
        b'      <local name="trMove" type="trsf" size="1" />'))
    start.write_bytes(text.replace(b"  call place(p2)", (
        b"  trOff={0,0,-80,0,0,0}\r\n  movel(appro(p1,trOff), tGrip, mSlow)\r\n  trMove.z=nStep\r\n"
        b"  movel(appro(p1,trMove), tGrip, mSlow)\r\n  call place(p2)")))
    res = filter_program([folder], CALIBRATED, NOMINAL)
    # hand count: the 6 motions of the application and 2 more
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 8, "corrected": 6, "named": 2}
    why = next(m.reason for m in res.motions if m.target == "appro(p1,trMove)")
    line = start.read_bytes().split(b"\r\n").index(b"  trMove.z=nStep") + 1
    assert why == f"appro(...) with a run-time trsf (trMove is set at run time (start.pgx:{line}))"


def test_data_declared_without_values_are_at_their_defaults(tmp_path):
    """A frame or tool declared without values is the identity on world / flange (a point in it is
    corrected); a point without values is no taught target (named so, not 'not declared')."""
    app = _s7_cell(tmp_path / "usrapp")
    dtx = app / "chess.dtx"
    v = _coords(_in_frame(Q[1], []))
    dtx.write_text(dtx.read_text().replace("  </Datas>", f"""\
    <Data name="fPart" access="private" xsi:type="array" type="frame" size="2" />
    <Data name="pEmpty" access="private" xsi:type="array" type="pointRx" size="1" />
    <Data name="pB" access="private" xsi:type="array" type="pointRx" size="1">
      <Value key="0" {v} shoulder="lefty" elbow="epositive" wrist="wpositive" fatherId="fPart[1]" />
    </Data>
  </Datas>"""))
    start = app / "start.pgx"
    start.write_text(start.read_text().replace("  movel(pA, tGrip, mNomSpeed)", (
        "  movel(pA, tGrip, mNomSpeed)\n  movel(pB, tGrip, mNomSpeed)\n  movel(pEmpty, tGrip, mNomSpeed)")))
    res = filter_program([app], CALIBRATED, NOMINAL)
    # hand count: the 2 Cartesian motions of the cell, and 2 more
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 4, "corrected": 2, "named": 2}
    assert {r["name"]: r["frame"] for r in res.rows} == {"pA[0]": "world[0]", "pB[0]": "fPart[1]"}
    why = next(m.reason for m in res.motions if m.target == "pEmpty")
    assert why == "pEmpty[0] has no values in the .dtx (all 0): no taught target"


def test_a_tool_on_a_tool_the_code_changes_is_named_and_compose_in_world_is_constant(tmp_path):
    app = _s7_cell(tmp_path / "usrapp")
    dtx = app / "chess.dtx"
    dtx.write_text(dtx.read_text().replace("  </Datas>", """\
    <Data name="tTip" access="private" xsi:type="array" type="tool" size="1">
      <Value key="0" z="25" fatherId="tGrip[0]" />
    </Data>
  </Datas>"""))
    start = app / "start.pgx"
    start.write_text(start.read_text().replace("  movel(pA, tGrip, mNomSpeed)", (
        "  tGrip.trsf.z = 200\n  movel(pA, tGrip, mNomSpeed)\n  movel(pA, tTip, mNomSpeed)\n"
        "  movel(compose(pA, world, {0,0,10,0,0,0}), flange, mNomSpeed)")))
    res = filter_program([app], CALIBRATED, NOMINAL)
    # hand count: the cell's 2 Cartesian motions and 2 more; only the one with the flange is corrected
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 4, "corrected": 1, "named": 3}
    reasons = {(m.target, m.reason) for m in res.motions if m.status == "named"}
    set_at = "tGrip.trsf.z is assigned in the program at run time (start.pgx:9)"
    assert ("pA", f"the tool tGrip is changed at run time: {set_at}") in reasons
    assert ("pA", f"the tool tTip: its tool tGrip is changed at run time: {set_at}") in reasons
    assert [r["tool"] for r in res.rows] == ["flange[0]"]


def test_s6_files_without_their_namespace_are_read_the_same(tmp_path):
    folder = _s6_application(tmp_path / "cell")
    for p in folder.iterdir():
        p.write_bytes(re.sub(rb' xmlns="\w+NameSpace"', b"", p.read_bytes()))
    res = filter_program([folder], CALIBRATED, NOMINAL)
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 6, "corrected": 5, "named": 1}


def test_a_movej_to_a_librarys_joints_is_no_cartesian_motion(tmp_path):
    usrapp = tmp_path / "usrapp"
    app = _s7_cell(usrapp)
    pjx = app / "chess.pjx"
    pjx.write_text(pjx.read_text().replace("<Libraries />", (
        '<Libraries>\n    <Library alias="libPos" path="Disk://libs/Pos/Pos.pjx" />\n  </Libraries>')))
    _s7(usrapp / "libs" / "Pos", "Pos.pjx", '<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">'
        '<Database><Data file="Pos.dtx" /></Database></Project>\n')
    _s7(usrapp / "libs" / "Pos", "Pos.dtx", (
        '<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
        'xmlns="http://www.staubli.com/robotics/VAL3/Data/2"><Datas>\n'
        '<Data name="jSafe" access="public" xsi:type="array" type="jointRx" size="1" />\n'
        '<Data name="pDrop" access="public" xsi:type="array" type="pointRx" size="1" />\n'
        '</Datas></Database>\n'))
    start = app / "start.pgx"
    start.write_text(start.read_text().replace("  movel(pA, tGrip, mNomSpeed)", (
        "  movel(pA, tGrip, mNomSpeed)\n  movej(libPos:jSafe, tGrip, mNomSpeed)\n"
        "  movel(libPos:pDrop, tGrip, mNomSpeed)")))
    res = filter_program([app], CALIBRATED, NOMINAL)
    # hand count: the cell's 2 Cartesian motions and the one to the library's point
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 3, "corrected": 1, "named": 2}
    assert "libPos:pDrop is data of library libPos, not in these files" in {m.reason for m in res.motions}


def test_s7_code_written_as_xml_text_is_read(tmp_path):
    """A <Code> without CDATA (its text XML-escaped) is read as the controller reads it."""
    app = _s7_cell(tmp_path / "usrapp")
    start = app / "start.pgx"
    text = start.read_text()
    code = re.search(r"<!\[CDATA\[(.*?)\]\]>", text, re.DOTALL)
    extra = '  if nId &lt; 3\n    putln(&quot;movel(pA)&quot;)\n  endIf\n'
    escaped = code.group(1).replace("  movel(pA", extra + "  movel(pA")
    start.write_text(text[:code.start()] + escaped + text[code.end():])
    res = filter_program([app], CALIBRATED, NOMINAL)
    assert json.loads(res.table_json())["summary"]["motions"] == {"total": 2, "corrected": 1, "named": 1}
    assert filter_program([app], NOMINAL, NOMINAL).outputs[start] == start.read_bytes()
