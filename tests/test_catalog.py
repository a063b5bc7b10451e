"""The robot catalog against the OPW forward kinematics of its sets, other sources and py-opw."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from test_convert import dh_product

from robocal import ModelError, Robot
from robocal.cli import main
from robocal.kinematics.catalog import catalog_descriptions, catalog_entry, catalog_names, catalog_specs
from robocal.kinematics.opw import opw_fk

REQUIRED = ["abb_irb120", "abb_irb1600", "abb_irb2400", "abb_irb2600", "abb_irb4600", "kuka_kr6_r700",
            "kuka_kr16_2", "fanuc_lrmate200id", "staubli_tx2_140", "puma560", "meca500", "ur5", "ur10",
            "ur3e", "ur5e", "ur10e", "ur16e", "ur20", "ur30", "kuka_kr210_r2700", "kuka_kr120_r2500",
            "fanuc_m20ia", "fanuc_m710ic50", "fanuc_r2000ic_165f", "abb_irb6700", "yaskawa_gp25"]
OPW_ROBOTS = [n for n in catalog_names() if "opw" in catalog_entry(n)]
CHAINS = yaml.safe_load((Path(__file__).parent / "data" / "ros_industrial_chains.yaml").read_text())
SCARAS = yaml.safe_load((Path(__file__).parent / "data" / "scara_sources.yaml").read_text())


def random_joints(robot: Robot, rng, n: int = 200) -> np.ndarray:
    return rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (n, robot.n_joints))


def test_catalog_lists_required_robots():
    assert set(REQUIRED) <= set(catalog_names()) and len(catalog_names()) >= 25
    for name, text in catalog_descriptions().items():
        assert text and "\n" not in text, name
    specs = catalog_specs()
    assert all(specs[n][0] > 0 and specs[n][1] > 0 for n in catalog_names() if n != "puma560")


def _urdf_fk(chain: dict, q: np.ndarray) -> np.ndarray:
    """URDF forward kinematics of a transcribed chain: per joint T(xyz) R(rpy) then the rotation
    by q about its axis, then the fixed joints to tool0 (rpy: fixed-axis XYZ, R = Rz Ry Rx)."""
    def fixed(row):
        T = np.eye(4)
        T[:3, :3] = Rotation.from_euler("xyz", row["rpy"]).as_matrix()
        T[:3, 3] = row["xyz"]
        return T

    out = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    for j, row in enumerate(chain["joints"]):
        turn = np.zeros((len(q), 4, 4))
        turn[:, :3, :3] = Rotation.from_rotvec(np.outer(q[:, j], row["axis"])).as_matrix()
        turn[:, 3, 3] = 1.0
        out = out @ fixed(row) @ turn
    for row in chain["tool0"]:
        out = out @ fixed(row)
    return out


@pytest.mark.parametrize("name", sorted(CHAINS))
def test_entry_equals_its_ros_industrial_urdf(name, rng):
    """Arms derived from a ROS-Industrial URDF (or with both an opw file and a URDF): the flange
    (tool0) pose of the catalog entry is the URDF's, over the joint limits."""
    robot = Robot.from_catalog(name)
    q = random_joints(robot, rng, 300)
    np.testing.assert_allclose(robot.fk(q), _urdf_fk(CHAINS[name], q), rtol=0, atol=CHAINS[name]["tolerance"])


def test_every_entry_is_checked_against_a_source():
    """Each catalog robot meets an independent source in some test: py-opw-kinematics on its OPW
    set, a ROS-I URDF chain, Universal Robots' DH (ur-analytic-ik, test_ur_ik), or a dedicated test."""
    dedicated = {"puma560", "abb_irb120", "meca500", "ur5", "ur10",
                 *SCARAS}  # the SCARAs: robotkinematicscatalogue's chains, tests/test_scara.py
    ur = {n for n in catalog_names() if Robot.from_catalog(n).has_ur_form}
    assert set(catalog_names()) <= set(OPW_ROBOTS) | set(CHAINS) | ur | dedicated


@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_opw_entry_equals_opw_fk(name, rng):
    robot = Robot.from_catalog(name)
    q = random_joints(robot, rng)
    np.testing.assert_allclose(robot.fk(q), opw_fk(robot.opw, q), rtol=0,
                               atol=1e-12)
    assert robot.parallel.tolist() == [False, False, True, False, False, False]


@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_opw_entry_against_py_opw_kinematics(name, rng):
    po = pytest.importorskip("py_opw_kinematics", reason="py-opw-kinematics (test extra) not installed")
    robot = Robot.from_catalog(name)
    p = robot.opw
    model = po.KinematicModel(a1=p.a1, a2=p.a2, b=p.b, c1=p.c1, c2=p.c2, c3=p.c3,
                              c4=p.c4, offsets=tuple(p.offsets),
                              flip_axes=tuple(s < 0 for s in p.signs))
    q = random_joints(robot, rng)
    theirs = po.Robot(model, degrees=False).batch_forward(q).as_matrix()
    np.testing.assert_allclose(robot.fk(q), theirs, rtol=0, atol=1e-12)


def test_known_poses_in_vendor_convention():
    """Zero pose as the controllers show it: ABB upper arm up and forearm forward, KUKA whole arm
    stretched forward (A2 = 0 is horizontal), Staubli straight up."""
    flange = {n: Robot.from_catalog(n).fk(np.zeros(6))[0, :3, 3] for n in
              ("abb_irb2400", "kuka_kr16_2", "staubli_tx2_140")}
    expected = {"abb_irb2400": [0.100 + 0.755 + 0.085, 0, 0.615 + 0.705 + 0.135],
                "kuka_kr16_2": [0.260 + 0.680 + 0.670 + 0.158, 0, 0.675 - 0.035],
                "staubli_tx2_140": [0.150, 0, 0.550 + 0.625 + 0.625 + 0.110]}
    for name, xyz in expected.items():
        np.testing.assert_allclose(flange[name], xyz, atol=1e-12)
    # KUKA A1 positive turns the arm clockwise seen from above (the vendor sign)
    kuka = Robot.from_catalog("kuka_kr16_2").fk(np.radians([[30, 0, 0, 0, 0, 0]]))[0]
    assert kuka[1, 3] < 0


def test_ur_from_official_dh(rng):
    """UR5/UR10 = the ur_kin.cpp DH product (flange = tool0 in the controller base); ur_kinematics'
    forward() is Rz(pi) * that * the ee_link rotation."""
    tables = {"ur5": ([0.089159, 0, 0, 0.10915, 0.09465, 0.0823], [0, -0.425, -0.39225, 0, 0, 0]),
              "ur10": ([0.1273, 0, 0, 0.163941, 0.1157, 0.0922], [0, -0.612, -0.5723, 0, 0, 0])}
    alpha = [np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0]
    ee = np.array([[0, -1, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0], [0, 0, 0, 1.0]])
    for name, (d, a) in tables.items():
        robot = Robot.from_catalog(name)
        q = random_joints(robot, rng, 100)
        T06 = dh_product(np.zeros(6), d, a, alpha, q)
        np.testing.assert_allclose(robot.fk(q), T06, rtol=0, atol=1e-12)
        ur_forward = np.diag([-1.0, -1, 1, 1]) @ T06 @ ee
        np.testing.assert_allclose(np.diag([-1.0, -1, 1, 1]) @ robot.fk(q) @ ee, ur_forward, atol=1e-12)
        assert robot.parallel.tolist() == [False, False, True, True, False, False]


def test_puma560_opw_equals_robotics_toolbox_dh(rng):
    robot = Robot.from_catalog("puma560")
    q = random_joints(robot, rng)
    rtb = dh_product(np.zeros(6), [0.67183, 0, 0.15005, 0.4318, 0, 0], [0, 0.4318, 0.0203, 0, 0, 0],
                     [np.pi / 2, 0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0], q)
    np.testing.assert_allclose(robot.fk(q), rtb, rtol=0, atol=1e-12)


def test_irb120_opw_equals_pybotics_mdh(rng):
    robot = Robot.from_catalog("abb_irb120")
    pyb = Robot.from_mdh([0, -90, 0, -90, 90, -90], [0, 0, 270, 70, 0, 0], [0, -90, 0, 0, 0, 180],
                         [290, 0, 0, 302, 0, 72], degrees=True, length_unit="mm")
    q = random_joints(robot, rng)
    np.testing.assert_allclose(robot.fk(q), pyb.fk(q), rtol=0, atol=1e-12)


def test_meca500_matches_dataset_mdh(rng):
    robot = Robot.from_catalog("meca500")
    assert robot.opw is None
    np.testing.assert_allclose(np.rad2deg(robot.limits[1]), [-70, 90])
    T = robot.fk(np.zeros(6))[0]
    np.testing.assert_allclose(T[:3, 3], [0.120 + 0.070, 0, 0.135 + 0.135 + 0.038], atol=1e-15)


def test_limits_are_vendor_values():
    assert np.allclose(np.rad2deg(Robot.from_catalog("abb_irb2600").limits[2]), [-180, 75])
    assert np.allclose(np.rad2deg(Robot.from_catalog("kuka_kr6_r700").limits[1]), [-190, 45])
    # the KR 210 R2700 extra's A2 works in [-140, -5] deg (its URDF): zero is outside its range
    assert np.allclose(np.rad2deg(Robot.from_catalog("kuka_kr210_r2700").limits[1]), [-140, -5])
    for name in catalog_names():
        robot = Robot.from_catalog(name)
        lim = robot.limits
        assert lim.shape == (4 if name in SCARAS else 6, 2) and (lim[:, 0] < lim[:, 1]).all(), name
        turning = lim[~robot.prismatic]  # a SCARA's quill is 0 at one end of its stroke
        if name != "kuka_kr210_r2700":
            assert (turning[:, 0] < 0).all() and (turning[:, 1] > 0).all(), name


def test_each_catalog_file_is_named_after_its_robot():
    """catalog_entry reads ``<name>.yaml`` alone: every file must carry the name it is filed under."""
    from importlib import resources

    folder = resources.files("robocal").joinpath("catalog")
    files = [p.name for p in folder.iterdir() if p.name.endswith(".yaml")]
    assert sorted(f.removesuffix(".yaml") for f in files) == catalog_names()
    assert all(catalog_entry(n)["name"] == n for n in catalog_names())


def test_unknown_name_lists_the_catalog():
    with pytest.raises(ModelError, match="unknown robot 'irb9999'.*abb_irb120.*ur10"):
        Robot.from_catalog("irb9999")


def test_cli_robots_lists_names(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name in REQUIRED:
        assert name in out


@pytest.mark.parametrize("name", ["kuka_kr16_2", "fanuc_lrmate200id", "ur10", "puma560"])
def test_one_robot_fk_path_equals_general_path(name, rng):
    """The one-robot FK path (quarter-turn swaps, lazy signs) against the broadcasting path, for
    robots whose alphas are multiples of 90 deg, with frames and with one tool per row."""
    from robocal.kinematics.fk import chain_frames
    from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

    robot = Robot.from_catalog(name)
    q = random_joints(robot, rng, 300)
    tools = make_transform(rotvec_to_matrix(rng.normal(size=(300, 3))), rng.normal(size=(300, 3)))
    batched = robot.links._replace(**{f: getattr(robot.links, f)[None] for f in robot.links._fields})
    for tool in (robot.tool, tools):
        fast = chain_frames(robot.links, robot.base, tool, q, frames=True)
        general = chain_frames(batched, robot.base, tool, q, frames=True)
        for a, b in zip(fast, general, strict=True):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)


def test_cli_robots_shows_one_robot(capsys):
    assert main(["robots", "kuka_kr16_2"]) == 0
    out = capsys.readouterr().out
    assert "kuka_kr16_2" in out and "tool pose" in out and out.count("q = [") == 3
    assert main(["robots", "no_such_robot"]) == 2
    assert "abb_irb120" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_demo_runs_the_pipeline(tmp_path, capsys):
    assert main(["--quiet", "demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "robust" in out and "compensated joint commands" in out and "open the report" in out
    for name in ("calibrated.yaml", "result.json", "report.html"):
        assert (tmp_path / name).stat().st_size > 0


def test_fk_polynomial_sin_cos_and_large_angle_fallback(rng):
    """The one-robot path's sin/cos polynomial agrees with libm; angles beyond its range use libm."""
    from robocal.kinematics.fk import _POLY_MAX, _sin_cos

    x = np.concatenate([rng.uniform(-50, 50, 5000), np.arange(-40, 41) * np.pi / 2, [0.0, 1e-300, 7e4]])
    c, s = np.empty_like(x), np.empty_like(x)
    _sin_cos(x, c, s, np.empty((4,) + x.shape))
    np.testing.assert_allclose(c, np.cos(x), rtol=0, atol=1e-15)
    np.testing.assert_allclose(s, np.sin(x), rtol=0, atol=1e-15)
    robot = Robot.from_catalog("abb_irb2400")
    q = random_joints(robot, rng, 50)
    big = q + 2 * np.pi * np.round(2 * _POLY_MAX / (2 * np.pi))
    np.testing.assert_allclose(robot.fk(big), robot.fk(q), rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", [n for n in catalog_names() if n not in ("meca500",)])
def test_closed_form_ik_round_trip_on_every_arm(name, rng):
    """Every catalog arm but the Meca500 (no closed form: its OPW set is not carried) has the OPW, UR
    or SCARA form; its closed-form IK recovers random joints, each solution FK-exact."""
    from robocal.ik import solve_all
    from robocal.ik.closed_form import has_closed_form

    robot = Robot.from_catalog(name)
    assert has_closed_form(robot) and (robot.has_opw_form or robot.has_ur_form or name in SCARAS)
    q = random_joints(robot, rng, 300)
    T = robot.fk(q)
    sols = solve_all(robot, T)
    d = np.abs(np.remainder(sols - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=2)
    assert (np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-7).all()
    ok = np.isfinite(sols).all(axis=2)
    err = np.abs(robot.fk(sols[ok]) - T[np.nonzero(ok)[0]]).max()
    assert err < 1e-9
