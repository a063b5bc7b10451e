"""The two implementations of the hot kernels (numpy, and numba from the ``fast`` extra): how one is
chosen, and that they agree with each other on forward kinematics and closed-form IK, including
singular poses (each is also checked against the independent truths of test_kinematics/test_ik)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import random_frame, random_robot, requires_numba, wrapped

import robocal as rc
from robocal.core.errors import RobocalError
from robocal.ik import solve_all
from robocal.ik.opw_ik import opw_form
from robocal.kinematics import kernels as kn
from robocal.kinematics.fk import _POLY_MAX, chain_frames
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

OPW_ROBOTS = ["abb_irb2600", "kuka_kr6_r700", "fanuc_lrmate200id", "puma560"]


def both(fn):
    """``fn()`` with the numpy kernels and with the compiled ones."""
    with kn.use_kernels("numpy"):
        a = fn()
    with kn.use_kernels("numba"):
        b = fn()
    return a, b


def assert_same_branches(robot, a, b, atol=1e-9):
    """Same branches present, same joints (mod 2 pi: a joint at +-pi may wrap either way). Near a
    singular wrist (|sin theta5| < 1e-6) only theta4 +- theta6 is well defined, so that is compared."""
    assert (np.isnan(a) == np.isnan(b)).all()
    ok = np.isfinite(a).all(axis=2)
    assert (ok == np.isfinite(b).all(axis=2)).all()
    o = opw_form(robot)
    pa, pb = (x[ok] * np.asarray(o.signs) - np.asarray(o.offsets) for x in (a, b))  # paper angles
    near = np.abs(np.sin(pa[:, 4])) < 1e-6
    turn = np.sign(np.cos(pa[:, 4]))
    for p in (pa, pb):
        p[near, 3] += turn[near] * p[near, 5]
        p[near, 5] = 0.0
    assert np.abs(wrapped(pa - pb)).max(initial=0.0) < atol


def test_choice_from_environment_and_context(monkeypatch):
    monkeypatch.setenv(kn.ENV, "numpy")
    assert kn.active() == "numpy"
    assert kn.compiled("robocal.kinematics.fk_numba") is None
    monkeypatch.setenv(kn.ENV, "bogus")
    with pytest.raises(RobocalError, match=kn.ENV):
        kn.active()
    with kn.use_kernels("numpy"):  # the context wins over the environment
        assert kn.active() == "numpy"
    with pytest.raises(RobocalError, match="kernels must be"), kn.use_kernels("fortran"):
        pass


def test_forced_numba_without_numba(monkeypatch):
    monkeypatch.setitem(kn._loaded, "robocal.kinematics.fk_numba", None)  # as if not installed
    with kn.use_kernels("numba"), pytest.raises(RobocalError, match=r"robocal\[fast\]"):
        kn.active()
    with kn.use_kernels("auto"):
        assert kn.active() == "numpy"


def test_core_runs_without_numba():
    """With numba unimportable the numpy path runs, and importing robocal never imports numba."""
    code = ("import sys; sys.modules['numba'] = None\n"
            "import numpy as np, robocal as rc\n"
            "from robocal.kinematics.kernels import active\n"
            "r = rc.Robot.from_catalog('abb_irb2600')\n"
            "T = r.fk(np.zeros((3, 6)))\n"
            "assert np.isfinite(rc.ik.solve_all(r, T)).all(axis=2).any(axis=1).all()\n"
            "print(active())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=300)
    assert out.stdout.strip() == "numpy"
    out = subprocess.run([sys.executable, "-c", "import sys, robocal; print('numba' in sys.modules)"],
                         capture_output=True, text=True, check=True, timeout=300)
    assert out.stdout.strip() == "False"


@requires_numba
def test_auto_imports_numba_only_for_large_work():
    """``auto`` leaves numba unimported for a small forward-kinematics call (its import costs more
    than it saves there) and uses it once imported, or for a call of LOAD_MIN_ITEMS poses."""
    code = ("import sys, numpy as np, robocal as rc\n"
            "from robocal.kinematics import kernels as kn\n"
            "r = rc.Robot.from_catalog('abb_irb2600')\n"
            "r.fk(np.zeros((100, 6)))\n"
            "print('numba' in sys.modules)\n"
            "kn.LOAD_MIN_ITEMS = 50\n"
            "r.fk(np.zeros((50, 6)))\n"
            "print('numba' in sys.modules, kn.compiled('robocal.kinematics.fk_numba', 1) is not None)")
    env = {**os.environ, kn.ENV: "auto"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env,
                         timeout=600)
    assert out.stdout.split() == ["False", "True", "True"]


@requires_numba
def test_fk_backends_agree(rng):
    for n in (6, 6, 3, 7):
        robot = random_robot(rng, n)
        q = rng.uniform(-4, 4, (3000, n))
        a, b = both(lambda r=robot, q=q: r.fk(q))
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)
        # the general broadcasting path (links with a batch dim) is a third implementation
        links = robot.links._replace(**{f: getattr(robot.links, f)[None] for f in robot.links._fields})
        np.testing.assert_allclose(b, chain_frames(links, robot.base, robot.tool, q), rtol=0, atol=1e-13)


@requires_numba
def test_fk_backends_agree_on_odd_input(rng):
    robot = random_robot(rng)
    q = rng.uniform(-4, 4, (1200, 6))
    q[700, 2] = 3 * _POLY_MAX  # beyond the polynomial sin/cos: its block uses libm
    tools = np.stack([random_frame(rng, 0.1) for _ in range(1200)])
    for args in ((q,), (q[::3],), (np.asfortranarray(q),), (q[:1],), (q[:0],)):
        a, b = both(lambda args=args: robot.fk(*args))
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    # one tool per row (several SMRs)
    a, b = both(lambda: chain_frames(robot.links, robot.base, tools, q))
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


@requires_numba
def test_frames_and_jacobian_backends_agree(rng):
    """The compiled frames (``frames=True``) and identification Jacobian against the numpy ones:
    every parameter of a robot with two extra SMRs, point and pose rows, a per-row tool."""
    robot = random_robot(rng)
    robot = rc.Robot(**{f: getattr(robot, f) for f in ("alpha", "a", "beta", "theta", "d")},
                     base=robot.base, tool=robot.tool, smr=rng.uniform(-0.1, 0.1, (2, 3)))
    q = rng.uniform(-4, 4, (700, 6))
    smr = rng.integers(0, 3, 700)
    names = robot.parameter_names
    for kind in ("point", "pose"):
        a, b = both(lambda kind=kind: robot.jacobian(q, names, kind=kind, smr=smr))
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    a, b = both(lambda: robot.jacobian(q[:, ::-1], names[3::4], smr=smr))  # a subset; strided joints
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    (ta, fa), (tb, fb) = both(lambda: robot.fk(q, frames=True, smr=smr))
    np.testing.assert_allclose(ta, tb, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fa, fb, rtol=0, atol=1e-13)


def _singular_and_edge_poses(robot, rng, n=300):
    """World poses: random, wrist singular (paper theta5 = 0, pi), wrist centre on J1, arm
    stretched and folded."""
    o = opw_form(robot)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (n, 6))
    groups = [q]
    for paper5 in (0.0, np.pi):
        g = q.copy()
        g[:, 4] = (paper5 + o.offsets[4]) * o.signs[4]
        groups.append(g)
    psi3 = np.arctan2(o.a2, o.c3)
    for phi in (0.0, np.pi):
        g = rng.uniform(-1, 1, (n, 6))
        g[:, 2] = (phi - psi3 + o.offsets[2]) * o.signs[2]
        groups.append(g)
    T = robot.fk(np.concatenate(groups))
    R = rotvec_to_matrix(rng.uniform(-2, 2, (n, 3)))
    C = np.stack([np.zeros(n), np.zeros(n), o.c1 + rng.uniform(0.2, 0.6, n) * (o.c2 + o.c3)], axis=1)
    on_axis = robot.base @ make_transform(R, C + o.c4 * R[:, :, 2]) @ robot.tool
    return np.concatenate([T, on_axis])


@requires_numba
@pytest.mark.parametrize("name", OPW_ROBOTS)
def test_ik_backends_agree(name, rng):
    robot = rc.Robot.from_catalog(name)
    T = _singular_and_edge_poses(robot, rng)
    a, b = both(lambda: solve_all(robot, T))
    assert np.isfinite(a).all(axis=2).sum() > 0.7 * a.shape[0] * 8 * 0.5
    # acos near +-1 (stretched / folded arm) amplifies rounding of 1e-16 to ~1e-8 rad
    assert_same_branches(robot, a, b, atol=1e-6)
    regular = slice(0, 300)
    assert_same_branches(robot, a[regular], b[regular], atol=1e-10)


@requires_numba
def test_ik_threads_give_identical_results(rng):
    robot = rc.Robot.from_catalog("abb_irb2600")
    T = robot.fk(rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (40000, 6)))
    with kn.use_kernels("numba"):
        one = solve_all(robot, T, threads=1)
        two = solve_all(robot, T, threads=2)
    np.testing.assert_array_equal(one, two)


@requires_numba
@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from([0.0, np.pi / 2, -np.pi, np.pi, 1e-9, -1e-9, 0.3, -2.5, 3.0, 1.0]),
                min_size=6, max_size=6), st.integers(0, 3), st.floats(-1.0, 1.0))
def test_property_ik_backends_agree(values, which, jitter):
    robot = rc.Robot.from_catalog(OPW_ROBOTS[which])
    q = np.clip(np.array([values, np.array(values) + jitter]), robot.limits[:, 0], robot.limits[:, 1])
    T = robot.fk(q)
    a, b = both(lambda: solve_all(robot, T))
    assert_same_branches(robot, a, b, atol=1e-6)
