"""URDF export/import: FK through a URDF library equals the model's; round trips keep FK."""

from __future__ import annotations

import io

import numpy as np
import pytest
from robots import random_frame, random_robot

from robocal import ModelError, Robot
from robocal.kinematics.transforms import make_transform
from robocal.kinematics.urdf import from_urdf, to_urdf, write_urdf
from robocal.kinematics.urdf_read import matrix_to_rpy, rpy_to_matrix

yourdfpy = pytest.importorskip("yourdfpy", reason="yourdfpy (test extra) is needed to parse URDF")


def industrial(rng: np.random.Generator | None = None) -> Robot:
    """An IRB 2600-like arm (parallel axes 2-3, spherical wrist), optionally perturbed (beta3 too)."""
    robot = Robot.from_mdh(alpha=[0, -90, 0, -90, 90, -90], a=[0, 150, 700, 115, 0, 0],
                           theta=[0, -90, 0, 0, 0, 180], d=[445, 0, 0, 795, 0, 85],
                           degrees=True, length_unit="mm", name="irb-like")
    if rng is None:
        return robot
    names = robot.default_free()
    delta = rng.normal(scale=1e-3, size=len(names))
    return robot.displaced(names, delta).with_frames(base=random_frame(rng, 2.0),
                                                     tool=random_frame(rng, 0.2))


def urdf_fk(text: str, q: np.ndarray, tip: str = "tool0", root: str = "world") -> np.ndarray:
    u = yourdfpy.URDF.load(io.StringIO(text), load_meshes=False, build_collision_scene_graph=False,
                           load_collision_meshes=False)
    out = []
    for qk in q:
        u.update_cfg(qk)
        out.append(u.get_transform(tip, root))
    return np.array(out)


@pytest.mark.parametrize("seed", range(4))
def test_export_fk_matches_yourdfpy(seed):
    rng = np.random.default_rng(seed)
    robot = random_robot(rng) if seed % 2 else industrial(rng)
    q = rng.uniform(-np.pi, np.pi, (12, robot.n_joints))
    T = urdf_fk(to_urdf(robot), q)
    np.testing.assert_allclose(T[:, :3, 3], robot.fk(q)[:, :3, 3], atol=1e-9, rtol=0)
    np.testing.assert_allclose(T[:, :3, :3], robot.fk(q)[:, :3, :3], atol=1e-9, rtol=0)


def test_export_writes_full_precision_and_limits(tmp_path):
    robot = industrial(np.random.default_rng(7))
    path = tmp_path / "r.urdf"
    write_urdf(robot, path)
    text = path.read_text()
    assert repr(float(robot.limits[0, 0])) in text
    u = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False,
                           load_collision_meshes=False)
    assert u.actuated_joint_names == [f"joint_{i}" for i in range(1, 7)]
    lower = [u.joint_map[f"joint_{i}"].limit.lower for i in range(1, 7)]
    np.testing.assert_array_equal(lower, robot.limits[:, 0])


@pytest.mark.parametrize("seed", range(6))
def test_round_trip_keeps_fk(seed):
    rng = np.random.default_rng(100 + seed)
    robot = [random_robot(rng), industrial(rng), industrial()][seed % 3]
    back = from_urdf(to_urdf(robot))
    q = rng.uniform(-np.pi, np.pi, (50, robot.n_joints))
    np.testing.assert_allclose(back.fk(q), robot.fk(q), atol=1e-9, rtol=0)
    np.testing.assert_array_equal(back.limits, robot.limits)


def test_import_uses_beta_on_parallel_axes_and_zero_offsets_where_axes_meet():
    robot = industrial()
    back = from_urdf(to_urdf(robot))
    np.testing.assert_array_equal(back.parallel, [False, False, True, False, False, False])
    # nominal geometry: a3 = 700 mm between the parallel axes, 795 mm along axis 4, wrist meets
    np.testing.assert_allclose(abs(back.a[2]), 0.7, atol=1e-12)
    np.testing.assert_allclose(np.abs(back.a[4:]), 0.0, atol=1e-12)
    np.testing.assert_allclose(back.beta, 0.0, atol=1e-12)
    tilted = robot.with_values({"beta3": 0.01})
    back = from_urdf(to_urdf(tilted))
    np.testing.assert_allclose(abs(back.beta[2]), 0.01, atol=1e-12)


UR_LIKE = """<?xml version="1.0"?>
<robot name="ur5e_like">
  <link name="base_link"/>
  <link name="base_link_inertia"/>
  <link name="base"/>
  <link name="shoulder_link"/><link name="upper_arm_link"/><link name="forearm_link"/>
  <link name="wrist_1_link"/><link name="wrist_2_link"/><link name="wrist_3_link"/>
  <link name="flange"/><link name="tool0"/>
  <joint name="base_link-base_link_inertia" type="fixed">
    <parent link="base_link"/><child link="base_link_inertia"/>
    <origin xyz="0 0 0" rpy="0 0 3.141592653589793"/>
  </joint>
  <joint name="base_link-base_fixed_joint" type="fixed">
    <parent link="base_link"/><child link="base"/>
    <origin xyz="0 0 0" rpy="0 0 3.141592653589793"/>
  </joint>
  <joint name="shoulder_pan_joint" type="revolute">
    <parent link="base_link_inertia"/><child link="shoulder_link"/>
    <origin xyz="0 0 0.1625" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.283185307179586" upper="6.283185307179586" effort="150" velocity="3.14"/>
  </joint>
  <joint name="shoulder_lift_joint" type="revolute">
    <parent link="shoulder_link"/><child link="upper_arm_link"/>
    <origin xyz="0 0 0" rpy="1.570796327 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.283185307179586" upper="6.283185307179586" effort="150" velocity="3.14"/>
  </joint>
  <joint name="elbow_joint" type="revolute">
    <parent link="upper_arm_link"/><child link="forearm_link"/>
    <origin xyz="-0.425 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.141592653589793" upper="3.141592653589793" effort="150" velocity="3.14"/>
  </joint>
  <joint name="wrist_1_joint" type="revolute">
    <parent link="forearm_link"/><child link="wrist_1_link"/>
    <origin xyz="-0.3922 0 0.1333" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.283185307179586" upper="6.283185307179586" effort="28" velocity="6.28"/>
  </joint>
  <joint name="wrist_2_joint" type="revolute">
    <parent link="wrist_1_link"/><child link="wrist_2_link"/>
    <origin xyz="0 -0.0997 -2.044881182297852e-11" rpy="1.570796327 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.283185307179586" upper="6.283185307179586" effort="28" velocity="6.28"/>
  </joint>
  <joint name="wrist_3_joint" type="continuous">
    <parent link="wrist_2_link"/><child link="wrist_3_link"/>
    <origin xyz="0 0.0996 -2.042830148012698e-11"
            rpy="1.570796326589793 3.141592653589793 3.141592653589793"/>
    <axis xyz="0 0 1"/>
  </joint>
  <joint name="wrist_3-flange" type="fixed">
    <parent link="wrist_3_link"/><child link="flange"/>
    <origin xyz="0 0 0" rpy="0 -1.5707963267948966 -1.5707963267948966"/>
  </joint>
  <joint name="flange-tool0" type="fixed">
    <parent link="flange"/><child link="tool0"/>
    <origin xyz="0 0 0" rpy="1.5707963267948966 0 1.5707963267948966"/>
  </joint>
</robot>
"""


def ur_dh_fk(q: np.ndarray) -> np.ndarray:
    """UR5e forward kinematics from Universal Robots' published standard DH table (frame 'base')."""
    d = [0.1625, 0, 0, 0.1333, 0.0997, 0.0996]
    a = [0, -0.425, -0.3922, 0, 0, 0]
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    out = np.tile(np.eye(4), (len(q), 1, 1))
    for i in range(6):
        ct, st = np.cos(q[:, i]), np.sin(q[:, i])
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        A = np.zeros((len(q), 4, 4))
        A[:, 0] = np.stack([ct, -st * ca, st * sa, a[i] * ct], 1)
        A[:, 1] = np.stack([st, ct * ca, -ct * sa, a[i] * st], 1)
        A[:, 2] = [0, sa, ca, d[i]]
        A[:, 3] = [0, 0, 0, 1]
        out = out @ A
    return out


def test_import_hand_written_ur_like_urdf():
    robot = from_urdf(UR_LIKE)
    assert robot.name == "ur5e_like" and robot.n_joints == 6
    np.testing.assert_array_equal(robot.parallel, [False, False, True, True, False, False])
    np.testing.assert_allclose(robot.limits[5], [-2 * np.pi, 2 * np.pi])
    rng = np.random.default_rng(3)
    q = rng.uniform(-np.pi, np.pi, (20, 6))
    # independent truth 1: a URDF library on the same text (root link base_link)
    np.testing.assert_allclose(robot.fk(q), urdf_fk(UR_LIKE, q, root="base_link"), atol=1e-9, rtol=0)
    # independent truth 2: the vendor's DH table (the URDF's 'base' frame is base_link rotated by pi)
    base = urdf_fk(UR_LIKE, q[:1], tip="base", root="base_link")[0]
    np.testing.assert_allclose(robot.fk(q), base @ ur_dh_fk(q), atol=1e-8, rtol=0)
    # exporting the imported model and importing again keeps FK
    np.testing.assert_allclose(from_urdf(to_urdf(robot)).fk(q), robot.fk(q), atol=1e-9, rtol=0)


def test_import_from_file_and_tip_choice(tmp_path):
    path = tmp_path / "ur.urdf"
    path.write_text(UR_LIKE)
    assert from_urdf(path).n_joints == 6
    assert from_urdf(str(path), tip="wrist_2_link").n_joints == 5


@pytest.mark.parametrize(("text", "match"), [
    ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x "y">]><robot name="r">&x;</robot>', "DOCTYPE"),
    ("<robot><link", "well-formed"),
    ("<model/>", "root element"),
    ('<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="prismatic">'
     '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>', "prismatic"),
    ('<robot name="r"><link name="a"/></robot>', "tip"),
])
def test_import_rejects_bad_input(text, match):
    with pytest.raises(ModelError, match=match):
        from_urdf(text)


def test_rpy_round_trip_including_gimbal_lock():
    rng = np.random.default_rng(5)
    mats = [rpy_to_matrix(rng.uniform(-3, 3, 3)) for _ in range(50)]
    mats += [rpy_to_matrix([0.3, s * np.pi / 2, -1.0]) for s in (1, -1)]
    for R in mats:
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy(R)), R, atol=1e-12)


def test_hostile_names_stay_well_formed():
    from dataclasses import replace

    odd = replace(industrial(), name='a--b"<&>')
    back = from_urdf(to_urdf(odd))
    assert back.name == 'a--b"<&>'


def test_cli_export_and_import(tmp_path):
    from robocal.cli import main

    model = tmp_path / "m.yaml"
    robot = industrial(np.random.default_rng(9))
    robot.save(model)
    before = model.read_bytes()
    urdf = tmp_path / "m.urdf"
    assert main(["--quiet", "export", str(model), "--urdf", str(urdf), "--frames", "model"]) == 0
    assert model.read_bytes() == before
    q = np.random.default_rng(1).uniform(-2, 2, (8, 6))
    np.testing.assert_allclose(urdf_fk(urdf.read_text(), q), robot.fk(q), atol=1e-9, rtol=0)
    back = tmp_path / "back.yaml"
    assert main(["--quiet", "export", str(urdf), "--yaml", str(back)]) == 0
    np.testing.assert_allclose(Robot.load(back).fk(q), robot.fk(q), atol=1e-9, rtol=0)
    assert main(["export", str(model)]) == 2


def test_cli_export_for_ros_puts_base_link_at_the_base_and_tool0_at_the_flange(tmp_path):
    """A tracker-calibrated model: the default URDF's root is base_link at frame {0} and tool0 the
    catalog's flange (not the tracker frame and the SMR, which are in a comment)."""
    from robocal.cli import main

    nominal = Robot.from_catalog("kuka_kr16_2")
    tracker = make_transform(rpy_to_matrix([0.3, -0.2, 1.0]), [2.5, 0.4, 1.1])
    smr = make_transform(np.eye(3), [0.02, -0.03, 0.08])
    measured = nominal.with_frames(base=tracker, tool=nominal.tool @ smr)
    measured.save(tmp_path / "cal.yaml")
    assert main(["--quiet", "export", str(tmp_path / "cal.yaml"), "--urdf", str(tmp_path / "r.urdf")]) == 0
    text = (tmp_path / "r.urdf").read_text()
    assert '<link name="world"/>' not in text and "laser tracker" in text
    q = np.random.default_rng(2).uniform(-1, 1, (6, 6))
    np.testing.assert_allclose(urdf_fk(text, q, root="base_link"), nominal.fk(q), atol=1e-9, rtol=0)
    assert main(["--quiet", "export", str(tmp_path / "cal.yaml"), "--urdf", str(tmp_path / "m.urdf"),
                 "--frames", "model"]) == 0
    back = urdf_fk((tmp_path / "m.urdf").read_text(), q)
    np.testing.assert_allclose(back, measured.fk(q), atol=1e-9, rtol=0)


def test_import_keeps_link_names_with_the_frame_each_rides_on():
    """Each named link moves rigidly with the model frame it is mapped to: the URDF library's pose of
    the link relative to the model's frame is the same at every configuration (independent truth)."""
    robot = from_urdf(UR_LIKE)
    assert robot.link_frames["base_link"] == 0 and robot.link_frames["wrist_3_link"] == 6
    assert robot.link_frames["tool0"] == 6  # fixed after the last moving joint
    q = np.random.default_rng(8).uniform(-np.pi, np.pi, (12, 6))
    _, frames = robot.fk(q, frames=True)  # (N, 7, 4, 4): {0}..{6}
    for link, j in robot.link_frames.items():
        relative = np.linalg.inv(urdf_fk(UR_LIKE, q, tip=link, root="base_link")) @ frames[:, j]
        np.testing.assert_allclose(relative, np.broadcast_to(relative[0], relative.shape), atol=1e-9)


def test_load_model_takes_the_urdf_tip_and_refuses_it_elsewhere(tmp_path):
    """``load_model(spec, tip=...)`` (what ``export --tip`` calls): the chain ends at ``tip`` in a
    URDF; a tip for a catalog name or a model YAML is refused, not silently ignored."""
    from robocal.kinematics.model import load_model

    path = tmp_path / "ur.urdf"
    path.write_text(UR_LIKE)
    assert load_model(str(path), tip="wrist_2_link").n_joints == 5
    assert load_model(str(path)).n_joints == 6
    with pytest.raises(ModelError, match="'tool0' is a URDF link, but abb_irb2600 is not a URDF"):
        load_model("abb_irb2600", tip="tool0")
