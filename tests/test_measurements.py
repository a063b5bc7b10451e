"""Measurements: canonical CSV round trips, validation, malformed files, fuzzed reader."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robocal import DataError, RobocalError, Robot, UnitError
from robocal.data import Measurements
from robocal.data.measurements import parse_csv
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.transforms import rotvec_to_matrix

MECA = Robot.from_catalog("meca500")


def _point_data(rng, N=12, sigma=True):
    return Measurements.from_arrays(
        "point",
        rng.uniform(-3, 3, (N, 6)),
        points=rng.uniform(-2, 2, (N, 3)),
        smr=rng.integers(0, 3, N),
        sigma=rng.uniform(1e-6, 1e-4, N) if sigma else None,
        pose_id=np.arange(N) // 2,
        source_row=np.arange(N) + 5,
        source="test set",
    )


def _same(a: Measurements, b: Measurements, rot_tol=0.0):
    assert a.kind == b.kind and a.source == b.source
    for f in ("joints", "pose_id", "smr", "source_row", "sigma", "points", "plane", "pair", "distance"):
        x, y = getattr(a, f), getattr(b, f)
        assert (x is None) == (y is None), f
        if x is not None:
            np.testing.assert_array_equal(x, y, err_msg=f)
    if a.rotations is not None:
        np.testing.assert_allclose(a.rotations, b.rotations, atol=rot_tol, rtol=0)


def test_point_round_trip_is_exact(tmp_path, rng):
    data = _point_data(rng)
    data.save(tmp_path / "d.csv")
    _same(data, Measurements.load(tmp_path / "d.csv"))


def test_pose_plane_distance_round_trips(tmp_path, rng):
    N = 8
    q = rng.uniform(-2, 2, (N, 6))
    pose = Measurements.from_arrays(
        "pose", q, points=rng.normal(size=(N, 3)), rotations=rotvec_to_matrix(rng.uniform(-3, 3, (N, 3)))
    )
    plane = Measurements.from_arrays("plane", q, plane=np.arange(N) % 3)
    dist = Measurements.from_arrays(
        "distance",
        q,
        pair=np.repeat(np.arange(N // 2), 2),
        distance=np.repeat(rng.uniform(0.1, 1, N // 2), 2),
        smr=np.tile([0, 1], N // 2),
    )
    for k, d in enumerate((pose, plane, dist)):
        d.save(tmp_path / f"{k}.csv")
        _same(d, Measurements.load(tmp_path / f"{k}.csv"), rot_tol=1e-15)


def test_reads_mm_deg_columns_and_comment(tmp_path):
    text = (
        "# from the tracker\nq1_deg,q2_deg,x_mm,y_mm,z_mm,sigma_mm\n"
        "90,-45,1000,2000,-500,0.01\n\n0,0,1,2,3,0.02\n"
    )
    (tmp_path / "a.csv").write_text(text)
    d = Measurements.load(tmp_path / "a.csv")
    np.testing.assert_allclose(d.joints, [[np.pi / 2, -np.pi / 4], [0, 0]])
    np.testing.assert_allclose(d.points, [[1, 2, -0.5], [1e-3, 2e-3, 3e-3]])
    np.testing.assert_allclose(d.sigma, [1e-5, 2e-5])
    assert d.source == "from the tracker"
    assert d.source_row.tolist() == [3, 5]  # file line numbers
    assert d.pose_id.tolist() == [0, 1] and d.smr.tolist() == [0, 0]


def test_external_axes_alone_are_a_positioner_file(tmp_path):
    # a 2-axis positioner's file: its axes are the e columns, no arm joints
    text = ("e1_deg,e2_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz\n-30,0,100,200,300,1,0,0,0\n"
            "-30,22.5,110,190,300,1,0,0,0\n")
    data = parse_csv(text)
    assert (data.n_joints, data.external, data.kind) == (2, 2, "pose")
    assert np.allclose(data.joints, np.deg2rad([[-30, 0], [-30, 22.5]]))
    path = tmp_path / "plate.csv"
    data.save(path)
    header = next(line for line in path.read_text().splitlines() if not line.startswith("#"))
    assert header.split(",")[2:4] == ["e1_rad", "e2_rad"]
    table = Robot.from_mdh([0, -90], [0, 0], [0, 0], [0, 400], degrees=True, length_unit="mm",
                           limits=[[-90, 90], [-360, 360]])
    assert Measurements.load(path, robot=table).n_joints == 2


def test_subset_and_split_keep_poses_together(rng):
    data = _point_data(rng, N=40)
    a, b = data.split_poses(0.25, seed=3)
    assert a.n_poses == 5 and b.n_poses == 15
    assert not set(a.pose_id) & set(b.pose_id)
    assert sorted(np.r_[a.source_row, b.source_row]) == sorted(data.source_row)
    a2, _ = data.split_poses(0.25, seed=3)
    np.testing.assert_array_equal(a.pose_id, a2.pose_id)
    assert data.first_poses(3).pose_id.tolist() == [0, 0, 1, 1, 2, 2]
    sub = data.subset(data.smr == 1)
    assert (sub.smr == 1).all() and len(sub) == int((data.smr == 1).sum())
    with pytest.raises(DataError):
        data.split_poses(1.0)
    with pytest.raises(DataError):
        data.subset(np.zeros(len(data), bool))


def test_from_arrays_validation(rng):
    q = rng.normal(size=(4, 6))
    with pytest.raises(DataError, match="kind"):
        Measurements.from_arrays("laser", q, points=np.zeros((4, 3)))
    with pytest.raises(DataError, match="points"):
        Measurements.from_arrays("point", q)
    with pytest.raises(DataError, match="do not take"):
        Measurements.from_arrays("point", q, points=np.zeros((4, 3)), plane=np.zeros(4, int))
    with pytest.raises(DataError, match="NaN"):
        Measurements.from_arrays("point", q, points=np.full((4, 3), np.nan))
    with pytest.raises(DataError, match="exactly 2"):
        Measurements.from_arrays("distance", q, pair=[0, 0, 0, 1], distance=np.ones(4))
    with pytest.raises(DataError, match="rotation"):
        Measurements.from_arrays("pose", q, points=np.zeros((4, 3)), rotations=np.ones((4, 3, 3)))


def test_check_against_robot(tmp_path):
    (tmp_path / "five.csv").write_text(
        "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,x_mm,y_mm,z_mm\n" + "0,0,0,0,0,1,2,3\n"
    )
    with pytest.raises(DataError, match=r"5 joint columns but meca500 has 6.*five\.csv|five\.csv.*5 joint"):
        Measurements.load(tmp_path / "five.csv", robot=MECA)
    # 2000-m spread for a 0.5 m robot: the values are millimetres labelled metres
    rows = "\n".join(f"0,0,0,0,0,0,{x},{y},0" for x, y in ((0, 0), (2, 0), (40, 30)))
    (tmp_path / "m.csv").write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_m,y_m,z_m\n" + rows + "\n")
    with pytest.raises(UnitError, match=r"m\.csv.*x_mm"):
        Measurements.load(tmp_path / "m.csv", robot=MECA)
    assert len(Measurements.load(tmp_path / "m.csv")) == 3  # without a robot only the tracker range applies


HEAD6 = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg"
MALFORMED = [
    ("", DataError, "empty"),
    ("# only a comment\n", DataError, "empty"),
    (f"{HEAD6},x_mm,y_mm,z_mm\n", DataError, "no data rows"),
    (f"{HEAD6},x_mm,y_mm\n0,0,0,0,0,0,1,2\n", DataError, "missing"),
    (f"{HEAD6},x_mm,y_mm,z_mm,colour\n0,0,0,0,0,0,1,2,3,4\n", DataError, "unknown column 'colour'"),
    (f"{HEAD6},x_cm,y_cm,z_cm\n0,0,0,0,0,0,1,2,3\n", UnitError, "unknown length unit 'cm'"),
    ("q1_grad,x_mm,y_mm,z_mm\n0,1,2,3\n", UnitError, "unknown angle unit"),
    ("q1,x_mm,y_mm,z_mm\n0,1,2,3\n", UnitError, "no unit"),
    (f"{HEAD6},x,y,z\n0,0,0,0,0,0,1,2,3\n", UnitError, "no unit"),
    (f"{HEAD6},x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,2,3\n0,0,0,0,0,0,nan,2,3\n", DataError, "line 3.*NaN"),
    (f"{HEAD6},x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,2\n", DataError, "line 2.*8 values"),
    (f"{HEAD6},x_mm,y_mm,z_mm\n0,0,0,0,0,0,1,abc,3\n", DataError, "line 2.*not a number"),
    (f"{HEAD6},x_mm,x_mm,z_mm\n0,0,0,0,0,0,1,2,3\n", DataError, "twice"),
    (f"{HEAD6},x_mm,y_m,z_mm\n0,0,0,0,0,0,1,2,3\n", UnitError, "mix units"),
    ("q1_deg,q2_rad,x_mm,y_mm,z_mm\n0,0,1,2,3\n", UnitError, "mix _deg and _rad"),
    ("q1_deg,q3_deg,x_mm,y_mm,z_mm\n0,0,1,2,3\n", DataError, "without gaps"),
    ("x_mm,y_mm,z_mm\n1,2,3\n", DataError, "no joint columns"),
    (f"{HEAD6}\n0,0,0,0,0,0\n", DataError, "no observation columns"),
    (f"{HEAD6},x_mm,y_mm,z_mm,plane\n0,0,0,0,0,0,1,2,3,0\n", DataError, "plane contacts"),
    (f"{HEAD6},x_mm,y_mm,z_mm,smr\n0,0,0,0,0,0,1,2,3,0.5\n", DataError, "integer"),
    (f"{HEAD6},x_mm,y_mm,z_mm,smr\n0,0,0,0,0,0,1,2,3,-1\n", DataError, "smr"),
    (f"{HEAD6},x_m,y_m,z_m\n0,0,0,0,0,0,1000,2000,30\n", UnitError, "line 2.*x_mm"),
    ("q1_rad,x_m,y_m,z_m\n90,1,2,3\n", UnitError, "degrees"),
    (f"{HEAD6},x_mm,y_mm,z_mm,qw,qx,qy,qz\n0,0,0,0,0,0,1,2,3,1,1,0,0\n", DataError, "quaternion norm"),
    (f"{HEAD6},pair,distance_mm\n0,0,0,0,0,0,0,100\n", DataError, "exactly 2"),
    (f"{HEAD6},x_mm,y_mm,z_mm,sigma_mm\n0,0,0,0,0,0,1,2,3,0\n", DataError, "sigma"),
]


@pytest.mark.parametrize(("text", "error", "match"), MALFORMED)
def test_malformed_files(tmp_path, text, error, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(error, match=match) as info:
        Measurements.load(path)
    assert "bad.csv" in str(info.value)


def test_unreadable_files(tmp_path):
    with pytest.raises(DataError, match="cannot read"):
        Measurements.load(tmp_path / "absent.csv")
    (tmp_path / "bin.csv").write_bytes(b"\xff\xfe\x00\x81garbage")
    with pytest.raises(DataError, match="UTF-8"):
        Measurements.load(tmp_path / "bin.csv")


_TOKENS = st.sampled_from(
    [
        "q1_deg",
        "q2_rad",
        "x_mm",
        "y_mm",
        "z_mm",
        "x_m",
        "smr",
        "plane",
        "pair",
        "distance_mm",
        "qw",
        "qx",
        "qy",
        "qz",
        "sigma_mm",
        "pose_id",
        "source_row",
        "1",
        "-0.5",
        "nan",
        "inf",
        "1e400",
        "abc",
        "",
        " ",
        "0",
        "3",
        "1e30",
        "#",
        '"',
        "q7_deg",
        "q1_cm",
        "9999999999999999999999",
    ]
)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.one_of(
        st.text(max_size=200),
        st.lists(st.lists(_TOKENS, min_size=1, max_size=8).map(",".join), min_size=0, max_size=6).map(
            "\n".join
        ),
    )
)
def test_fuzz_reader_raises_only_robocal_errors(text):
    try:
        data = parse_csv(text, "fuzz.csv")
    except RobocalError:
        return
    assert len(data) >= 1 and np.isfinite(data.joints).all()
    with contextlib.suppress(RobocalError):
        data.check_against(MECA)


def test_approach_directions_follow_the_measurement_order_and_survive_subsets(tmp_path):
    q = np.array([[0.0, 0.0], [0.1, -0.2], [0.1, -0.2], [0.0, 0.3]])
    data = Measurements.from_arrays("point", q, points=np.zeros((4, 3)), pose_id=[0, 1, 1, 2])
    assert data.approach.tolist() == [[0, 0], [1, -1], [1, -1], [-1, 1]]
    data.save(tmp_path / "all.csv")
    assert "approach1" not in (tmp_path / "all.csv").read_text()  # implied by the order
    part = data.subset([3, 0])
    assert part.approach.tolist() == [[-1, 1], [0, 0]]
    part.save(tmp_path / "part.csv")
    assert Measurements.load(tmp_path / "part.csv").approach.tolist() == [[-1, 1], [0, 0]]
    with pytest.raises(DataError, match="approach"):
        Measurements.from_arrays("point", q, points=np.zeros((4, 3)),
                                 conditions=Conditions(approach=np.full((4, 2), 2)))


def test_a_file_longer_than_a_chunk_reads_every_row_with_its_line_number():
    """The CSV body is read in blocks of CHUNK rows: rows, comments and blank lines across the
    block boundary keep their order and line numbers, and an error past it names its line."""
    from robocal.kinematics.fk import CHUNK

    n = CHUNK + 7
    q = np.linspace(-1.0, 1.0, n).tolist()
    lines = ["# provenance", "q1_rad,q2_rad,x_m,y_m,z_m"]
    for i in range(n):
        lines.append(f"{q[i]!r},{-q[i]!r},{i * 1e-3!r},0.5,0.25")
        if i == CHUNK - 2:
            lines += ["", "# a comment inside the data"]
    data = parse_csv("\n".join(lines))
    assert len(data) == n and np.array_equal(data.joints[:, 0], np.array(q))
    assert np.array_equal(data.points[:, 0], np.arange(n) * 1e-3)
    line_of_row = np.r_[np.arange(CHUNK - 1) + 3, np.arange(CHUNK - 1, n) + 5]
    assert np.array_equal(data.source_row, line_of_row)
    lines[-1] = "0.1,0.2,oops,0.5,0.25"
    with pytest.raises(DataError, match=f"line {len(lines)}, column x_m: 'oops' is not a number"):
        parse_csv("\n".join(lines))


def test_a_payload_mass_beyond_any_arm_names_the_unit_it_looks_like():
    """The mass check of a file's payload column says which unit the number fits
    (`robocal.core.magnitudes.likely_unit`, the one rule), not only 'give kilograms'."""
    from robocal.data.measurements import _conditions

    for mass, words in ((150_000.0, "grams: 150000 g = 150 kg"), (6000.0, "pounds: 6000 lb = 2722 kg")):
        with pytest.raises(DataError, match=f"it looks like {words}"):
            _conditions(np.array([[mass, 0.0, 0.0, 0.0]]), None, 1)
    with pytest.raises(DataError, match=r"outside 0..5000 kg: give payload_kg in kilograms"):
        _conditions(np.array([[1e9, 0.0, 0.0, 0.0]]), None, 1)
