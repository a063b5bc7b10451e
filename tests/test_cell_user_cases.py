"""A new user's and a tester's cases on work cells (issue 45): each test reproduces a defect found
by following docs/how-to/cell.md on cells of other families (KUKA + DKP-400, Yaskawa + MOTOPOS,
FANUC + turntable, two ABB arms + IRBP, a headstock on a slide, a 3-axis positioner) or by fuzzing
the cell inputs, and checks its fix."""
from __future__ import annotations

import numpy as np
from cells import two_axis_cell

import robocal as rc
from robocal.kinematics.transforms import make_transform


def test_compensate_summary_does_not_count_unreached_targets_as_corrections():
    """A target out of the arm's reach is not corrected: its shift is the solver's miss (150 mm on
    the how-to's cell), and the summary named it "corrections up to 172 mm" for targets "reached by
    arm". Only reached targets' corrections are figures; the unreached are counted."""
    cell = two_axis_cell(nests=True)
    targets = make_transform(np.diag([1.0, -1.0, -1.0]), [0.0, 0.0, 0.2])[None].repeat(2, 0)
    targets[1, :3, 3] = [0.0, 0.0, 3.0]  # 3 m above the plate: out of reach
    comp = rc.compensate(cell, cell, targets, positioner_values=np.zeros((2, 2)))
    assert comp.arm_compensation.converged.tolist() == [True, False]
    text = comp.summary()
    assert "1 reached" in text and "1 not reached" in text
    assert "corrections up to 0.0000 mm" in text  # the reached target on the nominal cell: none
    none = rc.compensate(cell, cell, targets[1:], positioner_values=np.zeros((1, 2)))
    assert "0 reached; none corrected" in none.summary()


def test_the_relation_says_where_the_cell_file_has_it():
    """"STN1 seen from arm: xyz [1399.106, 0.738, 901.787] mm, rpy [-89.99, -0.05, -89.98] deg" for
    a table whose file says mount [1400, 0, 0], rpy 0: the frame is the chain's {0} (the tilt axis'
    frame, the axis along its z), which the user cannot compare with the file. The relation now
    carries the cell file's own (the tilt axis 700 mm up at 1.1 m: [1100, 0, 700] mm) and says how
    far the calibration found it from there."""
    cell = two_axis_cell(nests=True)
    sim = rc.simulate_cell(cell, 40, 20, seed=5)
    (relation,) = rc.calibrate(cell, sim.data, nongeometric=None).relations
    d = relation.to_dict()
    np.testing.assert_allclose(d["nominal_xyz_mm"], [1100.0, 0.0, 700.0], atol=1e-9)
    off = np.linalg.norm(np.subtract(d["xyz_mm"], d["nominal_xyz_mm"]))
    assert abs(d["off_nominal_mm"] - off) < 1e-9 and 0.01 < off < 20.0  # the simulated mount errors
    assert f"the cell file has it {off:.3f} mm" in relation.sentence()


def test_krl_status_turn_out_of_float_range_is_named(tmp_path, capsys):
    """Fuzzing a DKP-400 seam program: ``T 1e400`` in an E6POS was an internal error (int(inf)):
    it is a status/turn that is not an integer, named with its place, nothing written."""
    from robocal.cli import main

    (tmp_path / "seam.src").write_text("DEF seam( )\r\n  PTP XP1\r\nEND\r\n")
    pos = "X 900.0,Y 0.0,Z 1000.0,A 0.0,B 90.0,C 0.0,S 2,T 1e400,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0"
    (tmp_path / "seam.dat").write_text(f"DEFDAT  seam\r\nDECL E6POS XP1={{{pos}}}\r\nENDDAT\r\n")
    (tmp_path / "out").mkdir()
    rc.Robot.from_catalog("kuka_kr16_2").save(tmp_path / "cal.yaml")
    code = main(["filter", str(tmp_path / "seam.src"), str(tmp_path / "seam.dat"), "--nominal", "kuka_kr16_2",
                 "--calibrated", str(tmp_path / "cal.yaml"), "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code != 0 and "seam.dat:2: status/turn '1e400' is not an integer" in err and "report" not in err
    assert not any((tmp_path / "out").iterdir())
