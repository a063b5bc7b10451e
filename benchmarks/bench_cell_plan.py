"""A positioner's planned table angles against a naive grid of as many (issue 45).

A simulated 2-axis tilt-and-turn positioner (a positioner-only cell; the truth is the cell
simulation's own draw, `robocal.data.cell_simulation.true_cell`: axis directions and zeros
0.025-0.05 deg, origins 0.1-0.2 mm, mount 1 mm / 0.05 deg, plate 0.2 mm / 0.05 deg), three nests at
known plate positions, 0.02 mm tracker noise, the tracker frame the world's. For each tracker
placement and seed: the nests measured at the 24 angle sets `plan_table` chooses (the tracker's line
of sight decides which nests are seen) and at a 3 x 8 grid over the limits (the nests the tracker
sees there), each calibrated by ``rc.calibrate`` on the cell (the positioner's own calibration);
the model error is the 3-D RMS of the calibrated nests against the truth, noise free, at 500 random
angle sets (held-out points), against the plan's predicted RMS (``predicted_rms_mm``, and
``grid_rms_mm`` for the grid: where the grid leaves parameters to their priors, its figure is the
priors' spread, larger than the simulated truth's errors).

``python benchmarks/bench_cell_plan.py``."""

from __future__ import annotations

import numpy as np
from results import figure, table

import robocal as rc
from robocal.campaign import Tracker
from robocal.campaign.positioner import NEST_NORMAL, nest_visibility, plan_table, table_grid
from robocal.core.errors import RobocalError
from robocal.data.cell_measurements import CellMeasurements
from robocal.data.cell_simulation import true_cell
from robocal.data.measurements import Measurements
from robocal.kinematics.positioner import positioner_chain
from robocal.kinematics.transforms import make_transform

TILT_TURN = [  # limits rad
    {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9], "limits": [-np.pi / 2, np.pi / 2]},
    {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25], "limits": [-np.pi, np.pi]}]
NESTS = np.array([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.15, -0.15, 0.0]])  # m, plate frame
TRACKERS = {"overhead (1.4, 1.5, 3.5) m, 70 deg": Tracker(position=[1.4, 1.5, 3.5], acceptance_deg=70),
            "side (1.2, 2.8, 2.0) m, 45 deg": Tracker(position=[1.2, 2.8, 2.0], acceptance_deg=45)}
N_TABLE = 24
SEEDS = range(8)
NOISE_MM = 0.02
HELD_OUT = 500


def cell() -> rc.Cell:
    chain = positioner_chain(TILT_TURN, make_transform(np.eye(3), [1.4, 0.0, 0.0]), name="tilt-turn")
    return rc.Cell({}, {"STN1": rc.Positioner(chain, unit="STN1", nests=NESTS)}, name="bench cell")


def nests_world(chain, q: np.ndarray) -> np.ndarray:
    F = chain.fk(q)
    return np.einsum("nij,kj->nki", F[:, :3, :3], NESTS) + F[:, None, :3, 3]


def calibrated_error(nominal: rc.Cell, truth: rc.Cell, q: np.ndarray, seen: np.ndarray, rng,
                     q_check: np.ndarray) -> float:
    """Model error (mm) at the nests over ``q_check`` of the positioner calibrated from the nests seen
    at ``q``; nan when the calibration refuses (the design does not determine the positioner)."""
    chain = truth.positioners["STN1"].chain
    pose, nest = np.nonzero(seen)
    points = nests_world(chain, q)[pose, nest] + rng.normal(0.0, NOISE_MM * 1e-3, (len(pose), 3))
    data = Measurements.from_arrays("point", q[pose], points=points, smr=nest + 1, pose_id=pose)
    try:
        cal = rc.calibrate(nominal, CellMeasurements.from_bodies(nominal, {"STN1": data}), nongeometric=None)
    except RobocalError:
        return float("nan")
    model = cal.in_tracker["STN1"]
    err = nests_world(model, q_check) - nests_world(chain, q_check)
    return float(np.sqrt(np.mean(np.sum(err**2, axis=2)))) * 1e3


def main() -> None:
    nominal = cell()
    chain = nominal.positioners["STN1"].chain
    rows = []
    for label, tracker in TRACKERS.items():
        plan = plan_table(chain, N_TABLE, nests=NESTS, tracker=tracker, seed=0)
        q_grid = table_grid(chain, N_TABLE)
        v_grid = nest_visibility(chain, q_grid, NESTS, np.tile(NEST_NORMAL, (len(NESTS), 1)), tracker)
        errors = {"plan": [], "grid": []}
        for seed in SEEDS:
            truth = true_cell(nominal, seed)
            rng = np.random.default_rng([seed, 1])
            q_check = rng.uniform(chain.limits[:, 0], chain.limits[:, 1], (HELD_OUT, 2))
            errors["plan"].append(calibrated_error(nominal, truth, plan.joints, plan.visible, rng, q_check))
            errors["grid"].append(calibrated_error(nominal, truth, q_grid, v_grid, rng, q_check))
        rms = {k: float(np.sqrt(np.nanmean(np.square(v)))) if np.isfinite(v).any() else float("nan")
               for k, v in errors.items()}
        failed = int(np.isnan(errors["grid"]).sum())
        grid_predicted = f"{plan.grid_rms_mm:.4f}" if np.isfinite(plan.grid_rms_mm) else "not determined"
        priors = ", ".join(plan.grid_not_determined) or "none"
        grid_measured = f"{rms['grid']:.4f}" if np.isfinite(rms["grid"]) else "-"
        readings = f"{int(plan.visible.sum())} / {int(v_grid.sum())}"
        rows.append([label, readings, f"{plan.predicted_rms_mm:.4f}", f"{rms['plan']:.4f}", grid_predicted,
                     grid_measured, priors, f"{failed} of {len(SEEDS)}"])
        if label.startswith("overhead"):
            figure("plan_rms_mm", f"{rms['plan']:.4f}")
            figure("grid_rms_mm", f"{rms['grid']:.4f}")
    table(f"positioner: {N_TABLE} planned table angle sets vs a 3 x 8 grid, calibrated nests' model error "
          f"over {HELD_OUT} held-out angle sets (3-D RMS, mm; {len(SEEDS)} true cells, {NOISE_MM} mm noise)",
          ["tracker", "nest readings plan / grid", "plan predicted", "plan measured", "grid predicted",
           "grid measured", "grid leaves to the priors", "grid calibrations refused"], rows, key="cell_plan")


if __name__ == "__main__":
    main()
