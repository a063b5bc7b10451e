"""Each motion of a program corrected with the load active where it runs.

Truth: a KR 210 R2700 whose payload compliance is known (the calibrated model *is* the truth, so
the model's own error is zero), a program that switches between two loads, written in each
vendor's syntax; the filtered program run by the nominal controller on the true robot at each
motion's load reaches the intended positions within the written numbers' resolution. Each motion's
correction is the one the same target gets filtered alone with ``--payload`` of its load.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from robocal import Robot
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.deploy.compensation import compensate
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.transforms import make_transform
from robocal.programs import filter_program
from robocal.programs.dialects.fanuc.loads import read_schedules
from robocal.programs.dialects.writing import wpr_text as fanuc_frame_text
from robocal.programs.load import LoadPlan, compensate_by_load
from robocal.programs.motions import summary
from robocal.programs.simulate import execute, write_program

N = 8  # targets; the load changes before target N // 2
HALF = N // 2
RESOLUTION_MM = 0.002  # the written positions' resolution and the orientation's effect on the TCP
TOOL = make_transform(Rotation.from_euler("z", 90, degrees=True).as_matrix(), np.array([0.05, 0.0, 0.25]))
FRAME = make_transform(np.eye(3), np.array([1.2, -0.4, 0.3]))


def payload_model(name: str, terms: dict[str, float], seed: int) -> tuple[Robot, Robot]:
    """``(nominal, calibrated)``: the catalog robot ``name`` and a perturbed copy (``seed``) with the
    payload compliance ``terms`` (rad/(kg m)), the truth a filtered program is judged against."""
    nominal = Robot.from_catalog(name)
    return nominal, perturbed(nominal, seed).with_joint_errors(list(terms)).with_values(terms)


def _robots():
    # rad/(kg m): ~1 mm at 150 kg
    return payload_model("kuka_kr210_r2700", {"payload2": 3e-6, "payload3": 4e-6, "payload5": 6e-6}, 5)


def _joints(nominal, n, seed=0):
    rng = np.random.default_rng(seed)
    mid, half = nominal.limits.mean(axis=1), np.minimum(np.ptp(nominal.limits, axis=1), 2 * np.pi) * 0.3
    q = rng.uniform(mid - half, mid + half, (6 * n, 6))
    return q[singularity_distance(nominal, q).sigma_rel > 0.05][:n]


def _tool0(mass_kg, cog_m, tool=None):
    """A load (kg, cog m) in tool0; ``tool``: the cog is given in that tool's frame."""
    c = np.asarray(cog_m, float)
    return np.array([mass_kg, *(c if tool is None else tool[:3, :3] @ c + tool[:3, 3])])


def _set_payload_after_tool(path, statement: str) -> None:
    """A FANUC TP program of write_program with ``statement`` (a PAYLOAD[...]) right after its
    UTOOL_NUM line."""
    text = path.read_bytes().decode()
    line = "   0:  UTOOL_NUM=1 ;"
    path.write_bytes(text.replace(line, f"{line}\r\n   0:  {statement} ;").encode())


def _insert_before(text: str, marker: str, line: str) -> str:
    at = text.index(marker)
    at = text.rindex("\n", 0, at) + 1
    return text[:at] + line + text[at:]


def _tool_file(path, tools: dict[int, tuple[str, str, float, tuple]]) -> Path:
    """A Yaskawa TOOL.CND as the controller saves it (64 blocks, CR LF) with ``tools``:
    number -> (name, frame text X,Y,Z,Rx,Ry,Rz (mm, deg), W kg, (Xg, Yg, Zg) mm); the rest empty."""
    lines = []
    for n in range(64):
        name, frame, kg, cog = tools.get(n, ("", "0,0,0,0,0,0", 0.0, (0, 0, 0)))
        f = [float(v) for v in frame.split(",")]
        lines += [f"//TOOL {n}", f"///NAME {name}".rstrip(),
                  ",".join([f"{v:.3f}" for v in f[:3]] + [f"{v:.4f}" for v in f[3:]]),
                  ",".join(f"{v:.3f}" for v in cog), f"{kg:.3f}", "0.000,0.000,0.000", "0.000,0,1"]
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode())
    return path


def _set_loads(dialect: str, paths, tmp_path):
    """Edit the written program to run targets 0..HALF-1 with load A and the rest with load B.
    Returns (A, B) in tool0 (kg, m) and the filter's extra arguments."""
    kwargs = {}
    if dialect == "krl":
        src = paths[0]
        text = src.read_text()
        text = text.replace(
            "  $TOOL = TOOL_DATA[1]\n",
            "  $TOOL = TOOL_DATA[1]\n  $LOAD = {M 150.0, CM {X 0.0, "
            "Y 0.0, Z 300.0, A 0.0, B 0.0, C 0.0}, J {X 0.0, Y 0.0, Z 0.0}}\n",
        )
        text = _insert_before(text, f" XP{HALF}\n", "  $LOAD = LOAD_DATA[4]\n")
        src.write_text(text)
        config = tmp_path / "$config.dat"
        config.write_text(
            "DEFDAT  $CONFIG\nDECL LOAD LOAD_DATA[4]={M 20.0,CM {X 50.0,Y 0.0,Z 100.0,A 0.0,B 0.0,"
            "C 0.0},J {X 0.0,Y 0.0,Z 0.0}}\nENDDAT\n"
        )
        kwargs["references"] = [config]
        return _tool0(150, [0, 0, 0.3]), _tool0(20, [0.05, 0, 0.1]), kwargs
    if dialect == "rapid":
        src = paths[0]
        text = src.read_bytes().decode()
        text = text.replace(
            "[1,[0,0,50],[1,0,0,0],0,0,0]];",
            "[20,[0,0,100],[1,0,0,0],0,0,0]];\r\n"
            "    PERS loaddata part:=[130,[0,0,200],[1,0,0,0],0.5,0.5,0.5];",
        )
        text = text.replace("    PROC main()\r\n", "    PROC main()\r\n        GripLoad part;\r\n")
        text = _insert_before(text, f" p{HALF}, v500", "        GripLoad load0;\r\n")
        src.write_bytes(text.encode())
        tool_load = _tool0(20, [0, 0, 0.1])
        part = _tool0(130, [0, 0, 0.2], TOOL)  # a payload's cog is in the tool frame
        both = np.array([150.0, *((tool_load[0] * tool_load[1:] + part[0] * part[1:]) / 150.0)])
        return both, tool_load, kwargs
    if dialect == "fanuc":
        src = paths[0]
        _set_payload_after_tool(src, "PAYLOAD[3]")
        text = _insert_before(src.read_bytes().decode(), f" P[{HALF + 1}] ",
                              "   0:  PAYLOAD[5:gripper empty] ;\r\n")
        src.write_bytes(text.encode())
        schedules = tmp_path / "payloads.csv"
        schedules.write_text(
            "schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm\n3,150,0,0,30\n5,20,5,0,10\n"
        )
        kwargs["payload_schedules"] = schedules
        return _tool0(150, [0, 0, 0.3]), _tool0(20, [0.05, 0, 0.1]), kwargs
    if dialect == "inform":  # the positions of the second half taught with tool 2: the same gripper
        # holding less, its load in the controller's tool file
        src = paths[0]
        text = src.read_bytes().decode()
        src.write_bytes(text.replace(f"\r\nC{HALF:05d}=", f"\r\n///TOOL 2\r\nC{HALF:05d}=").encode())
        tool = fanuc_frame_text(TOOL)  # X,Y,Z,Rx,Ry,Rz as the pendant's tool screen
        loads = {1: ("GRIPPER+PART", tool, 150.0, (0, 0, 300)), 2: ("GRIPPER", tool, 20.0, (50, 0, 100))}
        kwargs["references"] = [_tool_file(tmp_path / "TOOL.CND", loads)]
        return _tool0(150, [0, 0, 0.3]), _tool0(20, [0.05, 0, 0.1]), kwargs
    src = paths[0]  # URScript
    text = src.read_text()
    text = text.replace("def sim():\n", "def sim():\n  set_payload(150.0, [0.0, 0.0, 0.3])\n")
    lines = text.split("\n")
    moves = [k for k, line in enumerate(lines) if line.strip().startswith("movel(")]
    lines.insert(moves[HALF], "  set_payload(20.0, [0.05, 0.0, 0.1])")
    src.write_text("\n".join(lines))
    return _tool0(150, [0, 0, 0.3]), _tool0(20, [0.05, 0, 0.1]), kwargs


@pytest.mark.parametrize("dialect", ["krl", "rapid", "fanuc", "urscript", "inform"])
def test_each_motion_runs_with_the_load_set_before_it_and_reaches_the_truth(dialect, tmp_path):
    nominal, cal = _robots()
    q = _joints(nominal, N)
    folder = tmp_path / "in"
    folder.mkdir()
    paths, tools, frames = write_program(dialect, folder, nominal, q, TOOL, FRAME)
    a, b, kwargs = _set_loads(dialect, paths, tmp_path)
    res = filter_program(paths, cal, nominal, tools=tools, frames=frames, **kwargs)
    counts = summary(res.motions)
    assert counts == {"total": N, "corrected": N, "named": 0}  # every motion corrected or named
    assert len(res.loads) == 2 and all(f"{N // 2} motion(s)" in line for line in res.loads)
    assert res.loads[0].startswith("150 kg") and res.loads[1].startswith("20 kg")
    assert not [w for w in res.warnings if "assumed" in w]
    out = []
    for p in paths:
        o = tmp_path / p.name
        o.write_bytes(res.outputs[p])
        out.append(o)
    refs = kwargs.get("references", ())
    truth = cal.with_frames(base=nominal.base, tool=nominal.tool)
    for load, rows in ((a, slice(0, HALF)), (b, slice(HALF, N))):
        reached, _ = execute(
            out, truth.with_conditions(load), nominal, tools=tools, frames=frames, references=refs
        )
        unfiltered, wanted = execute(
            paths, truth.with_conditions(load), nominal, tools=tools, frames=frames, references=refs
        )
        err = np.linalg.norm(reached[rows, :3, 3] - wanted[rows, :3, 3], axis=1) * 1e3
        before = np.linalg.norm(unfiltered[rows, :3, 3] - wanted[rows, :3, 3], axis=1) * 1e3
        assert err.max() < RESOLUTION_MM, (dialect, err)
        assert before.min() > 50 * RESOLUTION_MM  # the errors were there to correct
        # the same motions filtered alone with --payload of their load: the same corrections
        alone = filter_program(
            paths,
            cal,
            nominal,
            tools=tools,
            frames=frames,
            payload=load,
            **{k: v for k, v in kwargs.items() if k == "references"},
        )
        assert [r["correction_mm"] for r in alone.rows[rows]] == [r["correction_mm"] for r in res.rows[rows]]
        assert alone.loads == [
            f"{load[0]:g} kg, centre of mass [{', '.join(f'{c * 1e3:.4g}' for c in load[1:])}] "
            "mm (--payload): every motion"
        ]


def _rapid_routine_program(tmp_path, nominal):
    """A RAPID module whose routine Approach is called with the part gripped and after releasing it."""
    paths, _, _ = write_program("rapid", tmp_path, nominal, _joints(nominal, 3), TOOL, FRAME)
    text = (
        paths[0]
        .read_bytes()
        .decode()
        .replace(
            "[1,[0,0,50],[1,0,0,0],0,0,0]];",
            "[20,[0,0,100],[1,0,0,0],0,0,0]];\r\n    PERS loaddata part:=[130,[0,0,200],[1,0,0,0],0,0,0];",
        )
    )
    head, _, _ = text.partition("    PROC main()")
    body = [
        "    PROC main()",
        "        MoveJ p0, v1000, fine, tReal\\WObj:=wCell;",
        "        GripLoad part;",
        "        Approach;",
        "        GripLoad load0;",
        "        Approach;",
        "        MoveL p2, v500, fine, tReal\\TLoad:=part\\WObj:=wCell;",
        "    ENDPROC",
        "    PROC Approach()",
        "        MoveL p1, v500, z10, tReal\\WObj:=wCell;",
        "    ENDPROC",
        "ENDMODULE",
        "",
    ]
    paths[0].write_bytes((head + "\r\n".join(body)).encode())
    return paths[0]


def test_a_target_run_with_two_loads_is_corrected_for_its_first_and_the_motion_named(tmp_path):
    nominal, cal = _robots()
    path = _rapid_routine_program(tmp_path, nominal)
    res = filter_program([path], cal, nominal)
    counts = summary(res.motions)
    assert counts == {"total": 3, "corrected": 2, "named": 1}
    named = next(m for m in res.motions if m.status == "named")
    assert named.instruction == "MoveL" and "p1" in named.target
    assert "corrected for the load of its first execution (150 kg" in named.reason
    assert "runs with 20 kg" in named.reason and "declare a copy of the target for each load" in named.reason
    assert any("not corrected: its target p1" in w for w in res.warnings)
    by_load = {line.split(" kg")[0]: line for line in res.loads}
    assert set(by_load) == {"20", "150", "130"}  # \TLoad:=part is p2's whole load, in tool0
    assert "(\\TLoad:=part)" in by_load["130"] and "centre of mass [0, 0, 200] mm" in by_load["130"]
    # p1 is corrected as with the part gripped (its first execution)
    part_in_tool0 = _tool0(130, [0, 0, 0.2], TOOL)
    grip = np.array([150.0, *((20 * np.array([0, 0, 0.1]) + 130 * part_in_tool0[1:]) / 150)])
    alone = filter_program([path], cal, nominal, payload=grip)
    assert [r["correction_mm"] for r in alone.rows if r["name"] == "p1"] == [
        r["correction_mm"] for r in res.rows if r["name"] == "p1"
    ]


def test_unreadable_or_missing_load_data_is_a_clear_error(tmp_path):
    nominal, cal = _robots()
    paths, tools, frames = write_program("fanuc", tmp_path, nominal, _joints(nominal, 2), TOOL, FRAME)
    _set_payload_after_tool(paths[0], "PAYLOAD[2]")
    with pytest.raises(
        DataError,
        match=r"sim.ls:7: PAYLOAD\[2\]: the payload schedules live in the controller: "
        r"give them with --payload-schedules",
    ):
        filter_program(paths, cal, nominal, tools=tools, frames=frames)
    with pytest.raises(
        DataError, match=r"payload schedule 2 is not in the schedules given \(they hold \[1\]\)"
    ):
        filter_program(paths, cal, nominal, tools=tools, frames=frames, payload_schedules={1: (10, 0, 0, 0)})
    given = filter_program(
        paths, cal, nominal, tools=tools, frames=frames, payload=[10.0]
    )  # --payload: every motion
    assert given.loads == ["10 kg, centre of mass [0, 0, 0] mm (--payload): every motion"]
    with pytest.raises(DataError, match="--payload-schedules is for FANUC programs"):
        filter_program(
            [_rapid_routine_program(tmp_path, nominal)], cal, nominal, payload_schedules={1: (1, 0, 0, 0)}
        )
    script = tmp_path / "cell.script"
    script.write_text(
        "def cell():\n  set_payload(m_part, [0, 0, 0.1])\n  movel(p[1.2, 0.2, 0.8, 3.14, 0, 0])\nend\n"
    )
    with pytest.raises(
        DataError,
        match=r"cell.script:2: set_payload\(m_part, \[0, 0, 0.1\]\): the payload is not "
        "written as numbers; give the load with --payload",
    ):
        filter_program([script], cal, nominal)


def test_fanuc_payload_schedules_from_sysvars_va_and_csv(tmp_path):
    va = tmp_path / "SYSVARS.VA"
    va.write_text(
        "[*SYSTEM*]$PLST_GRP1  Storage: CMOS  Access: RW  : ARRAY[10] OF PLST_GRP_T\n"
        "     Field: $PLST_GRP1[1].$COMMENT Access: RW: STRING[17] = 'GRIPPER'\n"
        "     Field: $PLST_GRP1[1].$PAYLOAD Access: RW: REAL = 4.500000e+01\n"
        "     Field: $PLST_GRP1[1].$PAYLOAD_X Access: RW: REAL = 0.000000e+00\n"
        "     Field: $PLST_GRP1[1].$PAYLOAD_Y Access: RW: REAL = -2.500000e+00\n"
        "     Field: $PLST_GRP1[1].$PAYLOAD_Z Access: RW: REAL = 1.500000e+01\n"
        "     Field: $PLST_GRP1[1].$PAYLOAD_IX Access: RW: REAL = 1.200000e+00\n"
        "     Field: $PLST_GRP1[2].$PAYLOAD Access: RW: REAL = -9999\n"
        "     Field: $PLST_GRP1[2].$PAYLOAD_X Access: RW: REAL = 0\n"
    )
    got = read_schedules(va)
    assert list(got) == [1]  # schedule 2 is the factory's placeholder: not set
    np.testing.assert_allclose(got[1], [45.0, 0.0, -0.025, 0.15])  # cm -> m
    csv_file = tmp_path / "p.csv"
    csv_file.write_text("schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm\n1,45,0,-2.5,15\n")
    assert read_schedules(csv_file) == got
    csv_file.write_text("schedule,mass\n1,45\n")
    with pytest.raises(DataError, match="not a SYSVARS.VA with \\$PLST_GRP1 nor a CSV with the header"):
        read_schedules(csv_file)


def test_filter_cli_reads_fanuc_payload_schedules_and_prints_the_loads(tmp_path, capsys):
    nominal, cal = _robots()
    cal.save(tmp_path / "cal.yaml")
    paths, tools, frames = write_program("fanuc", tmp_path, nominal, _joints(nominal, 4), TOOL, FRAME)
    _set_payload_after_tool(paths[0], "PAYLOAD[1]")
    (tmp_path / "pl.csv").write_text(
        "schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm\n1,90,0,0,25\n"
    )
    args = [
        "filter",
        str(paths[0]),
        "--calibrated",
        str(tmp_path / "cal.yaml"),
        "--nominal",
        "kuka_kr210_r2700",
        "-o",
        str(tmp_path / "out.ls"),
        "--tool",
        f"1={tools['1']}",
        "--frame",
        f"1={frames['1']}",
    ]
    assert main(args) == 2
    assert "--payload-schedules" in capsys.readouterr().err
    assert main([*args, "--payload-schedules", str(tmp_path / "pl.csv")]) == 0
    out = capsys.readouterr().out
    assert (
        "load: 90 kg, centre of mass [0, 0, 250] mm (sim.ls:7 (PAYLOAD[1])): 4 motion(s), sim.ls lines 8-11"
        in out
    )
    table = json.loads((tmp_path / "out.ls.targets.json").read_text())
    assert table["loads"] == [
        "90 kg, centre of mass [0, 0, 250] mm (sim.ls:7 (PAYLOAD[1])): 4 motion(s), sim.ls lines 8-11"
    ]


CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"


def _payload_model(name: str) -> tuple[Robot, Robot]:
    return payload_model(name, {"payload2": 2e-5, "payload3": 3e-5}, 3)


def test_corpus_machine_tending_gripload_and_tload():
    """A RAPID cell whose routines grip and release parts: each motion with its tool's load plus the
    part it holds; a position reached empty-handed and loaded is named where it runs with the other."""
    nominal, cal = _payload_model("abb_irb2600")
    res = filter_program([CORPUS / "machine_tending.mod"], cal, nominal)
    assert summary(res.motions) == {"total": 9, "corrected": 5, "named": 4}
    assert res.loads == [
        "18.5 kg, centre of mass [0, 12, 95] mm (tooldata tgripper): 4 motion(s), machine_tending.mod "
        "lines 29-30, 44, 49",
        "24.7 kg, centre of mass [0, 8.988, 132.7] mm (tooldata tgripper + machine_tending.mod:34 (GripLoad "
        "ldBlank;)): 3 motion(s), machine_tending.mod lines 35, 39-40",
        "23.4 kg, centre of mass [0, 9.487, 125.4] mm (tooldata tgripper + machine_tending.mod:52 (GripLoad "
        "ldFinished;)): 1 motion(s), machine_tending.mod line 53",
        "23.4 kg, centre of mass [0, 10, 124] mm (machine_tending.mod:23 (\\TLoad:=ldGripFinished)): "
        "1 motion(s), machine_tending.mod line 23",
    ]
    named = {(m.line, m.target) for m in res.motions if m.status == "named"}
    assert named == {(35, "pConveyorAbove"), (44, "pChuckAbove"), (49, "pChuck"), (53, "pChuckAbove")}
    # 24.7 kg: the 18.5 kg gripper (cog [0, 12, 95]) and the 6.2 kg blank 60 mm along the tool's z
    # (its TCP 185 mm out)
    cog = (18.5 * np.array([0, 12, 95]) + 6.2 * np.array([0, 0, 185 + 60])) / 24.7
    assert f"[0, {cog[1]:.4g}, {cog[2]:.4g}]" in res.loads[1]


def test_corpus_fanuc_payload_schedules_from_the_controllers_sysvars():
    nominal, cal = _payload_model("fanuc_r2000ic_165f")
    res = filter_program(
        [CORPUS / "pns0012.ls"],
        cal,
        nominal,
        payload_schedules=CORPUS / "SYSVARS.VA",
        tools={"1": "0,0,300,0,0,0"},
        frames={"1": "1500,0,200,0,0,0"},
    )
    assert summary(res.motions) == {"total": 4, "corrected": 4, "named": 0}
    assert res.loads == [
        "32 kg, centre of mass [0, 0, 180] mm (pns0012.ls:25 (PAYLOAD[1])): 2 motion(s), pns0012.ls "
        "lines 26-27",
        "82 kg, centre of mass [0, 0, 340] mm (pns0012.ls:30 (PAYLOAD[2:Bag 50kg])): 2 motion(s), pns0012.ls "
        "lines 31-32",
    ]


def test_corpus_kss8_with_sload_applies_to_its_motion_and_the_rest_run_with_the_default():
    nominal, cal = _payload_model("kuka_kr16_2")
    files = [CORPUS / "deburr_cell.src", CORPUS / "deburr_cell.dat"]
    res = filter_program(files, cal, nominal, references=[CORPUS / "$config.dat"])
    assert res.loads[0] == (
        "4.5 kg, centre of mass [0, 0, 90] mm (deburr_cell.src:27 ($LOAD = "
        "SLOAD(FP1.TOOL_NO))): 2 motion(s), deburr_cell.src lines 27, 31"
    )
    assert res.loads[1].startswith(
        "no load (the program sets none before these motions; the model's default, no payload): 8 motion(s)"
    )
    assert any("assumed no payload (0 kg)" in w for w in res.warnings)


@pytest.mark.parametrize("dialect", ["inform", "val3", "krl", "urscript"])
def test_a_payload_and_thermal_model_without_load_data_warns_of_the_defaults_it_assumed(dialect, tmp_path):
    nominal, cal = _robots()
    warm = (
        cal.with_joint_errors(["payload2", "payload3", "thermal"])
        .with_values({"payload2": 3e-6, "payload3": 4e-6, "thermal": 11.5e-6})
        .with_reference_temperature(24.0)
    )
    paths, tools, frames = write_program(dialect, tmp_path, nominal, _joints(nominal, 3), TOOL, FRAME)
    res = filter_program(paths, warm, nominal, tools=tools, frames=frames)
    assumed = [w for w in res.warnings if "assumed" in w]
    assert len(assumed) == 2 and "assumed no payload (0 kg)" in assumed[0] and "24 deg C" in assumed[1]
    why, where = {"inform": ("no tool file TOOL.CND given", "--references TOOL.CND, or --payload"),
                  "val3": ("a VAL3 program holds no load data", "(--payload"),
                  }.get(dialect, ("the program sets none before these motions", "in the program before these "
                                  "motions, or --payload"))
    assert res.loads and res.loads[0].startswith(f"no load ({why}; the model's default")
    assert where in assumed[0]
    hot = filter_program(paths, warm, nominal, tools=tools, frames=frames, payload=[50.0], temperature=30.0)
    assert not [w for w in hot.warnings if "assumed" in w]


@settings(max_examples=12, deadline=None)
@given(
    st.lists(st.sampled_from([None, (150.0, 0.0, 0.0, 0.3), (20.0, 0.05, 0.0, 0.1)]), min_size=1, max_size=9)
)
def test_compensating_per_load_puts_each_target_back_in_its_place(keys):
    """compensate_by_load against compensating every target alone at its own load."""
    nominal, cal = _robots()
    q = _joints(nominal, len(keys), seed=len(keys))
    F = nominal.fk(q)
    plan = LoadPlan(list(keys))
    got = compensate_by_load(plan, cal, 30.0, lambda m, i: compensate(m, nominal, F[i], seeds=q[i]))
    for i, key in enumerate(keys):
        alone = compensate(cal.with_conditions(key, 30.0), nominal, F[i : i + 1], seeds=q[i : i + 1])
        np.testing.assert_allclose(got.joints[i], alone.joints[0], atol=1e-12)
        np.testing.assert_allclose(got.corrected_targets[i], alone.corrected_targets[0], atol=1e-12)
        assert got.converged[i] == alone.converged[0]
        assert got.singularity.sigma_rel[i] == pytest.approx(alone.singularity.sigma_rel[0])
    assert any("assumed no payload" in a for a in got.assumed) == (None in keys)


def test_load_data_not_written_as_numbers_stops_only_the_motions_that_use_it(tmp_path):
    nominal, cal = _robots()
    path = _rapid_routine_program(tmp_path, nominal)
    text = path.read_bytes().decode()
    spare = "    PERS tooldata tSpare:=[TRUE,[[0,0,100],[1,0,0,0]],[nMass,[0,0,50],[1,0,0,0],0,0,0]];\r\n"
    path.write_bytes(text.replace("    PERS loaddata part", spare + "    PERS loaddata part").encode())
    assert summary(filter_program([path], cal, nominal).motions)["total"] == 3  # tSpare unused: no matter
    path.write_bytes(
        path.read_bytes().replace(b"MoveJ p0, v1000, fine, tReal", b"MoveJ p0, v1000, fine, tSpare")
    )
    with pytest.raises(
        DataError, match="tSpare: its load is not written as numbers; give the load with --payload"
    ):
        filter_program([path], cal, nominal)


def test_fanuc_payload_of_group_one_written_with_its_group(tmp_path):
    nominal, cal = _payload_model("fanuc_r2000ic_165f")
    path = tmp_path / "pns0012.ls"
    path.write_bytes((CORPUS / "pns0012.ls").read_bytes().replace(b"PAYLOAD[2:Bag 50kg]", b"PAYLOAD[GP1:2]"))
    res = filter_program(
        [path],
        cal,
        nominal,
        payload_schedules=CORPUS / "SYSVARS.VA",
        tools={"1": "0,0,300,0,0,0"},
        frames={"1": "1500,0,200,0,0,0"},
    )
    assert res.loads[1].startswith("82 kg, centre of mass [0, 0, 340] mm (pns0012.ls:30 (PAYLOAD[GP1:2]))")


def test_fanuc_payload_of_another_motion_group_is_not_the_arms(tmp_path):
    """A multi-group program (arm and positioner) sets each group's payload: the positioner's
    PAYLOAD[GP2:n] neither stops the run nor becomes the arm's load."""
    nominal, cal = _payload_model("fanuc_r2000ic_165f")
    path = tmp_path / "pns0012.ls"
    path.write_bytes((CORPUS / "pns0012.ls").read_bytes().replace(
        b"PAYLOAD[2:Bag 50kg]", b"PAYLOAD[GP2:7] ;\r\n  30:  PAYLOAD[GP1:2]"))
    kw = dict(payload_schedules=CORPUS / "SYSVARS.VA", tools={"1": "0,0,300,0,0,0"},
              frames={"1": "1500,0,200,0,0,0"})
    res = filter_program([path], cal, nominal, **kw)
    assert len(res.loads) == 2 and "PAYLOAD[GP1:2]" in res.loads[1] and "GP2" not in " ".join(res.loads)
    path.write_bytes(path.read_bytes().replace(b"PAYLOAD[GP2:7]", b"PAYLOAD[GP1:7]"))
    with pytest.raises(DataError, match="payload schedule 7 is not in the schedules given"):
        filter_program([path], cal, nominal, **kw)


def test_a_model_without_a_payload_term_reads_no_load_data(tmp_path):
    nominal = Robot.from_catalog("fanuc_r2000ic_165f")
    geometric = perturbed(nominal, 3)
    res = filter_program(
        [CORPUS / "pns0012.ls"],
        geometric,
        nominal,
        payload_schedules=CORPUS / "SYSVARS.VA",
        tools={"1": "0,0,300,0,0,0"},
        frames={"1": "1500,0,200,0,0,0"},
    )
    assert res.loads == [] and "--payload-schedules is not used" in res.warnings[-1]
    plain = filter_program(
        [CORPUS / "pns0012.ls"],
        geometric,
        nominal,
        payload=[50.0],
        tools={"1": "0,0,300,0,0,0"},
        frames={"1": "1500,0,200,0,0,0"},
    )
    assert (
        plain.loads == [] and summary(plain.motions)["corrected"] == 4
    )  # PAYLOAD[n] without schedules: fine


def test_krl_tool_changes_load_their_load_data_in_the_order_the_routines_run(tmp_path):
    """The routines are written after the main one: in text order every motion would follow the
    last BAS(#TOOL, 2); run in order, approach's motions carry LOAD_DATA[1] and place's LOAD_DATA[2]."""
    nominal, cal = _robots()
    paths, tools, frames = write_program("krl", tmp_path, nominal, _joints(nominal, 4), TOOL, FRAME)
    main_src = [
        "DEF sim( )",
        "  BAS(#INITMOV, 0)",
        "  BAS(#TOOL, 1)  ; the gripper, empty",
        "  $BASE = BASE_DATA[1]",
        "  approach()",
        "  BAS(#TOOL, 2)  ; the same gripper holding the part: its own tool and load data",
        "  place()",
        "END",
        "",
        "DEF approach( )",
        "  PTP XP0",
        "  LIN XP1",
        "END",
        "",
        "DEF place( )",
        "  LIN XP2",
        "  LIN XP3",
        "END",
        "",
    ]
    paths[0].write_text("\n".join(main_src))
    config = tmp_path / "$config.dat"
    config.write_text(
        "DEFDAT  $CONFIG\n"
        "LOAD_DATA[1]={M 35.0,CM {X 0.0,Y 0.0,Z 120.0,A 0.0,B 0.0,C 0.0},J {X 0.0,Y 0.0,Z 0.0}}\n"
        "LOAD_DATA[2]={M 135.0,CM {X 0.0,Y 0.0,Z 310.0,A 0.0,B 0.0,C 0.0},J {X 0.0,Y 0.0,Z 0.0}}\n"
        "ENDDAT\n"
    )
    tools = {"1": tools["1"], "2": tools["1"]}
    res = filter_program(paths, cal, nominal, tools=tools, frames=frames, references=[config])
    assert res.loads == [
        "35 kg, centre of mass [0, 0, 120] mm (sim.src:3 (BAS(#TOOL, 1))): 2 motion(s), sim.src lines 11-12",
        "135 kg, centre of mass [0, 0, 310] mm (sim.src:6 (BAS(#TOOL, 2))): 2 motion(s), sim.src lines 16-17",
    ]
    for load, names in (([35.0, 0, 0, 0.12], {"XP0", "XP1"}), ([135.0, 0, 0, 0.31], {"XP2", "XP3"})):
        alone = filter_program(
            paths, cal, nominal, tools=tools, frames=frames, references=[config], payload=load
        )
        assert [r["correction_mm"] for r in alone.rows if r["name"] in names] == [
            r["correction_mm"] for r in res.rows if r["name"] in names
        ]


def test_a_malformed_payload_is_a_clear_error(tmp_path):
    nominal, cal = _robots()
    path = _rapid_routine_program(tmp_path, nominal)
    for bad in ([10.0, 0.1], [-5.0]):
        with pytest.raises(DataError, match="a payload is a mass >= 0 kg"):
            filter_program([path], cal, nominal, payload=bad)


def test_urscript_partial_payload_setters_keep_the_other_half(tmp_path):
    nominal, cal = _robots()
    paths, tools, frames = write_program("urscript", tmp_path, nominal, _joints(nominal, 3), TOOL, FRAME)
    lines = paths[0].read_text().split("\n")
    moves = [k for k, line in enumerate(lines) if line.strip().startswith("movel(")]
    lines.insert(moves[2], "  set_payload(5.0)  # the centre of gravity kept")
    lines.insert(moves[1], "  set_payload_mass(3.0)")
    lines.insert(moves[0], "  set_payload_cog([0.0, 0.0, 0.1])  # no mass yet: the default")
    paths[0].write_text("\n".join(lines))
    res = filter_program(paths, cal, nominal, tools=tools, frames=frames)
    assert [line.split(" (")[0] for line in res.loads] == [
        "no load",
        "3 kg, centre of mass [0, 0, 100] mm",
        "5 kg, centre of mass [0, 0, 100] mm",
    ]


def test_payload_schedules_are_checked_against_the_nominal_rating_when_the_model_has_none(tmp_path):
    """A calibrated model saved without its rated payload: payload schedules in grams were let
    through (the check had only the calibrated model's rating); now they are checked against the
    nominal's, as --payload is (`check_masses`, one path)."""
    from dataclasses import replace

    nominal, cal = _robots()
    unrated = replace(cal, payload_kg=None)
    paths, tools, frames = write_program("fanuc", tmp_path, nominal, _joints(nominal, 2), TOOL, FRAME)
    _set_payload_after_tool(paths[0], "PAYLOAD[1]")
    with pytest.raises(DataError, match="--payload-schedules"):
        filter_program(paths, unrated, nominal, tools=tools, frames=frames,
                       payload_schedules={1: (150_000.0, 0, 0, 0)})  # 150 kg typed in grams
    with pytest.raises(DataError, match="--payload"):
        filter_program(paths, unrated, nominal, tools=tools, frames=frames, payload=[150_000.0])
