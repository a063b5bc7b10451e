"""Prismatic joints: FK against an independent product of transforms, the identification Jacobian
against finite differences, model files (joints rows, mdh/dh tables) and URDF both ways, numeric IK
over mixed chains."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal.core.errors import ModelError
from robocal.core.yaml_load import load_yaml
from robocal.ik import numeric
from robocal.kinematics.model import Robot
from robocal.kinematics.model_file import robot_kwargs
from robocal.kinematics.urdf import from_urdf, to_urdf


def _rot(axis: int, t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    T = np.eye(4)
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def _trans(v) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


def _reference_fk(robot: Robot, q: np.ndarray) -> np.ndarray:
    """One pose by the MDH + beta definition, matrix by matrix (the independent truth)."""
    T = robot.base.copy()
    for i in range(robot.n_joints):
        slide = robot.prismatic[i]
        T = T @ _rot(0, robot.alpha[i]) @ _trans([robot.a[i], 0, 0]) @ _rot(1, robot.beta[i])
        turn, slide_by = (0.0, q[i]) if slide else (q[i], 0.0)
        T = T @ _rot(2, robot.theta[i] + turn) @ _trans([0, 0, robot.d[i] + slide_by])
    return T @ robot.tool


def _mixed(seed: int = 0) -> Robot:
    """A 7-joint chain: a prismatic track carrying a KR 210 (through a perpendicular link)."""
    arm = Robot.from_catalog("kuka_kr210_r2700")
    rng = np.random.default_rng(seed)
    return Robot(alpha=np.r_[0.01, -np.pi / 2, arm.alpha[1:]], a=np.r_[0.02, 0.3, arm.a[1:]],
                 beta=np.r_[0.0, 0.0, arm.beta[1:]], theta=np.r_[0.1, 0.2, arm.theta[1:]],
                 d=np.r_[0.05, 0.4, arm.d[1:]] + rng.normal(0, 1e-3, 7), base=arm.base, tool=arm.tool,
                 prismatic=[True] + [False] * 6, limits=np.r_[[[0.0, 6.0]], arm.limits])


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000))
def test_fk_matches_definition(seed):
    robot = _mixed(seed)
    q = np.random.default_rng(seed).uniform(-1, 1, (4, 7)) * np.r_[3.0, [1.0] * 6]
    T = robot.fk(q)
    for k in range(4):
        np.testing.assert_allclose(T[k], _reference_fk(robot, q[k]), atol=1e-12)


def test_prismatic_value_moves_along_its_axis():
    robot = _mixed()
    q = np.zeros((1, 7))
    frames = robot.fk(q, frames=True)[1]
    axis = frames[0, 1, :3, 2]
    moved = q.copy()
    moved[0, 0] = 2.5
    np.testing.assert_allclose(robot.fk(moved)[0, :3, 3] - robot.fk(q)[0, :3, 3], 2.5 * axis, atol=1e-12)


def test_jacobian_matches_finite_differences_with_scale():
    robot = _mixed().with_joint_errors(["scale1", "scale3"]).with_values({"scale1": 2e-4, "scale3": 1e-4})
    q = np.random.default_rng(3).uniform(-1, 1, (6, 7)) * np.r_[3.0, [1.0] * 6]
    names = robot.default_free(orientation=True)
    assert "scale1" in names and "d1" in names
    J = robot.jacobian(q, names, kind="pose")
    eps = 1e-7
    for k, name in enumerate(names):
        Tp, Tm = (robot.displaced([name], [s * eps]).fk(q) for s in (1, -1))
        fd = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * eps)
        np.testing.assert_allclose(J[:, :3, k], fd, atol=1e-6 * max(1.0, np.abs(fd).max()), err_msg=name)


def test_scale_term_scales_the_slide():
    robot = _mixed().with_joint_errors(["scale1"]).with_values({"scale1": 2e-4})
    q = np.zeros((1, 7))
    q[0, 0] = 5.0
    exact = robot.nominal_robot().fk(q * np.r_[1 + 2e-4, [1.0] * 6])
    np.testing.assert_allclose(robot.fk(q), exact, atol=1e-12)


_GANTRY = """
units: {length: mm, angle: deg}
name: gantry
%s
limits: [[0, 2000], [0, 1000], [-500, 0], [-180, 180]]
"""


def test_model_file_tables_and_rows_round_trip(tmp_path):
    mdh = "mdh: {alpha: [0, -90, -90, 0], a: [0, 10, 0, 0], theta: [0, 90, 0, 0], d: [0, 0, 0, 100], " \
          "type: [prismatic, prismatic, prismatic, revolute]}"
    robot = Robot(**robot_kwargs(load_yaml(_GANTRY % mdh, "gantry")))
    assert robot.prismatic.tolist() == [True, True, True, False]
    np.testing.assert_allclose(robot.limits[:3], [[0, 2], [0, 1], [-0.5, 0]])
    robot.save(tmp_path / "g.yaml")
    again = Robot.load(tmp_path / "g.yaml")
    q = np.array([[0.5, 0.2, -0.1, 0.3]])
    np.testing.assert_array_equal(again.fk(q), robot.fk(q))
    assert again.prismatic.tolist() == robot.prismatic.tolist()
    np.testing.assert_allclose(robot.fk(q)[0], _reference_fk(robot, q[0]), atol=1e-12)


def test_dh_table_with_prismatic_joint():
    dh = "dh: {theta: [0, 90, 0, 0], d: [0, 0, 0, 100], a: [0, 0, 0, 0], alpha: [-90, -90, 0, 0], " \
         "type: [prismatic, prismatic, prismatic, revolute]}"
    robot = Robot(**robot_kwargs(load_yaml(_GANTRY % dh, "gantry")))
    q = np.array([0.5, 0.2, -0.1, 0.3])
    # standard DH: A_i = Rz(theta_i [+ q_i]) Tz(d_i [+ q_i]) Tx(a_i) Rx(alpha_i)
    T = np.eye(4)
    for i, (th, d, al) in enumerate(zip([0, 90, 0, 0], [0, 0, 0, 0.1], [-90, -90, 0, 0], strict=True)):
        th, al = np.deg2rad(th), np.deg2rad(al)
        slide = i < 3
        turn, slide_by = (0.0, q[i]) if slide else (q[i], 0.0)
        T = T @ _rot(2, th + turn) @ _trans([0, 0, d + slide_by]) @ _rot(0, al)
    np.testing.assert_allclose(robot.fk(q)[0], T, atol=1e-12)


def test_bad_joint_type_names_the_joint():
    with pytest.raises(ModelError, match=r"joints\[1\].*type"):
        Robot(**robot_kwargs(load_yaml("units: {length: m, angle: rad}\njoints:\n"
                                       "- {alpha: 0, a: 0, theta: 0, d: 0, type: slider}\n", "x")))


# A mobile manipulator's torso lift in the style of real robot descriptions (fixed joints with
# rpy origins, a prismatic lift with its limit, then a revolute arm).
_TORSO = """<?xml version="1.0"?>
<robot name="mobile_manipulator">
  <link name="base_footprint"/><link name="base_link"/><link name="torso_lift_link"/>
  <link name="shoulder_pan_link"/><link name="shoulder_lift_link"/><link name="upperarm_roll_link"/>
  <link name="elbow_flex_link"/><link name="forearm_roll_link"/><link name="wrist_flex_link"/>
  <link name="wrist_roll_link"/><link name="gripper_link"/>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
    <origin rpy="0 0 0" xyz="0 0 0.0726"/></joint>
  <joint name="torso_lift_joint" type="prismatic"><parent link="base_link"/><child link="torso_lift_link"/>
    <origin rpy="-6.123E-17 0 0" xyz="-0.086875 0 0.37743"/><axis xyz="0 0 1"/>
    <limit effort="450.0" lower="0" upper="0.38615" velocity="0.1"/></joint>
  <joint name="shoulder_pan_joint" type="revolute"><parent link="torso_lift_link"/>
    <child link="shoulder_pan_link"/>
    <origin rpy="0 0 0" xyz="0.119525 0 0.34858"/><axis xyz="0 0 1"/>
    <limit effort="33.82" lower="-1.6056" upper="1.6056" velocity="1.256"/></joint>
  <joint name="shoulder_lift_joint" type="revolute"><parent link="shoulder_pan_link"/>
    <child link="shoulder_lift_link"/>
    <origin rpy="0 0 0" xyz="0.117 0 0.0599999999999999"/><axis xyz="0 1 0"/>
    <limit effort="131.76" lower="-1.221" upper="1.518" velocity="1.454"/></joint>
  <joint name="upperarm_roll_joint" type="continuous"><parent link="shoulder_lift_link"/>
    <child link="upperarm_roll_link"/>
    <origin rpy="0 0 0" xyz="0.219 0 0"/><axis xyz="1 0 0"/><limit effort="76.94" velocity="1.571"/></joint>
  <joint name="elbow_flex_joint" type="revolute"><parent link="upperarm_roll_link"/>
    <child link="elbow_flex_link"/>
    <origin rpy="0 0 0" xyz="0.133 0 0"/><axis xyz="0 1 0"/>
    <limit effort="66.18" lower="-2.251" upper="2.251" velocity="1.521"/></joint>
  <joint name="forearm_roll_joint" type="continuous"><parent link="elbow_flex_link"/>
    <child link="forearm_roll_link"/>
    <origin rpy="0 0 0" xyz="0.197 0 0"/><axis xyz="1 0 0"/><limit effort="29.35" velocity="1.571"/></joint>
  <joint name="wrist_flex_joint" type="revolute"><parent link="forearm_roll_link"/>
    <child link="wrist_flex_link"/>
    <origin rpy="0 0 0" xyz="0.1245 0 0"/><axis xyz="0 1 0"/>
    <limit effort="25.7" lower="-2.16" upper="2.16" velocity="2.268"/></joint>
  <joint name="wrist_roll_joint" type="continuous"><parent link="wrist_flex_link"/>
    <child link="wrist_roll_link"/>
    <origin rpy="0 0 0" xyz="0.1385 0 0"/><axis xyz="1 0 0"/><limit effort="7.36" velocity="2.268"/></joint>
  <joint name="gripper_axis" type="fixed"><parent link="wrist_roll_link"/><child link="gripper_link"/>
    <origin rpy="0 0 0" xyz="0.16645 0 0"/></joint>
</robot>
"""

# A gantry with a 2-axis wrist: prismatic x, y, z on a portal, then C and B (origins and axes as
# exported by CAD).
_GANTRY_URDF = """<?xml version="1.0"?>
<robot name="portal_gantry">
  <link name="world"/><link name="x_carriage"/><link name="y_carriage"/><link name="z_ram"/>
  <link name="wrist"/><link name="hand"/><link name="flange"/>
  <joint name="x_axis" type="prismatic"><parent link="world"/><child link="x_carriage"/>
    <origin xyz="0.25 0.1 2.4" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0.0" upper="4.0" effort="2000" velocity="1.0"/></joint>
  <joint name="y_axis" type="prismatic"><parent link="x_carriage"/><child link="y_carriage"/>
    <origin xyz="0 0.35 -0.12" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0.0" upper="2.5" effort="1500" velocity="1.0"/></joint>
  <joint name="z_axis" type="prismatic"><parent link="y_carriage"/><child link="z_ram"/>
    <origin xyz="0.08 0 -0.2" rpy="0 0 0"/><axis xyz="0 0 -1"/>
    <limit lower="0.0" upper="1.2" effort="1000" velocity="0.5"/></joint>
  <joint name="a_axis" type="revolute"><parent link="z_ram"/><child link="wrist"/>
    <origin xyz="0 0 -0.4" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" effort="100" velocity="2.0"/></joint>
  <joint name="b_axis" type="revolute"><parent link="wrist"/><child link="hand"/>
    <origin xyz="0 0 -0.15" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2.0" upper="2.0" effort="80" velocity="2.0"/></joint>
  <joint name="flange_joint" type="fixed"><parent link="hand"/><child link="flange"/>
    <origin xyz="0.02 0 -0.1" rpy="3.141592653589793 0 0"/></joint>
</robot>
"""


def _urdf_fk(text: str, q: np.ndarray) -> np.ndarray:
    """The URDF's own forward kinematics along its single chain (the independent truth)."""
    import xml.etree.ElementTree as ET

    from robocal.kinematics.urdf_read import rpy_to_matrix

    T, k = np.eye(4), 0
    for j in ET.fromstring(text).findall("joint"):
        o = j.find("origin")
        xyz = [float(v) for v in o.get("xyz").split()] if o is not None else [0, 0, 0]
        rpy = [float(v) for v in o.get("rpy", "0 0 0").split()] if o is not None else [0, 0, 0]
        F = np.eye(4)
        F[:3, :3], F[:3, 3] = rpy_to_matrix(rpy), xyz
        T = T @ F
        if j.get("type") == "fixed":
            continue
        axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
        M = np.eye(4)
        if j.get("type") == "prismatic":
            M[:3, 3] = axis * q[k]
        else:
            from scipy.spatial.transform import Rotation
            M[:3, :3] = Rotation.from_rotvec(axis * q[k]).as_matrix()
        T, k = T @ M, k + 1
    return T


@pytest.mark.parametrize("text, n", [(_TORSO, 8), (_GANTRY_URDF, 5)])
def test_urdf_with_prismatic_joints_imports_and_exports(text, n):
    robot = from_urdf(text)
    assert robot.n_joints == n and robot.prismatic[0]
    rng = np.random.default_rng(1)
    q = rng.uniform(robot.limits[:, 0].clip(-1.5), robot.limits[:, 1].clip(max=1.5), (5, n))
    for k in range(5):
        np.testing.assert_allclose(robot.fk(q[k])[0], _urdf_fk(text, q[k]), atol=1e-12)
    out = to_urdf(robot)
    assert 'type="prismatic"' in out
    again = from_urdf(out)
    assert again.prismatic.tolist() == robot.prismatic.tolist()
    np.testing.assert_allclose(again.fk(q), robot.fk(q), atol=1e-12)
    np.testing.assert_allclose(again.limits[robot.prismatic], robot.limits[robot.prismatic])


def test_urdf_prismatic_without_limits_is_refused():
    text = _GANTRY_URDF.replace('<limit lower="0.0" upper="4.0" effort="2000" velocity="1.0"/>', "")
    with pytest.raises(ModelError, match="x_axis.*limit"):
        from_urdf(text)


def test_numeric_ik_over_a_mixed_chain():
    robot = _mixed()
    rng = np.random.default_rng(5)
    q = np.c_[rng.uniform(0.5, 5.5, 8), rng.uniform(-0.5, 0.5, (8, 6))]
    T = robot.fk(q)
    res = numeric.solve(robot, T, seeds=q + np.r_[0.05, [0.05] * 6])
    assert res.converged.all()
    np.testing.assert_allclose(robot.fk(res.joints), T, atol=1e-8)
    # the track held at the program's own value: only the arm moves
    locked = numeric.solve(robot, T, seeds=np.c_[q[:, :1], q[:, 1:] + 0.05], locked=[0])
    assert locked.converged.all()
    np.testing.assert_array_equal(locked.joints[:, 0], q[:, 0])
    with pytest.raises(Exception, match="needs seeds"):
        numeric.solve(robot, T)


_CELL = """units: {length: mm, angle: deg}
name: kr210 on a 6 m track
robot: %s
track: {direction: %s, limits: [0, 6000]}
mount: {xyz: [100, 200, 300], rpy: [1, 2, 30]}
"""


@pytest.mark.parametrize("direction", ["[1, 0, 0]", "[0, 0.6, 0.8]", "[0, 0, 1]"])
def test_cell_file_is_the_track_formula(tmp_path, direction):
    from scipy.spatial.transform import Rotation

    from robocal.kinematics.model import load_model

    (tmp_path / "cell.yaml").write_text(_CELL % ("kuka_kr210_r2700", direction))
    cell = load_model(str(tmp_path / "cell.yaml"))
    arm = Robot.from_catalog("kuka_kr210_r2700")
    assert cell.n_joints == 7 and cell.prismatic.tolist() == [True] + [False] * 6
    assert cell.joint_error_names == ["scale1"]
    np.testing.assert_allclose(cell.limits[0], [0.0, 6.0])
    u = np.array(load_yaml(direction, "d"), float)
    M = np.eye(4)
    M[:3, :3] = Rotation.from_euler("xyz", [1, 2, 30], degrees=True).as_matrix()
    M[:3, 3] = [0.1, 0.2, 0.3]
    rng = np.random.default_rng(2)
    q = np.c_[rng.uniform(0, 6, 6), rng.uniform(-1, 1, (6, 6))]
    for k in range(6):
        E = np.eye(4)
        E[:3, 3] = u * q[k, 0]
        np.testing.assert_allclose(cell.fk(q[k])[0], E @ M @ arm.fk(q[k, 1:])[0], atol=1e-12)
    cell.save(tmp_path / "saved.yaml")  # the calibrated-cell form: the chain itself
    again = Robot.load(tmp_path / "saved.yaml")
    np.testing.assert_array_equal(again.fk(q), cell.fk(q))
    np.testing.assert_array_equal(again.nominal, cell.nominal)


def test_cell_robot_file_relative_to_the_cell(tmp_path):
    from robocal.kinematics.model import load_model

    (tmp_path / "arms").mkdir()
    Robot.from_catalog("abb_irb2600").save(tmp_path / "arms" / "irb.yaml")
    (tmp_path / "cell.yaml").write_text(_CELL % ("arms/irb.yaml", "[1, 0, 0]"))
    assert load_model(str(tmp_path / "cell.yaml")).n_joints == 7
    (tmp_path / "bad.yaml").write_text(_CELL % ("kuka_kr210_r2700", "[1, 0, 0.1]"))
    with pytest.raises(ModelError, match="bad.yaml.*not a unit vector"):
        load_model(str(tmp_path / "bad.yaml"))


@pytest.mark.parametrize("text, kind", [(_TORSO, "point"), (_GANTRY_URDF, "pose")])
def test_urdf_with_prismatic_joints_calibrates(text, kind):
    """Simulated campaigns of the imported models (their prismatic joints' columns in m) calibrate
    to the noise; the calibrated model exports."""
    import robocal as rc
    from robocal.data.measurements import parse_csv
    from robocal.data.simulate import simulate_tracker

    robot = from_urdf(text)
    sim = simulate_tracker(robot, 120, seed=1, kind=kind, rotation_noise_deg=0.001)
    data = parse_csv(sim.data.to_csv(), "sim")
    assert data.linear.tolist() == robot.prismatic.tolist()
    cal, val = data.first_poses(80), data.subset(np.arange(80, 120))
    result = rc.calibrate(robot, cal, nongeometric="none")
    assert rc.evaluate(result.robot, val)["rms"] < 1.5 * sim.noise_floor_mm
    assert 'type="prismatic"' in to_urdf(result.robot)
