"""Work cells: arms and positioners in one world frame. The cell file against independent truths
(the axes composed by hand, catalog arms placed by hand), exact save/load round trips, the
controller's world of calibrated bodies, and every refusal of a malformed file."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.core.errors import ModelError
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.workcell import Cell, Positioner, cell_from_data, load_cell

TOL = 1e-12  # m: exact conversions, up to rounding
MM = 1e-3

CELL = {
    "units": {"length": "mm", "angle": "deg"},
    "name": "welding cell",
    "robot": "abb_irb2600",
    "positioner": {
        "unit": "STN1",
        "mount": {"xyz": [1400, 0, 0], "rpy": [0, 0, 30]},
        "axes": [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 900], "limits": [-90, 90]},
                 {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 250], "limits": [-360, 360]}],
        "plate": {"xyz": [10, 20, 5], "rpy": [0, 0, 45]},
        "nests": [[200, 0, 0], [0, 200, 0], [-150, -150, 0]],
    },
}

TWO_ARMS = {
    "units": {"length": "mm", "angle": "deg"},
    "name": "two robots",
    "robots": {"left": {"model": "abb_irb2600", "base": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]},
                        "unit": "ROB_1"},
               "right": {"model": "abb_irb2600", "base": {"xyz": [3000, 0, 0], "rpy": [0, 0, 180]},
                         "unit": "ROB_2"}},
    "positioners": {"STN1": {"axes": [{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 800]}],
                             "mount": {"xyz": [1500, 1000, 0]}},
                    "STN2": {"axes": [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 1000]},
                                      {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 300]}],
                             "mount": {"xyz": [1500, -1000, 0]}, "unit": "STN2"}},
}


def pose(xyz_mm, rpy_deg=(0, 0, 0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy_deg, degrees=True).as_matrix()
    T[:3, 3] = np.asarray(xyz_mm, float) * MM
    return T


def rot(axis, deg) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.asarray(axis, float) * np.deg2rad(deg)).as_matrix()
    return T


def tilt_turn_truth(e_deg) -> np.ndarray:
    """CELL's plate pose composed by hand: mount, tilt origin, tilt, turn origin, turn, plate."""
    return np.array([pose([1400, 0, 0], [0, 0, 30]) @ pose([0, 0, 900]) @ rot([1, 0, 0], a)
                     @ pose([0, 0, 250]) @ rot([0, 0, 1], b) @ pose([10, 20, 5], [0, 0, 45])
                     for a, b in e_deg])


E_DEG = np.array([[0, 0], [30, 0], [-45, 120], [80, -300], [12.5, 33.3]])


@pytest.fixture(scope="module")
def cell() -> Cell:
    return cell_from_data(CELL)


def write(tmp_path, data, name="cell.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_one_arm_and_a_tilt_turn_positioner(cell):
    assert list(cell.arms) == ["arm"] and list(cell.positioners) == ["STN1"] and cell.anchor == "arm"
    stn = cell.positioners["STN1"]
    assert stn.unit == "STN1" and stn.columns == ("e1", "e2") and stn.external_axes == (1, 2)
    np.testing.assert_allclose(stn.plate(np.deg2rad(E_DEG)), tilt_turn_truth(E_DEG), rtol=0, atol=TOL)
    np.testing.assert_allclose(stn.chain.limits, np.deg2rad([[-90, 90], [-360, 360]]))
    arm = Robot.from_catalog("abb_irb2600")
    np.testing.assert_array_equal(cell.arms["arm"].values, arm.values)


def test_nests_are_the_chains_smrs(cell):
    stn = cell.positioners["STN1"]
    np.testing.assert_allclose(stn.nests, np.array(CELL["positioner"]["nests"]) * MM)
    e = np.deg2rad(E_DEG)
    plates = tilt_turn_truth(E_DEG)
    for k, nest in enumerate(CELL["positioner"]["nests"], 1):
        truth = plates[:, :3, :3] @ (np.array(nest) * MM) + plates[:, :3, 3]
        seen = stn.chain.fk(e, smr=np.full(len(e), k))[:, :3, 3]
        np.testing.assert_allclose(seen, truth, rtol=0, atol=TOL)
    # the nominal model carries the nests too (the controller's model of the cell)
    np.testing.assert_allclose(stn.chain.nominal_robot().smr, stn.chain.smr, rtol=0, atol=TOL)


def test_several_arms_each_at_its_base(tmp_path):
    cell = load_cell(write(tmp_path, TWO_ARMS))
    assert cell.bodies == ["left", "right", "STN1", "STN2"] and cell.anchor == "left"
    assert cell.arm_units == {"left": "ROB_1", "right": "ROB_2"}
    assert cell.positioners["STN1"].unit == "STN1" and cell.positioners["STN1"].columns == ("e1",)
    assert cell.positioners["STN2"].columns == ("e2", "e3")
    arm = Robot.from_catalog("abb_irb2600")
    q = np.random.default_rng(3).uniform(-1, 1, (6, 6))
    np.testing.assert_allclose(cell.arms["right"].fk(q), pose([3000, 0, 0], [0, 0, 180]) @ arm.fk(q),
                               rtol=0, atol=TOL)
    np.testing.assert_allclose(cell.arms["left"].fk(q), arm.fk(q), rtol=0, atol=TOL)
    # the nominal model is placed too: the controller's right arm stands at 3 m
    np.testing.assert_allclose(cell.arms["right"].nominal_robot().base, pose([3000, 0, 0], [0, 0, 180]),
                               atol=TOL)
    assert cell.body("ROB_2") is cell.arms["right"] and cell.resolve("flange") == "left"
    assert cell.unit_of("right") == "ROB_2" and cell.unit_of("STN2") == "STN2"
    with pytest.raises(ModelError, match="'plate' the only positioner"):
        cell.resolve("plate")  # two positioners: no alias


def test_joint_columns_of_every_body(tmp_path):
    data = _with(TWO_ARMS, ("positioners", "STN1", "axes"),
                 [{"type": "prismatic", "axis": [0, 0, 1], "origin": [0, 0, 300], "limits": [0, 500]},
                  {"type": "revolute", "axis": [0, 0, 1], "origin": [100, 0, 0]}])
    cell = load_cell(write(tmp_path, data))
    assert [j.column for j in cell.joints("STN1")] == ["e1_mm", "e2_deg"]
    assert [j.column for j in cell.joints("STN2")] == ["e3_deg", "e4_deg"]
    assert [j.column for j in cell.joints("ROB_2")] == [f"q{i}_deg" for i in range(1, 7)]
    assert cell.joints("STN1")[0].limits == (0.0, 0.5)
    assert cell.positioners["STN2"].external_axes == (3, 4)


def test_track_arm_and_positioner_columns_follow_e1(tmp_path):
    data = {"units": {"length": "mm", "angle": "deg"}, "robot": "kuka_kr210_r2700",
            "track": {"direction": [1, 0, 0], "limits": [0, 6000]},
            "positioner": copy.deepcopy(CELL["positioner"])}
    cell = load_cell(write(tmp_path, data))
    arm = cell.arms["arm"]
    track = load_model(str(write(tmp_path, {k: data[k] for k in ("units", "robot", "track")}, "t.yaml")))
    np.testing.assert_array_equal(arm.values, track.values)
    assert cell.positioners["STN1"].columns == ("e2", "e3")
    assert cell.positioners["STN1"].external_axes == (2, 3)
    data["positioner"]["columns"] = ["e1", "e2"]
    with pytest.raises(ModelError, match="column e1 is already the track of arm 'arm''s"):
        load_cell(write(tmp_path, data))


def _same_cell(a: Cell, b: Cell) -> None:
    assert (a.name, a.description, a.arm_units) == (b.name, b.description, b.arm_units)
    assert a.bodies == b.bodies
    for name in a.bodies:
        x, y = a.body(name), b.body(name)
        for f in ("values", "nominal", "limits", "prismatic", "parallel", "smr"):
            np.testing.assert_array_equal(getattr(x, f), getattr(y, f))
        assert (x.name, x.description, x.joint_error_names) == (y.name, y.description, y.joint_error_names)
    for name, p in a.positioners.items():
        q = b.positioners[name]
        assert (p.unit, p.columns, p.external_axes) == (q.unit, q.columns, q.external_axes)
        assert (p.nests is None) == (q.nests is None)
        if p.nests is not None:
            np.testing.assert_array_equal(p.nests, q.nests)


@pytest.mark.parametrize("data", [CELL, TWO_ARMS], ids=["one-arm", "two-arms"])
def test_save_load_round_trip_is_exact(tmp_path, data):
    cell = cell_from_data(copy.deepcopy(data))
    cell.save(tmp_path / "saved.yaml")
    again = load_cell(tmp_path / "saved.yaml")
    _same_cell(cell, again)
    again.save(tmp_path / "again.yaml")
    assert (tmp_path / "again.yaml").read_text() == (tmp_path / "saved.yaml").read_text()
    e = np.deg2rad(E_DEG)
    stn = next(iter(cell.positioners))
    k = cell.positioners[stn].n_axes
    np.testing.assert_array_equal(again.positioners[stn].plate(e[:, :k]),
                                  cell.positioners[stn].plate(e[:, :k]))


def test_round_trip_of_calibrated_bodies_and_a_track(tmp_path):
    data = {"units": {"length": "mm", "angle": "deg"}, "robot": "kuka_kr210_r2700",
            "track": {"direction": [0, 1, 0], "limits": [-500, 6000]}, "mount": {"xyz": [0, 0, 300]},
            "positioner": copy.deepcopy(CELL["positioner"])}
    cell = cell_from_data(data)
    arm = cell.arms["arm"].with_values({"a3": cell.arms["arm"].get("a3") + 3e-4, "scale1": 2e-5})
    chain = cell.positioners["STN1"].chain
    moved = chain.with_values({"alpha2": chain.get("alpha2") + 1e-3, "smr2.x": chain.get("smr2.x") + 1e-4})
    calibrated = Cell({"arm": arm}, {"STN1": Positioner(moved, "STN1", ("e2", "e3"),
                                                        cell.positioners["STN1"].nests)})
    calibrated.save(tmp_path / "cal.yaml")
    _same_cell(calibrated, load_cell(tmp_path / "cal.yaml"))


def test_load_model_keeps_robots_and_refuses_cells(tmp_path):
    path = write(tmp_path, CELL)
    with pytest.raises(ModelError, match=r"cell.yaml: a work cell \(1 arm\(s\), 1 positioner\(s\)\), not one "
                                         r"robot: load it with robocal.load_cell"):
        load_model(str(path))
    with pytest.raises(ModelError, match=r"2 arm\(s\), 2 positioner\(s\)"):
        rc.Robot.load(write(tmp_path, TWO_ARMS))
    one = {"units": {"length": "mm", "angle": "deg"},
           "robots": {"solo": {"model": "abb_irb2600", "base": {"xyz": [500, 0, 0]}}}}
    robot = load_model(str(write(tmp_path, one)))
    np.testing.assert_allclose(robot.base, pose([500, 0, 0]), atol=TOL)
    # today's files: a model, a track cell, a catalog name (load_cell gives a one-arm cell)
    track = {"units": {"length": "mm", "angle": "deg"}, "robot": "kuka_kr210_r2700",
             "track": {"direction": [1, 0, 0], "limits": [0, 6000]}}
    assert load_model(str(write(tmp_path, track))).n_joints == 7
    one_arm = load_cell(write(tmp_path, track))
    assert list(one_arm.arms) == ["arm"] and one_arm.arms["arm"].n_joints == 7
    assert load_cell("ur10e").arms["arm"].name == "ur10e"


def test_in_world_anchors_on_the_first_arm():
    cell = cell_from_data(copy.deepcopy(TWO_ARMS))
    rng = np.random.default_rng(7)
    world_T_tracker = pose([2500, -300, 200], [3, -2, 70])
    tracker_T_world = np.linalg.inv(world_T_tracker)

    def seen(robot, deltas):  # a body as a calibration in the tracker frame returns it
        true = robot.with_values({k: robot.get(k) + v for k, v in deltas.items()})
        return true.with_frames(base=tracker_T_world @ true.base)

    calibrated = {"left": seen(cell.arms["left"], {"a2": 2e-4, "theta3": 1e-3}),
                  "ROB_2": seen(cell.arms["right"], {"d1": -3e-4}),
                  "STN2": seen(cell.positioners["STN2"].chain, {"alpha2": 5e-4, "d2": 1e-4})}
    world = cell.in_world(calibrated)
    np.testing.assert_array_equal(world.arms["left"].base, cell.arms["left"].base)
    e = rng.uniform(-1, 1, (5, 2))
    truth = world_T_tracker @ calibrated["STN2"].fk(e)
    np.testing.assert_allclose(world.positioners["STN2"].plate(e), truth, rtol=0, atol=1e-9)
    q = rng.uniform(-1, 1, (5, 6))
    np.testing.assert_allclose(world.arms["right"].fk(q), world_T_tracker @ calibrated["ROB_2"].fk(q),
                               rtol=0, atol=1e-9)
    np.testing.assert_allclose(world.arms["right"].get("d1"), cell.arms["right"].get("d1") - 3e-4)
    # the controller's nominal model is the cell's; an uncalibrated body stays nominal
    np.testing.assert_array_equal(world.arms["right"].nominal, cell.arms["right"].nominal)
    assert world.positioners["STN1"].chain is cell.positioners["STN1"].chain
    assert world.positioners["STN2"].unit == "STN2"
    with pytest.raises(ModelError, match="the anchor body 'left' must be among the calibrated bodies"):
        cell.in_world({"right": calibrated["ROB_2"]})
    with pytest.raises(ModelError, match="no body 'nobody'"):
        cell.in_world({"left": calibrated["left"], "nobody": calibrated["left"]})
    with pytest.raises(ModelError, match="calibrated 'STN1': its joints differ"):
        cell.in_world({"left": calibrated["left"], "STN1": calibrated["STN2"]})


def test_positioner_only_cell_anchors_on_the_positioner():
    data = {"units": {"length": "mm", "angle": "deg"}, "positioner": copy.deepcopy(CELL["positioner"])}
    cell = cell_from_data(data)
    assert cell.arms == {} and cell.anchor == "STN1" and cell.resolve("plate") == "STN1"
    chain = cell.positioners["STN1"].chain
    world = cell.in_world({"plate": chain.with_frames(base=pose([100, 0, 0]) @ chain.base)})
    np.testing.assert_array_equal(world.positioners["STN1"].chain.base, chain.base)


@pytest.mark.parametrize("form, table", [
    ("mdh", {"alpha": [0, -90], "a": [0, 120], "theta": [0, 30], "d": [900, 250]}),
    ("dh", {"theta": [0, 30], "d": [900, 250], "a": [120, 0], "alpha": [-90, 0]}),
])
def test_table_forms_are_model_tables_mounted(form, table):
    spec = {"unit": "STN1", form: table, "limits": [[-90, 90], [-360, 360]],
            "mount": {"xyz": [1400, 0, 0], "rpy": [0, 0, 30]},
            "plate": {"xyz": [10, 20, 5], "rpy": [0, 0, 45]}}
    chain = cell_from_data({**CELL, "positioner": spec}).positioners["STN1"].chain
    make = Robot.from_mdh if form == "mdh" else Robot.from_dh
    own = make(*table.values(), degrees=True, length_unit="mm")
    e = np.deg2rad(E_DEG)
    truth = pose([1400, 0, 0], [0, 0, 30]) @ own.fk(e) @ pose([10, 20, 5], [0, 0, 45])
    np.testing.assert_allclose(chain.fk(e), truth, rtol=0, atol=TOL)
    np.testing.assert_allclose(chain.limits, np.deg2rad(spec["limits"]))


def test_inline_model_and_model_file(tmp_path):
    cell = cell_from_data(CELL)
    chain = cell.positioners["STN1"].chain
    chain.save(tmp_path / "stn.yaml")
    data = {"units": {"length": "mm", "angle": "deg"}, "robot": "abb_irb2600",
            "positioner": {"model": "stn.yaml", "unit": "STN1"}}
    from_file = load_cell(write(tmp_path, data)).positioners["STN1"].chain
    np.testing.assert_array_equal(from_file.values, chain.values)
    data["positioner"]["model"] = {"units": {"length": "mm", "angle": "deg"},
                                   "axes": CELL["positioner"]["axes"]}
    data["positioner"]["mount"] = CELL["positioner"]["mount"]
    data["positioner"]["plate"] = CELL["positioner"]["plate"]
    inline = cell_from_data(data).positioners["STN1"]
    np.testing.assert_allclose(inline.plate(np.deg2rad(E_DEG)), tilt_turn_truth(E_DEG), rtol=0, atol=TOL)


def _with(data, path, value):
    data = copy.deepcopy(data)
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


DELETE = object()
P = ("positioner",)
AX = ("positioner", "axes")


@pytest.mark.parametrize("data, message", [
    (_with(CELL, ("stations",), 2), r"the cell: unknown key\(s\) \['stations'\]"),
    (_with(CELL, P + ("speed",), 2), r"positioner: unknown key\(s\) \['speed'\]"),
    (_with(CELL, AX, [{"type": "revolute", "axis": [0, 0, 0], "origin": [0, 0, 900]}]),
     r"STN1 axis 1: zero axis"),
    (_with(CELL, AX, [{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 900]},
                      {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 250]}]),
     r"STN1 axes 1 and 2: consecutive revolute axes are coaxial"),
    (_with(CELL, AX, [{"type": "revolute", "axis": [0, 0, 2], "origin": [0, 0, 900]}]),
     r"axis 1: axis \[0.0, 0.0, 2.0\] is not a unit vector"),
    (_with(CELL, AX + (0, "limits"), [90, -90]), r"STN1 axis 1: limits reversed"),
    (_with(CELL, AX + (0, "twist"), 1), r"axis 1: unknown key\(s\) \['twist'\]"),
    (_with(CELL, AX, [{"type": "revolute", "axis": [1, 0, 0]}] * 2
           + [{"type": "revolute", "axis": [0, 1, 0]}, {"type": "revolute", "axis": [0, 0, 1]}]),
     r"1 to 3 axes, got 4"),
    (_with(CELL, P + ("nests",), [[1, 2, 3], [4, 5]]), r"positioner.nests\[2\]: expected 3 values, got 2"),
    (_with(CELL, P + ("nests",), [1, 2, 3]), r"positioner.nests\[1\]: expected a list of numbers"),
    (_with(CELL, P + ("nests",), []), r"positioner.nests: expected a list of \[x, y, z\]"),
    (_with(CELL, P + ("columns",), ["e1"]), r"columns \['e1'\]: expected 2 distinct names"),
    (_with(CELL, P + ("columns",), ["e1", "e1"]), r"expected 2 distinct names"),
    (_with(CELL, P + ("columns",), ["q7", "e2"]), r"expected 2 distinct names e1, e2"),
    (_with(CELL, P + ("external_axes",), [2]), r"external_axes \[2\]: expected 2 distinct logical"),
    (_with(CELL, P + ("external_axes",), [2, 2]), r"expected 2 distinct logical external-axis numbers"),
    (_with(CELL, P + ("external_axes",), ["eax_b", "eax_c"]), r"external_axes \['eax_b', 'eax_c'\]: exp"),
    (_with(CELL, P + ("external_axes",), [0, 1]), r"external_axes \[0, 1\]: expected"),
    (_with(CELL, P + ("external_axes",), [True, 2]), r"external_axes \[True, 2\]: expected"),
    (_with(CELL, P + ("external_axes",), 2), r"positioner.external_axes: expected a list of logical"),
    (_with(CELL, P + ("program_axes",), ["eax_b", "eax_c"]), r"program_axes"),
    (_with(CELL, P + ("model",), "abb_irbp_a250"), r"give exactly one geometry"),
    (_with(CELL, P + ("axes",), DELETE), r"give exactly one geometry.*found none"),
    (_with(CELL, P + ("limits",), [[-1, 1], [-1, 1]]), r"positioner.limits: only with a dh or mdh table"),
    (_with(_with(CELL, P + ("axes",), DELETE), P + ("model",), "no_such_positioner"),
     r"positioner.model: unknown positioner 'no_such_positioner'; the catalog has: "),
    (_with(_with(CELL, P + ("axes",), DELETE), P + ("mdh",),
           {"alpha": [0, 0], "a": [0, 0], "theta": [0, 0], "d": [900, 250]}),
     r"axes 1 and 2: consecutive revolute axes are coaxial"),
    (_with(CELL, ("positioners",), {}), r"either positioner: \(one\) or positioners"),
    (_with(CELL, ("robots",), {"a": {"model": "abb_irb2600"}}), r"robots: give the arms either"),
    (_with(TWO_ARMS, ("robots", "right", "unit"), "ROB_1"),
     r"unit 'ROB_1' named twice \(bodies 'left' and 'right'\)"),
    (_with(TWO_ARMS, ("positioners", "STN2", "unit"), "STN1"), r"unit 'STN1' named twice"),
    (_with(TWO_ARMS, ("robots", "STN1"), {"model": "abb_irb2600", "unit": "ROB_3"}),
     r"body name 'STN1' used twice"),
    (_with(TWO_ARMS, ("robots", "right", "unit"), "STN2x") | {"positioners": {
        "STN2x": copy.deepcopy(TWO_ARMS["positioners"]["STN1"])}}, r"unit 'STN2x' named twice"),
    (_with(TWO_ARMS, ("robots", "right", "unit"), "STN1"), r"unit 'STN1' named twice"),
    (_with(TWO_ARMS, ("positioners", "STN2", "unit"), "left"),
     r"body name 'left' is also the unit of body 'STN2'"),
    (_with(TWO_ARMS, ("robots", "right", "speed"), 3), r"robots.right: unknown key\(s\) \['speed'\]"),
    (_with(TWO_ARMS, ("positioners", "STN1", "name"), "x"), r"positioners.STN1: unknown key\(s\) \['name'\]"),
    (_with(TWO_ARMS, ("positioners", "STN2", "columns"), ["e1", "e4"]),
     r"positioner 'STN2': column e1 is already positioner 'STN1''s"),
    (_with(TWO_ARMS, ("robots",), {}), r"robots: expected at least one arm"),
    (_with(TWO_ARMS, ("robots",), 3), r"robots: expected a mapping \{name: \{...\}\}, got 3"),
    (_with(TWO_ARMS, ("positioners",), True), r"positioners: expected a mapping \{name: \{...\}\}"),
    (_with(TWO_ARMS, ("positioners",), {}), r"positioners: expected at least one positioner"),
    (_with(CELL, P + ("columns",), ["e0", "e1"]), r"expected 2 distinct names e1, e2"),
    ({"units": {"length": "mm", "angle": "deg"}, "track": {"direction": [1, 0, 0], "limits": [0, 1]},
      "positioner": CELL["positioner"]}, r"a track and its mount belong to an arm"),
    (_with(CELL, ("units",), DELETE), r"the cell: missing key\(s\) \['units'\]"),
])
def test_malformed_cells_are_refused_naming_the_cause(tmp_path, data, message):
    with pytest.raises(ModelError, match=message) as info:
        load_cell(write(tmp_path, data))
    assert "\n" not in str(info.value) and str(info.value).startswith(str(tmp_path / "cell.yaml"))


def test_python_construction_is_validated():
    arm = Robot.from_catalog("abb_irb2600")
    chain = cell_from_data(CELL).positioners["STN1"].chain
    with pytest.raises(ModelError, match="a cell needs at least one body"):
        Cell({})
    with pytest.raises(ModelError, match="arm_units names no arm"):
        Cell({"a": arm}, arm_units={"b": "ROB_1"})
    with pytest.raises(ModelError, match="positioner 'p': expected a Positioner, got Robot"):
        Cell({"a": arm}, {"p": chain})
    with pytest.raises(ModelError, match="unit is empty"):
        Positioner(chain, " ")
    with pytest.raises(ModelError, match="robots.a.unit is empty"):
        Cell({"a": arm}, arm_units={"a": ""})
    with pytest.raises(ModelError, match="2 nests but its chain has 3 SMR offsets"):
        Positioner(chain, "S", nests=np.zeros((2, 3)))  # the chain carries the cell's 3 nests
    with pytest.raises(ModelError, match=r"nests must be a finite \(K, 3\) array"):
        Positioner(Robot.from_mdh([0], [0], [0], [0]), "S", nests=np.zeros((2, 2)))
    with pytest.raises(ModelError, match="1 to 3 axes, got 6"):
        Positioner(arm, "S")


def test_an_arm_on_a_track_among_several(tmp_path):
    from robocal.kinematics.model import track_chain

    data = _with(TWO_ARMS, ("robots", "right", "track"), {"direction": [0, 1, 0], "limits": [-1000, 5000]})
    data["positioners"]["STN1"]["columns"] = ["e2"]
    data["positioners"]["STN2"]["columns"] = ["e3", "e4"]
    cell = load_cell(write(tmp_path, data))
    arm = Robot.from_catalog("abb_irb2600")
    truth = track_chain(arm, [0, 1, 0], pose([3000, 0, 0], [0, 0, 180]), [-1.0, 5.0])
    np.testing.assert_array_equal(cell.arms["right"].values, truth.values)
    assert [j.column for j in cell.joints("right")][:2] == ["e1_mm", "q1_deg"]
    with pytest.raises(ModelError, match="column e1 is already the track of arm 'right''s"):
        load_cell(write(tmp_path, _with(data, ("positioners", "STN1", "columns"), ["e1"])))


def test_a_positioner_given_as_a_urdf(tmp_path):
    (tmp_path / "table.urdf").write_text("""<robot name="table">
      <link name="base"/><link name="tilt"/><link name="turn"/>
      <joint name="a1" type="revolute"><parent link="base"/><child link="tilt"/>
        <origin xyz="0 0 0.9"/><axis xyz="1 0 0"/><limit lower="-1.5" upper="1.5"/></joint>
      <joint name="a2" type="revolute"><parent link="tilt"/><child link="turn"/>
        <origin xyz="0 0 0.25"/><axis xyz="0 0 1"/><limit lower="-6" upper="6"/></joint>
    </robot>""")
    data = _with(_with(CELL, P + ("axes",), DELETE), P + ("model",), "table.urdf")
    urdf = load_cell(write(tmp_path, data)).positioners["STN1"]
    np.testing.assert_allclose(urdf.plate(np.deg2rad(E_DEG)), tilt_turn_truth(E_DEG), rtol=0, atol=TOL)


def test_in_world_keeps_estimated_smrs_nominal_and_the_cells_geometry():
    data = _with(CELL, P + ("nests",), DELETE)
    cell = cell_from_data(data)
    chain = cell.positioners["STN1"].chain
    # a calibration without nests estimates the SMRs' plate positions: two more SMRs on the chain
    estimated = Robot(**{f: getattr(chain, f) for f in ("alpha", "a", "beta", "theta", "d", "base", "tool",
                                                        "limits", "parallel")},
                      smr=[[0.1, 0, 0], [0, 0.1, 0]]).with_values({"d2": chain.get("d2") + 1e-4})
    world = cell.in_world({"arm": cell.arms["arm"], "STN1": estimated})
    moved = world.positioners["STN1"].chain
    assert len(moved.smr) == 2 and moved.get("d2") == pytest.approx(chain.get("d2") + 1e-4)
    nominal = dict(zip(moved.geometry_names, moved.nominal, strict=True))
    assert nominal["d2"] == chain.get("d2") and nominal["smr1.x"] == 0.1


def test_robots_command_shows_a_cell(tmp_path, capsys):
    from robocal.cli import main

    assert main(["robots", str(write(tmp_path, TWO_ARMS))]) == 0
    out = capsys.readouterr().out
    assert out.startswith("two robots (anchor: left)")
    assert "== positioner STN2 (unit STN2; columns e2_deg, e3_deg)" in out
    assert "== arm right (unit ROB_2; columns q1_deg" in out


def test_identifiability_says_which_case():
    with_nests = cell_from_data(CELL).positioners["STN1"]
    without = cell_from_data(_with(CELL, P + ("nests",), DELETE)).positioners["STN1"]
    assert "last axis' zero (theta2) are identified" in with_nests.identifiability
    assert "(theta2) and the plate frame's turn about that axis are one freedom" in without.identifiability
    assert repr(without) == "Positioner('STN1', unit 'STN1', columns ['e1', 'e2'])"


def test_a_positioner_with_nests_has_the_identification_jacobian():
    """The body is an ordinary robot to the identification: its Jacobian at the nests (SMR k) is the
    central difference of its forward kinematics."""
    chain = cell_from_data(CELL).positioners["STN1"].chain
    e = np.deg2rad([[10, 20], [-30, 100], [45, -200]])
    smr = np.array([1, 2, 3])
    names = chain.default_free(orientation=True)
    J = chain.jacobian(e, names, smr=smr)
    h = 1e-7
    for k, name in enumerate(names):
        step = (chain.displaced([name], [h]).fk(e, smr=smr) - chain.displaced([name], [-h]).fk(e, smr=smr))
        np.testing.assert_allclose(J[:, :, k], step[:, :3, 3] / (2 * h), rtol=0, atol=1e-8, err_msg=name)


def test_external_axes_are_logical_numbers():
    """A positioner's axes as the controller's logical external-axis numbers, language-neutral (each
    dialect names them: test_coordinated_rapid_krl); default its columns' numbers; saved and read back."""
    stn = cell_from_data(_with(CELL, P + ("external_axes",), [2, 3])).positioners["STN1"]
    assert stn.external_axes == (2, 3) and stn.to_dict()["external_axes"] == [2, 3]
    assert cell_from_data(CELL).positioners["STN1"].external_axes == (1, 2)
    assert Positioner(stn.chain, "STN1", external_axes=(np.int64(3), 1)).external_axes == (3, 1)


def test_positioner_from_catalog_in_python():
    mount = pose([1500, 0, 0], [0, 0, 90])
    table = Positioner.from_catalog("abb_irbp_a250", "STN1", mount, nests=np.eye(3) * 0.2)
    file = cell_from_data({"units": {"length": "mm", "angle": "deg"},
                           "positioner": {"model": "abb_irbp_a250", "unit": "STN1",
                                          "mount": {"xyz": [1500, 0, 0], "rpy": [0, 0, 90]},
                                          "nests": [[200, 0, 0], [0, 200, 0], [0, 0, 200]]}})
    e = np.deg2rad(E_DEG)
    for k in range(4):
        np.testing.assert_allclose(table.chain.fk(e, smr=np.full(len(e), k)),
                                   file.positioners["STN1"].chain.fk(e, smr=np.full(len(e), k)), atol=TOL)


def test_outside_limits_one_tolerance_in_the_joints_unit():
    """Robot.outside_limits, the one positioner limit check: a value written at its limit in
    degrees (or mm) converts to SI a rounding away and is at it; LIMIT_TOL (rad or m) beyond is
    outside; brute force against the plain comparison on random values."""
    from robocal.kinematics.model import LIMIT_TOL
    from robocal.kinematics.positioner import positioner_chain

    chain = positioner_chain([{"type": "revolute", "axis": [1, 0, 0], "limits": [-np.pi / 2, np.pi / 2]},
                              {"type": "prismatic", "axis": [0, 0, 1], "limits": [0.0, 1.2]}],
                             np.eye(4), name="p")
    at = np.array([[np.deg2rad(90.0) * (1 + 1e-15), 1200.0 * 1e-3 * (1 + 1e-15)]])
    assert not chain.outside_limits(at).any()
    beyond = np.array([[np.pi / 2 + 2 * LIMIT_TOL, 0.5], [0.0, -2 * LIMIT_TOL]])
    np.testing.assert_array_equal(chain.outside_limits(beyond), [[True, False], [False, True]])
    q = np.random.default_rng(0).uniform([-2, -0.2], [2, 1.4], (200, 2))
    lo, hi = chain.limits[:, 0], chain.limits[:, 1]
    np.testing.assert_array_equal(chain.outside_limits(q), (q < lo) | (q > hi))


def test_cell_pick_given_or_the_only_one():
    """Cell.pick: a body given by name or unit among its kind, else the only one; a body of
    another kind, an unknown name or no single one is refused naming the kind's bodies."""
    from robocal.core.errors import DataError
    from robocal.kinematics.positioner import positioner_chain

    arm = rc.Robot.from_catalog("abb_irb2600")
    turn = positioner_chain([{"type": "revolute", "axis": [0, 0, 1]}], np.eye(4), name="turntable")
    one = Cell({"left": arm}, {"STN1": Positioner(turn, unit="STN1")}, arm_units={"left": "ROB_1"})
    assert (one.pick("arm"), one.pick("arm", "ROB_1"), one.pick("positioner")) == ("left", "left", "STN1")
    with pytest.raises(DataError, match=r"'STN1' is not one of the cell's arms \(left\)"):
        one.pick("arm", "STN1")
    with pytest.raises(DataError, match=r"'nope' is not one of the cell's positioners \(STN1\)"):
        one.pick("positioner", "nope")
    two = Cell({"left": arm, "right": arm})
    with pytest.raises(DataError, match=r"the cell has 2 arms \(left, right\): name the one"):
        two.pick("arm")
    assert two.pick("positioner", optional=True) is None
    with pytest.raises(DataError, match=r"the cell has 0 positioners \(none\)"):
        two.pick("positioner")
