"""evaluate(): statistics against brute-force truths; the evaluate command; real-data baselines."""

from __future__ import annotations

import json

import numpy as np
import pytest
from robots import random_robot, require_datasets
from test_measurements import MECA

from robocal import DataError, PlausibilityError, Robot
from robocal.calibration.evaluation import evaluate
from robocal.cli import main
from robocal.data import Measurements, simulate_tracker
from robocal.data.importer import import_tracker
from robocal.report import position_stats


def test_position_stats_brute_force(rng):
    e = rng.normal(scale=1e-4, size=(101, 3))
    s = position_stats(e)
    norms = sorted(float(np.sqrt(sum(c * c for c in row))) * 1e3 for row in e)
    assert s["n"] == 101
    assert s["rms"] == pytest.approx(np.sqrt(sum(v * v for v in norms) / 101), rel=1e-12)
    assert s["mean"] == pytest.approx(sum(norms) / 101, rel=1e-12)
    assert s["max"] == pytest.approx(norms[-1], rel=1e-12)
    assert s["p95"] == pytest.approx(norms[95], rel=1e-12)  # rank 0.95 * 100 = 95 exactly
    assert position_stats(np.array([-3e-3]))["max"] == pytest.approx(3.0)
    with pytest.raises(DataError):
        position_stats(np.zeros(0))


def test_point_errors_are_measured_minus_model(rng):
    robot = random_robot(rng)
    q = rng.normal(size=(20, 6))
    offset = rng.normal(scale=1e-4, size=(20, 3))
    data = Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3] + offset)
    out = evaluate(robot, data)
    np.testing.assert_allclose(out["error_vectors_mm"], offset * 1e3, atol=1e-9)
    assert out["rms"] == pytest.approx(position_stats(offset)["rms"], rel=1e-6)


def test_fit_frame_removes_frame_errors():
    sim = simulate_tracker(MECA, 50, noise_mm=0.0, n_smr=2, seed=12, error_scale=0.0)
    assert evaluate(sim.truth, sim.data)["max"] < 1e-9
    with pytest.raises(DataError, match="fit-frame"):
        evaluate(MECA, sim.data)
    out = evaluate(MECA, sim.data, fit_frame=True)
    assert out["max"] < 1e-9 and isinstance(out["robot"], Robot)


def test_distance_and_plane_errors(rng):
    q = rng.uniform(-2, 2, (6, 6))
    p = MECA.fk(q)[:, :3, 3]
    true = np.linalg.norm(p[0::2] - p[1::2], axis=1)
    data = Measurements.from_arrays(
        "distance", q, pair=np.repeat(np.arange(3), 2), distance=np.repeat(true + [1e-4, -2e-4, 0], 2)
    )
    np.testing.assert_allclose(evaluate(MECA, data)["errors_mm"], np.repeat([-0.1, 0.2, 0.0], 2), atol=1e-9)
    sim = simulate_tracker(MECA, 40, kind="plane", n_planes=2, seed=3, noise_mm=0.0)
    assert evaluate(sim.truth, sim.data)["max"] < 1e-9
    with pytest.raises(PlausibilityError, match="misses the measurements"):  # the probe is not the flange
        evaluate(MECA, sim.data)
    assert evaluate(MECA, sim.data, force=True)["max"] > 1e-3  # the nominal tip is off the planes


def test_cli_evaluate_json(tmp_path):
    sim = simulate_tracker(MECA, 20, noise_mm=0.01, seed=2)
    sim.truth.save(tmp_path / "t.yaml")
    sim.data.save(tmp_path / "d.csv")
    assert (
        main(
            [
                "evaluate",
                str(tmp_path / "t.yaml"),
                str(tmp_path / "d.csv"),
                "--json",
                str(tmp_path / "o.json"),
            ]
        )
        == 0
    )
    out = json.loads((tmp_path / "o.json").read_text())
    assert out["evaluation"]["n"] == 20 and out["evaluation"]["rms"] == pytest.approx(
        sim.noise_floor_mm, rel=1e-9
    )
    assert main(["evaluate", str(tmp_path / "t.yaml"), str(tmp_path / "nope.csv")]) == 2


IRB120 = Robot.from_catalog("abb_irb120")


def test_real_data_nominal_after_registration():
    ds = require_datasets()
    meca = ds / "meca500-faro"
    cal, val = (
        import_tracker(
            sorted(meca.glob(f"{p}_data__*_Output.csv")), joints="cols=0-5:deg", points="cols=6-8:m"
        ).data
        for p in ("cal", "val")
    )
    from robocal.data import register

    stats = evaluate(register(MECA, cal), val)
    # datasets README baseline: nominal + fitted base/SMR, validation RMS 0.182 mm
    assert stats["n"] == 70 and 0.15 < stats["rms"] < 0.21
    irb = ds / "irb120-faro"
    data = import_tracker(
        joints=f"{irb}/measured_joints.txt:cols=0-5:deg",
        points=[f"{irb}/measured_SMR_{s}.txt:mm" for s in (1, 2, 3)],
    ).data
    first = data.first_poses(500)
    held = data.subset(~np.isin(data.pose_id, first.pose_id))
    stats = evaluate(register(IRB120, first), held)
    # README baseline: 0.952 mm on 500 held-out poses x 3 SMRs
    assert stats["n"] == 1500 and 0.8 < stats["rms"] < 1.1
