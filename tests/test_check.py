"""The check of a calibration: the test statistic against its closed form, the verdict on simulated
campaigns of an unchanged and a changed robot, what moved, and the command line with a history."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.history.check import ALPHA, Uncertainty, _p_value, _Whitened, check_calibration
from robocal.history.record import calibration_uncertainty
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix


@pytest.fixture(scope="module")
def calibrated():
    """A calibrated IRB 2600 (80 poses, 0.02 mm noise) with its truth and result."""
    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(nominal, 80, seed=21)
    result = rc.calibrate(nominal, sim.data, nongeometric="none", progress=False)
    return sim.truth, result


def _campaign(truth, seed: int, n: int = 20, **changes):
    """A check campaign of ``truth`` (changed by ``changes``: name -> shift, deg) with the tracker moved."""
    rng = np.random.default_rng(seed)
    robot = truth.with_values({k: truth.get(k) + np.deg2rad(v) for k, v in changes.items()})
    moved = make_transform(rotvec_to_matrix(np.deg2rad(5.0) * np.array([0.6, 0.0, 0.8])), [0.3, -0.2, 0.1])
    return simulate_tracker(replace(robot, base=moved @ robot.base), joints=sample_joints(truth, n, rng),
                            as_is=True, seed=seed).data


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(10, 40), st.integers(1, 9))
def test_the_statistic_is_the_generalised_least_squares_residual(seed, M, k):
    rng = np.random.default_rng(seed)
    J, r = rng.normal(size=(M, k)), rng.normal(size=M)
    A = rng.normal(size=(M, M))
    C = A @ A.T + M * np.eye(M)
    T = _Whitened(r, J, C).fit()[0]
    Ci = np.linalg.inv(C)
    expected = r @ (Ci - Ci @ J @ np.linalg.inv(J.T @ Ci @ J) @ J.T @ Ci) @ r
    assert pytest.approx(expected, rel=1e-9) == T
    assert _p_value(T, M - k, None) == pytest.approx(stats.chi2.sf(T, M - k))
    assert _p_value(T, M - k, 200) == pytest.approx(stats.f.sf(T / (M - k), M - k, 200))


def test_unchanged_robot_holds_and_a_moved_joint_zero_is_named(calibrated):
    truth, result = calibrated
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    same = check_calibration(result.robot, _campaign(truth, 1), unc)
    assert same.verdict == "holds" and same.p_value >= ALPHA and not same.to_dict().get("changed_parameters")
    assert any("theta1, theta6" in n for n in same.notes)
    moved = check_calibration(result.robot, _campaign(truth, 2, theta3=0.01), unc)
    assert moved.verdict == "changed" and moved.p_value < ALPHA
    first = moved.changed_parameters[0]
    assert first["name"] == "theta3" and first["unit"] == "deg"
    assert abs(first["shift"] - 0.01) < 3 * first["sigma"]
    assert moved.to_dict()["changed_parameters"] == moved.changed_parameters
    # theta1 turns the robot about its base axis: the refitted frame absorbs it, without a frame fit not
    hidden = check_calibration(result.robot, _campaign(truth, 3, theta1=0.02), unc)
    assert hidden.verdict == "holds"
    in_place = _campaign(truth, 4, theta1=0.02)
    in_place = simulate_tracker(truth.with_values({"theta1": truth.get("theta1") + np.deg2rad(0.02)}),
                                joints=in_place.joints, as_is=True, seed=4).data
    seen = check_calibration(result.robot, in_place, unc, fit_frame=False)
    # without a frame fit the change shows, but a turn about the base axis is a turned tracker frame to
    # the data (theta1's column lies in the frame's span): the frame is named, never theta1
    assert seen.verdict == "changed" and seen.frame_change["moved"] == ["tracker"]
    assert np.linalg.norm(seen.frame_change["rotation_deg"]) == pytest.approx(0.02, rel=0.05)
    assert not seen.changed_parameters and "--fit-frame" in seen.summary()


def test_the_result_json_carries_the_same_uncertainty_as_the_history(calibrated):
    _, result = calibrated
    recorded = Uncertainty.from_dict(calibration_uncertainty(result))
    from_json = Uncertainty.from_result(json.loads(result.to_json()))
    assert from_json.names == recorded.names and from_json.dof == recorded.dof
    assert from_json.noise_m == pytest.approx(recorded.noise_m, rel=1e-9)
    np.testing.assert_allclose(from_json.covariance, recorded.covariance, rtol=1e-5,
                               atol=1e-5 * np.abs(recorded.covariance).max())
    with pytest.raises(DataError, match="lacks what a check needs"):
        Uncertainty.from_result({"parameters": []})


def test_a_calibration_with_several_smrs_and_joint_error_terms_is_checked():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(nominal, 60, seed=5, n_smr=2)
    result = rc.calibrate(nominal, sim.data, nongeometric="compliance", progress=False)
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    assert any(n.startswith("comp") for n in unc.names)
    q = sample_joints(nominal, 20, np.random.default_rng(1))
    same = simulate_tracker(sim.truth, joints=q, as_is=True, seed=3, n_smr=2).data
    assert check_calibration(result.robot, same, unc).verdict == "holds"
    moved = sim.truth.with_values({"theta4": sim.truth.get("theta4") + np.deg2rad(0.05)})
    moved_data = simulate_tracker(moved, joints=q, as_is=True, seed=3, n_smr=2).data
    out = check_calibration(result.robot, moved_data, unc)
    assert out.verdict == "changed" and out.changed_parameters[0]["name"] == "theta4"


def test_stated_noise_gives_a_chi_square_test_and_bad_input_is_refused(calibrated):
    truth, result = calibrated
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    data = _campaign(truth, 5)
    out = check_calibration(result.robot, data, unc, noise_mm=0.02).to_dict()
    assert out["test"]["kind"] == "chi2" and out["test"]["noise_dof"] is None and out["verdict"] == "holds"
    # a far noisier instrument stated than the data show: the residuals are smaller than expected
    assert check_calibration(result.robot, data, unc, noise_mm=0.2).p_value > 0.999
    with pytest.raises(DataError, match="at least 8 poses"):
        check_calibration(result.robot, _campaign(truth, 6, n=5), unc)
    with pytest.raises(DataError, match="noise-mm"):
        check_calibration(result.robot, data, unc, noise_mm=-1)
    with pytest.raises(DataError, match="does not have"):
        check_calibration(result.robot, data, replace(unc, names=("gear2_s1", *unc.names[1:])))
    with pytest.raises(DataError, match="plane data, whose noise is not the tracker's"):
        check_calibration(result.robot, data, replace(unc, kind="plane"))
    assert check_calibration(result.robot, data, replace(unc, kind="plane"), noise_mm=0.02).verdict == "holds"


def test_check_command_with_a_history(calibrated, tmp_path, capsys):
    truth, result = calibrated
    model, res_json, hist = tmp_path / "cal.yaml", tmp_path / "result.json", str(tmp_path / "h.sqlite")
    result.problem.datasets[0].save(tmp_path / "cal.csv")
    assert main(["--quiet", "calibrate", str(tmp_path / "cal.csv"), "--robot", "abb_irb2600",
                 "--nongeometric", "none", "-o", str(model), "--json", str(res_json), "--history", hist,
                 "--robot-id", "IRB-7"]) == 0
    assert model.exists() and res_json.exists()  # the history is never the only copy
    assert main(["calibrate", str(tmp_path / "cal.csv"), "--robot", "abb_irb2600", "--history", hist]) == 2
    assert "go together" in capsys.readouterr().err
    for name, campaign in (("same", _campaign(truth, 7)), ("moved", _campaign(truth, 8, theta2=0.01))):
        campaign.save(tmp_path / f"{name}.csv")
    out = tmp_path / "check.json"
    base = ["check", str(model), str(tmp_path / "moved.csv"), "--fit-frame"]
    assert main([*base, "--history", hist, "--robot-id", "IRB-7", "--json", str(out)]) == 0
    moved = json.loads(out.read_text())
    assert moved["verdict"] == "changed" and moved["changed_parameters"][0]["name"] == "theta2"
    assert moved["calibration_record"] == 1
    # the same test from the result JSON instead of the history
    assert main([*base, "--result", str(res_json), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["verdict"] == "changed"
    assert main(["check", str(model), str(tmp_path / "same.csv"), "--fit-frame", "--history", hist,
                 "--robot-id", "IRB-7"]) == 0
    assert "holds" in capsys.readouterr().out
    capsys.readouterr()
    assert main([*base, "--history", hist, "--robot-id", "nobody"]) == 2
    assert "no calibration of robot id 'nobody'" in capsys.readouterr().err
    assert main(base) == 2
    assert "uncertainty" in capsys.readouterr().err
    assert main([*base, "--history", str(tmp_path / "none.sqlite"), "--robot-id", "IRB-7"]) == 2
    assert "does not exist" in capsys.readouterr().err and not (tmp_path / "none.sqlite").exists()
    from robocal.history.store import History, file_sha256

    with History(hist) as h:
        kinds = [(r.kind, r.summary.get("verdict"), r.parent) for r in h.entries("IRB-7")]
        calibration = h.entries("IRB-7")[0]
    assert kinds == [("calibration", None, None), ("check", "changed", 1), ("check", "holds", 1)]
    assert calibration.data == [{"file": str(tmp_path / "cal.csv"), "role": "calibration",
                                 "sha256": file_sha256(tmp_path / "cal.csv")}]
    a2 = next(p for p in calibration.parameters if p["name"] == "a2")
    assert a2["unit"] == "mm" and a2["sigma"] > 0 and calibration.summary["held_out_rms"] is None
    # an evaluation on held-out data is recorded as derived from that calibration; then the timeline
    assert main(["--quiet", "evaluate", str(model), str(tmp_path / "same.csv"), "--fit-frame",
                 "--history", hist, "--robot-id", "IRB-7"]) == 0
    timeline, page = tmp_path / "timeline.json", tmp_path / "history.html"
    assert main(["history", hist, "--robot-id", "IRB-7", "--json", str(timeline), "--report", str(page)]) == 0
    entries = json.loads(timeline.read_text())["entries"]
    assert [e["kind"] for e in entries] == ["calibration", "check", "check", "evaluation"]
    assert [e["verdict"] for e in entries] == [None, "changed", "holds", None]
    assert entries[1]["p_value"] < ALPHA <= entries[2]["p_value"] and entries[0]["p_value"] is None
    assert entries[0]["held_out_rms"] is None and entries[3]["held_out_rms"] == pytest.approx(
        entries[2]["rms"], rel=1e-9)  # the same data, the same frame fit: the same RMS
    assert entries[3]["parent"] == 1
    assert entries[1]["data"][0]["sha256"] == file_sha256(tmp_path / "moved.csv")
    assert all(e["date"].endswith("+00:00") for e in entries)
    html = page.read_text()
    assert html.count("<svg") == 1 and "IRB-7" in html and "changed" in html
    capsys.readouterr()
    assert main(["history", hist, "--robot-id", "IRB-8"]) == 2
    assert "no record of robot id 'IRB-8'" in capsys.readouterr().err
    assert main(["history", str(tmp_path / "none.sqlite"), "--robot-id", "IRB-7"]) == 2
    assert not (tmp_path / "none.sqlite").exists()


def test_offsets_only_recalibration_moves_only_the_joint_zeros(calibrated):
    from robocal.history.offsets import recalibrate_offsets, zero_shifts

    truth, result = calibrated
    nominal = rc.Robot.from_catalog("abb_irb2600")
    data = _campaign(truth, 9, n=60, theta2=0.01, theta3=-0.05)
    short = data.first_poses(20)
    held_out = data.subset(~np.isin(data.pose_id, short.pose_id))
    out = recalibrate_offsets(nominal, result.robot, short, validation=held_out, progress=False)
    assert out.settings["offsets_only"] and set(out.identifiability.dropped) == {"theta1", "theta6"}
    shifts = {r["name"]: r for r in zero_shifts(out, result.robot)}
    for name, shift in (("theta2", 0.01), ("theta3", -0.05)):
        assert abs(shifts[name]["shift"] - shift) < 3 * shifts[name]["sigma"] + 2e-4, name
    links = [n for n in result.robot.geometry_names if n[0] in "ad" or n.startswith("beta")]
    kept = out.robot.values[out.robot.indices(links)]
    assert np.array_equal(kept, result.robot.values[result.robot.indices(links)])
    assert out.validation["rms"] < 1.3 * 0.04  # the instrument's noise level: the change is undone
    held = recalibrate_offsets(nominal, result.robot, data, hold_out=40, progress=False)  # calibrate's split
    assert held.validation == out.validation and held.provenance["hold_out"] == 40
    with pytest.raises(DataError, match="not a calibration of"):
        recalibrate_offsets(rc.Robot.from_catalog("abb_irb4600"), result.robot, short)
    with pytest.raises(DataError, match="chooses its own params"):
        recalibrate_offsets(nominal, result.robot, short, params="all")


def test_offsets_only_command_records_a_derived_calibration(calibrated, tmp_path, capsys):
    from robocal.history.store import History

    truth, result = calibrated
    model, hist = tmp_path / "cal.yaml", str(tmp_path / "h.sqlite")
    result.problem.datasets[0].save(tmp_path / "cal.csv")
    _campaign(truth, 10, theta2=0.02).save(tmp_path / "check.csv")
    assert main(["--quiet", "calibrate", str(tmp_path / "cal.csv"), "--robot", "abb_irb2600",
                 "--nongeometric", "none", "-o", str(model), "--history", hist, "--robot-id", "R"]) == 0
    new = tmp_path / "recal.yaml"
    assert main(["calibrate", str(tmp_path / "check.csv"), "--robot", "abb_irb2600", "--offsets-only",
                 "--start", str(model), "-o", str(new), "--history", hist, "--robot-id", "R"]) == 0
    out = capsys.readouterr().out
    assert "joint zeros changed from the start: theta2 +0.0" in out and new.exists()
    with History(hist) as h:
        first, derived = h.entries("R")
    assert derived.parent == first.id and derived.summary["offsets_only"]
    assert derived.summary["zero_shifts"][0]["name"] == "theta2"
    for bad, message in ((["--offsets-only"], "go together"), (["--start", str(model)], "go together"),
                         (["--offsets-only", "--start", str(model), "--params", "all"],
                          "its own parameters")):
        assert main(["calibrate", str(tmp_path / "check.csv"), "--robot", "abb_irb2600", *bad]) == 2
        assert message in capsys.readouterr().err


def test_poses_check_plans_a_campaign_for_the_joint_zeros(tmp_path, capsys):
    robot = rc.Robot.from_catalog("abb_irb2600")
    q = sample_joints(robot, 40, np.random.default_rng(3))
    rc.Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3]).save(tmp_path / "poses.csv")
    out, program, plan = tmp_path / "check.csv", tmp_path / "check.mod", tmp_path / "check.json"
    assert main(["--quiet", "poses", "--robot", "abb_irb2600", "--check", "-n", "12", "--from",
                 str(tmp_path / "poses.csv"), "--smr-mm", "20,-30,80", "-o", str(out), "--rapid",
                 str(program), "--json", str(plan), "--starts", "1"]) == 0
    campaign = json.loads(plan.read_text())
    # theta1 and theta6 (confounded with base.rz and the tool) stay in the design with their priors
    assert campaign["parameters"] == ["theta1", "theta2", "theta3", "theta4", "theta5", "theta6", "base.x",
                                      "base.y", "base.z", "base.rx", "base.ry", "base.rz", "tool.x", "tool.y",
                                      "tool.z"]
    assert {d["name"]: d["status"] for d in campaign["dropped"]} == \
        {"theta1": "not identifiable", "theta6": "not identifiable"}
    assert len(out.read_text().splitlines()) == 13 and "MoveAbsJ" in program.read_text()
    assert main(["poses", "--robot", "abb_irb2600", "--check", "-n", "12", "--kind", "plane", "--from",
                 str(tmp_path / "poses.csv"), "-o", str(tmp_path / "x.csv")]) == 2
    assert "--check plans a tracker campaign" in capsys.readouterr().err
