"""Standard DH and OPW conversions to MDH + beta, against direct products of the source convention."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocal import ModelError, Robot
from robocal.kinematics.opw import OPWParameters, opw_fk


def dh_product(theta, d, a, alpha, q):
    """Textbook standard DH: prod Rz(theta + q) Tz(d) Tx(a) Rx(alpha), one pose at a time."""
    out = []
    for qq in q:
        T = np.eye(4)
        for i in range(len(theta)):
            c, s = np.cos(theta[i] + qq[i]), np.sin(theta[i] + qq[i])
            ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
            T = T @ np.array([[c, -s * ca, s * sa, a[i] * c], [s, c * ca, -c * sa, a[i] * s],
                              [0, sa, ca, d[i]], [0, 0, 0, 1]])
        out.append(T)
    return np.array(out)


def random_dh(rng, n):
    """Random DH table mixing generic values with the special ones (0, +-90, 180 deg, zero lengths)."""
    special = rng.random(n) < 0.5
    alpha = np.where(special, rng.choice([0, np.pi / 2, -np.pi / 2, np.pi], n), rng.uniform(-np.pi, np.pi, n))
    a = np.where(rng.random(n) < 0.3, 0.0, rng.uniform(-1, 1, n))
    d = np.where(rng.random(n) < 0.3, 0.0, rng.uniform(-1, 1, n))
    return rng.uniform(-np.pi, np.pi, n), d, a, alpha


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8))
def test_from_dh_equals_dh_product(seed, n):
    rng = np.random.default_rng(seed)
    theta, d, a, alpha = random_dh(rng, n)
    robot = Robot.from_dh(theta, d, a, alpha)
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (20, n))
    np.testing.assert_allclose(robot.fk(q), dh_product(theta, d, a, alpha, q), rtol=0, atol=1e-12)
    assert not robot.parallel[0]


def test_from_dh_units_and_frames(rng):
    theta, d, a, alpha = random_dh(rng, 6)
    si = Robot.from_dh(theta, d, a, alpha, limits=np.tile([-1.0, 1.0], (6, 1)))
    mm = Robot.from_dh(np.rad2deg(theta), d * 1e3, a * 1e3, np.rad2deg(alpha), degrees=True,
                       length_unit="mm", limits=np.tile([-np.rad2deg(1.0), np.rad2deg(1.0)], (6, 1)))
    q = rng.uniform(-np.pi, np.pi, (30, 6))
    np.testing.assert_allclose(mm.fk(q), si.fk(q), atol=1e-12)
    np.testing.assert_allclose(mm.limits, si.limits, atol=1e-15)
    base, tool = Robot.from_dh([0], [0.1], [0.2], [0.3]).fk(np.zeros((1, 1)))[0], np.eye(4)
    tool[:3, 3] = [0.01, 0.02, 0.03]
    framed = Robot.from_dh(theta, d, a, alpha, base=base, tool=tool)
    np.testing.assert_allclose(framed.fk(q), base @ dh_product(theta, d, a, alpha, q) @ tool, atol=1e-12)


def random_opw(rng) -> OPWParameters:
    return OPWParameters(*rng.uniform(-1, 1, 7), offsets=tuple(rng.uniform(-np.pi, np.pi, 6)),
                         signs=tuple(rng.choice([-1, 1], 6)))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_from_opw_equals_opw_fk(seed):
    rng = np.random.default_rng(seed)
    p = random_opw(rng)
    robot = Robot.from_opw(p.a1, p.a2, p.b, p.c1, p.c2, p.c3, p.c4, p.offsets, p.signs)
    q = rng.uniform(-2 * np.pi, 2 * np.pi, (20, 6))
    np.testing.assert_allclose(robot.fk(q), opw_fk(p, q), rtol=0, atol=1e-12)
    assert robot.parallel.tolist() == [False, False, True, False, False, False]  # J2 || J3
    assert robot.opw == p


def test_opw_fk_geometry_at_zero():
    """Paper zero pose: arm straight up, wrist centre at (a1, b, c1 + c2 + c3) when a2 = 0."""
    p = OPWParameters(0.1, 0.0, 0.05, 0.4, 0.5, 0.6, 0.07)
    T = opw_fk(p, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(T[:3, 3], [0.1, 0.05, 0.4 + 0.5 + 0.6 + 0.07], atol=1e-15)
    np.testing.assert_allclose(T[:3, :3], np.eye(3), atol=1e-15)
    # a positive sign-corrected joint 1 turns the arm about +z, a flipped one about -z
    q = np.array([[0.3, 0, 0, 0, 0, 0]])
    flipped = OPWParameters(0.1, 0.0, 0.05, 0.4, 0.5, 0.6, 0.07, signs=(-1, 1, 1, 1, 1, 1))
    np.testing.assert_allclose(opw_fk(flipped, q), opw_fk(p, -q), atol=1e-15)


def test_opw_fk_against_py_opw_kinematics(rng):
    po = pytest.importorskip("py_opw_kinematics", reason="py-opw-kinematics (test extra) not installed")
    for _ in range(5):
        p = random_opw(rng)
        model = po.KinematicModel(a1=p.a1, a2=p.a2, b=p.b, c1=p.c1, c2=p.c2, c3=p.c3, c4=p.c4,
                                  offsets=p.offsets, flip_axes=tuple(s < 0 for s in p.signs))
        q = rng.uniform(-np.pi, np.pi, (50, 6))
        theirs = po.Robot(model, degrees=False).batch_forward(q).as_matrix()
        np.testing.assert_allclose(opw_fk(p, q), theirs, atol=1e-12)


def test_arte_irb2400_dh_equals_opw_set(rng):
    """Two independent sources of one robot: the ARTE DH table and the opw_kinematics set."""
    dh = Robot.from_dh([0, -90, 0, 0, 0, 180], [0.615, 0, 0, 0.755, 0, 0.085],
                       [0.100, 0.705, 0.135, 0, 0, 0], [-90, 0, -90, 90, -90, 0], degrees=True)
    opw = OPWParameters(0.100, -0.135, 0, 0.615, 0.705, 0.755, 0.085,
                        offsets=(0, 0, -np.pi / 2, 0, 0, 0))
    q = rng.uniform(-np.pi, np.pi, (100, 6))
    np.testing.assert_allclose(dh.fk(q), opw_fk(opw, q), atol=1e-12)


def test_yaml_round_trip_keeps_opw(tmp_path):
    robot = Robot.from_opw(0.15, -0.115, 0, 0.445, 0.7, 0.795, 0.085, [0, 0, -90, 0, 0, 0],
                           [1, 1, 1, 1, 1, 1], degrees=True, name="irb2600")
    robot.save(tmp_path / "m.yaml")
    back = Robot.load(tmp_path / "m.yaml")
    assert back.opw == robot.opw
    np.testing.assert_array_equal(back.values, robot.values)


@pytest.mark.parametrize(("call", "match"), [
    (lambda: Robot.from_dh([0, 0], [0.1], [0, 0], [0, 0]), "DH d must have 2 values"),
    (lambda: Robot.from_dh([0, 0], [0.1, 0], [0, np.nan], [0, 0]), "NaN"),
    (lambda: Robot.from_dh([], [], [], []), "empty"),
    (lambda: Robot.from_dh([0], [0.1], [0], [0], length_unit="inch"), "unknown length unit"),
    (lambda: Robot.from_opw(0.1, 0, 0, 0.4, 0.5, 0.6, 0.1, [0] * 5), "OPW offsets must have 6"),
    (lambda: Robot.from_opw(0.1, 0, 0, 0.4, 0.5, 0.6, np.inf), "NaN or infinite"),
    (lambda: Robot.from_opw(0.1, 0, 0, 0.4, 0.5, 0.6, 0.1, [0] * 6, [1, 1, 2, 1, 1, 1]),
     "signs must be 6 values of \\+1 or -1"),
    (lambda: Robot.from_opw(0.1, 0, 0, 0.4, 0.5, 0.6, 0.1, length_unit="cm"), "unknown length unit"),
    (lambda: OPWParameters(0.1, 0, 0, 0.4, 0.5, float("nan"), 0.1), "c3 must be one finite number"),
    (lambda: opw_fk(OPWParameters(0, 0, 0, 0, 0, 0, 0), np.zeros((3, 5))), "shape \\(N, 6\\)"),
])
def test_bad_input(call, match):
    with pytest.raises(ModelError, match=match):
        call()
