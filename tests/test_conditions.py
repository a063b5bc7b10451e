"""The payloads and temperatures a calibration covered: recorded in the model, kept by its file, and
a warning wherever compensate, filter or evaluate use the model beyond them."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from test_payload_thermal import _palletize

from robocal import Robot
from robocal.calibration.evaluation import evaluate
from robocal.calibration.pipeline import calibrate
from robocal.cli import main
from robocal.core.errors import ModelError
from robocal.data.simulate import perturbed, simulate_tracker
from robocal.deploy.compensation import compensate
from robocal.kinematics.conditions import PAYLOAD_MARGIN_FRACTION, TEMPERATURE_MARGIN_K, CalibratedRange

BEYOND = "calibrated over: its correction there is extrapolated"


@pytest.fixture(scope="module")
def warm():
    """A KR 210 calibrated with payload and thermal terms on 0-150 kg and 20-35 deg C."""
    nominal = Robot.from_catalog("kuka_kr210_r2700")
    sim = simulate_tracker(nominal, 60, noise_mm=0.02, seed=1, payloads=[0, 75, 150], temperatures=(20, 35))
    return nominal, calibrate(nominal, sim.data, nongeometric="payload,thermal").robot


def test_a_calibration_records_the_conditions_it_covered_and_its_file_keeps_them(warm, tmp_path):
    nominal, model = warm
    covered = model.joint_errors.calibrated
    assert covered.payload_kg == (0.0, 150.0)
    assert covered.temperature_c == pytest.approx((20.0, 35.0))
    model.save(tmp_path / "m.yaml")
    assert Robot.load(tmp_path / "m.yaml").joint_errors.calibrated == covered
    data = yaml.safe_load((tmp_path / "m.yaml").read_text())
    del data["joint_errors"]["calibrated_conditions"]  # a file from before: loads, nothing to check
    (tmp_path / "old.yaml").write_text(yaml.safe_dump(data))
    old = Robot.load(tmp_path / "old.yaml")
    assert old.joint_errors.calibrated is None
    assert not [w for w in compensate(old, nominal, nominal.fk(np.zeros((1, 6))), payload=[300.0],
                                      temperature=60.0).assumed if BEYOND in w]
    data["joint_errors"]["calibrated_conditions"] = {"temperature_c": [35.0, 20.0]}
    (tmp_path / "bad.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(ModelError, match="calibrated_conditions.temperature_c: the lowest value 35 is above"):
        Robot.load(tmp_path / "bad.yaml")
    plain = calibrate(nominal, simulate_tracker(nominal, 60, noise_mm=0.02, seed=2).data,
                      nongeometric="compliance")
    plain.robot.save(tmp_path / "plain.yaml")  # joint errors without condition terms: no ranges to keep
    assert plain.robot.joint_errors is not None
    assert "calibrated_conditions" not in (tmp_path / "plain.yaml").read_text()


def test_compensate_warns_beyond_the_calibrated_payload_and_temperature_only(warm):
    nominal, model = warm
    targets = nominal.fk(np.deg2rad([[10, -80, 90, 5, 40, 0]]))
    edge = 150 * (1 + PAYLOAD_MARGIN_FRACTION)
    inside = compensate(model, nominal, targets, payload=[edge - 1],
                        temperature=35 + TEMPERATURE_MARGIN_K - 0.5)
    assert not [w for w in inside.assumed if BEYOND in w]
    outside = [w for w in compensate(model, nominal, targets, payload=[edge + 1],
                                     temperature=35 + TEMPERATURE_MARGIN_K + 0.5).assumed if BEYOND in w]
    assert len(outside) == 2
    assert outside[0].startswith(f"the payload {edge + 1:.4g} kg is beyond the 0 to 150 kg")
    assert outside[1].startswith("the temperature 37.5 deg C is beyond the 20 to 35 deg C")


def test_evaluate_names_the_rows_beyond_the_calibrated_temperatures(warm, tmp_path, capsys):
    nominal, model = warm
    hot = simulate_tracker(nominal, 12, noise_mm=0.02, seed=3, payloads=[100], temperatures=(40, 44)).data
    warnings = [w for w in evaluate(model, hot, fit_frame=True)["warnings"] if BEYOND in w]
    assert warnings == ["the temperature of 12 rows of the data (40 to 44 deg C) is beyond the 20 to 35 "
                        "deg C the model's thermal term was calibrated over: its correction there is "
                        "extrapolated (measure at this temperature to check it)"]
    mild = simulate_tracker(nominal, 12, noise_mm=0.02, seed=3, payloads=[100], temperatures=(22, 30)).data
    assert not [w for w in evaluate(model, mild, fit_frame=True)["warnings"] if BEYOND in w]
    model.save(tmp_path / "m.yaml")
    hot.save(tmp_path / "hot.csv")
    assert main(["evaluate", str(tmp_path / "m.yaml"), str(tmp_path / "hot.csv"), "--fit-frame"]) == 0
    assert "of 12 rows of hot.csv (40 to 44 deg C) is beyond" in capsys.readouterr().out


def test_filter_warns_of_a_program_run_beyond_the_calibrated_conditions(tmp_path):
    from robocal.programs import filter_program

    nominal = Robot.from_catalog("kuka_kr16_2")
    model = perturbed(nominal, 3).with_joint_errors(["payload2", "payload3", "thermal"]).with_values(
        {"payload2": 2e-5, "payload3": 3e-5, "thermal": 11.5e-6}).with_reference_temperature(24.0)
    model = model.with_calibrated_conditions(CalibratedRange(payload_kg=(0.0, 10.0),
                                                             temperature_c=(20.0, 28.0)))
    files, refs = _palletize(tmp_path, "{M 0.0,CM {X 0,Y 0,Z 0,A 0,B 0,C 0},J {X 0,Y 0,Z 0}}")
    ok = filter_program(files, model, nominal, references=refs, temperature=29.0, payload=[10.9, 0, 0, 0.1])
    assert not [w for w in ok.warnings if BEYOND in w]
    far = filter_program(files, model, nominal, references=refs, temperature=34.0, payload=[12.0, 0, 0, 0.1])
    assert [w.split(" is beyond")[0] for w in far.warnings if BEYOND in w] == \
        ["the payload 12 kg", "the temperature 34 deg C"]
    assert far.outputs != ok.outputs  # warned, still corrected (the terms are linear)
