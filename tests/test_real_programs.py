"""Filtering programs written the way public real programs with external axes are (issue 45: the
measurement on public RAPID / KRL / INFORM / FANUC programs, its defects each tested here in the
style of the program that showed it; the programs themselves are not copied: no licence allows it)."""

from __future__ import annotations

import pytest

import robocal as rc
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.programs import filter_program

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
    """Targets with eax_a values in a work object no unit moves are corrected as arm targets; those
    the arm at a fixed base cannot reach were named 'no solution ... (out of reach)' alone, which
    blames the target: their eax_a may carry the arm (here a track), and the reason says so with
    the values and the cell file to give; the reachable one is corrected; every motion accounted."""
    path = tmp_path / "Track_T_ROB1.mod"
    path.write_text(TRACK_TASK)
    res = filter_program(path, perturbed(ABB, 7), ABB, keep_unreached=True)
    status = {m.line: (m.status, m.reason) for m in res.motions}
    assert len(res.motions) == 3 and status[9][0] == "corrected"
    for line, value in ((7, "3079.80"), (8, "2749.92")):
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
