"""Staubli VAL3 applications (tests/data/programs/val3/): pointRx data with their frame and tool
chains, movej / movel / movec to points, array elements, appro and compose with constant trsf,
run-time points named per motion; only the numbers of the .dtx change (an absent coordinate is
added), byte for byte otherwise; the filtered points reach the intended poses."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from val3_tools import reached_before_after

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.kinematics.transforms import matrix_to_rotvec
from robocal.programs import filter_program
from robocal.programs.dialects.val3.reader import Val3Dialect, _read_data, application_files
from robocal.programs.registry import dialect_for
from robocal.programs.source import NUMBER_RE, ProgramText

APP = Path(__file__).parent / "data" / "programs" / "val3" / "pick_place"
NOMINAL = rc.Robot.from_catalog("staubli_tx2_140")
CALIBRATED = perturbed(NOMINAL, 7)
# motion (file:line) -> named reason pattern; the rest are corrected (hand count: 9 + 5; 1 joint move)
NAMED = {("start.pgx", 24): r"pOld\.trsf\.z is assigned in the program at run time",
         ("start.pgx", 27): r"pCam is received at run time \(sioGet\)",
         ("start.pgx", 29): r"l_pTmp is a local of start \(pointRx\): set at run time",
         ("start.pgx", 30): r"appro\(\.\.\.\) with an unknown trsf l_trOff",
         ("start.pgx", 31): r"computed at run time by here\(\)"}
PICKS = "pPick[0], pPick[1], pPick[2]"  # pPick[l_i] in a loop: every element
CORRECTED = {("start.pgx", 11): "pApproach[0]", ("start.pgx", 14): PICKS, ("start.pgx", 15): PICKS,
             ("start.pgx", 16): PICKS, ("start.pgx", 18): "pPlace[0]", ("start.pgx", 19): "pPlace[0]",
             ("start.pgx", 20): "pPlace[1], pPlace[0]", ("start.pgx", 21): "pPick[0]",
             ("pickPart.pgx", 8): PICKS}  # x_pPart: call pickPart(pPick[l_i])


def _app(tmp_path) -> Path:
    folder = tmp_path / "pick_place"
    shutil.copytree(APP, folder)
    return folder


def _outside_numbers(data: bytes) -> str:
    """The text with every number masked and coordinate attributes dropped (an absent coordinate
    may be added)."""
    text = re.sub(NUMBER_RE.pattern, "#", data.decode("utf-8"))
    return re.sub(r' (?:x|y|z|rx|ry|rz)="#"', "", text)


def test_every_motion_is_corrected_or_named(tmp_path):
    folder = _app(tmp_path)
    res = filter_program([folder], CALIBRATED, NOMINAL)
    assert sorted(r["name"] for r in res.rows) == ["pApproach[0]", "pPick[0]", "pPick[1]", "pPick[2]",
                                                   "pPlace[0]", "pPlace[1]"]
    counts = json.loads(res.table_json())["summary"]["motions"]
    hand = sum(len(re.findall(r"\bmove[jlc]\(", p.read_text())) for p in folder.glob("*.pgx"))
    assert counts == {"total": 14, "corrected": 9, "named": 5} and counts["total"] == hand - 1  # movej(jHome)
    for r in res.motions:
        key = (r.file, r.line)
        if r.status == "named":
            assert re.search(NAMED[key], r.reason), (key, r.reason)
        else:
            assert set(r.target.split(", ")) >= set(CORRECTED[key].split(", ")), (key, r.target)
    assert {(r.file, r.line) for r in res.motions} == set(NAMED) | set(CORRECTED)
    for p in application_files(folder):
        before = p.read_bytes()
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(before)
        assert res.outputs[p].count(b"\r\n") == before.count(b"\r\n") and p.read_bytes() == before
    dtx = res.outputs[folder / "pick_place.dtx"]
    assert dtx.startswith(b"\xef\xbb\xbf<?xml") and all(res.outputs[p] == p.read_bytes()
                                                       for p in folder.glob("*.pgx"))
    # an absent coordinate the correction makes non-zero is added after the one before it
    number = rb'="[-\d.]+"'
    assert re.search(rb'<Value key="0" x' + number + b" y" + number + b" z" + number + b" rx" + number
                     + b" ry" + number + b" rz=", dtx)


def test_identity_calibration_changes_no_byte(tmp_path):
    folder = _app(tmp_path)
    res = filter_program([folder], NOMINAL, NOMINAL)
    assert all(res.outputs[p] == p.read_bytes() for p in application_files(folder))


def test_filtered_points_reach_the_intended_poses(tmp_path):
    """Frames chained fConveyor -> fPallet -> world, the tool on the flange: the controller's IK of
    the filtered points (in their configuration) on the calibrated robot lands on the poses the
    application meant."""
    folder = _app(tmp_path)
    reached, before, X0 = reached_before_after(folder, tmp_path / "out", CALIBRATED, NOMINAL)
    err = np.linalg.norm(reached[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    turn = np.rad2deg(np.linalg.norm(matrix_to_rotvec(reached[:, :3, :3] @ np.swapaxes(X0[:, :3, :3], 1, 2)),
                                     axis=1))
    err0 = np.linalg.norm(before[:, :3, 3] - X0[:, :3, 3], axis=1) * 1e3
    assert err.max() < 0.003 and turn.max() < 0.0005 and err0.min() > 0.5


def test_rotation_notation_round_trips():
    """rx, ry, rz: R = Rx(rx) Ry(ry) Rz(rz) about the moving axes; read back nearest the old numbers."""
    d = Val3Dialect()
    rng = np.random.default_rng(4)
    v = np.column_stack([rng.uniform(-500, 500, (50, 3)), rng.uniform(-179, 179, (50, 3))])
    T = d.to_pose(v)
    R = np.array([Rotation.from_euler("x", a, degrees=True).as_matrix() @ Rotation.from_euler(
        "y", b, degrees=True).as_matrix() @ Rotation.from_euler("z", c, degrees=True).as_matrix()
        for a, b, c in v[:, 3:]])
    assert np.allclose(T[:, :3, :3], R, atol=1e-12)
    assert np.allclose(d.from_pose(T, v), v, atol=1e-9)


def test_older_cs8_layout_and_tool_chain(tmp_path):
    """Coordinates on an element inside <Value> and the type name point (older VAL3), a tool on a
    tool, a point in world, a user type beside them: read, filtered, unchanged by an identity
    calibration."""
    q = np.deg2rad([[10, 20, 80, 5, 60, 0]])
    tool = Val3Dialect().to_pose(np.array([[0, 0, 100, 0, 0, 0]]))[0] @ \
        Val3Dialect().to_pose(np.array([[0, 20, 60, 0, 30, 0]]))[0]
    v = Val3Dialect().from_pose(NOMINAL.fk(q) @ tool, np.zeros((1, 6)))[0]
    coords = " ".join(f'{k}="{x:.3f}"' for k, x in zip(("x", "y", "z", "rx", "ry", "rz"), v, strict=True))
    dtx = f"""<?xml version="1.0" encoding="utf-8" ?>
<Database xmlns="http://www.staubli.com/robotics/VAL3/Data/1">
  <Datas>
    <Data name="tFlange" type="tool" size="1"><Value key="0"><tool z="100" fatherId="flange[0]" />
      </Value></Data>
    <Data name="tTip" type="tool" size="1"><Value key="0">
      <tool y="20" z="60" ry="30" fatherId="tFlange[0]" /></Value></Data>
    <Data name="sPart" type="tPartInfo" size="1"><Value><Field name="nId" value="3" /></Value></Data>
    <Data name="pA" type="point" size="1"><Value key="0"><point {coords} fatherId="world[0]" />
      <config shoulder="lefty" elbow="epositive" wrist="wpositive" /></Value></Data>
  </Datas>
</Database>
"""
    pgx = """<?xml version="1.0" encoding="utf-8" ?>
<Programs xmlns="http://www.staubli.com/robotics/VAL3/Program/1"><Program name="start"><Code><![CDATA[begin
  movel(pA, tTip, mNomSpeed)
end]]></Code></Program></Programs>
"""
    (tmp_path / "old.dtx").write_text(dtx)
    (tmp_path / "start.pgx").write_text(pgx)
    files = [tmp_path / "old.dtx", tmp_path / "start.pgx"]
    assert dialect_for(files).name == "Staubli VAL3"
    res = filter_program(files, CALIBRATED, NOMINAL)
    assert [(r["name"], r["tool"], r["frame"]) for r in res.rows] == [("pA[0]", "tTip[0]", "world[0]")]
    assert res.motions[0].status == "corrected"
    assert _outside_numbers(res.outputs[files[0]]) == _outside_numbers(files[0].read_bytes())
    assert filter_program(files, NOMINAL, NOMINAL).outputs[files[0]] == files[0].read_bytes()


def test_undeclared_frame_and_malformed_number(tmp_path):
    folder = _app(tmp_path)
    dtx = folder / "pick_place.dtx"
    text = dtx.read_bytes()
    dtx.write_bytes(text.replace(b'<Data name="fConveyor"', b'<Data name="fOther"'))
    res = filter_program([folder], CALIBRATED, NOMINAL)
    named = [r for r in res.motions if "fConveyor[0] is not declared" in r.reason]
    assert [r.line for r in named] == [18, 19, 20]
    dtx.write_bytes(text.replace(b'x="294.445"', b'x="29a4.445"'))
    with pytest.raises(DataError, match=r'pick_place.dtx:\d+: pPick\[0\]: x="29a4.445" is not a number'):
        filter_program([folder], CALIBRATED, NOMINAL)


def test_cli_filters_an_application_folder(tmp_path, capsys):
    folder = _app(tmp_path)
    cal = tmp_path / "cal.yaml"
    CALIBRATED.save(cal)
    out = tmp_path / "filtered"
    out.mkdir()
    assert main(["filter", str(folder), "--calibrated", str(cal), "--nominal", "staubli_tx2_140", "-o",
                 str(out)]) == 0
    text = capsys.readouterr().out
    assert "14 motions: 9 corrected, 5 not corrected (each named)" in text
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [p.name for p in application_files(folder)] + ["pickPart.targets.csv", "pickPart.targets.json"])
    marked = [p for p in out.iterdir() if "<!-- robocal " in p.read_text(encoding="utf-8-sig")]
    assert marked and all(p.suffix in (".dtx", ".pgx", ".pjx") for p in marked)
    again = tmp_path / "again"
    again.mkdir()
    assert main(["filter", str(out / next(p.name for p in marked)), "--calibrated", str(cal), "--nominal",
                 "staubli_tx2_140", "-o", str(again)]) == 2
    assert "already filtered" in capsys.readouterr().err


def test_poses_writes_an_application_that_visits_the_planned_joints(tmp_path):
    """poses --val3 FOLDER: jointRx data read back by the VAL3 reader equal the planned joints, the
    start program visits them in order; no Cartesian motion (nothing to filter)."""
    folder = tmp_path / "campaign"
    assert main(["--quiet", "poses", "--robot", "staubli_tx2_140", "-n", "10", "--candidates", "600",
                 "--starts", "1", "--smr-mm", "20,-30,60", "-o", str(tmp_path / "poses.csv"), "--val3",
                 str(folder), "--speed-percent", "15", "--settle-s", "0.5"]) == 0
    planned = np.rad2deg(rc.data.measurements.read_joints(tmp_path / "poses.csv"))
    files = application_files(folder)
    assert sorted(p.name for p in files) == ["MeasurePose.pgx", "campaign.dtx", "campaign.pjx", "start.pgx",
                                             "stop.pgx"]
    data = _read_data(ProgramText(folder / "campaign.dtx"))
    joints = np.rad2deg([data[f"jPose[{k}]"].joints for k in range(10)])
    np.testing.assert_allclose(joints, planned, atol=1e-9)
    start = (folder / "start.pgx").read_text()
    assert re.findall(r"movej\(jPose\[(\d+)\], flange, mCampaign\)", start) == [str(k) for k in range(10)]
    assert re.findall(r"call MeasurePose\((\d+)\)", start) == [str(k) for k in range(1, 11)]
    assert 'vel="15"' in (folder / "campaign.dtx").read_text() and "delay(0.5)" in start
    assert (folder / "start.pgx").read_bytes().count(b"\r\n") == start.count("\n")
    res = filter_program([folder], NOMINAL, NOMINAL)
    assert res.rows == [] and res.motions == []


def test_a_parameter_no_call_gives_is_named(tmp_path):
    """A point parameter is followed to every call's argument; a program nobody calls names it."""
    folder = _app(tmp_path)
    text = (folder / "pickPart.pgx").read_bytes()
    (folder / "placePart.pgx").write_bytes(text.replace(b'name="pickPart"', b'name="placePart"'))
    res = filter_program([folder], CALIBRATED, NOMINAL)  # not in the project: not read, said so
    assert not [r for r in res.motions if r.file == "placePart.pgx"]
    assert any("placePart.pgx is not in the project (pick_place.pjx)" in w for w in res.warnings)
    pjx = folder / "pick_place.pjx"
    listed = b'<Program file="pickPart.pgx" />'
    pjx.write_bytes(pjx.read_bytes().replace(listed, listed + b'<Program file="placePart.pgx" />'))
    res = filter_program([folder], CALIBRATED, NOMINAL)
    named = [r for r in res.motions if r.file == "placePart.pgx"]
    why = "x_pPart is a parameter of placePart that no call in these files gives"
    assert [r.reason for r in named] == [why]
    assert [r.status for r in res.motions if r.file == "pickPart.pgx"] == ["corrected"]
