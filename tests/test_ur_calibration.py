"""UR factory calibration: calibration.conf and the ROS driver's ur_calibration YAML, both ways,
checked against independent compositions (tests/ur_tools.py: the controller's DH chain, the
xacro's joint origins, a port of the driver's algorithm)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from ur_tools import DATA, dh_fk, driver_yaml, lines_to_dh, true_arm_dh, xacro_fk

import robocal as rc
from robocal.cli import main
from robocal.core.errors import ModelError
from robocal.kinematics.manufacturer import ur as vur

CONF = DATA / "ur5e_calibration.conf"
YAML10 = DATA / "ur10e_calibration.yaml"
POS_TOL = 1e-9  # m (1e-6 mm)
ROT_TOL = 1e-8  # rad


def _rotation_error(A, B):
    R = np.einsum("nji,njk->nik", A[:, :3, :3], B[:, :3, :3])
    vee = np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    return np.arctan2(np.linalg.norm(vee, axis=1) / 2, (np.trace(R, axis1=1, axis2=2) - 1) / 2)


def _assert_same(A, B):
    assert np.linalg.norm(A[:, :3, 3] - B[:, :3, 3], axis=1).max() < POS_TOL
    assert np.abs(A[:, :3, :3] - B[:, :3, :3]).max() < ROT_TOL
    assert _rotation_error(A, B).max() < ROT_TOL


def _controller_table(text, name):
    deltas = vur.parse_calibration_conf(text, "t")
    nom = vur.nominal_dh(name)
    return nom.theta + deltas.theta, nom.d + deltas.d, nom.a + deltas.a, nom.alpha + deltas.alpha


def _joints(n=1000, seed=0):
    return np.random.default_rng(seed).uniform(-2 * np.pi, 2 * np.pi, (n, 6))


def test_conf_import_equals_the_controllers_dh_at_1000_joint_vectors():
    text = CONF.read_text()
    theta, d, a, alpha = _controller_table(text, "ur5e")
    assert np.abs(d).max() > 100  # the real files' near-parallel description
    robot = vur.import_calibration(CONF, "ur5e").robot
    q = _joints()
    _assert_same(robot.fk(q), dh_fk(theta, d, a, alpha, q))
    assert np.abs(robot.d).max() < 0.2
    assert robot.parallel.tolist() == rc.Robot.from_catalog("ur5e").parallel.tolist()


def test_zero_deltas_give_the_catalog_model_exactly():
    zero = "[mounting]\n" + "\n".join(f"{k} = [0, 0, 0, 0, 0, 0]" for k in vur.DELTA_KEYS) + "\n"
    for name in ("ur5e", "ur10e", "ur3", "ur30"):
        robot = vur.from_calibration_conf(zero, name).robot
        cat = rc.Robot.from_catalog(name)
        assert np.allclose(robot.values, cat.values, rtol=0, atol=1e-15)
        assert cat.has_ur_form


@pytest.mark.parametrize("tilt", [1e-7, 1e-6, 1e-5, 3e-4, 3e-3])
def test_near_parallel_dh_pair_converts_exactly_whatever_d(tilt):
    """Axes 2-4 tilted out of parallel by ``tilt`` rad: DH d grows as 1/tilt (to 10^5 m and
    beyond); MDH + beta keeps the arm's sizes and the DH chain's forward kinematics."""
    nom = rc.Robot.from_catalog("ur10e")
    moved = nom.with_values({"alpha3": tilt, "beta3": -2 * tilt, "alpha4": -tilt, "beta4": 1.5 * tilt,
                             "a3": nom.get("a3") + 1e-4, "theta3": 1e-3})
    tcp, frames = moved.fk(np.zeros((1, 6)), frames=True)
    theta, d, a, alpha = lines_to_dh(frames[0, 1:, :3, 2], frames[0, 1:, :3, 3], tcp[0])
    mdh = vur.mdh_beta_from_lines(*vur._dh_lines(vur.DHTable(theta, d, a, alpha)), nom.parallel)
    robot = rc.Robot(**{k: mdh[k] for k in ("alpha", "a", "beta", "theta", "d", "base", "tool")})
    q = _joints(200, 1)
    ref = dh_fk(theta, d, a, alpha, q)
    slack = 20 * np.finfo(float).eps * np.abs(d).max()  # the DH rows place their lines to |d| eps
    assert np.linalg.norm(robot.fk(q)[:, :3, 3] - ref[:, :3, 3], axis=1).max() < POS_TOL + slack
    assert _rotation_error(robot.fk(q), ref).max() < ROT_TOL + slack / 0.1
    assert np.allclose(robot.links.beta, moved.beta, atol=1e-9) and np.abs(robot.d).max() < 0.2


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(["ur3e", "ur5e", "ur10e", "ur16e", "ur20", "ur30"]),
       tilts=st.lists(st.floats(-8.0, -2.5), min_size=4, max_size=4),
       signs=st.lists(st.sampled_from([-1.0, 1.0]), min_size=4, max_size=4),
       seed=st.integers(0, 2**16))
def test_any_near_parallel_ur_converts_exactly(name, tilts, signs, seed):
    """Catalog URs tilted out of parallel by 1e-8..3e-3 rad on axes 2-4 (DH d up to ~10^7 m),
    with sub-millimetre errors elsewhere: DH -> MDH + beta keeps the DH chain's kinematics."""
    nom = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(seed)
    t = np.array(signs) * 10.0 ** np.array(tilts)
    moved = nom.with_values({"alpha3": t[0], "beta3": t[1], "alpha4": t[2], "beta4": t[3],
                             **{f"a{i}": nom.get(f"a{i}") + rng.normal(0, 3e-4) for i in range(2, 6)},
                             **{f"theta{i}": nom.get(f"theta{i}") + rng.normal(0, 1e-3)
                                for i in range(1, 7)}})
    tcp, frames = moved.fk(np.zeros((1, 6)), frames=True)
    theta, d, a, alpha = lines_to_dh(frames[0, 1:, :3, 2], frames[0, 1:, :3, 3], tcp[0])
    mdh = vur.mdh_beta_from_lines(*vur._dh_lines(vur.DHTable(theta, d, a, alpha)), nom.parallel)
    robot = rc.Robot(**{k: mdh[k] for k in ("alpha", "a", "beta", "theta", "d", "base", "tool")})
    q = _joints(50, seed)
    ref = dh_fk(theta, d, a, alpha, q)
    # a DH row with d = 10^7 m places its line only to |d| eps = 2e-9 m, and the arm's direction
    # (over ~0.1 m) to |d| eps / 0.1 m: the bounds grow by that (nothing for real files' |d| < 1e3 m)
    slack = 20 * np.finfo(float).eps * np.abs(d).max()
    assert np.linalg.norm(robot.fk(q)[:, :3, 3] - ref[:, :3, 3], axis=1).max() < POS_TOL + slack
    assert _rotation_error(robot.fk(q), ref).max() < ROT_TOL + slack / 0.1
    # and it is the arm that was tilted: as near it as the DH table itself is (a table with d of
    # 10^7 m, computed from the tilted lines, holds them only to ~|d| eps / tilt: the conversion
    # may not add to that, but cannot remove it)
    table_gap = np.abs(ref[:, :3, 3] - moved.fk(q)[:, :3, 3]).max()
    assert np.abs(robot.fk(q)[:, :3, 3] - moved.fk(q)[:, :3, 3]).max() < table_gap + POS_TOL + slack


def test_ur_calibration_yaml_is_read_as_the_xacro_composes_it():
    kin = yaml.safe_load(YAML10.read_text())["kinematics"]
    robot = vur.import_calibration(YAML10, "ur10e").robot
    q = _joints()
    _assert_same(robot.fk(q), xacro_fk(kin, q))


def _driver_tables():
    theta, d, a, alpha = true_arm_dh("ur10e", 32)
    text = "[mounting]\n" + "\n".join(f"{k} = [ {', '.join(repr(v) for v in vals)}]"
                                      for k, vals in DRIVER_DELTAS_2.items()) + "\n"
    return [(theta, d, a, alpha), _controller_table(text, "ur10")]


@pytest.mark.parametrize("case", [0, 1])
def test_driver_yaml_and_controller_differ_by_the_euler_convention(case):
    """The driver's YAML composed by the xacro is not the controller's arm (measured here); read
    with Eigen's convention (Rx Ry Rz) it is, but for the last row's Rx(alpha6) Tx(a6)."""
    theta, d, a, alpha = _driver_tables()[case]
    kin = driver_yaml(theta, d, a, alpha)
    q = _joints(1000, 3)
    ctrl = dh_fk(theta, d, a, alpha, q)
    gap = np.linalg.norm(ctrl[:, :3, 3] - xacro_fk(kin, q)[:, :3, 3], axis=1)
    assert gap.max() > 1e-4  # ROS is off by more than 0.1 mm somewhere

    def eigen_reading(kin):
        origins = [vur.make_transform(vur.rot_x(k["roll"]) @ vur.rot_y(k["pitch"]) @ vur.rot_z(k["yaw"]),
                                      (k["x"], k["y"], k["z"])) for k in kin.values()]
        return vur.origins_fk(np.array(origins), q, np.eye(4))

    without_last = ctrl @ np.linalg.inv(vur.make_transform(vur.rot_x(alpha[5]), (a[5], 0, 0)))
    assert np.abs(eigen_reading(kin) - without_last).max() < 1e-9
    if case == 1:  # the earlier correctAxis (atan) put this arm's elbow half a turn off
        old = eigen_reading(driver_yaml(theta, d, a, alpha, release="atan"))
        assert np.linalg.norm(old[:, :3, 3] - without_last[:, :3, 3], axis=1).max() > 1.0


def _calibrated(seed=4):
    factory = vur.import_calibration(CONF, "ur5e").robot
    rng = np.random.default_rng(seed)
    names = [n for n in factory.default_free() if not n.startswith(("base", "tool"))]
    cal = factory.displaced(names, rng.normal(0, 3e-4, len(names)))
    tracker = vur.make_transform(vur.rot_z(0.7) @ vur.rot_x(0.1), (2.0, -1.0, 0.3))
    smr = vur.make_transform(np.eye(3), (0, 0.05, 0.2))
    return cal.with_frames(base=tracker @ cal.base, tool=cal.tool @ smr), factory


def test_export_composes_to_the_calibrated_arm(tmp_path):
    cal, factory = _calibrated()
    text = vur.to_ur_calibration(cal, factory)
    kin = yaml.safe_load(text)["kinematics"]
    assert kin["hash"].startswith("calib_")
    q = _joints()
    arm = cal.with_frames(base=factory.base, tool=factory.tool)  # base -> flange (--frames robot)
    _assert_same(xacro_fk(kin, q), arm.fk(q))
    back = vur.from_ur_calibration(text, "ur5e").robot  # and read back
    _assert_same(back.fk(q), arm.fk(q))


def test_export_refuses_what_the_xacro_cannot_hold():
    cal, factory = _calibrated()
    off_axis = factory.with_frames(tool=factory.tool @ vur.make_transform(np.eye(3), (0.001, 0, 0)))
    with pytest.raises(ModelError, match="off joint 6's axis"):
        vur.to_ur_calibration(cal, off_axis)
    abb = rc.Robot.from_catalog("abb_irb2600")
    with pytest.raises(ModelError, match="not a Universal Robots arm"):
        vur.to_ur_calibration(abb, abb)


def test_not_linearised_status_is_imported_with_a_note():
    text = CONF.read_text().replace("calibration_status = 2", "calibration_status = 1")
    result = vur.from_calibration_conf(text, "ur5e")
    assert "not linearised" in result.notes[0]


def test_cli_export_warns_naming_joint_error_terms(tmp_path, capsys):
    cal, factory = _calibrated()
    cal = cal.with_joint_errors(["comp2_3", "backlash2"])
    cal.save(tmp_path / "cal.yaml")
    factory.save(tmp_path / "factory.yaml")
    out = tmp_path / "out.yaml"
    assert main(["export", str(tmp_path / "cal.yaml"), "--nominal", str(tmp_path / "factory.yaml"),
                 "--ur-calibration", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "comp2_3" in printed and "backlash2" in printed and "not representable" in printed
    kin = yaml.safe_load(out.read_text())["kinematics"]
    q = _joints(100)
    _assert_same(xacro_fk(kin, q), cal.with_joint_errors([]).with_frames(base=factory.base,
                                                                          tool=factory.tool).fk(q))


def test_cli_import_calibration_writes_a_model_usable_as_robot(tmp_path, capsys):
    out = tmp_path / "factory.yaml"
    assert main(["import-calibration", str(CONF), "--robot", "ur5e", "-o", str(out)]) == 0
    robot = rc.Robot.load(out)
    theta, d, a, alpha = _controller_table(CONF.read_text(), "ur5e")
    q = _joints(50)
    _assert_same(robot.fk(q), dh_fk(theta, d, a, alpha, q))


@pytest.mark.parametrize("text, match", [
    ("[mounting]\ndelta_theta = [0, 0, 0, 0, 0, 0]\n", "lacks delta_a, delta_d, delta_alpha"),
    ("[mounting]\n" + "\n".join(f"{k} = [0, 0, 0, 0, 0]" for k in vur.DELTA_KEYS), "6 finite numbers"),
    ("[mounting]\n" + "\n".join(f"{k} = [0, 0, 0, 0, 0, x]" for k in vur.DELTA_KEYS), "not a number"),
    ("[mounting]\n" + "\n".join(f"{k} = [0, 0, 0, 0, 0, 0]" for k in vur.DELTA_KEYS)
     + "\ncalibration_status = 0\n", "not initialised"),
    ("[mounting]\n" + "\n".join(f"{k} = [0, 0, 0, 0, 0, 1e9]" for k in vur.DELTA_KEYS), "beyond"),
])
def test_malformed_conf_is_refused_naming_the_problem(text, match):
    with pytest.raises(ModelError, match=match):
        vur.from_calibration_conf(text, "ur5e")


def test_calibration_of_another_model_is_refused(tmp_path, capsys):
    assert main(["import-calibration", str(CONF), "--robot", "ur10e", "-o", str(tmp_path / "x.yaml")]) == 2
    err = capsys.readouterr().err
    assert "another robot model (it fits ur5, ur5e)" in err
    # the ROS driver's UR10 deltas: refused as a UR5e, recognised as a UR10 (or the close UR10e)
    text = "[mounting]\n" + "\n".join(f"{k} = [ {', '.join(repr(v) for v in vals)}]"
                                      for k, vals in DRIVER_DELTAS.items())
    with pytest.raises(ModelError, match=r"it fits ur10, ur10e\)"):
        vur.from_calibration_conf(text, "ur5e")
    with pytest.raises(ModelError, match="not a Universal Robots"):
        vur.from_calibration_conf(CONF.read_text(), "abb_irb2600")
    with pytest.raises(ModelError, match="it fits ur10e"):
        vur.from_ur_calibration(YAML10.read_text(), "ur5e")
    bad = YAML10.read_text().replace("    yaw:", "    yawn:", 1)
    with pytest.raises(ModelError, match="expected the keys"):
        vur.from_ur_calibration(bad, "ur10e")


def _factory_and_truth(tmp_path):
    """The factory model (the controller's) and a recalibrated arm whose nominal it is."""
    factory = vur.import_calibration(CONF, "ur5e").robot
    names = [n for n in factory.default_free() if not n.startswith(("base", "tool"))]
    cal = factory.displaced(names, np.random.default_rng(9).normal(0, 2e-4, len(names)))
    assert np.allclose(cal.nominal, factory.values)  # calibrated from the factory model
    factory.save(tmp_path / "factory.yaml")
    cal.save(tmp_path / "cal.yaml")
    return factory, cal


def _walk(n=12):
    base = np.array([0.3, -1.4, 1.6, -1.8, -1.5, 0.4])
    return base + np.linspace(0, 1, n)[:, None] * np.array([0.5, 0.3, -0.4, 0.3, 0.2, 0.6])


def test_factory_model_as_nominal_seeds_ik_compensate_and_plan(tmp_path):
    factory, cal = _factory_and_truth(tmp_path)
    assert not factory.has_ur_form  # the factory arm itself has no closed form ...
    q = _walk()
    T = cal.fk(q)
    for robot, nominal in ((factory, None), (cal, None), (cal, factory)):  # ... it is seeded by the UR one
        res = rc.ik.solve(robot, robot.fk(q) if robot is factory else T, nominal=nominal)
        assert res.converged.all() and res.position_error.max() < 1e-9
    from robocal.deploy.compensation import compensate, format_csv, pose_columns

    comp = compensate(cal, factory, T, start=q[0])
    assert comp.converged.all()
    _assert_same(cal.fk(comp.joints), T)
    _assert_same(factory.fk(comp.joints), comp.corrected_targets)
    cols, vals = pose_columns(T, {"length": "mm", "orientation": "deg"})
    (tmp_path / "targets.csv").write_text(format_csv(cols, vals))
    out = tmp_path / "commands.csv"
    assert main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "targets.csv"), "--nominal",
                 str(tmp_path / "factory.yaml"), "-o", str(out)]) == 0
    got = np.deg2rad(np.loadtxt(out, delimiter=",", skiprows=2, usecols=range(6)))  # marker, header
    assert np.linalg.norm(cal.fk(got)[:, :3, 3] - T[:, :3, 3], axis=1).max() < 1e-9
    flange = cal.with_frames(base=factory.base, tool=factory.tool)
    cols, vals = pose_columns(flange.fk(q), {"length": "mm", "orientation": "deg"})
    (tmp_path / "poses.csv").write_text(format_csv(cols, vals))
    assert main(["plan", "--robot", str(tmp_path / "cal.yaml"), "--nominal", str(tmp_path / "factory.yaml"),
                 str(tmp_path / "poses.csv"), "-o", str(tmp_path / "joints.csv")]) == 0
    planned = np.deg2rad(np.loadtxt(tmp_path / "joints.csv", delimiter=",", skiprows=1))
    assert np.linalg.norm(flange.fk(planned)[:, :3, 3] - flange.fk(q)[:, :3, 3], axis=1).max() < 1e-6


def test_factory_model_as_nominal_filters_a_urscript_program(tmp_path):
    from robocal.programs.filter import filter_program

    factory, cal = _factory_and_truth(tmp_path)
    res = filter_program(DATA / "programs" / "pick_place.script", cal, factory)
    assert len(res.rows) == 5 and not res.uncorrected and not res.warnings
    assert all(r["converged"] and r["reachable"] and 0.01 < r["correction_mm"] < 2 for r in res.rows)
    out, program = tmp_path / "out.script", DATA / "programs" / "pick_place.script"
    assert main(["filter", str(program), "--calibrated", str(tmp_path / "cal.yaml"),
                 "--nominal", str(tmp_path / "factory.yaml"), "-o", str(out)]) == 0
    assert out.read_text() != (DATA / "programs" / "pick_place.script").read_text()


# Deltas from the ROS 2 driver's ur_calibration test (UniversalRobots/Universal_Robots_ROS2_Driver,
# ur_calibration/test/calibration_test.cpp), added there to a UR10: d of 439 and -446 m, theta 7.1 rad
DRIVER_DELTAS = {
    "delta_d": [-0.000144894975118076141, 303.469135666158195, -309.88394307789747, 6.41459904397394975,
                -4.48232900190081995e-05, -0.00087071402790364627],
    "delta_a": [0.000108651068627930392, 0.240324175250532346, 0.00180628180213493472,
                2.63076149165684402e-05, 3.96638632500012715e-06, 0],
    "delta_theta": [1.59613525316931737e-07, -0.917209621528830232, 7.12936131346499469,
                    0.0710299029424392298, -1.64258976526054923e-06, 9.17286101034808787e-08],
    "delta_alpha": [-0.000444781952841921679, -0.00160215112531214153, 0.00631917793331091861,
                    -0.00165055247340828437, 0.000763682515545038854, 0]}
DRIVER_DELTAS_2 = {
    "delta_d": [-0.000160188285741325043, 439.140974079900957, -446.027059806332147, 6.88618689642360149,
                -3.86588496858186748e-05, -0.00087908274257374186],
    "delta_a": [2.12234865571205891e-05, 0.632017132627700651, 0.00229833638891230319,
                -4.61409023720933908e-05, -6.39280053471801522e-05, 0],
    "delta_theta": [-2.41478068943590252e-07, 1.60233952386694556, -1.68607190752171299,
                    0.0837331147700118711, -1.01260355871157781e-07, 3.91986209186123702e-08],
    "delta_alpha": [-0.000650246557584166496, 0.00139416666825590402, 0.00693818880325995126,
                    -0.000811641562390219562, 0.000411120504570705592, 0]}


@pytest.mark.parametrize("deltas", [DRIVER_DELTAS, DRIVER_DELTAS_2])
def test_the_ros_drivers_own_test_deltas_import_exactly(deltas):
    text = "[mounting]\n" + "\n".join(f"{k} = [ {', '.join(repr(v) for v in vals)}]"
                                      for k, vals in deltas.items()) + "\n"
    robot = vur.from_calibration_conf(text, "ur10").robot
    theta, d, a, alpha = _controller_table(text, "ur10")
    q = _joints(1000, 7)
    _assert_same(robot.fk(q), dh_fk(theta, d, a, alpha, q))
    assert np.abs(robot.d).max() < 0.2 and np.abs(robot.beta).max() < 0.01


# ur_description's config/ur5e/default_kinematics.yaml (ros-industrial/universal_robot)
UR5E_DEFAULT_KINEMATICS = {
    "shoulder": {"x": 0, "y": 0, "z": 0.1625, "roll": 0, "pitch": 0, "yaw": 0},
    "upper_arm": {"x": 0, "y": 0, "z": 0, "roll": 1.570796327, "pitch": 0, "yaw": 0},
    "forearm": {"x": -0.425, "y": 0, "z": 0, "roll": 0, "pitch": 0, "yaw": 0},
    "wrist_1": {"x": -0.3922, "y": 0, "z": 0.1333, "roll": 0, "pitch": 0, "yaw": 0},
    "wrist_2": {"x": 0, "y": -0.0997, "z": -2.044881182297852e-11, "roll": 1.570796327, "pitch": 0, "yaw": 0},
    "wrist_3": {"x": 0, "y": 0.09959999999999999, "z": -2.042830148012698e-11, "roll": 1.570796326589793,
                "pitch": 3.141592653589793, "yaw": 3.141592653589793}}


def test_nominal_export_puts_every_link_frame_where_ur_description_has_it():
    """The links' frames (where ur_description hangs the meshes), not only tool0, are the same."""
    ur5e = rc.Robot.from_catalog("ur5e")
    mine = yaml.safe_load(vur.to_ur_calibration(ur5e, ur5e))["kinematics"]

    def origin(k):
        R = vur.rpy_to_matrix((k["roll"], k["pitch"], k["yaw"]))
        return vur.make_transform(R, (k["x"], k["y"], k["z"]))

    for link, theirs in UR5E_DEFAULT_KINEMATICS.items():
        assert np.abs(origin(mine[link]) - origin(theirs)).max() < 1e-9, link


def _tilted_conf(name="ur5e", tilt=1e-4, seed=0):
    """A calibration.conf of catalog ``name`` whose axes 2-4 are tilted ~``tilt`` rad out of parallel
    (its delta_d reaches kilometres), with the DH table it describes."""
    nom = rc.Robot.from_catalog(name)
    rng = np.random.default_rng(seed)
    t = rng.choice([-1.0, 1.0], 4) * tilt * rng.uniform(0.5, 1.0, 4)
    moved = nom.with_values({"alpha3": t[0], "beta3": t[1], "alpha4": t[2], "beta4": t[3]})
    tcp, frames = moved.fk(np.zeros((1, 6)), frames=True)
    theta, d, a, alpha = lines_to_dh(frames[0, 1:, :3, 2], frames[0, 1:, :3, 3], tcp[0])
    ndh = vur.nominal_dh(name)
    rows = zip(vur.DELTA_KEYS, (theta - ndh.theta, a - ndh.a, d - ndh.d, alpha - ndh.alpha), strict=True)
    text = "[mounting]\n" + "".join(f"{k} = [ {', '.join(repr(float(v)) for v in vals)}]\n"
                                    for k, vals in rows)
    return text, (theta, d, a, alpha)


@pytest.mark.parametrize("seed", [0, 1])
def test_conf_with_kilometre_deltas_imports_within_a_bound_scaled_to_them(seed, tmp_path, capsys):
    """delta_d of 3-6 km (axes 1e-4 rad out of parallel): the self-check's bound grows with the
    table's lengths (it said "internal ... 1.88e-12 rad, please report this" before); the model is
    the table's arm within that bound, through the API and the CLI."""
    text, table = _tilted_conf(seed=seed)
    assert np.abs(table[1]).max() > 3000
    robot = vur.from_calibration_conf(text, "ur5e").robot
    q = _joints(200, seed)
    tol_m, tol_rad = vur.self_check_tolerance(np.abs(np.r_[table[1], table[2]]).max(), 0.0996)
    assert tol_m < 1e-10 and tol_rad < 1e-9  # still far below anything measurable
    ref = dh_fk(*table, q)
    assert np.abs(robot.fk(q)[:, :3, 3] - ref[:, :3, 3]).max() < 10 * tol_m
    conf = tmp_path / "calibration.conf"
    conf.write_text(text)
    assert main(["import-calibration", str(conf), "--robot", "ur5e", "-o", str(tmp_path / "m.yaml")]) == 0
    assert "report" not in capsys.readouterr().err


def test_conf_key_given_twice_is_refused_naming_it(tmp_path, capsys):
    """delta_a twice (the second 10 mm longer): refused naming the key and both lines (the last
    copy used to win silently), API and CLI (exit 2, one line)."""
    text = CONF.read_text()
    line = next(raw for raw in text.splitlines() if raw.strip().startswith("delta_a "))
    longer = line.replace("[ -7.906", "[ 9.92094", 1)  # a1 + 10 mm
    assert longer != line
    twice = text.replace(line, line + "\n" + longer, 1)
    with pytest.raises(ModelError, match=r"line 4: delta_a is given twice in \[mounting\] \(first at line 3"):
        vur.from_calibration_conf(twice, "ur5e")
    conf = tmp_path / "calibration.conf"
    conf.write_text(twice)
    assert main(["import-calibration", str(conf), "--robot", "ur5e", "-o", str(tmp_path / "m.yaml")]) == 2
    err = capsys.readouterr().err.strip()
    assert "delta_a is given twice" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "m.yaml").exists()


def test_twist_gap_of_another_model_is_worded_in_degrees(tmp_path, capsys):
    """A twist (alpha) far from the nominal is worded in deg, a length in mm (it was "+100.0 mm"),
    API and CLI."""
    nom = vur.nominal_dh("ur5e")
    deltas = {"delta_theta": np.zeros(6), "delta_a": np.zeros(6), "delta_d": np.zeros(6),
              "delta_alpha": np.r_[0.0, 0.0, 0.1, 0.0, 0.0, 0.0]}
    text = "[mounting]\n" + "".join(f"{k} = [ {', '.join(repr(float(v)) for v in deltas[k])}]\n"
                                    for k in vur.DELTA_KEYS)
    assert nom.alpha[2] == 0.0
    with pytest.raises(ModelError, match=r"alpha4 is \+5\.73 deg from the nominal"):
        vur.from_calibration_conf(text, "ur5e")
    conf = tmp_path / "calibration.conf"
    conf.write_text(text)
    assert main(["import-calibration", str(conf), "--robot", "ur5e", "-o", str(tmp_path / "m.yaml")]) == 2
    err = capsys.readouterr().err
    assert "alpha4 is +5.73 deg" in err and " mm from the nominal" not in err
