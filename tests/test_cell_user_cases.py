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
    assert "the cell file has it at xyz [1100.000, 0.000, 700.000] mm, rpy [" in relation.sentence()
    assert f"deg, {off:.3f} mm and" in relation.sentence()


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


def _tilt_turn_cell(nests) -> rc.Cell:
    from robocal.kinematics.positioner import positioner_chain

    chain = positioner_chain([{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.7]},
                              {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25]}],
                             make_transform(np.eye(3), [1.1, 0.0, 0.0]), name="tilt-turn")
    return rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")},
                   {"STN1": rc.Positioner(chain, unit="STN1", nests=np.array(nests))})


def test_nests_on_one_line_do_not_claim_to_fix_the_plate_frame():
    """One nest, or two (here 100 mm apart on the plate's x), cannot fix the plate frame's turn
    about their line: the calibration held the plate's tilts (tool.rx, tool.ry) at nominal, and the
    result said "SMR nests at known plate positions fix the plate frame ... the plate frame ... are
    identified". It now names what is held and asks for 3 nests not on one line."""
    for nests in ([[0.2, 0.0, 0.0]], [[0.2, 0.0, 0.0], [0.1, 0.0, 0.0]]):
        cell = _tilt_turn_cell(nests)
        sim = rc.simulate_cell(cell, 30, 20, seed=2)
        cal = rc.calibrate(cell, sim.data, nongeometric=None)
        (plate,) = cal.plates
        held = cal.results["STN1"].identifiability.dropped
        assert "tool.rx" in held or "tool.ry" in held  # what the fit itself could not see
        assert "fix the plate frame" not in plate.sentence and "lie on one line" in plate.sentence
        assert all(p in plate.sentence for p in held if p.startswith("tool."))
    cal = rc.calibrate(_tilt_turn_cell(NESTS := [[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]]),
                       rc.simulate_cell(_tilt_turn_cell(NESTS), 30, 20, seed=2).data, nongeometric=None)
    assert "nests at known plate positions fix the plate frame" in cal.plates[0].sentence


def test_a_turntable_zero_is_the_mounts_turn_not_a_lack_of_table_angles():
    """A 1-axis turntable with 3 nests (the FANUC cell): its zero and the mount's turn about the axis
    are one freedom whatever the angles measured; it said "these data do not determine theta1 ...
    measure more table angles", which more angles cannot cure."""
    from robocal.kinematics.positioner import positioner_chain

    chain = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.6]}],
                             make_transform(np.eye(3), [1.3, 0.0, -0.5]), name="turntable")
    cell = rc.Cell({"arm": rc.Robot.from_catalog("fanuc_m20ia")}, {"GP2": rc.Positioner(
        chain, unit="GP2", nests=np.array([[0.3, 0, 0], [0, 0.3, 0], [-0.2, -0.2, 0]]))})
    cal = rc.calibrate(cell, rc.simulate_cell(cell, 30, 60, seed=3).data, nongeometric=None)
    sentence = cal.plates[0].sentence
    assert "theta1" in cal.results["GP2"].identifiability.dropped
    assert "mount's turn about that axis are one freedom" in sentence and "more table angles" not in sentence


def _three_axis_csv(tmp_path):
    from robocal.kinematics.positioner import positioner_chain

    chain = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.4]},
                              {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.5],
                               "limits": [-np.pi / 2, np.pi / 2]},
                              {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.2]}],
                             make_transform(np.eye(3), [1.5, 0.0, -0.4]), name="three-axis")
    cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb4600")}, {"STN1": rc.Positioner(
        chain, unit="STN1", nests=np.array([[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]]))})
    sim = rc.simulate_cell(cell, 10, 5, seed=1)
    sim.data.save(tmp_path / "m.csv")
    return cell, (tmp_path / "m.csv").read_text().splitlines()


def test_a_bad_positioner_value_is_named_by_its_file_column(tmp_path):
    """'nan' (or 'abc') in a plate row's e1 column was refused as "column q1_rad" (the positioner's
    axes are read as its chain's joints): the message names the file's column."""
    cell, lines = _three_axis_csv(tmp_path)
    header = lines[[k for k, line in enumerate(lines) if not line.startswith("#")][0]].split(",")
    k = next(i for i, line in enumerate(lines) if line.startswith("STN1,"))
    for bad in ("nan", "abc"):
        cells = lines[k].split(",")
        cells[header.index("e1_rad")] = bad
        text = "\n".join([*lines[:k], ",".join(cells), *lines[k + 1:]]) + "\n"
        try:
            rc.CellMeasurements.parse(text, cell, "m.csv")
        except rc.DataError as exc:
            assert f"line {k + 1}, column e1_rad: '{bad}'" in str(exc) and "q1_rad" not in str(exc)
        else:
            raise AssertionError("accepted")


def test_positioner_values_without_a_body_column_are_named(tmp_path):
    """Without the body column every row was taken as the arm's, and the first plate row failed
    with "column q1_rad: '' is not a number": the cause is the missing body column."""
    cell, lines = _three_axis_csv(tmp_path)
    rows = [line for line in lines if not line.startswith("#")]
    text = "\n".join(line.split(",", 1)[1] for line in rows) + "\n"  # the body column dropped
    try:
        rc.CellMeasurements.parse(text, cell, "m.csv")
    except rc.DataError as exc:
        assert "no 'body' column, but the positioners' columns (e1_rad, e2_rad, e3_rad)" in str(exc)
    else:
        raise AssertionError("accepted")
    arm_only = "\n".join(line.split(",", 1)[1] for line in rows if not line.startswith("STN1,")) + "\n"
    assert len(rc.CellMeasurements.parse(arm_only, cell, "m.csv")["arm"]) == 10  # empty e columns: arm rows


def test_compensate_names_the_arm_of_a_two_arm_cell(tmp_path, capsys):
    """Two arms and a table: compensate said "the cell has 2 arms (left, right): name the one the
    targets are for" but had no option to name it (and rc.compensate no argument). --arm (body or
    unit) picks it; each arm's joints reach the plate target on the (here nominal) cell; a
    positioner named as the arm was an internal error (KeyError)."""
    from robocal.cli import main
    from robocal.kinematics.positioner import positioner_chain

    turn = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.6]}],
                            make_transform(np.eye(3), [1.3, 0.0, 0.0]), name="turntable")
    right_base = make_transform(np.diag([-1.0, -1.0, 1.0]), [2.6, 0.0, 0.0])
    arm = rc.Robot.from_catalog("abb_irb2600")
    cell = rc.Cell({"left": arm, "right": arm.with_frames(base=right_base)},
                   {"STN1": rc.Positioner(turn, unit="STN1")}, arm_units={"left": "ROB_1", "right": "ROB_2"})
    cell.save(tmp_path / "cell.yaml")
    (tmp_path / "t.csv").write_text("x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg,e1_deg\n0,0,100,180,0,0,30\n")
    d = str(tmp_path)
    base = ["compensate", f"{d}/cell.yaml", f"{d}/t.csv", "--nominal", f"{d}/cell.yaml", "-o"]
    for name, unit in (("left", "ROB_1"), ("right", "ROB_2")):
        assert main([*base, f"{d}/{name}.csv", "--arm", unit]) == 0
        row = (tmp_path / f"{name}.csv").read_text().splitlines()[2].split(",")
        q = np.deg2rad([float(v) for v in row[:6]])[None]
        tcp = cell.arms[name].fk(q)[0]
        plate = cell.positioners["STN1"].plate(np.deg2rad([[30.0]]))[0]
        np.testing.assert_allclose((np.linalg.inv(plate) @ tcp)[:3, 3], [0, 0, 0.1], atol=1e-6)
    capsys.readouterr()
    assert main([*base, f"{d}/x.csv", "--arm", "plate"]) != 0
    err = capsys.readouterr().err
    assert "'plate' is not one of the cell's arms (left, right)" in err and "report" not in err
    assert not (tmp_path / "x.csv").exists()


def test_uncoordinated_targets_with_a_cell_do_not_ask_for_a_cell(tmp_path, capsys):
    """A target in wobj0 carrying STN1's values, in a program filtered WITH the cell file: corrected
    as an arm target (right), but the warning went on "if a track or gantry carries the arm, give
    its cell file (--model CELL.yaml)", the file just given."""
    from robocal.cli import main

    cell = two_axis_cell(nests=True)
    cell.save(tmp_path / "cell.yaml")
    (tmp_path / "free.mod").write_text(
        "MODULE Free\n  CONST robtarget pFree:=[[1000,0,1000],[0,0,1,0],[0,0,0,0],"
        "[9E+09,10,20,9E+09,9E+09,9E+09]];\n  PROC main()\n    MoveL pFree,v100,fine,tool0;\n  ENDPROC\n"
        "ENDMODULE\n")
    d = str(tmp_path)
    assert main(["filter", f"{d}/free.mod", "--model", f"{d}/cell.yaml", "--calibrated", f"{d}/cell.yaml",
                 "-o", f"{d}/out.mod"]) == 0
    out = capsys.readouterr().out
    assert "1 of 1 Cartesian target(s) filtered" in out and "corrected as arm targets" in out
    assert "give its cell file" not in out


def test_mutated_cell_measurements_are_read_or_refused_in_one_line(tmp_path):
    """Property (a small, seeded form of the fuzzing done for issue 45): a cell CSV with random
    cells replaced by odd values (empty, nan, text, huge, another body's name) is read or refused
    with a DataError naming the cause; never another exception."""
    import random

    cell, lines = _three_axis_csv(tmp_path)
    rng = random.Random(45)
    odd = ["", "nan", "inf", "1e400", "abc", "-0", "0", "1e-300", "plate", "flange", "STN2", "arm", "7", "-1"]
    for _ in range(60):
        rows = [line.split(",") for line in lines]
        for _ in range(rng.randint(1, 3)):
            k = rng.randrange(1, len(rows))
            rows[k][rng.randrange(len(rows[k]))] = rng.choice(odd)
        try:
            rc.CellMeasurements.parse("\n".join(",".join(r) for r in rows) + "\n", cell, "m.csv")
        except rc.DataError as exc:
            assert "m.csv" in str(exc) and "\n" not in str(exc)


def test_a_turntable_without_nests_is_refused_for_its_cause():
    """A 1-axis turntable (or a slide along its turn axis) with SMRs at unknown places: their
    registration cannot fix the frame (its turn about the axis, its shift along it). The refusal
    said "the pose set is degenerate ... they barely change the flange's orientation ...: measure
    poses spread over the workspace and over the wrist's orientations", which no table angles
    cure; it now names the cause and the remedy (nests)."""
    from robocal.kinematics.positioner import positioner_chain

    chain = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.6]}],
                             make_transform(np.eye(3), [1.3, 0.0, -0.5]), name="turntable")
    cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb4600")}, {"STN1": rc.Positioner(chain, unit="STN1")})
    sim = rc.simulate_cell(cell, 30, 30, seed=4)
    try:
        rc.calibrate(cell, sim.data, nongeometric=None)
    except rc.IdentificationError as exc:
        text = str(exc)
        assert text.startswith("STN1: SMRs at unknown places on a plate that turns about one axis only")
        assert "nests:" in text and "wrist" not in text
    else:
        raise AssertionError("calibrated")


def test_rapid_inline_target_with_a_confdata_variable_is_named_not_fatal(tmp_path, capsys):
    """RoboDK writes a positioner program's targets inline with a confdata variable,
    ``MoveL [[x,y,z],[q..],conf,[9E9,0,0,..]],Speed000,Zone000,tool \\WObj:=Frame000;`` (valid
    RAPID): the whole file was refused ("malformed robtarget inline@11: expected groups of 3, 4, 4
    numbers"). Each such motion is now named with its cause, the others filtered."""
    from robocal.cli import main

    (tmp_path / "pos.mod").write_text(
        "MODULE Pos\n  VAR confdata conf := [0,0,0,0];\n"
        "  CONST robtarget p1:=[[1000,0,1000],[0,0,1,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\n"
        "  PROC main()\n    MoveL p1,v100,fine,tool0;\n"
        "    MoveL [[1000,100,1000],[0,0,1,0],conf,[9E9,9E9,9E9,9E9,9E9,9E9]],v100,fine,tool0;\n"
        "  ENDPROC\nENDMODULE\n")
    arm = rc.Robot.from_catalog("abb_irb2600")
    arm.with_values({"a2": arm.get("a2") + 0.0005}).save(tmp_path / "cal.yaml")
    d = str(tmp_path)
    code = main(["filter", f"{d}/pos.mod", "--nominal", "abb_irb2600", "--calibrated", f"{d}/cal.yaml",
                 "-o", f"{d}/out.mod"])
    out = capsys.readouterr().out
    assert code == 0 and "1 of 1 Cartesian target(s) filtered" in out and "1 not corrected" in out
    assert "configuration (confdata) is the variable conf" in out
    text = (tmp_path / "out.mod").read_text()
    assert "[[1000,100,1000],[0,0,1,0],conf,[9E9,9E9,9E9,9E9,9E9,9E9]]" in text  # left as it is
