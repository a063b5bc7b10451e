"""Yaskawa INFORM jobs corrected with the load of each position's tool, read from the controller's
tool file TOOL.CND (tests/data/programs/corpus: PALLETIZE.JBI, a bag palletizer whose positions
taught with the bag carry tool 2, and its TOOL.CND written in the layout of real controller
backups: 64 blocks, frame / centre of gravity / W / inertia lines, CR LF).

Truth: a GP180 whose payload compliance is known (the calibrated model is the truth); the filtered
job, run by the nominal controller on the true arm at each motion's load, reaches the taught
positions within the written numbers' resolution, and each motion's correction is the one the same
job gets filtered with ``--payload`` of its load.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_program_loads import payload_model

from robocal import Robot
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs import filter_program
from robocal.programs.dialects.inform.reader import InformDialect
from robocal.programs.dialects.inform.tool_file import read_tool_file
from robocal.programs.motions import summary
from robocal.programs.simulate import execute
from robocal.programs.source import ProgramText

CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"
JOB, TOOLS = CORPUS / "PALLETIZE.JBI", CORPUS / "TOOL.CND"
RESOLUTION_MM = 0.002  # the written positions' 3 decimals (mm) and 4 (deg) at a 420 mm TCP
EMPTY = np.array([38.0, 0.0, 0.0, 0.16])  # tool 1: the gripper (kg, m in the flange frame)
BAG = np.array([98.0, 0.0, 0.0, 0.31])  # tool 2: the gripper holding a bag


def _robots() -> tuple[Robot, Robot]:
    # rad/(kg m): ~0.5 mm at 98 kg
    return payload_model("yaskawa_gp180", {"payload2": 4e-6, "payload3": 5e-6, "payload5": 8e-6}, 11)


def test_the_tool_file_gives_each_tool_its_frame_and_load():
    tools = read_tool_file(ProgramText(TOOLS))
    assert sorted(tools, key=int) == [str(n) for n in range(64)]
    gripper, bag = tools["1"], tools["2"]
    assert (gripper.name, gripper.frame, gripper.mass, gripper.line) == (
        "GRIPPER", (0.0, 0.0, 420.0, 0.0, 0.0, 0.0), 38.0, 8)
    np.testing.assert_allclose(gripper.cog, [0, 0, 0.16])
    assert (bag.name, bag.mass) == ("GRIPPER+BAG", 98.0)
    np.testing.assert_allclose(bag.cog, [0, 0, 0.31])
    assert tools["3"].mass == 0.0 and tools["3"].frame[2] == 480.0  # a pointer: a frame, no load set


def test_palletizer_motions_run_with_their_tools_load_and_reach_the_truth(tmp_path):
    nominal, cal = _robots()
    res = filter_program([JOB], cal, nominal, references=[TOOLS])  # tool frames from TOOL.CND too
    assert summary(res.motions) == {"total": 8, "corrected": 8, "named": 0}
    assert res.loads == [
        '38 kg, centre of mass [0, 0, 160] mm (TOOL.CND tool 1 "GRIPPER"): 5 motion(s), PALLETIZE.JBI '
        "lines 24-26, 35-36",
        '98 kg, centre of mass [0, 0, 310] mm (TOOL.CND tool 2 "GRIPPER+BAG"): 3 motion(s), PALLETIZE.JBI '
        "lines 30-32",
    ]
    assert not res.warnings  # the tools' frames given by the file: no "TOOL 0 taken as the flange"
    out = tmp_path / JOB.name
    out.write_bytes(res.outputs[JOB])
    truth = cal.with_frames(base=nominal.base, tool=nominal.tool)
    for load, rows in ((EMPTY, [0, 1, 2, 6]), (BAG, [3, 4, 5])):
        reached, _ = execute([out], truth.with_conditions(load), nominal, references=[TOOLS])
        unfiltered, wanted = execute([JOB], truth.with_conditions(load), nominal, references=[TOOLS])
        err = np.linalg.norm(reached[rows, :3, 3] - wanted[rows, :3, 3], axis=1) * 1e3
        before = np.linalg.norm(unfiltered[rows, :3, 3] - wanted[rows, :3, 3], axis=1) * 1e3
        assert err.max() < RESOLUTION_MM, err
        assert before.min() > 50 * RESOLUTION_MM
        alone = filter_program([JOB], cal, nominal, references=[TOOLS], payload=load)
        names = {f"C{k:05d}" for k in rows}
        assert [r["correction_mm"] for r in alone.rows if r["name"] in names] == [
            r["correction_mm"] for r in res.rows if r["name"] in names]


def test_the_tool_files_frames_give_the_tcp_and_tool_overrides_them():
    pos = InformDialect().parse([ProgramText(JOB)], {}, {}, [ProgramText(TOOLS)])
    np.testing.assert_allclose(pos.tools["2"], make_transform(np.eye(3), np.array([0, 0, 0.42])))
    given = InformDialect().parse([ProgramText(JOB)], {}, {"2": InformDialect().to_pose(
        np.array([[0, 0, 400, 0, 0, 0.0]]))[0]}, [ProgramText(TOOLS)])
    assert given.tools["2"][2, 3] == pytest.approx(0.4) and given.tools["1"][2, 3] == pytest.approx(0.42)


def _job_with_tool(tmp_path, number: int) -> Path:
    path = tmp_path / JOB.name
    path.write_bytes(JOB.read_bytes().replace(b"///TOOL 2", f"///TOOL {number}".encode()))
    return path


def test_a_tool_without_a_load_or_missing_from_the_file_stops_the_motions_that_use_it(tmp_path):
    nominal, cal = _robots()
    with pytest.raises(DataError, match=r"PALLETIZE.JBI:13: C00003: its tool 3 has no load in TOOL.CND "
                                        r"\(W 0 kg at line 22: not registered on the controller\); give the "
                                        r"load with --payload"):
        filter_program([_job_with_tool(tmp_path, 3)], cal, nominal, references=[TOOLS])
    short = tmp_path / "TOOL.CND"
    short.write_bytes(TOOLS.read_bytes().split(b"//TOOL 2")[0])
    with pytest.raises(DataError, match=r"C00003: its tool 2 is not in the tool file TOOL.CND given "
                                        r"\(it holds tools 0-1\)"):
        filter_program([JOB], cal, nominal, references=[tmp_path / "TOOL.CND"],
                       tools={"2": "0,0,420,0,0,0"})
    # --payload runs every motion with it: the tool file's loads are not read
    ok = filter_program([_job_with_tool(tmp_path, 3)], cal, nominal, references=[TOOLS], payload=[60.0])
    assert ok.loads == ["60 kg, centre of mass [0, 0, 0] mm (--payload): every motion"]


def test_a_job_without_its_tool_file_runs_with_the_default_and_says_so():
    nominal, cal = _robots()
    res = filter_program([JOB], cal, nominal, tools={"1": "0,0,420,0,0,0", "2": "0,0,420,0,0,0"})
    assert res.loads[0].startswith("no load") and any("assumed no payload (0 kg)" in w for w in res.warnings)


@pytest.mark.parametrize("old, new, message", [
    (b"0.000,0.000,160.000\r\n", b"0.000,160.000\r\n",
     r"TOOL.CND:11: malformed line '0.000,160.000' of tool 1: expected Xg,Yg,Zg \(the centre of gravity\)"),
    (b"38.000\r\n", b"38 kg\r\n", r"TOOL.CND:12: malformed line '38 kg' of tool 1: expected W \(the mass\)"),
    (b"//TOOL 2\r\n", b"//TOOL 1\r\n", r"TOOL.CND:15: tool 1 is given twice"),
    (b"//TOOL 2\r\n", b"//TOOL " + b"2" * 5000 + b"\r\n", r"TOOL.CND:15: a number of 5000 digits"),
    (b"0.000,0.000,310.000\r\n98.000\r\n2.500,2.500,1.100\r\n0.000,0,1\r\n", b"",
     r"TOOL.CND:15: tool 2 has 1 line\(s\) of numbers"),
])
def test_a_malformed_tool_file_is_a_clear_error(tmp_path, old, new, message):
    path = tmp_path / "TOOL.CND"
    path.write_bytes(TOOLS.read_bytes().replace(old, new, 1))
    with pytest.raises(DataError, match=message):
        read_tool_file(ProgramText(path))


_NUM = st.floats(-5000, 5000, allow_nan=False).map(lambda v: round(v, 3))


@settings(max_examples=40, deadline=None)
@given(st.dictionaries(st.integers(0, 63), st.tuples(
    st.lists(_NUM, min_size=6, max_size=6), st.lists(_NUM, min_size=3, max_size=3),
    st.floats(0, 2000).map(lambda v: round(v, 3)), st.text("ABC +-_1", max_size=12).map(str.strip),
    st.booleans()), min_size=1), st.sampled_from(["\n", "\r\n"]))
def test_the_tool_file_reads_back_what_was_written(tools, newline):
    """Any block as a controller writes it (a ///CRC line or not, LF or CR LF) reads back."""
    lines = []
    for n, (frame, cog, kg, name, crc) in tools.items():
        lines += [f"//TOOL {n}", *(["///CRC 381761669"] if crc else []), f"///NAME {name}",
                  ",".join(f"{v:.3f}" for v in frame), ",".join(f"{v:.3f}" for v in cog), f"{kg:.3f}",
                  "0.000,0.000,0.000", "0.000,0,1"]
    got = read_tool_file(ProgramText("TOOL.CND", (newline.join(lines) + newline).encode()))
    assert set(got) == {str(n) for n in tools}
    for n, (frame, cog, kg, name, _) in tools.items():
        e = got[str(n)]
        assert (e.frame, e.mass, e.name) == (tuple(frame), kg, name)
        np.testing.assert_allclose(e.cog, np.array(cog) * 1e-3)


def test_filter_cli_reads_the_tool_file_and_prints_the_loads(tmp_path, capsys):
    nominal, cal = _robots()
    cal.save(tmp_path / "cal.yaml")
    job = tmp_path / JOB.name
    shutil.copy(JOB, job)
    args = ["filter", str(job), "--calibrated", str(tmp_path / "cal.yaml"), "--nominal", "yaskawa_gp180",
            "-o", str(tmp_path / "out.JBI"), "--references", str(TOOLS)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert ('load: 98 kg, centre of mass [0, 0, 310] mm (TOOL.CND tool 2 "GRIPPER+BAG"): 3 motion(s), '
            "PALLETIZE.JBI lines 30-32") in out
    table = json.loads((tmp_path / "out.JBI.targets.json").read_text())
    assert table["loads"][0].startswith("38 kg")
    assert main([*args[:-1], str(CORPUS / "PICK_PLACE.JBI")]) == 2  # a job: no TOOL.CND, UFRAME.CND, VAR.DAT
    assert "not a UFRAME.CND nor a TOOL.CND" in capsys.readouterr().err


def test_a_tool_the_job_rewrites_at_run_time_is_named(tmp_path):
    """SETTOOL TL#(n) P.. writes tool n's data from a position variable when the job runs (offline
    generators emit it before a motion): the frame and load given for tool n are not what runs."""
    nominal, cal = _robots()
    path = tmp_path / JOB.name
    path.write_bytes(JOB.read_bytes().replace(b"NOP\r\n", b"NOP\r\nSETTOOL TL#(2) P010\r\n"))
    res = filter_program([path], cal, nominal, references=[TOOLS])
    assert summary(res.motions) == {"total": 8, "corrected": 5, "named": 3}
    named = [m for m in res.motions if m.status == "named"]
    assert [m.target for m in named] == ["C00003", "C00004", "C00005"]
    assert "taught with tool 2, whose data the job writes at run time by SETTOOL at PALLETIZE.JBI:23" in \
        named[0].reason
    assert [line.split(" (")[0] for line in res.loads] == ["38 kg, centre of mass [0, 0, 160] mm"]


def test_the_tool_file_given_as_a_job_is_a_clear_error():
    nominal, cal = _robots()
    with pytest.raises(DataError, match="TOOL.CND is a controller file of tools or user frames .*: give it "
                                        "with --references"):
        filter_program([JOB, TOOLS], cal, nominal)
    with pytest.raises(DataError, match="or the controller's TOOL.CND / UFRAME.CND with --references"):
        filter_program([JOB], cal, nominal)  # the tools' data given nowhere


def test_a_number_thousands_of_digits_long_is_no_index(tmp_path):
    """A mangled file (a number of 5000 digits where a tool or position number stands) is a one-line
    error or a named motion, never Python's integer-conversion limit."""
    nominal, cal = _robots()
    long = b"7" * 5000
    for old, new in ((b"///TOOL 2", b"///TOOL " + long), (b"C00003=", b"C" + long + b"="),
                     (b"MOVL C00003", b"MOVL C" + long)):
        path = tmp_path / JOB.name
        path.write_bytes(JOB.read_bytes().replace(old, new, 1))
        try:
            res = filter_program([path], cal, nominal, references=[TOOLS])
        except DataError as exc:
            assert "\n" not in str(exc)
        else:
            assert summary(res.motions)["named"] >= 1
