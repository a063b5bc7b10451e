"""A cell's measurement CSV: the body column, the positioner's columns, the split per body, the
refusals (one line naming the file and the line) and the exact round trip."""

from __future__ import annotations

import numpy as np
import pytest
from cells import two_axis_cell

import robocal as rc
from robocal.data.cell_measurements import CellMeasurements

TEXT = """# a small cell campaign
body,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,e1_deg,e2_deg,x_mm,y_mm,z_mm,smr
flange,0,10,20,0,30,0,,,1000,0,1000,0
arm,5,10,20,0,30,0,10,20,1010,0,1000,0
plate,,,,,,,10,20,1400,10,1100,1
STN1,,,,,,,15,40,1400,10,1100,2
"""


def test_split_per_body():
    cell = two_axis_cell()
    data = CellMeasurements.parse(TEXT, cell, "c.csv")
    assert list(data.bodies) == ["arm", "STN1"]
    arm, plate = data["arm"], data["STN1"]
    assert arm.joints.shape == (2, 6) and plate.joints.shape == (2, 2)
    np.testing.assert_allclose(np.rad2deg(plate.joints), [[10, 20], [15, 40]])
    assert plate.source_row.tolist() == [5, 6] and arm.source_row.tolist() == [3, 4]  # the cell file's lines
    assert plate.smr.tolist() == [1, 2]
    np.testing.assert_allclose(plate.points[0], [1.4, 0.01, 1.1])
    assert len(data) == 4


def test_without_body_column_every_row_is_on_the_anchor():
    cell = two_axis_cell()
    text = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n0,10,20,0,30,0,1000,0,1000\n"
    data = CellMeasurements.parse(text, cell, "c.csv")
    assert list(data.bodies) == ["arm"] and len(data["arm"]) == 1


def test_round_trip_is_exact(tmp_path):
    cell = two_axis_cell()
    data = CellMeasurements.parse(TEXT, cell, "c.csv")
    data.save(tmp_path / "cell.csv")
    back = CellMeasurements.load(tmp_path / "cell.csv", cell)
    for body in data.bodies:
        for field in ("joints", "points", "smr", "pose_id", "source_row"):
            assert np.array_equal(getattr(back[body], field), getattr(data[body], field)), (body, field)


@pytest.mark.parametrize(("edit", "says"), [
    (("STN1,,", "STN9,,"), "line 6: body 'STN9' is not in the cell"),
    ((",15,40,", ",15,,"), "line 6: a row on the positioner STN1's plate without its value e2_deg"),
    ((",15,40,", ",15,400,"), "line 6: the positioner STN1's axis e2 = 400 deg is outside its limits"),
    ((",e1_deg,e2_deg", ",f1,f2"), "line 5: a row on the positioner STN1's plate but the file has no column"),
])
def test_refusals_name_the_line(edit, says):
    cell = two_axis_cell()
    text = TEXT.replace(*edit)
    if edit[1] == ",f1,f2":  # no positioner columns at all: drop them
        cut = [line.split(",") for line in TEXT.splitlines()[1:]]
        text = "\n".join([TEXT.splitlines()[0]] + [",".join(c[:7] + c[9:]) for c in cut]) + "\n"
    with pytest.raises(rc.DataError) as err:
        CellMeasurements.parse(text, cell, "c.csv")
    assert says in str(err.value) and "\n" not in str(err.value)


def test_from_bodies_checks_limits():
    cell = two_axis_cell()
    q = np.array([[0.1, 7.0]])  # e2 beyond +-360 deg
    plate = rc.Measurements.from_arrays("point", q, points=[[1.4, 0.0, 1.1]], smr=[1])
    with pytest.raises(rc.DataError, match="outside its limits"):
        CellMeasurements.from_bodies(cell, {"plate": plate})
