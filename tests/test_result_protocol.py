"""One protocol for every result the API returns (issue 43): ``summary()`` (text), ``warnings`` (a
list attribute, never a method), ``to_dict()`` (plain data) and ``write(...)`` (the paths it wrote);
and the pieces of the command line that moved into the API (hold-out split, the default error
model's reason, the swapped-model check)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cells import two_axis_cell

import robocal as rc
from robocal.calibration.evaluation import EvaluationResult
from robocal.core.errors import DataError
from robocal.data.importer import ImportResult
from robocal.deploy.formats import export_model
from robocal.deploy.models import load_model_pair
from robocal.deploy.tcp import ToolCalibration
from robocal.history.check import Uncertainty, check_calibration
from robocal.history.timeline import Timeline
from robocal.kinematics.manufacturer.ur import ImportedCalibration


@pytest.fixture(scope="module")
def sim():
    return rc.simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 40, noise_mm=0.01, seed=2)


def results(sim, tmp_path) -> dict:
    """name -> (result, its write() call writing into tmp_path)."""
    nominal = rc.Robot.from_catalog("abb_irb2600")
    cal = rc.calibrate(nominal, sim.data, nongeometric=None)
    real = nominal.with_values({"a2": nominal.get("a2") + 5e-4})
    comp = rc.compensate(real, nominal, nominal.fk(np.array([[0.1, 0.2, 0.1, 0.3, 0.4, 0.5]])))
    unc = Uncertainty(names=("a2",), covariance=np.array([[1e-10]]), noise_m=1e-5, dof=200)
    ur5e = rc.Robot.from_catalog("ur5e")
    q = np.linspace([0.0, -1.2, 1.3, -0.4, 1.2, 0.0], [0.6, -1.0, 1.5, -0.2, 1.4, 0.5], 4)
    tool = ToolCalibration(tcp=np.array([0.0, 0.0, 0.2]), point=np.array([1.0, 0.0, 0.5]),
                           residuals=np.array([1e-5, 2e-5, 1e-5, 2e-5]), spread_deg=35.0)
    entry = {"id": 1, "date": "2026-12-06 03:00:00", "kind": "calibration", "held_out_rms": 0.03, "rms": 0.02}
    p = tmp_path
    target = ("[[1139.82,200.98,722.77],[0.1300295,-0.08641011,0.98767211,0.01137611],[0,0,-1,0],"
              "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]")
    (p / "cell.mod").write_text(f"MODULE Cell\n  CONST robtarget pPick:={target};\n  PROC main()\n"
                                "    MoveJ pPick, v1000, fine, tool0;\n  ENDPROC\nENDMODULE\n")
    return {
        "filter": (rc.filter_program(p / "cell.mod", real, nominal),
                   lambda r: r.write(p / "cell_cal.mod", p / "cell_targets")),
        "calibration": (cal, lambda r: r.write(p / "c.yaml", p / "c.json")),
        "compensation": (comp, lambda r: r.write(p / "commands.csv", p / "parameters.csv")),
        "evaluation": (rc.evaluate(sim.truth, sim.data), lambda r: r.write(p / "e.json")),
        "check": (check_calibration(sim.truth, sim.data, unc),
                  lambda r: r.write(p / "check.json", model="m.yaml")),
        "tool": (tool, lambda r: r.write(p / "tool.json")),
        "path": (rc.ik.plan_path(ur5e, ur5e.fk(q)), lambda r: r.write(p / "joints.csv")),
        "simulation": (sim, lambda r: r.write(p / "d.csv", p / "truth.yaml")),
        "import": (ImportResult(data=sim.data), lambda r: r.write(p / "imported.csv")),
        "identifiability": (rc.analyze(nominal, sim.data.joints), lambda r: r.write(p / "ident.json")),
        "timeline": (Timeline("R1", [entry]), lambda r: r.write(p / "timeline.json")),
        "model export": (export_model(nominal, urdf=p / "r.urdf"), lambda r: r.write()),
        "urdf-like export": (rc.export_urdf_like(ur5e, VENDOR_UR5E), lambda r: r.write(p / "ur5e_cal.urdf")),
        "imported calibration": (ImportedCalibration(ur5e, "calibration.conf", ["a note"]),
                                 lambda r: r.write(p / "factory.yaml")),
        **_cell_results(p),
    }


def _cell_results(p: Path) -> dict:
    """A work cell's results (issue 45): its simulation, calibration, evaluation and targets."""
    cell = two_axis_cell(nests=True)
    sim = rc.simulate_cell(cell, 30, 20, seed=1)
    cal = rc.calibrate(cell, sim.data, nongeometric=None)
    target = np.eye(4)
    target[:3, :3], target[2, 3] = np.diag([1.0, -1.0, -1.0]), 0.2
    comp = rc.compensate(cal.calibrated, cell, target, positioner_values=[0.1, 0.5])
    return {"cell simulation": (sim, lambda r: r.write(p / "cell.csv", p / "true_cell.yaml")),
            "cell calibration": (cal, lambda r: r.write(p / "cal_cell.yaml", p / "cal_cell.json")),
            "cell evaluation": (rc.evaluate(cal.calibrated, sim.data),
                                lambda r: r.write(p / "cell_eval.json")),
            "cell compensation": (comp, lambda r: r.write(p / "cell_cmd.csv", ARM_COLUMNS, TABLE_COLUMNS))}


VENDOR_UR5E = Path(__file__).resolve().parent / "data" / "urdf_vendor" / "ur5e.urdf"  # issue 49
ARM_COLUMNS = [f"q{i}_deg" for i in range(1, 7)]
TABLE_COLUMNS = ["e1_deg", "e2_deg"]


def test_every_result_has_the_protocol(sim, tmp_path):
    for name, (result, write) in results(sim, tmp_path).items():
        assert isinstance(result.summary(), str) and result.summary(), name
        assert isinstance(result.warnings, list), f"{name}: warnings is {type(result.warnings).__name__}"
        json.dumps(result.to_dict(), default=str)  # plain data
        written = write(result)
        assert written and all(Path(path).is_file() for path in written), name


def test_a_filters_table_json_is_its_dict(sim, tmp_path):
    result, _ = results(sim, tmp_path)["filter"]
    assert json.loads(result.table_json()) == json.loads(json.dumps(result.to_dict()))
    assert result.to_dict()["summary"]["targets"] == 1


def test_evaluate_still_returns_the_dict(sim):
    stats = rc.evaluate(sim.truth, sim.data, names={"model": "truth.yaml", "data": "d.csv"})
    assert isinstance(stats, dict) and isinstance(stats, EvaluationResult)
    assert stats["warnings"] is stats.warnings and stats["rms"] < 0.05
    assert stats.summary().startswith("point errors of truth.yaml on d.csv (40 poses): n 40, rms ")


def test_hold_out_judges_the_last_poses(sim):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    held = rc.calibrate(nominal, sim.data, nongeometric="none", hold_out=10)
    assert held.problem.n_poses == 30 and held.validation["n"] == 10
    assert held.provenance["hold_out"] == 10  # the report's 'hold-out split' row, without the CLI
    assert held.error_model_choice is None  # named: no default to explain
    with pytest.raises(DataError, match="between 1 and 39"):
        rc.calibrate(nominal, sim.data, hold_out=40)
    with pytest.raises(DataError, match="splits one calibration file"):
        rc.calibrate(nominal, sim.data, validation=sim.data, hold_out=5)


def test_the_result_says_why_the_default_error_model_is_geometric(sim):
    result = rc.calibrate(rc.Robot.from_catalog("abb_irb2600"), sim.data.first_poses(20))
    assert result.error_model_choice.startswith("geometric (20 poses: the default chooses non-geometric")
    assert result.summary().endswith(f"error model: {result.error_model_choice}")  # said without the CLI


def test_swapped_models_are_refused(tmp_path):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    path = tmp_path / "calibrated.yaml"
    nominal.with_values({"a2": nominal.get("a2") + 1e-4}).save(path)
    calibrated, controller = load_model_pair(str(path), "abb_irb2600")
    assert controller.name == "abb_irb2600" and calibrated.get("a2") != controller.get("a2")
    with pytest.raises(DataError, match="look swapped"):
        load_model_pair("abb_irb2600", str(path))


def test_a_network_file_for_a_method_without_one_is_refused_by_the_api(sim, tmp_path):
    """``write(network=...)`` of a method that trains no network is refused by the API (as by
    ``calibrate --network-out``), nothing written, not an AttributeError."""
    from robocal.core.errors import IdentificationError

    cal = rc.calibrate(rc.Robot.from_catalog("abb_irb2600"), sim.data, nongeometric="none")
    with pytest.raises(IdentificationError, match="needs the neural method"):
        cal.write(output=tmp_path / "cal.yaml", network=tmp_path / "net.npz")
    assert not (tmp_path / "cal.yaml").exists()
