"""A positioner's axes (URDF-like) converted to robocal's chain: forward kinematics against an
independent composition of the axes (scipy rotations about the given axes, translations), to
1e-12, on random axes and joint values; every refusal names its cause."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from robocal.core.errors import ModelError
from robocal.kinematics.model import Robot
from robocal.kinematics.positioner import COAXIAL_TOL, check_chain, positioner_chain

FK_TOL = 1e-12  # m and rotation-matrix entries: the conversion is exact up to rounding


def pose(xyz, rpy=(0.0, 0.0, 0.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF rpy: fixed axes x, y, z
    T[:3, 3] = xyz
    return T


def composed(axes, mount, plate, e) -> np.ndarray:
    """The axes' own forward kinematics, written independently: mount, then per axis its origin,
    its rpy and its motion (a rotation by e_i about the axis, or a slide of e_i along it), then
    the plate."""
    out = []
    for row in np.atleast_2d(e):
        T = mount.copy()
        for ax, value in zip(axes, row, strict=True):
            T = T @ pose(ax["origin"], ax.get("rpy", (0.0, 0.0, 0.0)))
            u = np.asarray(ax["axis"], float) / np.linalg.norm(ax["axis"])
            J = np.eye(4)
            if ax["type"] == "revolute":
                J[:3, :3] = Rotation.from_rotvec(u * value).as_matrix()
            else:
                J[:3, 3] = u * value
            T = T @ J
        out.append(T @ plate)
    return np.array(out)


def unit_vectors():
    return st.lists(st.floats(-1, 1), min_size=3, max_size=3).filter(
        lambda v: np.linalg.norm(v) > 0.1).map(lambda v: (np.asarray(v) / np.linalg.norm(v)).tolist())


def vectors(bound):
    return st.lists(st.floats(-bound, bound), min_size=3, max_size=3)


axis_strategy = st.fixed_dictionaries({
    "type": st.sampled_from(["revolute", "revolute", "prismatic"]), "axis": unit_vectors(),
    "origin": vectors(1.5), "rpy": vectors(3.0)})


def _coaxial_or_redundant(axes) -> bool:
    try:
        positioner_chain([{**a, "limits": [-1, 1]} for a in axes])
    except ModelError as exc:
        return "coaxial" in str(exc) or "one direction" in str(exc)
    return False


@settings(max_examples=60, deadline=None)
@given(axes=st.lists(axis_strategy, min_size=1, max_size=3), mount=st.tuples(vectors(3.0), vectors(3.0)),
       plate=st.tuples(vectors(0.5), vectors(3.0)), seed=st.integers(0, 2**32 - 1))
def test_fk_equals_the_axes_composition(axes, mount, plate, seed):
    assume(not _coaxial_or_redundant(axes))
    axes = [{**a, "limits": [-2.0, 2.0]} for a in axes]
    M, P = pose(*mount), pose(*plate)
    robot = positioner_chain(axes, M, P)
    e = np.random.default_rng(seed).uniform(-2.0, 2.0, (7, len(axes)))
    np.testing.assert_allclose(robot.fk(e), composed(axes, M, P, e), rtol=0, atol=FK_TOL)
    assert robot.prismatic.tolist() == [a["type"] == "prismatic" for a in axes]


TILT_TURN = [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9], "limits": [-1.5, 1.5]},
             {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25]}]


@pytest.mark.parametrize("axes", [
    TILT_TURN,
    # parallel, not coaxial (a Ferris-wheel station axis): Hayati's beta, flagged parallel
    [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 1.0]},
     {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0.6, 0], "rpy": [0.3, 0, 0]}],
    # nearly parallel (2 deg)
    [{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.5]},
     {"type": "revolute", "axis": [0, np.sin(0.035), np.cos(0.035)], "origin": [0.4, 0, 0.1]}],
    # a lift, then a turn about the same direction, then a tilt
    [{"type": "prismatic", "axis": [0, 0, 1], "origin": [0, 0, 0.3], "limits": [0, 1.2]},
     {"type": "revolute", "axis": [0, 0, 1], "origin": [0.2, 0, 0]},
     {"type": "revolute", "axis": [0, 1, 0], "origin": [0, 0, 0.1]}],
])
def test_fk_of_typical_positioners(axes):
    rng = np.random.default_rng(1)
    M, P = pose([1.4, 0.2, 0.0], [0, 0, 0.5]), pose([0.01, 0.02, 0.03], [0.1, -0.2, 0.3])
    robot = positioner_chain(axes, M, P)
    e = rng.uniform(-1.0, 1.0, (20, len(axes)))
    np.testing.assert_allclose(robot.fk(e), composed(axes, M, P, e), rtol=0, atol=FK_TOL)


def test_nearly_parallel_axes_a_nanometre_apart_keep_the_offset():
    """Hypothesis' case: two axes 1.2e-4 rad from parallel through one point 7.6e-6 m off the first
    axis' foot, so the second axis' foot is 9.3e-10 m from the first frame's origin; that offset is
    kept (it was dropped as rounding: FK off by 9.2e-10 m), FK exact to rounding."""
    axis = {"type": "revolute", "axis": [0.015623093000542114, 0.9998779520346953, 0.0],
            "origin": [0.0, 0.0, 0.0625], "rpy": [0.0, 0.0078125, 0.0], "limits": [-2.0, 2.0]}
    axes = [axis, {**axis, "origin": [0.0, 0.0, 0.0]}]
    robot = positioner_chain(axes)
    e = np.random.default_rng(0).uniform(-2.0, 2.0, (7, 2))
    np.testing.assert_allclose(robot.fk(e), composed(axes, np.eye(4), np.eye(4), e), rtol=0, atol=FK_TOL)
    assert 9e-10 < abs(robot.a[1]) < 1e-9


def test_parallel_axes_carry_beta_and_limits_default_to_a_turn():
    axes = [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 1.0]},
            {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0.6, 0]}]
    robot = positioner_chain(axes)
    assert robot.parallel.tolist() == [False, True]
    np.testing.assert_array_equal(robot.limits, [[-2 * np.pi, 2 * np.pi]] * 2)


def test_tilt_turn_geometry_and_round_trip(tmp_path):
    robot = positioner_chain(TILT_TURN, pose([1.4, 0, 0]), name="irbp")
    e = np.array([[0.0, 0.0], [np.pi / 2, 0.0], [0.0, np.pi / 2]])
    np.testing.assert_allclose(robot.fk(e)[:, :3, 3], [[1.4, 0, 1.15], [1.4, -0.25, 0.9], [1.4, 0, 1.15]],
                               atol=FK_TOL)
    np.testing.assert_allclose(robot.limits[0], [-1.5, 1.5])
    robot.save(tmp_path / "p.yaml")
    again = Robot.load(tmp_path / "p.yaml")
    np.testing.assert_array_equal(again.values, robot.values)
    np.testing.assert_array_equal(again.fk(e), robot.fk(e))


def test_axis_within_the_tolerance_is_normalised():
    near = [{"type": "revolute", "axis": [0, 0, 1 + 5e-7], "origin": [0, 0, 0.5]}]
    exact = [{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.5]}]
    e = np.array([[0.3], [1.2]])
    np.testing.assert_allclose(positioner_chain(near).fk(e), positioner_chain(exact).fk(e), atol=FK_TOL)


def test_limits_given_apart():
    axes = [{k: v for k, v in a.items() if k != "limits"} for a in TILT_TURN]
    robot = positioner_chain(axes, limits=[[-1, 1], [-6, 6]])
    np.testing.assert_array_equal(robot.limits, [[-1, 1], [-6, 6]])


REV = {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0]}


@pytest.mark.parametrize("axes, kwargs, message", [
    ([], {}, r"1 to 3 axes, got 0"),
    ([REV, {**REV, "axis": [1, 0, 0]}, REV, {**REV, "axis": [0, 1, 0]}], {}, r"1 to 3 axes, got 4"),
    ([{**REV, "axis": [0, 0, 0]}], {}, r"axis 1: zero axis \[0.0, 0.0, 0.0\]: give the direction it turns"),
    ([REV, {**REV, "type": "prismatic", "axis": [0, 0, 0], "limits": [0, 1]}], {},
     r"axis 2: zero axis .* slides along"),
    ([{**REV, "axis": [1, 1, 0]}], {},
     r"axis 1: axis \[1.0, 1.0, 0.0\] is not a unit vector \(norm 1.41421\)"),
    ([REV, {**REV, "origin": [0, 0, 0.7]}], {}, r"axes 1 and 2: consecutive revolute axes are coaxial"),
    ([REV, {**REV, "axis": [0, 0, -1], "origin": [0, 0, -0.2]}], {}, r"axes 1 and 2: .* coaxial"),
    ([{**REV, "axis": [1, 0, 0]}, REV, {**REV, "origin": [0, 0, 0.4]}], {}, r"axes 2 and 3: .* coaxial"),
    ([{**REV, "type": "prismatic", "limits": [0, 1]}, {**REV, "type": "prismatic", "origin": [1, 0, 0],
                                                      "limits": [0, 1]}], {},
     r"axes 1 and 2: both prismatic along one direction"),
    ([{**REV, "limits": [1.0, -1.0]}], {}, r"axis 1: limits reversed: lower 1 is not below upper -1"),
    ([{**REV, "limits": [1.0, 1.0]}], {}, r"limits reversed"),
    ([REV], {"limits": [[2.0, -2.0]]}, r"axis 1: limits reversed"),
    ([{**REV, "type": "prismatic"}], {}, r"axis 1: a prismatic axis needs its limits"),
    ([{**REV, "type": "spherical"}], {}, r"axis 1.type: expected revolute or prismatic"),
    ([{**REV, "offset": 3}], {}, r"axis 1: unknown key\(s\) \['offset'\]"),
    ([{"type": "revolute"}], {}, r"axis 1: missing key\(s\) \['axis'\]"),
    ([{**REV, "origin": [0, 0]}], {}, r"axis 1.origin: expected 3 finite numbers"),
    ([{**REV, "limits": [-1, 1]}], {"limits": [[-1, 1]]}, r"either per axis or as limits=, not both"),
    ([REV], {"limits": [[-1, 1], [-1, 1]]}, r"limits must be 1 \(lower, upper\) pairs"),
])
def test_refusals_name_the_cause(axes, kwargs, message):
    with pytest.raises(ModelError, match=message) as info:
        positioner_chain(axes, name="pos", **kwargs)
    assert "\n" not in str(info.value)


def test_coaxial_within_the_tolerance_only():
    apart = [REV, {**REV, "origin": [10 * COAXIAL_TOL, 0, 0.7]}]
    assert positioner_chain(apart).n_joints == 2


def test_check_chain_on_tables():
    coaxial = Robot.from_mdh([0, 0], [0, 0], [0, 0], [0.5, 0.3])  # two revolute joints on one line
    with pytest.raises(ModelError, match="axes 1 and 2: consecutive revolute axes are coaxial"):
        check_chain(coaxial, "table")
    with pytest.raises(ModelError, match="1 to 3 axes, got 6"):
        check_chain(Robot.from_catalog("abb_irb2600"), "irb")
    check_chain(Robot.from_mdh([0, np.pi / 2], [0, 0], [0, 0], [0.5, 0.3]), "ok")


# ----------------------------------------------------------------- the catalog's positioners
from robocal.kinematics.catalog import positioner_names  # noqa: E402
from robocal.kinematics.workcell import catalog_positioner, cell_from_data  # noqa: E402

REQUIRED = {"abb_irbp_a250", "kuka_dkp400", "yaskawa_motopos_d250"}


def test_catalog_has_the_common_positioners():
    names = set(positioner_names())
    assert names >= REQUIRED and names & {"abb_irbp_c500", "abb_irbp_l300"}


@pytest.mark.parametrize("name", positioner_names())
def test_catalog_positioner_is_sourced_and_loads(name):
    chain, payload = catalog_positioner(name)
    assert 1 <= chain.n_joints <= 3 and payload > 0
    text = chain.description
    assert "Source to check:" in text and "http" in text and "chosen:" in text, \
        "say where the numbers come from and which were chosen"
    e = np.zeros((1, chain.n_joints))
    assert np.isfinite(chain.fk(e)).all()
    assert (chain.limits[:, 0] < 0).all() and (chain.limits[:, 1] > 0).all()
    # by name in a cell file, placed at its mount
    cell = cell_from_data({"units": {"length": "mm", "angle": "deg"},
                           "positioner": {"model": name, "unit": "STN1", "mount": {"xyz": [1500, 0, 0]}}})
    placed = cell.positioners["STN1"].chain
    np.testing.assert_allclose(placed.fk(e)[0, :3, 3], chain.fk(e)[0, :3, 3] + [1.5, 0, 0], atol=FK_TOL)


def test_tilt_turn_entry_is_the_axes_it_declares():
    chain, _ = catalog_positioner("abb_irbp_a250")
    e = np.random.default_rng(4).uniform(-1.5, 1.5, (9, 2))
    axes = [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9]},
            {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25]}]
    np.testing.assert_allclose(chain.fk(e), composed(axes, np.eye(4), np.eye(4), e), atol=FK_TOL)


def test_unknown_catalog_positioner():
    with pytest.raises(ModelError, match="unknown positioner 'abb_irbp_z9'; the catalog has: abb_irbp_a250"):
        catalog_positioner("abb_irbp_z9")


def test_robots_command_lists_and_shows_positioners(capsys):
    from robocal.cli import main

    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "positioners (a cell file's positioner: model: NAME)" in out
    assert out.index("abb_irb2600") < out.index("positioners (") < out.index("abb_irbp_a250")
    assert main(["robots", "kuka_dkp400"]) == 0
    shown = capsys.readouterr().out
    assert shown.startswith("kuka_dkp400: KUKA DKP-400") and "    2 " in shown


def test_catalog_page_lists_every_positioner():
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "catalog.md").read_text()
    section = page[page.index("## Positioners"):]
    for name in positioner_names():
        assert f"| `{name}` |" in section, name
