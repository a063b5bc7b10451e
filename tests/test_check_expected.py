"""The expected error of a check after an offsets-only re-fit comes from the full calibration
(robocal.history.expected): a bent forearm the re-fit partly absorbs is found changed; the merged
uncertainty against its blocks; an orphan re-fit and an offsets-only result JSON refused.
Simulated on a KUKA KR 16 with the truth known, through the command line and the API."""

from __future__ import annotations

import json

import numpy as np
import pytest

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.history.check import Uncertainty, check_calibration, load_calibration
from robocal.history.expected import expected_uncertainty
from robocal.history.offsets import recalibrate_offsets
from robocal.history.store import Record

ROBOT = "kuka_kr16_2"
# a crash bent the forearm: twist and length of link 3 and the J3 zero (rad, m)
BEND = {"alpha3": 0.0012, "a3": 0.0004, "theta3": 0.001}


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    """A history with a full calibration and an offsets-only re-fit after the crash (CLI), and the
    check campaign of the bent robot; (folder, bent truth, check data)."""
    folder = tmp_path_factory.mktemp("crash")
    sim = rc.simulate_tracker(rc.Robot.from_catalog(ROBOT), 60, noise_mm=0.01, seed=7)
    sim.data.save(folder / "cal.csv")
    bent = sim.truth.with_values({k: sim.truth.get(k) + v for k, v in BEND.items()})
    rc.simulate_tracker(bent, 20, noise_mm=0.01, seed=8, as_is=True).data.save(folder / "off.csv")
    check = rc.simulate_tracker(bent, 15, noise_mm=0.01, seed=9, as_is=True).data
    check.save(folder / "chk.csv")
    keep = ["--history", str(folder / "h.sqlite"), "--robot-id", "R1"]
    assert main(["--quiet", "calibrate", str(folder / "cal.csv"), "--robot", ROBOT, "--nongeometric", "none",
                 "-o", str(folder / "cal.yaml"), "--json", str(folder / "cal.json"), *keep]) == 0
    assert main(["--quiet", "calibrate", str(folder / "off.csv"), "--robot", ROBOT, "--offsets-only",
                 "--start", str(folder / "cal.yaml"), "-o", str(folder / "recal.yaml"), "--json",
                 str(folder / "recal.json"), *keep]) == 0
    return folder, bent, check


def test_check_after_offsets_only_refit_of_a_bent_arm_says_changed(history, capsys):
    folder, bent, check = history
    recal = rc.Robot.load(folder / "recal.yaml")
    true_mm = rc.evaluate(recal, check, fit_frame=True)["rms"]
    assert true_mm > 0.3  # mm: the re-fit absorbed only part of the bend
    capsys.readouterr()
    assert main(["check", str(folder / "recal.yaml"), str(folder / "chk.csv"), "--fit-frame", "--history",
                 str(folder / "h.sqlite"), "--robot-id", "R1", "--json", str(folder / "check.json")]) == 0
    out = json.loads((folder / "check.json").read_text())
    assert out["verdict"] == "changed"
    assert out["predicted_rms_mm"] < 0.1 < true_mm  # the full calibration's floor, not the re-fit's residual
    assert out["test"]["noise_mm"] < 0.02  # the calibration's 0.01 mm noise per coordinate
    # the same through the API, from the history's records
    robot, unc, _ = load_calibration(str(folder / "recal.yaml"), None, str(folder / "h.sqlite"), "R1")
    assert check_calibration(robot, check, unc).verdict == "changed"


def test_the_full_calibration_still_holds_on_the_unbent_robot(history):
    folder, bent, _ = history
    truth = bent.with_values({k: bent.get(k) - v for k, v in BEND.items()})
    data = rc.simulate_tracker(truth, 15, noise_mm=0.01, seed=10, as_is=True).data
    robot, unc, _ = load_calibration(str(folder / "cal.yaml"), None, str(folder / "h.sqlite"), "R1")
    assert check_calibration(robot, data, unc).verdict == "holds"


def test_an_offsets_only_result_json_is_refused_and_the_full_one_taken(history):
    folder, _, check = history
    with pytest.raises(DataError, match="offsets-only re-fit"):
        load_calibration(str(folder / "recal.yaml"), str(folder / "recal.json"), None, None)
    robot, unc, _ = load_calibration(str(folder / "recal.yaml"), str(folder / "cal.json"), None, None)
    assert check_calibration(robot, check, unc, fit_frame=True).verdict == "changed"


def test_the_re_fit_itself_warns_when_more_than_the_zeros_moved(history):
    folder, bent, _ = history
    nominal, start = rc.Robot.from_catalog(ROBOT), rc.Robot.load(folder / "cal.yaml")
    where = {"history": str(folder / "h.sqlite"), "robot_id": "R1"}
    bent_refit = recalibrate_offsets(nominal, start, rc.Measurements.load(folder / "off.csv"), **where)
    assert [w for w in bent_refit.warnings if "more than the joint zeros changed" in w]
    # only a zero moved (a motor change): the re-fit meets the floor, nothing said
    truth = bent.with_values({k: bent.get(k) - v for k, v in BEND.items()})
    knocked = truth.with_values({"theta2": truth.get("theta2") + 0.002})
    data = rc.simulate_tracker(knocked, 20, noise_mm=0.01, seed=11, as_is=True).data
    refit = recalibrate_offsets(nominal, start, data, **where)
    assert not [w for w in refit.warnings if "joint zeros changed" in w]
    alone = recalibrate_offsets(nominal, start, rc.Measurements.load(folder / "off.csv"))
    # no history: the instrument's noise is the floor (the full calibration may have left as much: said)
    assert [w for w in alone.warnings if "instrument's noise" in w and "joint zeros changed" in w]


class _Store:
    """A history's calibration records, as `History.entries` gives them."""

    def __init__(self, records):
        self.records = records

    def entries(self, robot_id, kind=None):
        return self.records


def _record(ident, names, cov, noise, parent=None, offsets=False) -> Record:
    return Record(robot_id="R", kind="calibration", model_yaml="", summary={"offsets_only": offsets},
                  uncertainty={"names": names, "covariance": np.asarray(cov).tolist(), "noise_m": noise,
                               "dof": 100 * ident, "kind": "point"}, parent=parent, id=ident)


def test_merged_uncertainty_against_its_blocks():
    full = _record(1, ["a2", "theta2", "d4"], [[4.0, 1.0, 0.5], [1.0, 9.0, 2.0], [0.5, 2.0, 16.0]], 1e-5)
    refit = _record(2, ["theta2", "theta3"], [[8.0, 1.0], [1.0, 2.0]], 4e-4, parent=1, offsets=True)
    again = _record(3, ["theta3"], [[32.0]], 8e-4, parent=2, offsets=True)
    store = _Store([full, refit, again])
    assert expected_uncertainty(store, full) is full.uncertainty
    merged = expected_uncertainty(store, refit)
    assert merged["names"] == ["a2", "theta2", "d4", "theta3"]
    assert merged["noise_m"] == 1e-5 and merged["dof"] == 100  # the full calibration's floor
    scale = (1e-5 / 4e-4) ** 2
    expected = np.array([[4.0, 0, 0.5, 0], [0, 8 * scale, 0, scale], [0.5, 0, 16.0, 0],
                         [0, scale, 0, 2 * scale]])
    np.testing.assert_allclose(merged["covariance"], expected, rtol=1e-12)
    chained = Uncertainty.from_dict(expected_uncertainty(store, again))  # walks back to record 1
    assert chained.noise_m == 1e-5 and chained.covariance[3, 3] == pytest.approx(32.0 * (1e-5 / 8e-4) ** 2)
    with pytest.raises(DataError, match="no full calibration"):
        expected_uncertainty(_Store([refit, again]), again)
    refit.uncertainty["covariance"] = "not a matrix"
    with pytest.raises(DataError, match="malformed uncertainty"):
        expected_uncertainty(store, refit)
    with pytest.raises(DataError, match="lacks what a check needs"):
        Uncertainty.from_result([1])  # a result JSON that is no mapping
