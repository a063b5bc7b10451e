"""Forward kinematics and the identification Jacobian against independent truths."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import SHARED, random_robot

from robocal import DataError, ModelError, Robot
from robocal.kinematics.transforms import invert_transform, rotvec_to_matrix


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    R = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]], "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
         "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis]
    T = np.eye(4)
    T[:3, :3] = R
    return T


def _trans(axis: str, dist: float) -> np.ndarray:
    T = np.eye(4)
    T["xyz".index(axis), 3] = dist
    return T


def naive_fk(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Textbook product of 4x4 matrices, one pose at a time (the independent truth)."""
    out = []
    for qq in q:
        T = robot.base.copy()
        for i in range(robot.n_joints):
            T = (T @ _rot("x", robot.alpha[i]) @ _trans("x", robot.a[i]) @ _rot("y", robot.beta[i])
                 @ _rot("z", robot.theta[i] + qq[i]) @ _trans("z", robot.d[i]))
        out.append(T @ robot.tool)
    return np.array(out)


def test_fk_matches_naive_product(rng, kernels):
    for _ in range(5):
        robot = random_robot(rng)
        q = rng.uniform(-np.pi, np.pi, (50, 6))
        np.testing.assert_allclose(robot.fk(q), naive_fk(robot, q), atol=1e-12)


def test_fk_frames_end_at_flange(rng):
    robot = random_robot(rng)
    q = rng.uniform(-np.pi, np.pi, (7, 6))
    tcp, frames = robot.fk(q, frames=True)
    assert frames.shape == (7, 7, 4, 4)
    np.testing.assert_allclose(frames[:, 0], np.broadcast_to(robot.base, (7, 4, 4)))
    np.testing.assert_allclose(frames[:, -1] @ robot.tool, tcp, atol=1e-12)


def test_fk_chunks_large_batches(rng, kernels):
    robot = random_robot(rng)
    q = rng.uniform(-np.pi, np.pi, (70000, 6))
    T = robot.fk(q)
    np.testing.assert_allclose(T[[0, 65535, 65536, 69999]], naive_fk(robot, q[[0, 65535, 65536, 69999]]),
                               atol=1e-12)


def test_ur10_external_reference(kernels):
    """pybotics' UR10 MDH poses (shared/reference) reproduced by Robot.from_mdh."""
    path = SHARED / "reference" / "ur10-mdh-fk.csv"
    if not path.exists():
        pytest.skip(f"external reference {path} absent")
    data = np.loadtxt(path, delimiter=",", comments="#")
    pi = np.pi
    robot = Robot.from_mdh(alpha=[0, pi / 2, 0, 0, -pi / 2, pi / 2], a=[0, 0, 612.7, 571.6, 0, 0],
                           theta=[0, pi, 0, 0, 0, pi], d=[118, 0, 0, 163.9, 115.7, 92.2],
                           length_unit="mm")
    T = robot.fk(np.deg2rad(data[:, :6]))
    ref = data[:, 6:].reshape(-1, 4, 4)
    np.testing.assert_allclose(T[:, :3, 3] * 1000, ref[:, :3, 3], atol=1e-6)
    np.testing.assert_allclose(T[:, :3, :3], ref[:, :3, :3], atol=1e-9)


def _fd_jacobian(robot: Robot, q, names, kind, h=1e-6):
    cols = []
    for k in range(len(names)):
        e = np.zeros(len(names))
        e[k] = h
        Tp, Tm = robot.displaced(names, e).fk(q), robot.displaced(names, -e).fk(q)
        dp = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
        if kind == "point":
            cols.append(dp)
        else:
            # angular velocity from dR R^T (skew part)
            W = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h) @ np.swapaxes(robot.fk(q)[:, :3, :3], 1, 2)
            w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
            cols.append(np.concatenate([dp, w], axis=1))
    return np.stack(cols, axis=2)


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_jacobian_matches_central_differences(rng, kind, kernels):
    worst = 0.0
    for _ in range(4):
        robot = random_robot(rng)
        names = robot.parameter_names
        q = rng.uniform(-np.pi, np.pi, (20, 6))
        J = robot.jacobian(q, names, kind=kind)
        assert J.shape == (20, 3 if kind == "point" else 6, len(names))
        Jfd = _fd_jacobian(robot, q, names, kind)
        err = np.abs(J - Jfd).max() / np.abs(Jfd).max()
        worst = max(worst, err)
    assert worst <= 1e-6, worst


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8))
def test_jacobian_property_any_chain_length(seed, n):
    rng = np.random.default_rng(seed)
    robot = random_robot(rng, n)
    q = rng.uniform(-np.pi, np.pi, (5, n))
    names = robot.parameter_names
    J = robot.jacobian(q, names, kind="pose")
    Jfd = _fd_jacobian(robot, q, names, "pose")
    assert np.abs(J - Jfd).max() <= 1e-6 * max(1.0, np.abs(Jfd).max())


def test_displaced_rotation_is_multiplicative(rng):
    robot = random_robot(rng)
    d = np.array([0.01, -0.02, 0.03])
    moved = robot.displaced(["base.rx", "base.ry", "base.rz"], d)
    np.testing.assert_allclose(moved.base, np.block([[rotvec_to_matrix(d), np.zeros((3, 1))],
                                                     [np.zeros((1, 3)), 1]]) @ robot.base, atol=1e-12)
    moved = robot.displaced(["tool.rx", "tool.ry", "tool.rz"], d)
    np.testing.assert_allclose(moved.tool[:3, :3], rotvec_to_matrix(d) @ robot.tool[:3, :3], atol=1e-12)
    np.testing.assert_allclose(moved.tool[:3, 3], robot.tool[:3, 3], atol=1e-12)


def test_parameter_view_get_set(rng):
    robot = random_robot(rng)
    assert len(robot.parameter_names) == 5 * 6 + 12
    r2 = robot.with_values({"a3": 0.25, "base.x": 1.5})
    assert r2.get("a3") == 0.25 and r2.get("base.x") == 1.5
    np.testing.assert_allclose(r2.with_values({"base.rz": robot.get("base.rz")}).base[:3, :3],
                               robot.base[:3, :3], atol=1e-12)
    assert robot.get("a3") != 0.25  # copies, never in place
    with pytest.raises(ModelError, match="unknown parameter"):
        robot.get("a9")


def test_yaml_round_trip_exact(tmp_path, rng):
    robot = random_robot(rng)
    robot = robot.with_values({"d2": 0.123456789012345})
    path = tmp_path / "r.yaml"
    robot.save(path)
    back = Robot.load(path)
    for f in ("alpha", "a", "beta", "theta", "d", "base", "tool", "limits", "parallel", "nominal"):
        np.testing.assert_array_equal(getattr(back, f), getattr(robot, f))
    assert "length: m" in path.read_text()


def test_yaml_hand_written_mm_deg(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("units: {length: mm, angle: deg}\njoints:\n"
                    "  - {alpha: 0, a: 0, theta: 0, d: 100, limits: [-90, 90]}\n"
                    "  - {alpha: 90, a: 50, theta: 0, d: 0}\n"
                    "tool: {xyz: [0, 0, 10], rpy: [0, 0, 90]}\n")
    robot = Robot.load(path)
    assert robot.d[0] == pytest.approx(0.1) and robot.alpha[1] == pytest.approx(np.pi / 2)
    assert robot.limits[0, 1] == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(robot.tool[:3, 0], [0, 1, 0], atol=1e-12)


def test_yaml_dh_table_keeps_its_conversion_frames(tmp_path, rng):
    """A ``dh:`` file = the DH product, with a last link (a6, alpha6) whose frame the conversion
    must put into the tool, and the file's base/tool wrapped around it."""
    theta, d = [0, 10, 0, 0, 0, 0], [400, 0, 0, 300, 0, 80]
    a, alpha = [25, 400, 30, 0, 0, 20], [90, 0, 90, -90, 90, 45]
    path = tmp_path / "dh.yaml"
    path.write_text(f"units: {{length: mm, angle: deg}}\n"
                    f"dh: {{theta: {theta}, d: {d}, a: {a}, alpha: {alpha}}}\n"
                    "base: {xyz: [100, -50, 20], rpy: [0, 0, 30]}\n"
                    "tool: {xyz: [0, 0, 120], rpy: [10, 0, 0]}\n")
    robot = Robot.load(path)
    q = rng.uniform(-np.pi, np.pi, (20, 6))
    base = _trans("x", 0.1) @ _trans("y", -0.05) @ _trans("z", 0.02) @ _rot("z", np.radians(30))
    tool = _trans("z", 0.12) @ _rot("x", np.radians(10))
    expected = []
    for row in q:
        T = base
        for i in range(6):
            T = T @ _rot("z", np.radians(theta[i]) + row[i]) @ _trans("z", d[i] * 1e-3) \
                @ _trans("x", a[i] * 1e-3) @ _rot("x", np.radians(alpha[i]))
        expected.append(T @ tool)
    np.testing.assert_allclose(robot.fk(q), np.array(expected), rtol=0, atol=1e-12)


@pytest.mark.parametrize("text,match", [
    ("joints: [1, 2]\nunits: {length: m, angle: rad}\n", r"joints\[1\] \(joint 1\): expected a mapping"),
    ("joints: []\nunits: {length: m, angle: rad}\n", "non-empty"),
    ("joints: [{a: 1}]\n", "declare its units"),
    ("joints: [{a: 1}]\nunits: {length: furlong, angle: rad}\n", "unknown units"),
    ("joints: [{alpha: 0, a: .nan, theta: 0, d: 0}]\nunits: {length: m, angle: rad}\n", "not finite"),
    ("joints: [{alpha: 0, a: hello, theta: 0, d: 0}]\nunits: {length: m, angle: rad}\n",
     "expected a number"),
    ("joints: [{alpha: 0, a: 1, theta: 0}]\nunits: {length: m, angle: rad}\n",
     r"joints\[1\] \(joint 1\): missing key\(s\) \['d'\]"),
    ("!!python/object/apply:os.system ['echo hacked']\n", "not valid"),
    ("joints: [{a: 1, b: 2}]\nunits: {length: m, angle: rad}\n", "unknown key"),
    ("key: [unclosed\n", "not valid"),
])
def test_yaml_bad_input(tmp_path, text, match):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ModelError, match=match):
        Robot.load(path)


def test_bad_joints_and_parameters(rng):
    robot = random_robot(rng)
    with pytest.raises(DataError, match="shape"):
        robot.fk(np.zeros((3, 5)))
    with pytest.raises(DataError, match="NaN"):
        robot.fk(np.array([[0, 0, np.nan, 0, 0, 0]]))
    with pytest.raises(ModelError, match="NaN"):
        Robot(alpha=[0, np.inf], a=[0, 0], beta=[0, 0], theta=[0, 0], d=[0, 0])
    with pytest.raises(ModelError, match="must have 2"):
        Robot(alpha=[0, 0], a=[0], beta=[0, 0], theta=[0, 0], d=[0, 0])


def test_invert_transform(rng):
    from robots import random_frame

    T = random_frame(rng)
    np.testing.assert_allclose(T @ invert_transform(T), np.eye(4), atol=1e-12)


def test_jacobian_with_extra_smrs(rng, kernels):
    robot = random_robot(rng)
    robot = Robot(**{f: getattr(robot, f) for f in ("alpha", "a", "beta", "theta", "d")},
                  base=robot.base, tool=robot.tool, smr=rng.uniform(-0.1, 0.1, (2, 3)))
    q = rng.uniform(-np.pi, np.pi, (9, 6))
    smr = np.arange(9) % 3
    names = robot.parameter_names
    J = robot.jacobian(q, names, smr=smr)
    h = 1e-6
    for k, name in enumerate(names):
        e = np.zeros(len(names))
        e[k] = h
        fd = (robot.displaced(names, e).fk(q, smr=smr)[:, :3, 3]
              - robot.displaced(names, -e).fk(q, smr=smr)[:, :3, 3]) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-7, err_msg=name)
    np.testing.assert_allclose(robot.fk(q, smr=smr)[smr == 0], robot.fk(q[smr == 0]), atol=1e-12)


def test_empty_batches(rng, kernels):
    for robot in (random_robot(rng), Robot.from_catalog("abb_irb2600")):
        assert robot.fk(np.zeros((0, 6))).shape == (0, 4, 4)
        assert robot.fk(np.zeros((0, 6)), frames=True)[1].shape == (0, 7, 4, 4)
        assert robot.jacobian(np.zeros((0, 6)), ["a2", "d4"]).shape == (0, 3, 2)


def test_model_yaml_doc_examples_load(tmp_path):
    """Every YAML example of docs/model-yaml.md is a valid model (a work cell's: a valid cell); the
    catalog's are the catalog's."""
    import re
    import textwrap
    from pathlib import Path

    from robocal.kinematics.workcell import load_cell

    doc = (Path(__file__).resolve().parents[1] / "docs" / "model-yaml.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", doc, re.S)
    assert len(blocks) >= 4
    q = np.random.default_rng(0).uniform(-1, 1, (5, 6))
    for k, block in enumerate(blocks):
        path = tmp_path / f"m{k}.yaml"
        path.write_text(textwrap.dedent(block))
        if re.search(r"^(positioners?|robots):", textwrap.dedent(block), re.M):
            assert load_cell(path).bodies
            continue
        robot = Robot.load(path)
        name = robot.name
        if name in ("abb_irb2600", "ur5", "meca500"):
            np.testing.assert_allclose(robot.fk(q), Robot.from_catalog(name).fk(q), atol=1e-12)


def test_values_are_read_once_and_never_aliased():
    """values_of / get read the vector computed once per model; values hands out a private copy."""
    robot = Robot.from_catalog("abb_irb2600").displaced(["a2", "base.rz", "tool.x"], [1e-3, 0.2, 0.01])
    names = robot.parameter_names
    vec = robot.values
    assert np.array_equal(robot.values_of(names), vec)
    assert [robot.get(nm) for nm in names] == vec.tolist()
    vec[:] = 0.0  # the caller's copy: the model is unchanged
    assert robot.get("a2") == robot.values[robot.indices(["a2"])[0]] != 0.0
    picked = robot.values_of(["a2"])
    picked[0] = 0.0
    assert robot.get("a2") != 0.0
    with pytest.raises(ModelError):
        robot.values_of(["nope"])
