"""A cell's arm model that gives a ``tool`` (the SMR 0 its measurements call the tool, as the
measurement docs say) keeps its flange for programs: the controller's tool data sit on the flange,
not on the SMR. Found by benchmarks/hidden_cell.py (a truth with its own kinematics): with a 40 mm
SMR declared as the tool, coordinated targets had been corrected as if the torch were mounted
40 mm further out, and landed 0.012-0.052 mm off where the calibrated cell itself puts them.

Truth here: the same cell without the SMR (the catalog arm) must give the same corrected program,
byte for byte, and the same cell compensation; the flange of an OPW model with a tool is the
catalog's flange (KUKA's included, whose model composes a turned flange)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.programs import filter_program

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import hidden_cell as hc  # noqa: E402


def _cells(folder: Path, arm_name: str, unit: str, axes) -> tuple[rc.Cell, rc.Cell, hc.Truth]:
    """The cell file with the arm's SMRs declared (tool: SMR 0 at 40 mm) and the same cell with the
    catalog arm (no SMR): nominal cells."""
    t = hc.make_truth(3, arm_name, unit, axes)
    with_smr = rc.load_cell(hc.write_cell(folder, t, nests=True, name="smr.yaml"))
    text = (folder / "smr.yaml").read_text().replace(f"robot: {arm_name}_smr.yaml", f"robot: {arm_name}")
    (folder / "plain.yaml").write_text(text)
    return with_smr, rc.load_cell(folder / "plain.yaml"), t


def _calibrated(cell: rc.Cell) -> rc.Cell:
    """The cell with the same link and axis errors (whatever its arm's tool)."""
    arm, (name, pos) = cell.arms["arm"], next(iter(cell.positioners.items()))
    arm_err = {
        "a2": arm.get("a2") + 4e-4,
        "theta3": arm.get("theta3") + 3e-4,
        "d4": arm.get("d4") - 3e-4,
        "alpha5": arm.get("alpha5") + 2e-4,
    }
    pos_err = {"theta2": pos.chain.get("theta2") + 5e-4, "a2": pos.chain.get("a2") + 3e-4}
    return cell.in_world({"arm": arm.with_values(arm_err), name: pos.chain.with_values(pos_err)})


@pytest.mark.parametrize("arm_name", ["abb_irb2600", "kuka_kr16_2"])
def test_flange_of_a_model_with_a_tool_is_the_catalogs(tmp_path, arm_name):
    with_smr, plain, _ = _cells(tmp_path, arm_name, "STN1", (2, 3))
    np.testing.assert_allclose(with_smr.flange("arm"), rc.Robot.from_catalog(arm_name).tool, atol=1e-15)
    np.testing.assert_allclose(
        with_smr.arms["arm"].tool[:3, 3] @ with_smr.flange("arm")[:3, :3], [0, 0, 0.04], atol=1e-15
    )  # the tool is SMR 0, 40 mm out on the flange's z
    assert plain.flanges == {}
    with_smr.save(tmp_path / "saved.yaml")
    np.testing.assert_array_equal(rc.load_cell(tmp_path / "saved.yaml").flange("arm"), with_smr.flange("arm"))


def test_coordinated_targets_do_not_depend_on_the_measured_smr(tmp_path):
    with_smr, plain, t = _cells(tmp_path, "abb_irb2600", "STN1", (2, 3))
    e, _, cfg, T = hc.plan_targets(t, 4, 5)
    program = hc.rapid_module(tmp_path, e, cfg, T, "STN1")
    a = filter_program([program], _calibrated(with_smr), with_smr)
    b = filter_program([program], _calibrated(plain), plain)
    assert a.outputs[program] == b.outputs[program] != program.read_bytes()
    on_plate = hc.WORKPIECE @ T
    ca = rc.compensate(_calibrated(with_smr), with_smr, on_plate, positioner_values=e, tool=hc.TORCH)
    cb = rc.compensate(_calibrated(plain), plain, on_plate, positioner_values=e, tool=hc.TORCH)
    np.testing.assert_allclose(ca.joints, cb.joints, atol=1e-12)
    np.testing.assert_allclose(ca.corrected_targets, cb.corrected_targets, atol=1e-12)
