"""Yaskawa INFORM and FANUC TP programs with a second motion group (issue 45): a station / group that
moves on its own leaves the arm's targets arm targets (corrected, one summary warning); a motion
coordinated with it (INFORM SMOV with a station, FANUC COORD) moves its target with the station's
plate: corrected with a cell whose positioner has that unit (the nominal controller then drives
the real cell to the intended point on the workpiece), else named; every motion accounted; only
pose numbers change. Jobs written in the styles of public cells (``///GROUP1 RB1,BS1`` /
``///GROUP2 ST1``, ``+MOVJ EC``, ``SMOVL ... +MOVJ EC``; ``DEFAULT_GROUP = 1,1,*,*,*``, GP1/GP2
position blocks, ``L P[n] ... COORD``), not copied from them."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
import robocal.programs.filter as filter_module
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.kinematics.transforms import invert_transform, make_transform
from robocal.programs import filter_program
from robocal.programs.dialects.fanuc.reader import FanucDialect
from robocal.programs.dialects.inform.reader import InformDialect
from robocal.programs.dialects.writing import program_poses
from robocal.programs.positioner import CoordinatedProgram, Station
from robocal.programs.simulate import execute
from robocal.programs.source import NUMBER_RE, ProgramText

INFORM_ARM = rc.Robot.from_catalog("yaskawa_gp25")
FANUC_ARM = rc.Robot.from_catalog("fanuc_lrmate200id")
TOOL = make_transform(np.eye(3)[None], np.array([[0.0, 0.0, 0.18]]))[0]  # a 180 mm torch
LANDS_MM = 0.003  # the file's resolution (3 decimals of mm, 4 of deg) seen at the TCP
# a tilt-and-turn positioner 1.3 m in front of the arm: tilt about the world x axis, turn 250 mm above
MOUNT = make_transform(Rotation.from_euler("y", 90, degrees=True).as_matrix()[None],
                       np.array([[1.3, 0, 0.5]]))[0]
POSITIONER = rc.Robot.from_mdh(alpha=[0, -90], a=[0, 0], theta=[0, 0], d=[0, 250], degrees=True,
                               length_unit="mm", base=MOUNT, limits=[[-90, 90], [-360, 360]])
E = np.array([[10.0, -30.0], [20.0, -30.0], [30.0, 15.0], [-45.0, 120.0]])  # deg
Q = np.deg2rad([[0, 10, -20, 0, -70, 0], [5, 15, -15, 10, -60, 5], [-5, 20, -10, -10, -65, -5],
                [10, 5, -25, 5, -75, 10]])


def _cell(monkeypatch, arm: rc.Robot, unit: str, axes=("E1", "E2"), calibrated_positioner=None) -> None:
    """Filter with a cell of ``arm`` and the positioner as ``unit`` (perturbed: the calibrated one)."""
    station = Station(unit, POSITIONER, calibrated_positioner or perturbed(POSITIONER, 3), tuple(axes))
    cell = CoordinatedProgram({unit: station})
    monkeypatch.setattr(filter_module, "cell_models", lambda c, n, arm=None: (c, n, cell))


def _outside_numbers(data: bytes) -> str:
    return re.sub(r" *" + NUMBER_RE.pattern, "#", data.decode("latin-1"))


def _written(res, paths: list[Path], folder: Path) -> list[Path]:
    folder.mkdir()
    out = []
    for p in paths:
        (folder / p.name).write_bytes(res.outputs[p])
        out.append(folder / p.name)
    return out


# ----------------------------------------------------------------------------- INFORM
def _inform_job(folder: Path, moves: list[str], *, groups=("RB1", "ST1"), station="ANGLE", var=None) -> Path:
    """A job with the arm's positions C0000k at joints Q[k] (ROBOT frame, tool 1) and the station's
    EC0000k at E[k] (``station``: ANGLE in deg, PULSE in pulses), ``moves`` as its instructions."""
    d = InformDialect()
    P, cfg = program_poses(d, INFORM_ARM, Q, TOOL, np.eye(4))
    v = d.from_pose(P, np.zeros((len(Q), 6)))
    pos = []
    for k in range(len(Q)):
        pos += [f"///RCONF {d.scheme.text(cfg[k])},0,0",
                f"C{k:05d}=" + ",".join([f"{x:.3f}" for x in v[k, :3]] + [f"{x:.4f}" for x in v[k, 3:]])]
    ec = [f"EC{k:05d}=" + ",".join(f"{x:.4f}" if station == "ANGLE" else str(int(x * 1000)) for x in E[k])
          for k in range(len(E))]
    heads = [f"///GROUP{k + 1} {g}" for k, g in enumerate(groups)]
    text = ["/JOB", "//NAME CELL", "//POS", f"///NPOS {len(Q)},0,{len(E)},0,0,0", "///TOOL 1",
            "///POSTYPE ROBOT", "///RECTAN", *pos, "///POSTYPE PULSE", f"///{station}", *ec, "//INST",
            "///DATE 2024/05/02 09:10", "///ATTR SC,RW", *heads, "NOP", *moves, "END", ""]
    path = folder / "CELL.JBI"
    path.write_bytes("\r\n".join(text).encode())
    return path


INFORM_TOOLS = {"1": "0,0,180,0,0,0"}


def test_inform_station_moving_on_its_own_leaves_arm_targets(tmp_path):
    """+MOVJ EC (a second group), BC of a robot on base axes, MOVJ P126 +MOVJ EX000 with P126 in VAR.DAT:
    each motion has its record and its robot target is corrected as an arm target; one summary
    warning; nothing outside the pose numbers changes."""
    moves = ["MOVJ C00000 VJ=25.00 +MOVJ EC00000 VJ=50.00", "MOVL C00001 V=100.0 +MOVJ EC00001",
             "MOVL C00002 V=100.0 PL=0", "MOVJ P126 VJ=25.00 +MOVJ EX000 VJ=20.00",
             "MOVL C00003 V=100.0 +MOVJ EX001"]
    job = _inform_job(tmp_path, moves, groups=("RB1", "ST1"))
    var = tmp_path / "VAR.DAT"
    d = InformDialect()
    v = d.from_pose(INFORM_ARM.fk(Q[:1]) @ TOOL, np.zeros((1, 6)))[0]
    form = d.scheme.text(d.scheme.encode(INFORM_ARM, Q[:1])[0])
    var.write_bytes("\r\n".join(["//P", "///TOOL 1", "///POSTYPE ROBOT", "///RECTAN",
                                 f"///RCONF {form},0,0", "P0126=" + ",".join(f"{x:.3f}" for x in v),
                                 "//EX", "///POSTYPE PULSE", "///PULSE", "EX0000=0,0", ""]).encode())
    res = filter_program([job, var], perturbed(INFORM_ARM, 7), INFORM_ARM, tools=INFORM_TOOLS)
    assert res.summary_dict()["motions"] == {"total": 5, "corrected": 5, "named": 0}
    assert [m.line for m in res.motions] == [28, 29, 30, 31, 32]
    said = [w for w in res.warnings if "external-axis values" in w]
    assert len(said) == 1 and said[0].startswith("4 target(s)"), res.warnings
    for p in (job, var):
        assert _outside_numbers(res.outputs[p]) == _outside_numbers(p.read_bytes())
    same = filter_program([job, var], INFORM_ARM, INFORM_ARM, tools=INFORM_TOOLS)
    assert all(same.outputs[p] == p.read_bytes() for p in (job, var))


def test_inform_coordinated_motions_without_a_cell_are_named(tmp_path):
    """SMOVL with a station: named, asking for the cell file; a conveyor SMOVL (CV#) keeps its reason;
    an SMOVL without the station's position and one whose position is in pulses are named with why."""
    moves = ["SMOVL C00000 V=100.0 +MOVJ EC00000", "SMOVL C00001 V=100.0 CV#(1) CTP=0.000",
             "SMOVL C00002 V=80.0"]
    res = filter_program([_inform_job(tmp_path, moves)], perturbed(INFORM_ARM, 7), INFORM_ARM,
                         tools=INFORM_TOOLS)
    reasons = [m.reason for m in res.motions]
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 0, "named": 3}
    assert "coordinated with ST1: give a cell file (--model CELL.yaml) whose positioner has unit ST1" \
        in reasons[0]
    assert "follows a conveyor" in reasons[1]
    assert "gives no station position (EC)" in reasons[2]
    pulses = tmp_path / "pulses"
    pulses.mkdir()
    res = filter_program([_inform_job(pulses, moves[:1], station="PULSE")], perturbed(INFORM_ARM, 7),
                         INFORM_ARM, tools=INFORM_TOOLS)
    assert "encoder pulses" in res.motions[0].reason


def test_inform_coordinated_targets_land_on_the_workpiece(tmp_path, monkeypatch):
    """SMOVL ... +MOVJ EC with a cell whose positioner is ST1: the nominal controller (nominal arm IK of
    the corrected position) drives the calibrated arm to the point the job meant on the plate,
    ``calibrated_plate(e) @ inv(nominal_plate(e)) @ X``; the station's values, the forms and every
    other byte stay."""
    calibrated_positioner = perturbed(POSITIONER, 3)
    _cell(monkeypatch, INFORM_ARM, "ST1", calibrated_positioner=calibrated_positioner)
    moves = [f"SMOVL C{k:05d} V=100.0 +MOVJ EC{k:05d}" for k in range(len(Q))]
    job = _inform_job(tmp_path, moves, groups=("RB1", "ST1"))
    calibrated = perturbed(INFORM_ARM, 7)
    res = filter_program([job], calibrated, INFORM_ARM, tools=INFORM_TOOLS)
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 4, "named": 0}
    assert _outside_numbers(res.outputs[job]) == _outside_numbers(job.read_bytes())
    ec = re.findall(rb"^EC.*$", job.read_bytes(), re.M)
    assert re.findall(rb"^EC.*$", res.outputs[job], re.M) == ec
    out = _written(res, [job], tmp_path / "out")
    reached, _ = execute(out, calibrated, INFORM_ARM, tools=INFORM_TOOLS)
    before, X = execute([job], calibrated, INFORM_ARM, tools=INFORM_TOOLS)
    e = np.deg2rad(E)
    intended = calibrated_positioner.fk(e) @ invert_transform(POSITIONER.fk(e)) @ X
    err = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1) * 1e3
    err0 = np.linalg.norm(before[:, :3, 3] - intended[:, :3, 3], axis=1) * 1e3
    assert err.max() < LANDS_MM and err0.min() > 10 * LANDS_MM, (err, err0)


def test_inform_refusals(tmp_path, monkeypatch):
    """A station the cell does not have, a station value outside its axis' limits: one line, nothing
    written."""
    job = _inform_job(tmp_path, ["SMOVL C00000 V=100.0 +MOVJ EC00000"], groups=("RB1", "ST2"))
    _cell(monkeypatch, INFORM_ARM, "ST1")
    with pytest.raises(DataError, match=r"mechanical unit ST2, which is not in the cell"):
        filter_program([job], perturbed(INFORM_ARM, 7), INFORM_ARM, tools=INFORM_TOOLS)
    far = tmp_path / "far"
    far.mkdir()
    job = _inform_job(far, ["SMOVL C00003 V=100.0 +MOVJ EC00003"])
    job.write_bytes(job.read_bytes().replace(b"EC00003=-45.0000", b"EC00003=-95.0000"))
    with pytest.raises(DataError, match=r"ST1 axis E1 = -95.*outside the positioner's limits"):
        filter_program([job], perturbed(INFORM_ARM, 7), INFORM_ARM, tools=INFORM_TOOLS)


def test_inform_target_used_coordinated_and_not_is_named(tmp_path):
    moves = ["SMOVL C00000 V=100.0 +MOVJ EC00000", "MOVL C00000 V=100.0", "MOVL C00001 V=100.0"]
    res = filter_program([_inform_job(tmp_path, moves)], perturbed(INFORM_ARM, 7), INFORM_ARM,
                         tools=INFORM_TOOLS)
    assert [m.status for m in res.motions] == ["named", "named", "corrected"]
    assert all("cannot serve both" in m.reason for m in res.motions[:2])


# ----------------------------------------------------------------------------- FANUC
FANUC_FRAMES = {"frames": {"1": "0,0,0,0,0,0"}, "tools": {"2": "0,0,180,0,0,0"}}


def _fanuc_program(folder: Path, moves: list[str], *, extended: float | None = None,
                   positioner: bool = True) -> Path:
    """A TP program (DEFAULT_GROUP 1,1) whose P[k+1] hold the arm's pose at Q[k] in UF 1 (the world)
    and GP2's axes at E[k]; ``extended``: an E1 of group 1 too."""
    d = FanucDialect()
    P, cfg = program_poses(d, FANUC_ARM, Q, TOOL, np.eye(4))
    v = d.from_pose(P, np.zeros((len(Q), 6)))
    pos = []
    for k in range(len(Q)):
        ext = f",\n\tE1=  {extended:9.3f}  mm" if extended is not None else ""
        gp2 = (f"\n   GP2:\n\tUF : 1, UT : 2,\n\tJ1=  {E[k, 0]:9.3f} deg,\tJ2=  {E[k, 1]:9.3f} deg"
               if positioner else "")
        pos.append(f"P[{k + 1}]{{\n   GP1:\n\tUF : 1, UT : 2,\t\tCONFIG : '{d.scheme.text(cfg[k])}',\n"
                   f"\tX = {v[k, 0]:9.3f}  mm,\tY = {v[k, 1]:9.3f}  mm,\tZ = {v[k, 2]:9.3f}  mm,\n"
                   f"\tW = {v[k, 3]:9.3f} deg,\tP = {v[k, 4]:9.3f} deg,\tR = {v[k, 5]:9.3f} deg"
                   f"{ext}{gp2}\n}};")
    head = ["/PROG  CELL", "/ATTR", "OWNER\t\t= MNEDITOR;", "COMMENT\t\t= \"\";", "PROTECT\t\t= READ_WRITE;",
            "TCD:  STACK_SIZE\t= 0,", "      TASK_PRIORITY\t= 50,", "      TIME_SLICE\t= 0,",
            "      BUSY_LAMP_OFF\t= 0,", "      ABORT_REQUEST\t= 0,", "      PAUSE_REQUEST\t= 0;",
            "DEFAULT_GROUP\t= 1,1,*,*,*;", "CONTROL_CODE\t= 00000000 00000000;", "/MN",
            "   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=2 ;"]
    mn = [f"{k + 3:4d}:{m}    ;" for k, m in enumerate(moves)]
    path = folder / "cell.ls"
    path.write_bytes("\r\n".join([*head, *mn, "/POS", *pos, "/END", ""]).encode())
    return path


def test_fanuc_second_group_on_its_own_leaves_arm_targets(tmp_path):
    """GP2 values in every position, no COORD: all arm targets (the program of 999 such motions was
    named whole before); an E1 of group 1 (an integrated rail carrying the arm) stays named."""
    path = _fanuc_program(tmp_path, ["J P[1] 100% CNT50", "L P[2] 250mm/sec CNT100", "L P[3] 250mm/sec FINE",
                                     "J P[4] 50% FINE"])
    res = filter_program([path], perturbed(FANUC_ARM, 7), FANUC_ARM, **FANUC_FRAMES)
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 4, "named": 0}
    assert sum("external-axis values" in w for w in res.warnings) == 1
    assert _outside_numbers(res.outputs[path]) == _outside_numbers(path.read_bytes())
    rail = tmp_path / "rail"
    rail.mkdir()
    path = _fanuc_program(rail, ["J P[1] 100% CNT50"], extended=1500.0)
    res = filter_program([path], perturbed(FANUC_ARM, 7), FANUC_ARM, **FANUC_FRAMES)
    assert res.summary_dict()["motions"]["named"] == 1 and "E1 = 1500.000" in res.motions[0].reason


def test_fanuc_coordinated_motion(tmp_path, monkeypatch):
    """L ... COORD: named without a cell; with a cell whose positioner is GP2 the arm's position is
    on the leader's plate (its coordinated frame): the nominal controller puts it at
    ``nominal_plate(e) @ P`` and the corrected one drives the calibrated arm to
    ``calibrated_plate(e) @ P``; GP2's values and every other byte stay."""
    moves = ["J P[1] 100% CNT50 COORD", "L P[2] 250mm/sec CNT100 COORD", "L P[3] 250mm/sec CNT100 COORD",
             "L P[4] 250mm/sec FINE COORD"]
    d = FanucDialect()
    # the positions on the plate: the arm's poses at Q seen from the nominal plate at E
    plate = POSITIONER.fk(np.deg2rad(E))
    path = _fanuc_program(tmp_path, moves)
    values = d.from_pose(invert_transform(plate) @ FANUC_ARM.fk(Q) @ TOOL, np.zeros((len(Q), 6)))
    text = path.read_text()
    for k in range(len(Q)):  # the arm's numbers of P[k+1] replaced by its pose on the plate
        block = re.search(rf"P\[{k + 1}\]\{{.*?\}};", text, re.S).group(0)
        new = block
        for key, x in zip("XYZWPR", values[k], strict=True):
            new = re.sub(rf"\b{key} = +[-\d.]+", f"{key} = {x:9.3f}", new, count=1)
        text = text.replace(block, new)
    path.write_bytes(text.encode())
    calibrated = perturbed(FANUC_ARM, 7)
    res = filter_program([path], calibrated, FANUC_ARM, **FANUC_FRAMES)
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 0, "named": 4}
    assert all("coordinated with GP2: give a cell file" in m.reason for m in res.motions)
    calibrated_positioner = perturbed(POSITIONER, 3)
    _cell(monkeypatch, FANUC_ARM, "GP2", calibrated_positioner=calibrated_positioner)
    res = filter_program([path], calibrated, FANUC_ARM, **FANUC_FRAMES)
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 4, "named": 0}
    out = res.outputs[path]
    assert _outside_numbers(out) == _outside_numbers(path.read_bytes())
    assert re.findall(rb"J[12]=.*", out) == re.findall(rb"J[12]=.*", path.read_bytes())
    # the controller: nominal IK (in the position's CONFIG) of nominal_plate(e) @ P'
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "cell.ls").write_bytes(out)
    prog = d.parse([ProgramText(tmp_path / "out" / "cell.ls")], {}, {})
    P = d.to_pose(np.array([t.values() for t in prog.targets]))
    problems, warnings = [], []
    F = plate @ P @ invert_transform(TOOL)
    q = filter_module.controller_joints(d, prog, prog.targets, FANUC_ARM, F, problems, warnings)
    assert not problems
    reached = calibrated.fk(q) @ TOOL
    intended = calibrated_positioner.fk(np.deg2rad(E)) @ d.to_pose(values)
    err = np.linalg.norm(reached[:, :3, 3] - intended[:, :3, 3], axis=1) * 1e3
    assert err.max() < LANDS_MM, err


def test_fanuc_position_used_coordinated_and_not_is_named(tmp_path):
    path = _fanuc_program(tmp_path, ["L P[1] 250mm/sec CNT100 COORD", "J P[1] 50% FINE", "J P[2] 50% FINE"])
    res = filter_program([path], perturbed(FANUC_ARM, 7), FANUC_ARM, **FANUC_FRAMES)
    assert [m.status for m in res.motions] == ["named", "named", "corrected"]
    assert "cannot serve both" in res.motions[1].reason
