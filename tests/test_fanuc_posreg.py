"""FANUC position registers read from the controller's backup POSREG.VA (``--references``):
motions to PR[n] corrected, the corrected values delivered as the TP program PR_CAL.LS, registers
written at run time named with where; every motion accounted, every byte of the programs outside
the corrected numbers unchanged (robocal.programs.dialects.fanuc.posreg)."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.data.simulate import simulate_tracker
from robocal.programs.dialects.fanuc.configuration import FANUCConfig
from robocal.programs.dialects.fanuc.posreg import read_posreg
from robocal.programs.motions import CORRECTED
from robocal.programs.source import ProgramText

# tests/data/fanuc_backup/POSREG.VA: written for these tests in the style of real controller
# backups (CRLF, trailing blanks, %9.3f with the leading zero of |x| < 1 dropped, a joint register
# with Group: on its index line and a blank line after it, Uninitialized registers, an EXT1 line of
# zero, a second motion group, the next variable of the file after it)
POSREG = (Path(__file__).parent / "data" / "fanuc_backup" / "POSREG.VA").read_bytes().decode()

PALLET = """/PROG  PALLET
/ATTR
OWNER\t\t= MNEDITOR;
COMMENT\t\t= "";
LINE_COUNT\t= 18;
PROTECT\t\t= READ_WRITE;
DEFAULT_GROUP\t= 1,*,*,*,*;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=2 ;
   3:J PR[1:HOME] 100% FINE    ;
   4:J PR[10:PICK_APP] 100% CNT50    ;
   5:L PR[11:PICK] 200mm/sec FINE    ;
   6:L PR[10:PICK_APP] 500mm/sec CNT50    ;
   7:  PR[20:PLACE]=PR[12:PLACE_BASE]    ;
   8:  PR[20,3:PLACE]=PR[20,3:PLACE]+R[5:LAYER_H]    ;
   9:L PR[20:PLACE] 200mm/sec FINE    ;
  10:L P[1] 200mm/sec FINE Offset,PR[13:LIFT]    ;
  11:L PR[14:SPARE] 200mm/sec FINE    ;
  12:J PR[12:PLACE_BASE] 100% FINE    ;
  13:  ! PR[11:PICK]=LPOS ;
  14:J P[1] 100% FINE    ;
  15:L PR[15:RAIL] 200mm/sec FINE    ;
  16:L PR[16] 200mm/sec FINE    ;
  17:L P[2] 100mm/sec FINE Offset,PR[13:LIFT]    ;
  18:L PR[17:DROP] 100mm/sec FINE Offset,PR[13:LIFT]    ;
/POS
P[1]{
   GP1:
\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =   650.000  mm,\tY =   -80.000  mm,\tZ =   300.000  mm,
\tW =   180.000 deg,\tP =     0.000 deg,\tR =    90.000 deg
};
P[2]{
   GP1:
\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',
\tX =   700.000  mm,\tY =    40.000  mm,\tZ =   250.000  mm,
\tW =   180.000 deg,\tP =    10.000 deg,\tR =    90.000 deg
};
/END
"""
FRAME = "100,0,0,0,0,0"  # UF 1 (mm, deg)
TOOL = "0,0,150,0,0,0"  # UT 2


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_bytes(text.replace("\r\n", "\n").replace("\n", "\r\n").encode())
    return path


def _models():
    nominal = rc.Robot.from_catalog("fanuc_m20ia")
    truth = replace(simulate_tracker(nominal, 10, seed=7, noise_mm=0.0).truth, tool=nominal.tool,
                    smr=np.zeros((0, 3)))
    return nominal, truth


def _pose(values) -> np.ndarray:
    """X, Y, Z mm, W, P, R deg -> 4x4 m."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("ZYX", np.asarray(values, float)[[5, 4, 3]], degrees=True).as_matrix()
    T[:3, 3] = np.asarray(values[:3], float) * 1e-3
    return T


def test_posreg_va_is_read_as_a_controller_writes_it(tmp_path):
    regs = read_posreg(ProgramText(_write(tmp_path, "POSREG.VA", POSREG)))
    assert sorted(regs.cartesian) == [10, 11, 12, 13, 17, 20]
    assert regs.other[1] is None  # a joint register: nothing to correct
    assert "Uninitialized" in regs.other[2] and "Uninitialized" in regs.other[14]
    assert "EXT1 700.000" in regs.other[15]
    np.testing.assert_array_equal(regs.cartesian[10].values(), [612.5, -120.0, 480.0, 180.0, -0.649, 90.0])
    assert regs.comments[12] == "PLACE_BASE" and regs.cartesian[11].config.tolist() == [0, 0, 0, 0, 0, 0]


def test_scara_registers_read_their_hand(tmp_path):
    text = ("[*POSREG*]$POSREG  Storage: CMOS  Access: RW  : ARRAY[1,3] OF Position Reg\n"
            "    [1,1] =   'A' \n  Group: 1   Config: R, 0, 0, -1\n"
            "  X:   300.000   Y:   100.000   Z:    50.000\n  W:   180.000   P:     0.000   R:    10.000\n"
            "    [1,2] =   'B' \n  Group: 1   Config: L\n"
            "  X:   300.000   Y:  -100.000   Z:    50.000\n  W:   180.000   P:     0.000   R:    10.000\n")
    regs = read_posreg(ProgramText(_write(tmp_path, "POSREG.VA", text)))
    scheme = FANUCConfig()
    assert scheme.text(regs.cartesian[1].config) == "R, 0, 0, -1"
    assert scheme.text(regs.cartesian[2].config) == "L, 0, 0, 0" and len(regs.cartesian[2].config_spans) == 1


def test_motions_to_registers_are_corrected_onto_the_truth_and_delivered_as_a_tp_program(tmp_path):
    nominal, truth = _models()
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    before = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL})
    res = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                            references=[posreg])
    # 13 motions; with the backup 12 to a Cartesian pose (PR[1:HOME] is a joint register, not counted
    # as a joint P[] is not), 7 corrected; without it only P[1] (line 14)
    for r, total, corrected in ((before, 13, 1), (res, 12, 7)):
        assert len(r.motions) == total and sum(m.status == CORRECTED for m in r.motions) == corrected
        assert all((m.status == CORRECTED) != bool(m.reason) for m in r.motions)
    why = {m.line: m.reason for m in res.motions if m.status != CORRECTED}
    assert "written at PALLET.ls:15 (PR[20]=...)" in why[17]
    assert "P[1] is shifted by Offset,PR[13:LIFT] here and a pose in other motions" in why[18]
    assert "PR[14] is Uninitialized in POSREG.VA" in why[19]
    assert "EXT1" in why[23] and "PR[16] is not in POSREG.VA" in why[24]
    assert "PR[10:PICK_APP] is a position register" in {m.line: m.reason for m in before.motions}[12]
    # the program: only P[1]'s numbers change (and the marker line): PR motions name the register
    out = res.outputs[program].decode()
    marker = re.compile(r"^  19:  !robocal[^\n]*\n", re.MULTILINE)
    original = PALLET.replace("\n", "\r\n")
    kept = marker.sub("", out.replace("\r\n", "\n")).replace("LINE_COUNT\t= 19", "LINE_COUNT\t= 18")
    numbers = re.compile(r" *-?[\d.]+(?= +(?:mm|deg))")  # with its padding: the width is kept
    assert numbers.sub("#", kept) == numbers.sub("#", original.replace("\r\n", "\n"))
    assert [len(k) for k in kept.split("\n")] == [len(k) for k in original.split("\r\n")]
    assert "\r\n" in out and posreg not in res.outputs  # the backup is never written
    # the setter program: PR[n:comment]=P[k], P[k] the corrected values in the frames of the motions
    setter = res.outputs[posreg.with_name("PR_CAL.LS")].decode()
    assert re.findall(r"PR\[\d+:\w+\]=P\[\d\]", setter) == ["PR[10:PICK_APP]=P[1]", "PR[11:PICK]=P[2]",
                                                           "PR[12:PLACE_BASE]=P[3]", "PR[17:DROP]=P[4]"]
    values = np.array([[float(v) for v in re.findall(r"[XYZWPR] = +([-\d.]+)", b)]
                       for b in setter.split("/POS")[1].split("P[")[1:]])
    assert setter.count("UF : 1, UT : 2,") == 4 and setter.count("CONFIG : 'N U T, 0, 0, 0'") == 4
    # independent truth: the controller's nominal IK of each corrected value (the branch its
    # CONFIG names) run on the true robot puts the tool where the backup's value means; P[2], moved
    # to only with Offset,PR[13:LIFT] (Z + 50 mm in UF 1), lands shifted where P[2] + 50 mm means,
    # and so does PR[17:DROP] (moved to only with that offset: its PR_CAL value in UF 1 itself)
    regs = read_posreg(ProgramText(posreg))
    lift = np.array([0.0, 0.0, 50.0, 0.0, 0.0, 0.0])
    meant = np.array([regs.cartesian[n].values() + (n == 17) * lift for n in (10, 11, 12, 17)])
    values[3] += lift
    p2 = [float(v) for v in re.findall(r"[XYZWPR] = +([-\d.]+)", out.split("P[2]{")[1])]
    _lands_on_truth(nominal, truth, np.vstack([values, np.add(p2, lift)]),
                    np.vstack([meant, np.add([700.0, 40.0, 250.0, 180.0, 10.0, 90.0], lift)]))


def _lands_on_truth(nominal, truth, values, meant):
    """The corrected ``values`` (N, 6) in UF 1 with UT 2, solved by the nominal model in the
    configuration N U T and run on ``truth``, reach the poses ``meant`` mean."""
    uf, ut = _pose([100, 0, 0, 0, 0, 0]), _pose([0, 0, 150, 0, 0, 0])
    F = uf @ np.array([_pose(v) for v in values]) @ np.linalg.inv(ut)
    sols = rc.ik.solve_all(nominal, F)
    rows = FANUCConfig().encode(nominal, np.nan_to_num(sols))
    pick = np.argmax(np.all(rows[..., :3] == 0, axis=-1) & np.isfinite(sols).all(-1), axis=1)
    q = sols[np.arange(len(values)), pick]
    reached = np.linalg.inv(truth.base) @ truth.fk(q) @ ut
    want = uf @ np.array([_pose(v) for v in meant])
    assert np.abs(values[:, :3] - meant[:, :3]).max() > 0.1  # a real correction, not a copy
    np.testing.assert_allclose(reached[:, :3, 3], want[:, :3, 3], atol=5e-6)  # 3-decimal rounding
    cos = (np.trace(np.swapaxes(reached[:, :3, :3], 1, 2) @ want[:, :3, :3], axis1=1, axis2=2) - 1) / 2
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 2e-3


def test_the_cli_writes_the_setter_beside_the_program(tmp_path, capsys):
    from robocal.cli import main

    nominal, truth = _models()
    truth.save(tmp_path / "cal.yaml")
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    data = posreg.read_bytes()
    out = tmp_path / "out"
    out.mkdir()
    assert main(["filter", str(program), "--references", str(posreg), "--calibrated",
                 str(tmp_path / "cal.yaml"), "--nominal", "fanuc_m20ia", "--frame", f"1={FRAME}", "--tool",
                 f"2={TOOL}", "-o", str(out / "PALLET.ls")]) == 0
    said = capsys.readouterr().out
    assert "12 motions: 7 corrected, 5 not corrected" in said
    assert (out / "PR_CAL.LS").read_text().startswith("/PROG  PR_CAL") and posreg.read_bytes() == data


def test_the_api_writes_the_setter_beside_the_one_program_as_the_cli_does(tmp_path):
    """FilterResult.write with one output path: the program there, PR_CAL.LS beside it (the
    command line's placement, now the result's own)."""
    nominal, truth = _models()
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    res = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                            references=[posreg])
    out = tmp_path / "out"
    out.mkdir()
    written = res.write(out / "PALLET.ls")
    assert set(written) == {out / "PALLET.ls", out / "PR_CAL.LS"}
    setter = res.outputs[posreg.with_name("PR_CAL.LS")].decode()
    written_setter = (out / "PR_CAL.LS").read_text()  # the same program, with the calibrated model's marker
    assert written_setter.startswith("/PROG  PR_CAL") and "!robocal" in written_setter
    lines = re.compile(r"PR\[\d+:\w+\]=P\[\d\]")
    assert lines.findall(written_setter) == lines.findall(setter)


def test_a_register_without_frames_set_is_named_and_two_register_files_refused(tmp_path):
    nominal, truth = _models()
    text = PALLET.replace("   1:  UFRAME_NUM=1 ;\n", "   1:  ;\n")
    program = _write(tmp_path, "PALLET.ls", text)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    res = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                            references=[posreg])
    assert "UFRAME_NUM and UTOOL_NUM are not both set" in {m.line: m.reason for m in res.motions}[12]
    csv = tmp_path / "pr.csv"
    csv.write_text("register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,config\n")
    with pytest.raises(rc.DataError, match="position registers are given twice"):
        rc.filter_program(program, truth, nominal, references=[posreg], position_registers=csv)


def test_a_scara_register_row_is_read(tmp_path):
    from robocal.programs.dialects.fanuc.registers import read_registers

    path = tmp_path / "pr.csv"
    path.write_text('register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,config\n6,300,100,50,180,0,10,"R, 0, 0, -1"\n')
    t = read_registers(ProgramText(path))[6]
    assert FANUCConfig().text(t.config) == "R, 0, 0, -1"
    assert [s[2] for s in t.config_spans] == ["R", "0", "0", "-1"]


def test_a_scara_config_with_the_hand_alone_is_read_and_kept(tmp_path):
    """An SR program's CONFIG 'R' / 'L' without turn numbers: the hand selects the solution, the
    turns are the controller's nearest (0), and the CONFIG text stays as written."""
    robot = rc.Robot.from_catalog("fanuc_sr6ia")
    truth = replace(simulate_tracker(robot, 10, seed=5, noise_mm=0.0).truth, tool=robot.tool,
                    smr=np.zeros((0, 3)))
    q = np.deg2rad([[30.0, 40.0, 0.0, 10.0], [-50.0, -60.0, 0.0, 80.0]])
    q[:, 2] = [-0.05, -0.1]
    T = robot.fk(q)
    rpw = Rotation.from_matrix(T[:, :3, :3]).as_euler("ZYX", degrees=True)
    pos = []
    for k, (p, (r, pp, w), hand) in enumerate(zip(T[:, :3, 3] * 1e3, rpw, "RL", strict=True), start=1):
        pos += [f"P[{k}]{{", "   GP1:", f"\tUF : 0, UT : 0,\t\tCONFIG : '{hand}',",
                f"\tX = {p[0]:.3f}  mm,\tY = {p[1]:.3f}  mm,\tZ = {p[2]:.3f}  mm,",
                f"\tW = {w:.3f} deg,\tP = {pp:.3f} deg,\tR = {r:.3f} deg", "};"]
    text = "\n".join(["/PROG  T", "/MN", "   1:J P[1] 100% FINE    ;", "   2:J P[2] 100% FINE    ;", "/POS",
                      *pos, "/END", ""])
    (tmp_path / "t.ls").write_text(text)
    same = rc.filter_program(tmp_path / "t.ls", robot, robot)
    assert [r["configuration"] for r in same.rows] == ["kept", "kept"]
    assert max(r["correction_mm"] for r in same.rows) < 1e-6
    res = rc.filter_program(tmp_path / "t.ls", truth, robot)
    out = res.outputs[tmp_path / "t.ls"].decode()
    assert "CONFIG : 'R'," in out and "CONFIG : 'L'," in out
    assert min(r["correction_mm"] for r in res.rows) > 0.01


def test_a_posreg_va_fetched_over_http_is_read_and_one_without_registers_refused(tmp_path):
    html = "<HTML><PRE>" + POSREG.replace("\r\n", "\n") + "</PRE></HTML>\n"
    regs = read_posreg(ProgramText(_write(tmp_path, "POSREG.VA", html)))
    assert sorted(regs.cartesian) == [10, 11, 12, 13, 17, 20]
    nominal, truth = _models()
    program = _write(tmp_path, "PALLET.ls", PALLET)
    empty = tmp_path / "x" / "posreg.va"
    empty.parent.mkdir()
    empty.write_text("[*NUMREG*]$NUMREG  Storage: CMOS  Access: RW  : ARRAY[1] OF Numeric Reg\n"
                     "  [1] = 0  ''\n")
    with pytest.raises(rc.DataError, match="not the controller's POSREG.VA"):
        rc.filter_program(program, truth, nominal, references=[empty])
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    with pytest.raises(rc.DataError, match="give it with --references"):
        rc.filter_program(program, truth, nominal, position_registers=posreg)


def test_frames_selected_through_the_system_variables_are_followed(tmp_path):
    """Offline generators select the frames with $MNUFRAMENUM[1]= n / $MNUTOOLNUM[1]= n."""
    nominal, truth = _models()
    text = PALLET.replace("   1:  UFRAME_NUM=1 ;", "   1:  $MNUFRAMENUM[1]= 1;").replace(
        "   2:  UTOOL_NUM=2 ;", "   2:  $MNUTOOLNUM[1]= 2;")
    program = _write(tmp_path, "PALLET.ls", text)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    res = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                            references=[posreg])
    assert sum(m.status == CORRECTED for m in res.motions) == 7
    indirect = _write(tmp_path, "INDIR.ls", "/PROG  INDIR\n/MN\n   1:  PR[R[3]]=LPOS    ;\n/POS\n/END\n")
    res = rc.filter_program([program, indirect], truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                            references=[posreg])
    assert any("INDIR.ls:3: a register whose number is known at run time" in w for w in res.warnings)


def test_the_frames_of_the_backup_sysframe_va_are_the_ones_used(tmp_path):
    """SYSFRAME.VA ($MNUFRAME, $MNUTOOL) gives UF 1 and UT 2 as --frame / --tool did: the same
    output bytes; a --frame given overrides the backup's."""
    from robocal.programs.dialects.fanuc.reader import FanucDialect
    from robocal.programs.dialects.fanuc.sysframe import read_sysframe

    sysframe = tmp_path / "SYSFRAME.VA"
    sysframe.write_bytes((Path(__file__).parent / "data" / "fanuc_backup" / "SYSFRAME.VA").read_bytes())
    user, tool = read_sysframe(ProgramText(sysframe), FanucDialect().to_pose)
    assert sorted(user) == sorted(tool) == ["1", "2", "3"]
    np.testing.assert_allclose(user["2"], _pose([500, -200, 80, 0.5, 0, 90]), atol=1e-12)
    np.testing.assert_allclose(tool["2"], _pose([0, 0, 150, 0, 0, 0]), atol=1e-12)
    nominal, truth = _models()
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    given = rc.filter_program(program, truth, nominal, frames={"1": FRAME}, tools={"2": TOOL},
                              references=[posreg])
    backup = rc.filter_program(program, truth, nominal, references=[posreg, sysframe])
    assert backup.outputs == given.outputs and not any("differ" in w for w in backup.warnings)
    other = rc.filter_program(program, truth, nominal, frames={"1": "120,0,0,0,0,0"},
                              references=[posreg, sysframe])
    assert other.outputs[program] != given.outputs[program]


def test_main_section_is_one_span_for_reader_registers_and_marker():
    """sections.main_section: /MN to the /POS header after it (a remark '! see /POS' is no
    header), else the end; the register writes found in it are those of /MN only."""
    from robocal.programs.dialects.fanuc.registers import assignments
    from robocal.programs.dialects.fanuc.sections import main_section

    text = ("/PROG T\n/MN\n   1:  ! see /POS ;\n   2:  PR[5]=LPOS ;\n/POS\n"
            "   3:  PR[6]=LPOS ;\n/END\n")
    start, stop = main_section(text)
    assert text[start:].startswith("/MN") and text[stop:].startswith("/POS\n   3")
    no_pos = "/PROG T\n/MN\n   1:  PR[7]=LPOS ;\n"
    assert main_section(no_pos) == (8, len(no_pos))
    assert main_section("/PROG T\n/POS\n/END\n") is None
    out, indirect = assignments([ProgramText(Path("t.ls"), text.encode())])
    assert out == {5: "t.ls:4"} and indirect == []
