"""``robocal calibrate`` and ``robocal analyze`` through the command line."""

from __future__ import annotations

import json
from contextlib import nullcontext

import numpy as np
import pytest

from robocal import DataError, Robot
from robocal.cli import main
from robocal.data.measurements import Measurements, read_joints


@pytest.fixture
def campaign(tmp_path):
    out = tmp_path / "sim.csv"
    assert main(["simulate", "--robot", "abb_irb2600", "--poses", "160", "--seed", "3",
                 "-o", str(out), "--truth", str(tmp_path / "truth.yaml")]) == 0
    data = Measurements.load(out)
    data.subset(np.flatnonzero(data.pose_id < 100)).save(tmp_path / "cal.csv")
    data.subset(np.flatnonzero(data.pose_id >= 100)).save(tmp_path / "val.csv")
    return tmp_path


def test_calibrate_writes_model_and_json(campaign, capsys):
    d = campaign
    rc = main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600",
               "--validate", str(d / "val.csv"), "-o", str(d / "cal.yaml"), "--json", str(d / "r.json")])
    assert rc == 0
    text = capsys.readouterr().out
    assert "->" in text and "not identifiable" in text
    result = json.loads((d / "r.json").read_text())
    assert result["validation"]["rms"] < 0.05 and result["before"]["rms"] > 0.2
    calibrated = Robot.load(d / "cal.yaml")
    truth = Robot.load(d / "truth.yaml")
    q = Measurements.load(d / "val.csv").joints
    np.testing.assert_allclose(calibrated.fk(q)[:, :3, 3], truth.fk(q)[:, :3, 3], atol=1e-4)


def test_calibrate_method_options(campaign):
    d = campaign
    assert main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--method",
                 "robust", "--set", "k0=2.0", "--set", "ridge=gcv", "--json", str(d / "r.json")]) == 0
    settings = json.loads((d / "r.json").read_text())["settings"]
    assert settings["k0"] == 2.0 and settings["ridge"] == "gcv"


def test_failed_calibration_writes_nothing(campaign, capsys):
    d = campaign
    few = Measurements.load(d / "cal.csv").subset(np.arange(6))
    few.save(d / "few.csv")
    rc = main(["calibrate", str(d / "few.csv"), "--robot", "abb_irb2600", "-o", str(d / "out.yaml"),
               "--json", str(d / "out.json")])
    err = capsys.readouterr().err
    assert rc == 2 and "more poses" in err and "Traceback" not in err
    assert not (d / "out.yaml").exists() and not (d / "out.json").exists()
    rc = main(["calibrate", str(d / "cal.csv"), "--robot", "no_such_robot"])
    assert rc == 2 and "abb_irb2600" in capsys.readouterr().err


def test_analyze_a_planned_pose_set(tmp_path, capsys):
    q = np.random.default_rng(0).uniform(-60, 60, (40, 6))
    path = tmp_path / "plan.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
                    + "\n".join(",".join(map(str, r)) for r in q) + "\n")
    assert main(["analyze", str(path), "--robot", "abb_irb2600", "--tool-mm", "30,20,80"]) == 0
    out = capsys.readouterr().out
    assert "rank 27 of 34" in out and "  not identifiable: d1  (confounded with base.z)" in out
    assert "estimated: 27; not determined by these data (held near nominal by their priors): 0; not " \
        "identifiable (held at nominal): 7" in out
    np.testing.assert_allclose(read_joints(path), np.deg2rad(q))


@pytest.mark.parametrize("text", ["", "a,b\n1,2\n", "q1_deg,q2_deg\n1,x\n", "q1_deg,q3_deg\n1,2\n",
                                  "q1_deg,q2_deg\n"])
def test_read_joints_bad_files(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(DataError):
        read_joints(path)


def test_nongeometric_terms_and_network_out(campaign):
    d = campaign
    assert main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--nongeometric",
                 "gear", "-o", str(d / "ng.yaml"), "--json", str(d / "ng.json")]) == 0
    assert "joint_errors" in (d / "ng.yaml").read_text()
    assert json.loads((d / "ng.json").read_text())["nongeometric"]
    neural = ["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--method", "neural",
              "--set", "epochs=20", "--network-out", str(d / "net.npz")]
    assert main(neural) == 2 and not (d / "net.npz").exists()  # the epoch limit is not convergence
    assert main([*neural, "--force"]) == 0
    from robocal.identify.neural import BPNetwork

    assert BPNetwork.load(d / "net.npz").outputs
    assert main(["calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--network-out",
                 str(d / "net.npz")]) == 2


def test_hold_out_the_last_poses(campaign, capsys):
    d = campaign
    assert main(["--quiet", "calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--hold-out", "30",
                 "--json", str(d / "h.json")]) == 0
    result = json.loads((d / "h.json").read_text())
    assert result["validation"]["n"] == 30 and result["after"]["n"] == 70
    assert main(["calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", "--hold-out", "100"]) == 2
    assert "--hold-out must be between" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["--set", "seed=1"], "not a method option"),
    (["--set", "populaton=10", "--method", "genetic"], "has no option"),
    (["--set", "k0=abc", "--method", "robust"], "must be float"),
    (["--set", "population=2.5", "--method", "genetic"], "must be int"),
    (["--method", "neural", "--set", "epochs=0"], "epochs"),
    (["--method", "genetic", "--nongeometric", "gear"], "lsq, robust"),
    (["--json", "/nonexistent/folder/r.json"], "folder does not exist"),
])
def test_bad_options_are_clear_errors(campaign, capsys, argv, message):
    d = campaign
    with pytest.raises(SystemExit) if argv[:2] == ["--set", "seed=1"] else nullcontext():
        rc = main(["calibrate", str(d / "cal.csv"), "--robot", "abb_irb2600", *argv])
        assert rc == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
