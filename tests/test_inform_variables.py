"""Yaskawa INFORM, issue 46: jobs whose motions a reader could miss (the layouts public jobs and
offline generators write), the controller's VAR.DAT given with --references (its P variables
corrected in VAR_CAL.DAT), variables assigned at run time named with that reason. Every case
states its motions counted by hand; corrected + named == that count, and only numbers change."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.data.simulate import perturbed
from robocal.programs import filter_program
from robocal.programs.dialects.inform.reader import InformDialect
from robocal.programs.source import NUMBER_RE

CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"
TOOLS = {"1": "0,-35,410,0,-30,0", "3": "0,0,180,0,0,0"}
NOMINAL = rc.Robot.from_catalog("yaskawa_gp25")
CALIBRATED = perturbed(NOMINAL, 7)
Q = np.deg2rad([[0, 10, -20, 0, -70, 0], [15, 20, -15, 5, -75, 10], [-10, 15, -25, 0, -60, 5],
                [5, 5, -30, 0, -65, 0], [10, 12, -22, 3, -70, 4], [-5, 18, -18, -3, -72, -6],
                [20, 8, -28, 2, -68, 3]])
POSES = InformDialect().from_pose(NOMINAL.fk(Q), np.zeros((len(Q), 6)))  # flange poses (tool 0), mm deg
HEAD = ["///TOOL 0", "///POSTYPE ROBOT", "///RECTAN", "///RCONF 1,0,0,0,0,0,0,0"]


def _values(k: int) -> str:
    return ",".join(f"{x:.3f}" for x in POSES[k][:3]) + "," + ",".join(f"{x:.4f}" for x in POSES[k][3:])


def _job(pos: list[str], inst: list[str], *, newline="\r\n", nop=True, end=True, bom=b"") -> bytes:
    lines = ["/JOB", "//NAME J", "//POS", *pos, "//INST", "///DATE 2024/01/01 00:00", "///ATTR SC,RW",
             "///GROUP1 RB1", *(["NOP"] if nop else []), *inst, *(["END"] if end else []), ""]
    return bom + newline.join(lines).encode()


def _outside_numbers(data: bytes) -> str:
    return re.sub(NUMBER_RE.pattern, "#", data.decode("latin-1"))


def _counts(res) -> dict:
    return json.loads(res.table_json())["summary"]["motions"]


P_ENTRIES = [f"P{k:05d}={_values(k)}" for k in range(6)]
P_MOVES = [f"MOVL P{k:03d} V=100.0" for k in range(6)]
# name -> the job's bytes; every one has 6 motions to Cartesian positions (hand count), all correctable
SILENT_BEFORE = {
    # an offline generator's layout (PinkyAndBrain's MotomanProtocolFileCreator): a second
    # ///POSTYPE BASE with no ///RECTAN after it; 8-decimal values, five-digit operands
    "POSTYPE BASE without RECTAN": _job(["///NPOS 0,0,0,7,0,0", *HEAD, "P00000=10.000,0.000,0.000,0.0000,"
                                         "0.0000,0.0000", "///POSTYPE BASE",
                                         *(f"P{k + 1:05d}={_values(k)}" for k in range(6))],
                                        [f"MOVL P{k + 1:05d} V=0100.0000000" for k in range(6)]),
    "RECTAN before POSTYPE": _job(["///NPOS 0,0,0,6,0,0", "///TOOL 0", "///RECTAN", "///POSTYPE ROBOT",
                                   "///RCONF 1,0,0,0,0,0,0,0", *P_ENTRIES], P_MOVES),
    "UTF-8 byte-order mark": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *P_ENTRIES], P_MOVES, bom=b"\xef\xbb\xbf"),
}
READ_BEFORE = {  # layouts read before too: kept so
    "lone CR line ends": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *P_ENTRIES], P_MOVES, newline="\r"),
    "no NOP, no END": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *P_ENTRIES], P_MOVES, nop=False, end=False),
    "indented, // comments": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *P_ENTRIES],
                                  [f"    MOVL P{k:03d} V=100.0  //TO C0000{k} +MOVJ" for k in range(6)]),
    "' comment lines and labels": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *P_ENTRIES],
                                       [x for k in range(6)
                                        for x in (f"'MOVL P{k:03d}", f"*L{k} " + P_MOVES[k])]),
    "P100 without zero padding": _job(["///NPOS 0,0,0,6,0,0", *HEAD, *(f"P{100 + k}={_values(k)}"
                                                                      for k in range(6))],
                                      [f"MOVJ P{100 + k}" for k in range(6)]),
}


@pytest.mark.parametrize("case", [*SILENT_BEFORE, *READ_BEFORE])
def test_every_motion_of_these_layouts_is_read(case, tmp_path):
    data = (SILENT_BEFORE | READ_BEFORE)[case]
    path = tmp_path / "J.JBI"
    path.write_bytes(data)
    hand = 6  # counted in the job above
    res = filter_program([path], CALIBRATED, NOMINAL)
    assert _counts(res) == {"total": hand, "corrected": hand, "named": 0}
    assert _outside_numbers(res.outputs[path]) == _outside_numbers(data) and path.read_bytes() == data
    assert res.outputs[path].count(b"\r") == data.count(b"\r")
    assert filter_program([path], NOMINAL, NOMINAL).outputs[path] == data


def test_a_job_without_motion_records_says_why(tmp_path):
    """The public jobs of hehonglu123/Welding_Motoman's layout: C positions in pulses without a
    ///POSTYPE (2 joint motions) and a station's own motion (///GROUP1 ST1): no record, a warning."""
    pulses = tmp_path / "LINEAR.JBI"
    pulses.write_bytes("\n".join([
        "/JOB", "//NAME AAA", "//POS", "///NPOS 2,0,0,0,0,0", "C00000=-48629,112084,69901,4161,-52375,-4796",
        "C00001=-46969,105372,61036,4871,-50464,-5567", "//INST", "///DATE 2023/02/07 09:03", "///ATTR SC,RW",
        "///GROUP1 RB1", "NOP", "MOVL C00000 V=10.0 PL=8", "MOVL C00001 V=10.0 PL=0", "END", ""]).encode())
    station = tmp_path / "TURN.JBI"
    station.write_bytes("\n".join([
        "/JOB", "//NAME AAA", "//POS", "///NPOS 0,0,1,0,0,0", "///TOOL 12", "///POSTYPE PULSE", "///PULSE",
        "EC00000=-29914,0", "//INST", "///DATE 2023/11/10 10:40", "///ATTR SC,RW", "///GROUP1 ST1", "NOP",
        "MOVJ EC00000 VJ=90.0", "END", ""]).encode())
    none = "motion instruction(s) and no motion of the arm to a Cartesian position:"
    for path, what in ((pulses, f"2 {none} 2 to joint (pulse) positions"),
                       (station, f"1 {none} 1 of a station alone")):
        res = filter_program([path], CALIBRATED, NOMINAL)
        assert _counts(res) == {"total": 0, "corrected": 0, "named": 0}
        assert any(w.startswith(f"{path.name}: {what}") for w in res.warnings), res.warnings


def test_var_dat_given_with_references_is_corrected_in_var_cal(tmp_path):
    """PICK_PLACE moves to P001, which the controller's VAR.DAT holds: given with --references it
    is corrected, delivered in VAR_CAL.DAT with the same numbers as when VAR.DAT is filtered as a
    program file (whose poses test_inform checks on the calibrated robot); every other byte of it
    kept; the backup itself untouched."""
    job, var = (tmp_path / n for n in ("PICK_PLACE.JBI", "VAR.DAT"))
    for p in (job, var):
        shutil.copy(CORPUS / p.name, p)
    before = var.read_bytes()
    # PICK_PLACE by hand: 13 motion instructions, 1 to a joint position (P003 in VAR.DAT, PULSE):
    # 12 Cartesian; corrected 9 (C00000-C00005, P001); named 3 (P002 GETPOS, LP000 SET, P[I000])
    res = filter_program([job], CALIBRATED, NOMINAL, tools=TOOLS, references=[var])
    assert _counts(res) == {"total": 12, "corrected": 9, "named": 3}
    cal = tmp_path / "VAR_CAL.DAT"
    assert set(res.outputs) == {job, cal} and "P0001" in [r["name"] for r in res.rows]
    as_program = filter_program([job, var], CALIBRATED, NOMINAL, tools=TOOLS)
    assert res.outputs[cal] == as_program.outputs[var] != before
    assert _outside_numbers(res.outputs[cal]) == _outside_numbers(before) and var.read_bytes() == before
    assert any("corrected in VAR_CAL.DAT" in w for w in res.warnings)
    # through the CLI: VAR_CAL.DAT beside the filtered job
    model = tmp_path / "cal.yaml"
    CALIBRATED.save(model)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["--quiet", "filter", str(job), "--calibrated", str(model), "--nominal", "yaskawa_gp25", "-o",
                 str(out / "PICK_CAL.JBI"), "--references", str(var), "--tool", "3=0,0,180,0,0,0"]) == 0
    assert (out / "VAR_CAL.DAT").read_bytes() == res.outputs[cal]


def test_var_dat_user_frame_variables_with_uframe_cnd(tmp_path):
    """P variables in VAR.DAT taught in user frame 2 (///POSTYPE USER, ///USER 2), the frame from
    UFRAME.CND (also a reference): corrected as the same positions saved in the job with --frame."""
    frame = "1250.000,-300.000,450.000,0.0000,0.0000,15.0000"
    cnd = tmp_path / "UFRAME.CND"
    cnd.write_bytes(f"//UFRAME 2\r\n///NAME FIXTURE\r\n////BUSER {frame}\r\n".encode())
    W = InformDialect().to_pose(np.array([[float(v) for v in frame.split(",")]]))[0]
    in_frame = InformDialect().from_pose(np.linalg.inv(W) @ NOMINAL.fk(Q[:3]), np.zeros((3, 6)))
    text = [",".join(f"{x:.3f}" for x in v[:3]) + "," + ",".join(f"{x:.4f}" for x in v[3:]) for v in in_frame]
    head = ["///TOOL 0", "///POSTYPE USER", "///USER 2", "///RECTAN", "///RCONF 1,0,0,0,0,0,0,0"]
    var = tmp_path / "VAR.DAT"
    entries = [f"P{k + 1:04d}={t}" for k, t in enumerate(text)]
    var.write_bytes("\r\n".join(["//B", "B000=0", "//P", *head, *entries, ""]).encode())
    job = tmp_path / "UF.JBI"
    job.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], [f"MOVL P{k + 1:03d} V=100.0" for k in range(3)]))
    same = tmp_path / "SAME.JBI"
    same.write_bytes(_job(["///NPOS 3,0,0,0,0,0", *head, *(f"C{k:05d}={t}" for k, t in enumerate(text))],
                          [f"MOVL C{k:05d} V=100.0" for k in range(3)]))
    res = filter_program([job], CALIBRATED, NOMINAL, references=[var, cnd])
    ref = filter_program([same], CALIBRATED, NOMINAL, frames={"2": frame})
    assert _counts(res) == {"total": 3, "corrected": 3, "named": 0}  # 3 by hand
    assert [r["correction_mm"] for r in res.rows] == pytest.approx([r["correction_mm"] for r in ref.rows])


def test_variables_assigned_at_run_time_are_named(tmp_path):
    """Each run-time write of a P variable (SET, SUB, ADD, MUL, CNVRT, GETS, MULMAT, INVMAT, SETE,
    anywhere in the job: after the motion too, a loop) names every motion to it even though VAR.DAT
    holds a value; LP local variables likewise; a write with a run-time index names every motion to
    a variable of its kind in the job that does it."""
    var = tmp_path / "VAR.DAT"
    var.write_bytes("\r\n".join(["//P", *HEAD, *(f"P{k:04d}={_values(k)}" for k in range(7)), ""]).encode())
    writes = ["SET P001 P000", "SUB P002 P000", "ADD P003 P000", "CNVRT P004 P000 BF", "GETS P005 $PX001",
              "MULMAT LP000 P000 P001"]
    moves = [f"MOVL P{k:03d} V=100.0" for k in range(6)] + ["MOVL LP000 V=100.0", "MOVL LP001 V=100.0"]
    job = tmp_path / "RT.JBI"
    job.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], ["*LOOP", *moves, *writes, "SETE P006 (1) D000",
                                                   "JUMP *LOOP"]))
    # by hand: 8 motions; P000 corrected; P001-P005, LP000 (MULMAT), LP001 (a local variable) named
    res = filter_program([job], CALIBRATED, NOMINAL, references=[var])
    assert _counts(res) == {"total": 8, "corrected": 1, "named": 7}
    named = [r.reason for r in res.motions if r.status == "named"]
    for k, write in enumerate(["SET", "SUB", "ADD", "CNVRT", "GETS", "MULMAT"]):
        reason = named[k]
        assert f"is assigned at run time by {write} (RT.JBI:" in reason, (k, reason)
    assert "LP001 is a local position variable: assigned at run time" in named[-1]
    indexed = tmp_path / "IX.JBI"
    indexed.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], ["SET P[I000] P006", "MOVL P000 V=100.0",
                                                       "MOVL C00000 V=100.0"]))
    res = filter_program([indexed], CALIBRATED, NOMINAL, references=[var])
    # by hand: 2 motions; P000 named (SET P[I000] may write it), C00000 not in the files: named
    assert _counts(res) == {"total": 2, "corrected": 0, "named": 2}
    assert "P000 may be assigned at run time by SET P[I000] (IX.JBI:" in res.motions[0].reason


def test_station_coordinated_smov_is_no_conveyor(tmp_path):
    """SMOVL/SMOVC coordinated with a station (no CV#): named for the station, never 'follows a
    conveyor'; SMOVL ... CV#(1) is the conveyor."""
    pos = ["///NPOS 2,0,0,0,0,0", *HEAD, f"C00000={_values(0)}", f"C00001={_values(1)}"]
    path = tmp_path / "ST.JBI"
    data = _job(pos, ["SMOVL C00000 V=100.0 +MOVJ EC00000 VJ=10.00", "SMOVC C00001 V=100.0",
                      "SMOVL C00000 V=100.0 CV#(1) CTP=0.000"])
    path.write_bytes(data.replace(b"///GROUP1 RB1", b"///GROUP1 RB1\r\n///GROUP2 ST1"))
    res = filter_program([path], CALIBRATED, NOMINAL)
    reasons = [r.reason for r in res.motions]
    assert _counts(res)["total"] == 3  # by hand
    assert all("conveyor" not in r and "ST1" in r for r in reasons[:2]), reasons
    assert "follows a conveyor" in reasons[2]


def test_a_global_variable_another_job_assigns_is_named(tmp_path):
    """P variables are global: P001 assigned by SET in the job CALLed (given with it) is named in
    the caller; LP000 assigned there is the callee's own and the caller's LP000 is named as a local
    variable, not for the callee's SET."""
    var = tmp_path / "VAR.DAT"
    var.write_bytes("\r\n".join(["//P", *HEAD, *(f"P{k:04d}={_values(k)}" for k in range(3)), ""]).encode())
    main_job, sub = tmp_path / "MAIN.JBI", tmp_path / "SUB.JBI"
    moves = ["CALL JOB:SUB", "MOVL P000 V=100.0", "MOVL P001 V=100.0", "MOVL LP000 V=100.0"]
    main_job.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], moves))
    sub.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], ["SET P001 P002", "SET LP000 P002"]))
    res = filter_program([main_job, sub], CALIBRATED, NOMINAL, references=[var])
    # by hand: 3 motions (MAIN); P000 corrected, P001 and LP000 named
    assert _counts(res) == {"total": 3, "corrected": 1, "named": 2}
    reasons = [r.reason for r in res.motions if r.status == "named"]
    assert "P001 is assigned at run time by SET (SUB.JBI:" in reasons[0]
    assert "LP000 is a local position variable" in reasons[1]


@pytest.mark.parametrize("case", ["lone CR line ends", "no NOP, no END"])
def test_the_filtered_job_is_marked_whatever_its_layout(case, tmp_path):
    """The marker comment lands in a CR-only job (after NOP) and in one without NOP (before its first
    instruction), with the job's line ends: filtering the output again is refused."""
    path = tmp_path / "J.JBI"
    path.write_bytes(READ_BEFORE[case])
    out = tmp_path / "J_CAL.JBI"
    filter_program([path], CALIBRATED, NOMINAL).write(out)
    data = out.read_bytes()
    marks = re.findall(rb"'robocal [^\r\n]*(\r\n|\r)", data)
    assert len(marks) == 1 and marks[0] == (b"\r" if case == "lone CR line ends" else b"\r\n")
    with pytest.raises(rc.core.errors.DataError, match="already filtered"):
        filter_program([out], CALIBRATED, NOMINAL)
    assert _counts(filter_program([out], CALIBRATED, NOMINAL, force=True)) == {"total": 6, "corrected": 6,
                                                                              "named": 0}


def _backup_var(tmp_path, forms: list[str]) -> Path:
    """A VAR.DAT in a controller backup's layout (the public lukelalondePZ/Komatsu-Press-Demo's):
    P000 unused, P001 pulses, P002 and P003 BASE (type 16, tool 0, forms ``forms``), P004 in user
    coordinates (type 18), P005 unused."""
    var = tmp_path / "VAR.DAT"
    rect = [f'"RECTAN"0,0,0,{forms[k]},0,16,{_values(k)},0.0000,0.0000' for k in range(2)]
    zeros = "0" * 24
    lines = ["//VAR", "///PFNUM 6,0,0,0", "///SHARE 250,250,250,250,250,250,0,0", "///B",
             "0,0,0,0,0,0,0,0,0,0", "///S", "", "", "///P", '"UNUSED"',
             f'"PULSE"0,0,3,{zeros},0,0,2,-76037,-66182,0,4682,0,0,0', *rect,
             f'"RECTAN"0,0,3,{zeros},0,18,{_values(2)},0.0000,0.0000', '"UNUSED"', "///BP", "///EX", ""]
    var.write_bytes("\n".join(lines).encode())
    return var


def test_a_backups_var_dat_layout(tmp_path):
    """The VAR.DAT of a controller's CMOS backup (one line per P variable): BASE variables corrected
    like the same positions saved in a job (same correction), in VAR_CAL.DAT with only their numbers
    changed; a pulse variable is a joint position; a user-coordinate one and an unused one named."""
    forms = ["".join(map(str, InformDialect().scheme.encode(NOMINAL, Q[k]).clip(0, 1))) + "0" * 18
             for k in range(2)]
    var = _backup_var(tmp_path, forms)
    job = tmp_path / "B.JBI"
    job.write_bytes(_job(["///NPOS 0,0,0,0,0,0"], [f"MOVL P{k:03d} V=100.0" for k in range(1, 6)]))
    res = filter_program([job], CALIBRATED, NOMINAL, references=[var])
    # by hand: 5 motions, P001 to pulses (no record); P002, P003 corrected; P004 (type 18) and P005
    # (unused) named
    assert _counts(res) == {"total": 4, "corrected": 2, "named": 2}
    named = [r.reason for r in res.motions if r.status == "named"]
    assert "P004 is in coordinate type 18 of VAR.DAT" in named[0]
    assert 'P005 is "UNUSED" in VAR.DAT' in named[1]
    cal = tmp_path / "VAR_CAL.DAT"
    assert _outside_numbers(res.outputs[cal]) == _outside_numbers(var.read_bytes())
    same = tmp_path / "SAME.JBI"
    rconf = [",".join(f[:6]) + ",0,0" for f in forms]
    same.write_bytes(_job(["///NPOS 2,0,0,0,0,0", "///TOOL 0", "///POSTYPE BASE", "///RECTAN",
                           *(x for k in range(2)
                             for x in (f"///RCONF {rconf[k]}", f"C{k:05d}={_values(k)}"))],
                          ["MOVL C00000 V=100.0", "MOVL C00001 V=100.0"]))
    ref = filter_program([same], CALIBRATED, NOMINAL)
    assert [r["correction_mm"] for r in res.rows] == pytest.approx([r["correction_mm"] for r in ref.rows])
    as_program = filter_program([job, var], CALIBRATED, NOMINAL)  # told from its content, not .DAT
    assert _counts(as_program) == _counts(res) and as_program.outputs[var] == res.outputs[cal]
    identity = filter_program([job], NOMINAL, NOMINAL, references=[var])
    assert identity.outputs.get(cal, var.read_bytes()) == var.read_bytes()


def test_the_second_robots_motions_are_named(tmp_path):
    """A job of two robots (///GROUP1 RB1, ///GROUP2 RB2): each instruction's +MOVL part moves the
    second robot to its own position: named (another robot's model), never lost; the first robot's
    corrected."""
    pos = ["///NPOS 4,0,0,0,0,0", *HEAD, *(f"C{k:05d}={_values(k)}" for k in range(4))]
    path = tmp_path / "TWO.JBI"
    data = _job(pos, ["MOVL C00000 V=100.0 +MOVL C00001 V=100.0",
                      "MOVJ C00002 VJ=10.00 +MOVJ C00003 VJ=10.00"])
    path.write_bytes(data.replace(b"///GROUP1 RB1", b"///GROUP1 RB1\r\n///GROUP2 RB2"))
    res = filter_program([path], CALIBRATED, NOMINAL)
    # by hand: 4 motions, 2 of each robot
    assert _counts(res) == {"total": 4, "corrected": 2, "named": 2}
    named = [r.reason for r in res.motions if r.status == "named"]
    assert all("a position of RB2, another robot" in r for r in named) and len(named) == 2
