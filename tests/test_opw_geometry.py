"""Closed-form IK chosen by the chain's geometry (robocal.kinematics.opw_geometry): OPW arms read
from a URDF or a DH / MDH table -- no `opw:` key -- get their OPW set derived from the joint lines
and exact closed-form IK; chains that are not of that form (a Franka Panda, a 5-axis arm, a wrist
whose axes do not meet) get "no closed form" and numeric IK, seeded by the nearest OPW arm when
they are near one. Truth: each model's own forward kinematics (the joints we started from)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import ModelError
from robocal.ik.closed_form import has_closed_form, seed_model
from robocal.kinematics.opw_geometry import opw_model, round_trip_gap

N_POSES = 1000
EXACT_M = 1e-9  # the closed form's own check (robocal.ik.opw_ik.TOL)

# Kawasaki RS007N, ROS-Industrial khi_robot (BSD-3-Clause) khi_rs_description/urdf/rs007n_macro.xacro,
# expanded by hand: joint lengths 0.36, 0, 0.355, 0.0925, 0.2825, 0.078 m, wrist rotations +-90 deg
# (radians(90) as xacro writes it), axes 0 0 -1 / 0 0 1 alternating; limits from the same file.
_RS007N = [  # (xyz, rpy, axis, lower, upper in deg)
    ("0 0 0.36", "0 0 0", "0 0 -1", -180, 180),
    ("0 0 0.0", "0 -1.5707963267948966 0", "0 0 1", -135, 135),
    ("0.355 0 0", "0 0 0", "0 0 -1", -155, 155),
    ("0.0925 0 0", "0 1.5707963267948966 0", "0 0 1", -200, 200),
    ("0 0 0.2825", "0 -1.5707963267948966 0", "0 0 -1", -125, 125),
    ("0.078 0 0", "0 1.5707963267948966 0", "0 0 1", -360, 360),
]
# Denso VS-060, DENSORobot/denso_robot_ros denso_robot_descriptions/vs060_description/vs060.urdf
_VS060 = [
    ("0 0 0.1815", "0 0 0", "0 0 1", -170, 170),
    ("0 0 0.1635", "0 0 0", "0 1 0", -120, 120),
    ("0 0 0.305", "0 0 0", "0 1 0", -125, 155),
    ("-0.01 0 0.1645", "0 0 0", "0 0 1", -270, 270),
    ("0 0 0.1355", "0 0 0", "0 1 0", -120, 120),
    ("0 0 0.07", "0 0 0", "0 0 1", -360, 360),
]


def _urdf(name: str, joints, rounded: bool = False) -> str:
    """A URDF of a serial chain base_link -> link1 .. link6 -> tool0 (``rounded``: every +-pi/2
    written 1.5708, as hand-written files do)."""
    parts = [f'<robot name="{name}"><link name="base_link"/>']
    parent = "base_link"
    for i, (xyz, rpy, axis, lo, hi) in enumerate(joints, 1):
        if rounded:
            rpy = rpy.replace("1.5707963267948966", "1.5708")
        parts.append(f'<link name="link{i}"/><joint name="joint{i}" type="revolute"><parent link="{parent}"/>'
                     f'<child link="link{i}"/><origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
                     f'<limit lower="{float(np.deg2rad(lo))!r}" upper="{float(np.deg2rad(hi))!r}" '
                     'effort="1" velocity="1"/>'
                     "</joint>")
        parent = f"link{i}"
    parts.append(f'<link name="tool0"/><joint name="flange" type="fixed"><parent link="{parent}"/>'
                 '<child link="tool0"/><origin xyz="0 0 0" rpy="0 0 0"/></joint></robot>')
    return "".join(parts)


def _mdh_mm(rows) -> rc.Robot:
    """A robot from rows (alpha rad, a mm, d mm, theta rad) as robotkinematicscatalogue writes them."""
    rows = np.array(rows, float)
    return rc.Robot.from_mdh(rows[:, 0], rows[:, 1], rows[:, 3], rows[:, 2], length_unit="mm")


# robotkinematicscatalogue (inversekinematics/__6DOF): Comau N 220-2.7 and Nachi MZ25, MDH
_COMAU_N220 = [[0, 0, 775, 0], [-np.pi / 2, 400, 0, -np.pi / 2], [0, 1050, 0, -np.pi / 2],
               [-np.pi / 2, 280, 1220, 0], [np.pi / 2, 0, 0, 0], [-np.pi / 2, 0, 229.5, np.pi]]
_NACHI_MZ25 = [[0, 0, 550, 0], [-np.pi / 2, 170, 0, 0], [0, 880, 0, 0], [-np.pi / 2, 190, 810, 0],
               [np.pi / 2, 0, 0, 0], [-np.pi / 2, 0, 115, 0]]
# Comau Smart5 NJ4 220-2.7 (same source): a 60 deg wrist whose axes 4-5 and 5-6 meet 170 mm apart
_COMAU_NJ4_60DEG = [[0, 0, 830, 0], [-np.pi / 2, 400, 0, -np.pi / 2], [0, 1175, 0, -np.pi / 2],
                    [-np.pi / 2, 250, 1165, np.pi / 2], [np.deg2rad(60), 0, 170, 0],
                    [-np.deg2rad(60), 0, 225, np.pi / 2]]


def _dh_tables():
    """Standard DH tables (PARAMETERS.md 4.1 / 4.2: ARTE and the Robotics Toolbox), no OPW key."""
    abb = dict(theta_offsets=[0, -np.pi / 2, 0, 0, 0, np.pi], alpha=[-np.pi / 2, 0, -np.pi / 2, np.pi / 2,
                                                                     -np.pi / 2, 0])
    return {
        "arte_irb1600": rc.Robot.from_dh(d=[0.4865, 0, 0, 0.6, 0, 0.065], a=[0.15, 0.475, 0, 0, 0, 0], **abb),
        "arte_kr16_2": rc.Robot.from_dh(theta_offsets=[0, -np.pi / 2, 0, 0, 0, 0],
                                        d=[0.675, 0, 0, 0.67, 0, 0.115], a=[0.26, 0.68, -0.035, 0, 0, 0],
                                        alpha=abb["alpha"]),
        "rtb_puma560": rc.Robot.from_dh(theta_offsets=[0] * 6, d=[0.67183, 0, 0.15005, 0.4318, 0, 0],
                                        a=[0, 0.4318, 0.0203, 0, 0, 0],
                                        alpha=[np.pi / 2, 0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0]),
        "rtb_irb140": rc.Robot.from_dh(theta_offsets=[0] * 6, d=[0.352, 0, 0, 0.38, 0, 0.065],
                                       a=[0.07, 0.36, 0, 0, 0, 0], alpha=abb["alpha"]),
    }


def _models(tmp_path):
    (tmp_path / "rs007n.urdf").write_text(_urdf("rs007n", _RS007N))
    (tmp_path / "vs060.urdf").write_text(_urdf("vs060", _VS060))
    return {"rs007n_urdf": rc.load_model(str(tmp_path / "rs007n.urdf")),
            "vs060_urdf": rc.load_model(str(tmp_path / "vs060.urdf")),
            "comau_n220_mdh": _mdh_mm(_COMAU_N220), "nachi_mz25_mdh": _mdh_mm(_NACHI_MZ25),
            **_dh_tables()}


def _round_trip(robot: rc.Robot, n: int = N_POSES, seed: int = 0):
    """Random joints inside +-pi -> poses -> every closed-form branch: (largest FK error of a
    returned solution (m), share of poses whose own joints are among the branches)."""
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, 6))
    T = robot.fk(q)
    sols = rc.ik.solve_all(robot, T)
    ok = np.isfinite(sols).all(axis=2)
    fk = robot.fk(np.where(ok[..., None], sols, 0.0).reshape(-1, 6)).reshape(n, 8, 4, 4)
    err = np.linalg.norm(fk[..., :3, 3] - T[:, None, :3, 3], axis=2)[ok].max()
    wrapped = np.remainder(sols - q[:, None] + np.pi, 2 * np.pi) - np.pi
    found = (np.abs(wrapped) < 1e-7).all(axis=2).any(axis=1)
    return float(err), float(found.mean()), ok.sum(axis=1)


def test_opw_arms_without_an_opw_key_get_exact_closed_form_ik(tmp_path):
    """RS007N and VS-060 from their URDFs, Comau N220 and Nachi MZ25 from MDH tables, IRB 1600,
    KR 16-2, Puma 560 (b != 0) and IRB 140 from DH tables: each is recognised as an OPW arm (it said
    "no closed form" before) and 1,000 random poses round-trip through every branch."""
    for name, robot in _models(tmp_path).items():
        assert robot.opw is None and has_closed_form(robot), name
        err, found, branches = _round_trip(robot)
        assert err < EXACT_M and found == 1.0, (name, err, found)
        assert branches.min() >= 1 and np.median(branches) == 8, name


def test_derived_opw_set_is_the_vendors_set():
    """The catalog's OPW arms with their key dropped: the derived set is the published one
    (lengths, offsets of joints 1-5 and signs, KUKA's and FANUC's conventions included) and the
    model the same."""
    for name in ("abb_irb2600", "kuka_kr16_2", "fanuc_m20ia", "staubli_tx2_140"):
        cat = rc.Robot.from_catalog(name)
        derived = opw_model(replace(cat, opw=None))
        assert derived is not None, name
        for key in ("a1", "a2", "b", "c1", "c2", "c3", "c4"):
            assert abs(getattr(derived.opw, key) - getattr(cat.opw, key)) < 1e-12, (name, key)
        assert derived.opw.signs == cat.opw.signs, name
        # joint 6's offset only turns the flange frame: the derived model's tool holds it
        assert np.allclose(derived.opw.offsets[:5], cat.opw.offsets[:5], atol=1e-12), name
        assert max(round_trip_gap(cat, derived)) < 1e-13


def test_random_opw_arms_in_any_placement_are_recognised():
    """Random OPW sets (b, negative a2, any offsets and signs) placed by random base and tool
    frames, rebuilt from their joint lines as an MDH table: recognised and round-tripped."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        lengths = rng.uniform(-0.3, 0.3, 7)
        lengths[[3, 4, 5]] = rng.uniform(0.2, 1.2, 3)  # c1, c2, c3
        base = rc.kinematics.transforms.make_transform(
            rc.kinematics.transforms.rotvec_to_matrix(rng.normal(0, 1, 3)), rng.uniform(-1, 1, 3))
        arm = rc.Robot.from_opw(*lengths, offsets=rng.uniform(-np.pi, np.pi, 6),
                                signs=rng.choice([-1, 1], 6), base=base)
        bare = replace(arm, opw=None)
        assert has_closed_form(bare)
        err, found, _ = _round_trip(bare, 200, int(rng.integers(1 << 16)))
        assert err < EXACT_M and found == 1.0


def _panda() -> rc.Robot:
    """Franka Emika Panda, Craig's MDH from Franka's documentation (7 joints)."""
    return rc.Robot.from_mdh(alpha=[0, -np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, np.pi / 2, np.pi / 2],
                             a=[0, 0, 0, 0.0825, -0.0825, 0, 0.088], theta=[0] * 7,
                             d=[0.333, 0, 0.316, 0, 0.384, 0, 0])


def test_chains_not_of_the_form_have_no_closed_form():
    """A Franka Panda (7 joints), a 5-axis arm and the Comau NJ4's 60 deg offset wrist: "no closed
    form" from the API; numeric IK still solves the NJ4 (no nearby closed form to seed it)."""
    five = rc.Robot.from_dh(theta_offsets=[0] * 5, d=[0.4865, 0, 0, 0.6, 0], a=[0.15, 0.475, 0, 0, 0],
                            alpha=[-np.pi / 2, 0, -np.pi / 2, np.pi / 2, -np.pi / 2])
    nj4 = _mdh_mm(_COMAU_NJ4_60DEG)
    for robot in (_panda(), five, nj4):
        assert robot.opw_model is None and not has_closed_form(robot)
        with pytest.raises(ModelError, match="no closed form"):
            rc.ik.solve_all(robot, robot.fk(np.zeros((1, robot.n_joints))))
    assert opw_model(nj4, seed=True) is None
    q = np.random.default_rng(3).uniform(-0.5, 0.5, (20, 6))
    res = rc.ik.solve(nj4, nj4.fk(q), seeds=q + 0.05)
    assert res.converged.all()


def test_near_opw_chain_is_seeded_by_its_nearest_opw_arm(tmp_path):
    """The RS007N written with rpy 1.5708 (7e-6 rad off a right angle): not exactly OPW, so no
    closed form of its own (its solutions would miss by microns), but the nearest OPW arm seeds
    numeric IK, which reaches every pose to 1e-10 m."""
    (tmp_path / "rounded.urdf").write_text(_urdf("rs007n", _RS007N, rounded=True))
    robot = rc.load_model(str(tmp_path / "rounded.urdf"))
    assert robot.opw_model is None and not has_closed_form(robot)
    seed = seed_model(robot)
    assert seed is not robot and seed.opw is not None
    q = np.random.default_rng(5).uniform(-2.0, 2.0, (200, 6))
    res = rc.ik.solve(robot, robot.fk(q))
    assert res.converged.all()
    assert np.linalg.norm(robot.fk(res.joints)[:, :3, 3] - robot.fk(q)[:, :3, 3], axis=1).max() < 1e-9
    # and a path over its branches (the seed model's own base and tool kept: "no IK solution" else)
    path = np.linspace([0.1, -0.3, 0.2, 0.0, 0.6, 0.0], [0.5, 0.1, -0.2, 0.4, 0.9, 0.3], 10)
    plan = rc.ik.plan_path(robot, robot.fk(path))
    assert np.linalg.norm(robot.fk(plan.joints)[:, :3, 3] - robot.fk(path)[:, :3, 3], axis=1).max() < 1e-9


def test_calibrated_urdf_arm_is_seeded_by_its_nominal_closed_form(tmp_path):
    """A calibrated model of the URDF-read RS007N (its chain moved off the form): numeric IK seeded
    by the nominal's derived closed form, every pose reached."""
    (tmp_path / "rs007n.urdf").write_text(_urdf("rs007n", _RS007N))
    nominal = rc.load_model(str(tmp_path / "rs007n.urdf"))
    names = nominal.geometry_names
    rng = np.random.default_rng(11)
    moved = nominal.with_values({n: nominal.get(n) + rng.normal(0, 2e-4) for n in names})
    assert moved.opw_model is None
    q = rng.uniform(-2.0, 2.0, (200, 6))
    res = rc.ik.solve(moved, moved.fk(q), nominal=nominal)
    assert res.converged.all()


def test_cli_plan_on_an_opw_urdf(tmp_path, capsys):
    """`robocal plan --robot rs007n.urdf` (a closed form needed): planned (it said no closed form);
    a Panda and the NJ4's offset wrist: refused in one line (exit 2)."""
    from robocal.deploy.compensation import format_csv, pose_columns

    (tmp_path / "rs007n.urdf").write_text(_urdf("rs007n", _RS007N))
    robot = rc.load_model(str(tmp_path / "rs007n.urdf"))
    q = np.linspace([0.1, -0.3, 0.2, 0.0, 0.6, 0.0], [0.5, 0.1, -0.2, 0.4, 0.9, 0.3], 10)
    cols, vals = pose_columns(robot.fk(q), {"length": "mm", "orientation": "deg"})
    (tmp_path / "poses.csv").write_text(format_csv(cols, vals))
    out = tmp_path / "joints.csv"
    assert main(["plan", "--robot", str(tmp_path / "rs007n.urdf"), str(tmp_path / "poses.csv"),
                 "-o", str(out)]) == 0
    joints = np.deg2rad(np.loadtxt(out, delimiter=",", skiprows=1))
    assert np.linalg.norm(robot.fk(joints)[:, :3, 3] - robot.fk(q)[:, :3, 3], axis=1).max() < 1e-6
    capsys.readouterr()
    panda = tmp_path / "panda.yaml"
    _panda().save(panda)
    assert main(["plan", "--robot", str(panda), str(tmp_path / "poses.csv"), "-o", str(out)]) == 2
    assert "robot has 7 joints" in capsys.readouterr().err
    nj4 = tmp_path / "nj4.yaml"
    _mdh_mm(_COMAU_NJ4_60DEG).save(nj4)
    assert main(["plan", "--robot", str(nj4), str(tmp_path / "poses.csv"), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no closed form" in err and len(err.strip().splitlines()) == 1
