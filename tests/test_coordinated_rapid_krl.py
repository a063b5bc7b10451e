"""Programs with external axes (issue 45): RAPID and KRL readers fill the axes and the frames a
mechanical unit carries; uncoordinated values are arm targets; coordinated targets are named
without a cell and corrected with one, landing on a hidden true cell (tests/cell_programs.py)."""

from __future__ import annotations

import re

import cell_programs as cp
import numpy as np
import pytest

from robocal.core.errors import DataError
from robocal.programs import filter_program
from robocal.programs.dialects.krl.reader import KRLDialect
from robocal.programs.dialects.rapid.reader import RapidDialect
from robocal.programs.dialects.writing import frame_text
from robocal.programs.registry import dialect_named
from robocal.programs.source import ProgramText

# The goal (issue 45): coordinated targets filtered land on the true cell within this factor of the
# calibrated model's own error plus this margin (file rounding: 0.001 mm, 1e-6 quaternion), and at
# least this many times better than unfiltered.
GOAL_FACTOR, GOAL_MARGIN_M, GOAL_GAIN = 1.3, 0.002e-3, 10.0


def _rapid(tmp_path, text: str):
    path = tmp_path / "m.mod"
    path.write_bytes(text.encode())
    return path, RapidDialect().parse([ProgramText(path)], {}, {})


RAPID = """MODULE Stn
  PERS tooldata tTorch:=[TRUE,[[0,0,300],[1,0,0,0]],[4,[0,0,100],[1,0,0,0],0,0,0]];
  PERS wobjdata wobjSTN1:=[FALSE,FALSE,"STN1",[[0,0,0],[1,0,0,0]],[[0,0,250],[1,0,0,0]]];
  PERS wobjdata wobjMoved:=[FALSE,FALSE,"STN2",[[100,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  TASK PERS wobjdata wobjHeld:=[TRUE,TRUE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  PERS wobjdata wobjNoUnit:=[FALSE,FALSE,"",[[0,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST robtarget p1:=[[10,20,30],[0,0,1,0],[0,0,0,0],[9E+09,30.5,-120,9E+09,9E+09,9E+09]];
  CONST robtarget p2:=[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,0,0,9E9,9E9,9E9]];
  PROC main()
    ActUnit STN1;
    MoveL p1,v100,fine,tTorch\\WObj:=wobjSTN1;
    MoveL p2,v100,fine,tTorch;
    DeactUnit STN1;
  ENDPROC
ENDMODULE
"""


def test_rapid_reads_axes_and_the_units_moving_work_objects(tmp_path):
    """eax values as data (9E9 and 9E9 written 9E9: unused), ufmec of robhold FALSE / ufprog
    FALSE work objects as carried frames in oframe (the controller defines a moving work object's
    uframe: a stored one that is not the identity is said and not used, as in RobotStudio's
    exports, which store the plate's world pose there); robhold TRUE and ufprog FALSE without a
    unit stay unsupported, each with its own reason."""
    _, prog = _rapid(tmp_path, RAPID)
    p1, p2 = prog.targets
    assert p1.axes == {"eax_b": 30.5, "eax_c": -120.0} and p2.axes == {"eax_b": 0.0, "eax_c": 0.0}
    assert prog.carried == {"wobjstn1": "STN1", "wobjmoved": "STN2"}
    assert np.allclose(prog.frames["wobjstn1"][:3, 3], [0, 0, 0.25])
    said = "wobjMoved moves with STN2: its uframe (100.0, 0.0, 0.0 mm ...) is not used"
    assert any(said in w for w in prog.warnings) and np.allclose(prog.frames["wobjmoved"], np.eye(4))
    assert "robhold TRUE" in prog.unsupported["frame:wobjheld"]
    assert "ufmec ''" in prog.unsupported["frame:wobjnounit"]
    assert not any("ActUnit" in w for w in prog.warnings)  # STN1 is activated; STN2 moves no used target
    _, prog = _rapid(tmp_path, RAPID.replace("ActUnit STN1;", ""))
    assert [w for w in prog.warnings if "ActUnit" in w] == [
        "no ActUnit STN1 in these files: the work objects STN1 moves follow it only while it is active "
        "(activated at start-up or by another module?)"]


def test_without_a_cell_coordinated_targets_are_named_and_the_others_corrected(tmp_path):
    """A plain arm: the STN1 target is named with the unit and the cell file to give; the wobj0
    target with eax values is corrected as an arm target; every motion accounted."""
    nominal = cp.cells(0)[0].arms["arm"]
    path, _ = _rapid(tmp_path, RAPID)
    res = filter_program(path, cp.perturbed(nominal, 3), nominal)
    assert res.summary_dict()["motions"] == {"total": 2, "corrected": 1, "named": 1}
    named = next(m for m in res.motions if m.status == "named")
    assert named.target == "p1" and named.reason == ("p1: coordinated with STN1: give a cell file (--model "
                                                     "CELL.yaml) whose positioner has unit STN1")
    assert sum("external-axis values (eax_b, eax_c)" in w for w in res.warnings) == 1


def _krl(tmp_path, src: str, dat: str, config: str | None):
    paths = [tmp_path / "w.src", tmp_path / "w.dat"]
    paths[0].write_text(src)
    paths[1].write_text(dat)
    refs = []
    if config is not None:
        refs = [tmp_path / "$config.dat"]
        refs[0].write_text(config)
    prog = KRLDialect().parse([ProgramText(p) for p in paths], {}, {}, [ProgramText(p) for p in refs])
    return paths, refs, prog


KRL_DAT = ("DEFDAT w\nDECL E6POS XP1={X 10.0,Y 0.0,Z 5.0,A 0.0,B 0.0,C 180.0,S 6,T 50,E1 12.5,E2 -40.0,"
           "E3 0.0,E4 0.0,E5 0.0,E6 0.0}\n"
           "DECL FDAT FP1={TOOL_NO 1,BASE_NO 3,IPO_FRAME #BASE,POINT2[] \" \"}\nENDDAT\n")
KRL_CONFIG = ('DEFDAT $CONFIG\nMACHINE_DEF[2]={NAME[] "DKP400",COOP_KRC_INDEX 1,PARENT[] "WORLD",'
              'ROOT {X 1100.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0},MECH_TYPE #EASYS,GEOMETRY[] " "}\n'
              'MACHINE_FRAME_DAT[3]={MACH_DEF_INDEX 2,PARENT[] "DKP400",GEOMETRY[] " "}\n'
              "TOOL_DATA[1]={X 0.0,Y 0.0,Z 250.0,A 0.0,B 0.0,C 0.0}\n"
              "BASE_DATA[3]={X 50.0,Y 0.0,Z 120.0,A 30.0,B 0.0,C 0.0}\nENDDAT\n")


@pytest.mark.parametrize("base", ["$BASE=EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,BASE_DATA[3])",
                                  "BAS(#BASE,3)", "FDAT_ACT=FP1"])
def test_krl_reads_bases_on_an_external_kinematic(tmp_path, base):
    """EK(MACHINE_DEF[m].ROOT, ..., BASE_DATA[n]), BAS(#BASE, n) and an inline form's FDAT with
    MACHINE_FRAME_DAT[n] on machine m: the base is carried by the machine's NAME, its frame
    BASE_DATA[n] (in the machine's flange frame); E1..E6 as data, zeros included."""
    src = f"DEF w( )\n  $TOOL=TOOL_DATA[1]\n  {base}\n  LIN XP1\nEND\n"
    _, _, prog = _krl(tmp_path, src, KRL_DAT, KRL_CONFIG)
    (t,) = prog.targets
    assert prog.carried == {"3@DKP400": "DKP400"} and t.frame == "3@DKP400"
    assert np.allclose(prog.frames["3@DKP400"], prog.frames["3"])
    assert t.axes == {"E1": 12.5, "E2": -40.0, "E3": 0.0, "E4": 0.0, "E5": 0.0, "E6": 0.0}
    nominal = cp.cells(0, arm=cp.KUKA_ARM)[0].arms["arm"]
    paths, refs, _ = _krl(tmp_path, src, KRL_DAT, KRL_CONFIG)
    res = filter_program(paths, nominal, nominal, references=refs)  # a plain arm: named
    assert [m.reason for m in res.motions] == ["XP1: coordinated with DKP400: give a cell file (--model "
                                               "CELL.yaml) whose positioner has unit DKP400"]


def test_krl_external_kinematic_without_its_declaration_is_named(tmp_path):
    """EK of a machine no file declares (no $config.dat): with a plain arm each motion is named with
    what to give; a plain BAS(#BASE, n) without MACHINE_FRAME_DAT stays a fixed base; an EK literal
    offset is read."""
    src = "DEF w( )\n  $TOOL=TOOL_DATA[1]\n" \
          "  $BASE=EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,BASE_DATA[3])\n" \
          "  LIN XP1\nEND\n"
    nominal = cp.cells(0, arm=cp.KUKA_ARM)[0].arms["arm"]
    paths, _, prog = _krl(tmp_path, src, KRL_DAT, None)
    res = filter_program(paths, nominal, nominal, tools={"1": "0,0,250,0,0,0"})
    assert res.summary_dict()["motions"] == {"total": 1, "corrected": 0, "named": 1}
    assert res.motions[0].reason == (
        "XP1: coordinated with a unit the files do not name (MACHINE_DEF[2], declared in no file given): "
        "give a cell file (--model CELL.yaml) with its positioner (and the file naming the unit, e.g. "
        "$config.dat, with --references)")
    config = KRL_CONFIG.replace("{MACH_DEF_INDEX 2", "{MACH_DEF_INDEX 0")
    _, _, prog = _krl(tmp_path, src.replace(src.splitlines()[2], "  BAS(#BASE,3)"), KRL_DAT, config)
    assert prog.targets[0].frame == "3" and not prog.carried
    literal = "  $BASE=EK(MACHINE_DEF[2].ROOT,#EASYS,{X 10.0,Y 0.0,Z 100.0,A 90.0,B 0.0,C 0.0})"
    _, _, prog = _krl(tmp_path, src.replace(src.splitlines()[2], literal), KRL_DAT, KRL_CONFIG)
    (key,) = prog.carried
    assert prog.carried[key] == "DKP400" and np.allclose(prog.frames[key][:3, 3], [0.01, 0, 0.1])


def test_each_dialect_names_the_logical_external_axes():
    """A positioner's logical external axes (2, 3) as each language's programs name them: RAPID and
    KRL among the robot's external axes, FANUC's motion group and INFORM's station their own axes
    1..m; a language without external axes, or an axis beyond its names, is refused."""
    names = {k: dialect_named(k).positioner_axes((2, 3)) for k in ("rapid", "krl", "fanuc", "inform")}
    assert names == {"rapid": ("eax_b", "eax_c"), "krl": ("E2", "E3"), "fanuc": ("E1", "E2"),
                     "inform": ("E1", "E2")}
    assert dialect_named("rapid").positioner_axes((6, 1)) == ("eax_f", "eax_a")
    with pytest.raises(DataError, match="no name for external axis 7"):
        dialect_named("krl").positioner_axes((7,))
    with pytest.raises(DataError, match="URScript programs name no external axes"):
        dialect_named("urscript").positioner_axes((1,))


def _identity_outside_numbers(d, before: list, after: list, refs=()) -> None:
    """Every byte of the files outside the pose numbers of the targets is unchanged."""
    def stripped(paths):
        texts = [ProgramText(p) for p in paths]
        prog = d.parse(texts, {}, {}, [ProgramText(p) for p in refs])
        spans = {}
        for t in prog.targets:
            spans.setdefault(t.source.path.name, []).extend((n.start, n.end) for n in t.numbers)
        out = []
        for s in texts:
            text, pos, parts = s.text, 0, []
            for a, b in sorted(spans.get(s.path.name, [])):
                parts.append(text[pos:a])
                pos = b
            out.append("#".join([*parts, text[pos:]]))
        return out

    assert stripped(before) == stripped(after)


def _goal(before: dict, after: dict, model: np.ndarray) -> dict:
    rms = {k: float(np.sqrt(np.mean(v ** 2))) for k, v in
           (("unfiltered", before["error"]), ("filtered", after["error"]), ("model", model))}
    assert rms["filtered"] <= GOAL_FACTOR * rms["model"] + GOAL_MARGIN_M, rms
    assert (after["error"] <= GOAL_FACTOR * model + GOAL_MARGIN_M).all(), rms
    assert rms["unfiltered"] >= GOAL_GAIN * rms["filtered"], rms
    return rms


@pytest.mark.parametrize("robotstudio", [False, True])
def test_coordinated_rapid_targets_land_on_the_true_cell(tmp_path, robotstudio):
    """Declared robtargets in ABB's example style; or inline ones with the plate's world pose
    stored as the uframe, as RobotStudio exports them (not used: the targets still land)."""
    nominal, true, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 30)
    path = cp.rapid_program(tmp_path, nominal, q, e, T, robotstudio=robotstudio)
    res = filter_program(path, calibrated, nominal)
    assert res.summary_dict()["motions"] == {"total": 32, "corrected": 32, "named": 0}
    assert sum("its uframe" in w for w in res.warnings) == robotstudio
    out = tmp_path / "out.mod"
    out.write_bytes(res.outputs[path])
    _identity_outside_numbers(RapidDialect(), [path], [out])
    before = cp.landing([path], [], nominal, true)
    after = cp.landing([out], [], nominal, true, intended=[path])
    _goal(before, after, cp.model_error(after["q"], after["e"], calibrated, true))


@pytest.mark.parametrize("form", ["ek", "bas", "spline"])
def test_coordinated_krl_targets_land_on_the_true_cell(tmp_path, form):
    nominal, true, calibrated = cp.cells(3, arm=cp.KUKA_ARM, unit="DKP400", external_axes=(1, 2))
    q, e, T = cp.poses(nominal, 30)
    paths, config = cp.krl_program(tmp_path, nominal, q, e, T, form=form)
    res = filter_program(paths, calibrated, nominal, references=[config])
    assert res.summary_dict()["motions"] == {"total": 31, "corrected": 31, "named": 0}
    outs = [tmp_path / f"out_{p.name}" for p in paths]
    for p, o in zip(paths, outs, strict=True):
        o.write_bytes(res.outputs[p])
    _identity_outside_numbers(KRLDialect(), paths, outs, [config])
    before = cp.landing(paths, [config], nominal, true)
    after = cp.landing(outs, [config], nominal, true, intended=paths)
    _goal(before, after, cp.model_error(after["q"], after["e"], calibrated, true))


def test_refusals_name_the_cause_in_one_line(tmp_path):
    """A unit the cell does not have, a value outside the positioner's limits: one line each."""
    nominal, _, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 3)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    text = path.read_bytes()
    path.write_bytes(text.replace(b'"STN1"', b'"STN2"'))
    with pytest.raises(DataError, match=r"^stn_weld.mod:\d+ \(pW0\): the program moves with mechanical unit "
                                        r"STN2, which is not in the cell \(its positioners: STN1\)[^\n]*$"):
        filter_program(path, calibrated, nominal)
    m = re.search(rb"\[9E\+09,(-?[\d.]+),", text)
    path.write_bytes(text[:m.start(1)] + b"95.000" + text[m.end(1):])
    with pytest.raises(DataError, match=r"^stn_weld.mod:\d+ \(pW0\): STN1 axis eax_b = 95 deg "
                                        r"\(limits -90 \.\. 90\): outside the positioner's limits[^\n]*$"):
        filter_program(path, calibrated, nominal)


def test_a_cell_refuses_a_robot_base(tmp_path):
    nominal, _, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 2)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    with pytest.raises(DataError, match=r"^robot_base \(--robot-base\) is for an arm alone"):
        filter_program(path, calibrated, nominal, robot_base=np.eye(4))


def test_a_coordinated_target_without_its_positioner_values_is_named(tmp_path):
    nominal, _, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 3)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    text = path.read_bytes()
    m = re.search(rb"pW1:=\[[^;]*\[9E\+09,(-?[\d.]+),", text)
    path.write_bytes(text[:m.start(1)] + b"9E+09" + text[m.end(1):])
    res = filter_program(path, calibrated, nominal)
    named = [m for m in res.motions if m.status == "named"]
    assert [m.target for m in named] == ["pW1"] and "gives no value for its axis eax_b" in named[0].reason
    assert res.summary_dict()["motions"] == {"total": 5, "corrected": 4, "named": 1}


def test_the_filter_command_takes_the_cell_files(tmp_path, capsys):
    """robocal filter PROGRAM --model CELL.yaml --calibrated CALIBRATED_CELL.yaml: the cell files as
    Cell.save writes them; the output is what the API gives; a program's unknown unit is one line
    and nothing is written."""
    from robocal.cli import main

    nominal, _, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 5)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    nominal.save(tmp_path / "cell.yaml")
    calibrated.save(tmp_path / "calibrated_cell.yaml")
    out = tmp_path / "out.mod"
    args = ["filter", str(path), "--model", str(tmp_path / "cell.yaml"), "--calibrated",
            str(tmp_path / "calibrated_cell.yaml"), "-o", str(out)]
    assert main(args) == 0
    api = tmp_path / "api.mod"
    filter_program(path, calibrated, nominal).write(api)
    assert out.read_bytes() == api.read_bytes()
    assert "7 motions: 7 corrected" in capsys.readouterr().out
    path.write_bytes(path.read_bytes().replace(b'"STN1"', b'"STN7"'))
    out.unlink()
    assert main(args) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "mechanical unit STN7, which is not in the cell" in err[0] and not out.exists()


def test_a_calibrated_plate_far_from_the_nominal_one_is_said(tmp_path):
    """A calibrated positioner mounted 40 mm from the nominal cell's (another cell's calibration, or a
    mount drawn far off): corrected, and one warning gives how far the plate moved."""
    import robocal as rc
    from robocal.kinematics.transforms import make_transform

    nominal, _, calibrated = cp.cells(0)
    q, e, T = cp.poses(nominal, 4)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    assert not any("plate is up to" in w for w in filter_program(path, calibrated, nominal).warnings)
    p = calibrated.positioners["turntable"]
    far = rc.Positioner(p.chain.with_frames(base=p.chain.base @ make_transform(np.eye(3), [0.04, 0, 0])),
                        p.unit, external_axes=p.external_axes)
    moved = rc.Cell(calibrated.arms, {"turntable": far})
    res = filter_program(path, moved, nominal, keep_unreached=True)
    said = [w for w in res.warnings if "plate is up to" in w]
    assert len(said) == 1 and re.match(r"the calibrated STN1's plate is up to (3[89]|4[01])\.\d mm", said[0])


def test_station_values_of_a_prismatic_axis_are_millimetres(tmp_path):
    """A lift (prismatic, mm in programs) and a turn (deg): values read by logical axis, SI out;
    the limits refused in the axis' unit."""
    from robocal.kinematics.positioner import positioner_chain
    from robocal.programs.positioner import Station
    from robocal.programs.target import Target

    chain = positioner_chain([{"type": "prismatic", "axis": [0, 0, 1], "limits": [0.0, 0.5]},
                              {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.3]}])
    station = Station("LIFT", chain, chain, (1, 2))
    axes = station.axes(dialect_named("rapid"))
    (tmp_path / "p.mod").write_text("MODULE m\nENDMODULE\n")
    t = Target(ProgramText(tmp_path / "p.mod"), 0, "p", [], axes={"eax_a": 250.0, "eax_b": 90.0})
    assert axes == ("eax_a", "eax_b") and np.allclose(station.values(t, axes), [0.25, np.pi / 2])
    t.axes["eax_a"] = 600.0
    with pytest.raises(DataError, match=r"^p.mod:1 \(p\): LIFT axis eax_a = 600 mm \(limits 0 \.\. 500\)"):
        station.check_limits(t, station.values(t, axes), axes)
    assert "no value for its axis E1, E2:" in station.values(t, station.axes(dialect_named("krl")))


@pytest.mark.parametrize("root", ["MACHINE_DEF[2].ROOT", "{X 1100.0,Y 450.0,Z 0.0,A 0.0,B 0.0,C 0.0}"])
def test_krl_unnamed_machine_is_the_cells_only_positioner(tmp_path, root):
    """A KRL program whose EK machine no file names (no $config.dat; or a literal root, K_ROOT, with
    #EASYS): with a cell of one positioner it is that one, said once; the targets land as with the
    machine named."""
    nominal, true, calibrated = cp.cells(3, arm=cp.KUKA_ARM, unit="DKP400", external_axes=(1, 2))
    q, e, T = cp.poses(nominal, 6)
    paths, config = cp.krl_program(tmp_path, nominal, q, e, T)
    src = paths[0].read_bytes().replace(b"EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,",
                                        f"EK({root},#EASYS,".encode())
    paths[0].write_bytes(src)
    tools = {"1": frame_text(cp.TOOL, "zyx")}
    frames = {"3": frame_text(cp.OFRAME, "zyx")}
    res = filter_program(paths, calibrated, nominal, tools=tools, frames=frames)
    said = [w for w in res.warnings if "a unit it does not name" in w]
    assert len(said) == 1 and said[0].endswith("taken as the cell's only positioner, DKP400")
    assert res.summary_dict()["motions"] == {"total": 7, "corrected": 7, "named": 0}
    named = filter_program(paths, calibrated, nominal, tools=tools, frames=frames, references=[config])
    if root.startswith("MACHINE_DEF"):  # $config.dat names it: the same corrections, nothing said
        assert named.outputs == res.outputs and not any("does not name" in w for w in named.warnings)


def test_krl_spline_form_without_config_says_the_base_is_taken_as_fixed(tmp_path):
    """EK(K_ROOT(FP1.BASE_NO), ...) without $config.dat: whether a machine carries base 3 is unknown;
    it is taken as a fixed base (KSS's own rule without MACHINE_FRAME_DAT), said once."""
    nominal, _, calibrated = cp.cells(3, arm=cp.KUKA_ARM, unit="DKP400", external_axes=(1, 2))
    q, e, T = cp.poses(nominal, 4)
    paths, _ = cp.krl_program(tmp_path, nominal, q, e, T, form="spline")
    prog = KRLDialect().parse([ProgramText(p) for p in paths], {}, {})
    assert not prog.carried and {t.frame for t in prog.targets} == {"3", "0"}
    said = [w for w in prog.warnings if "K_ROOT" in w]
    assert said == ["$BASE=EK(K_ROOT(..)) of base 3: whether a machine carries it is in $config.dat's "
                    "MACHINE_FRAME_DAT, not given (--references): taken as a fixed base"]


def test_two_arms_each_program_with_its_own_arm_in_the_shared_world(tmp_path):
    """A cell of two arms and a positioner: the first (ROB_1) anchors the world; ROB_2's program,
    filtered with arm='ROB_2', lands on the true plate although ROB_2 really stands 1.5 mm / 0.05
    deg from where the controller has it (its calibrated place in the shared world is used);
    without arm the run is refused naming the arms."""
    nominal, true, calibrated = cp.cells(0, two_arms=True)
    q, e, T = cp.poses(nominal, 20)
    path = cp.rapid_program(tmp_path, nominal, q, e, T)
    with pytest.raises(DataError, match=r"has arms left \(ROB_1\), arm \(ROB_2\): name the arm"):
        filter_program(path, calibrated, nominal)
    with pytest.raises(DataError, match=r"--arm turntable: not an arm of the cell"):
        filter_program(path, calibrated, nominal, arm="turntable")
    res = filter_program(path, calibrated, nominal, arm="ROB_2")
    out = tmp_path / "out.mod"
    out.write_bytes(res.outputs[path])
    before = cp.landing([path], [], nominal, true)
    after = cp.landing([out], [], nominal, true, intended=[path])
    rms = _goal(before, after, cp.model_error(after["q"], after["e"], calibrated, true))
    assert rms["unfiltered"] > 1e-3  # the placement error is seen unfiltered
