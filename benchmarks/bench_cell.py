"""A work cell (issue 45's first goal): a simulated ABB IRB 2600 and a 2-axis tilt-and-turn
positioner 1.4 m in front of it, errors on both (arm: link errors 0.05-0.5 mm / 0.005-0.05 deg;
positioner: axis directions and zeros 0.025-0.05 deg, axis origins 0.1-0.2 mm, mount 1 mm / 0.05 deg,
plate frame 0.2 mm / 0.05 deg), one SMR on the flange and three on the plate (in declared nests, or
at unknown places), 0.02 mm tracker noise, one tracker frame. Calibrated with ``rc.calibrate(cell,
data)`` (one calibration per body, the defaults) on 100 arm poses and 40 table poses, judged on 100 +
40 held-out poses of the same campaign (same truth, tracker and SMRs). Goal: held-out RMS <= 1.3 x
the held-out rows' noise floor (the RMS of the noise added to them), with the nests known and
without. Also: where the arm's SMR is in the plate frame (nests) or its distance to each plate SMR
(no nests) at 500 random arm and table poses over the whole joint ranges, calibrated cell against the
truth (what a coordinated program needs), and the relation's 1-sigma.

``python benchmarks/bench_cell.py``."""

from __future__ import annotations

import numpy as np
from results import figure, table

import robocal as rc
from robocal.kinematics.positioner import positioner_chain
from robocal.kinematics.transforms import invert_transform, make_transform

TILT_TURN = [  # tilt about x 900 mm up, turn 250 mm above it; limits rad
    {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9], "limits": [-np.pi / 2, np.pi / 2]},
    {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25], "limits": [-np.pi, np.pi]}]
NESTS = np.array([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.15, -0.15, 0.0]])  # m, plate frame
SEEDS = range(5)
N_ARM, N_TABLE = 100, 40  # calibration poses; as many held out
N_CHECK = 500  # random arm and table poses of the coordinated-motion check
GOAL = 1.3


def cell(nests: bool) -> rc.Cell:
    chain = positioner_chain(TILT_TURN, make_transform(np.eye(3), [1.4, 0.0, 0.0]), name="tilt-turn")
    return rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")},
                   {"STN1": rc.Positioner(chain, unit="STN1", nests=NESTS if nests else None)},
                   name="IRB 2600 + tilt-and-turn table")


def _floor_mm(noise: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(noise**2, axis=1)))) * 1e3


def coordinated_error_mm(nominal: rc.Cell, sim, cal, seed: int) -> float:
    """RMS (mm) over random poses of the arm's SMR in the plate frame (nests) or of its distance to
    each plate SMR (no nests), calibrated against the truth, each in its own world."""
    rng = np.random.default_rng([seed, 45])
    arm, table_chain = nominal.arms["arm"], nominal.positioners["STN1"].chain
    q = rng.uniform(arm.limits[:, 0], arm.limits[:, 1], (N_CHECK, 6))
    e = rng.uniform(table_chain.limits[:, 0], table_chain.limits[:, 1], (N_CHECK, 2))
    true_tcp = sim.truth.arms["arm"].fk(q)[:, :3, 3]
    tcp = cal.calibrated.arms["arm"].with_frames(tool=cal.results["arm"].robot.tool).fk(q)[:, :3, 3]
    truth, ours = sim.truth.positioners["STN1"], cal.calibrated.positioners["STN1"]
    if nominal.positioners["STN1"].nests is not None:
        def in_plate(plate, p):
            return np.einsum("nji,nj->ni", plate[:, :3, :3], p - plate[:, :3, 3])

        error = np.linalg.norm(in_plate(ours.plate(e), tcp) - in_plate(truth.plate(e), true_tcp), axis=1)
    else:
        world_T_tracker = cal.calibrated.arms["arm"].base @ invert_transform(cal.results["arm"].robot.base)
        plate = cal.results["STN1"].robot  # tracker frame, the SMRs numbered from 0
        error = []
        for k in range(1, len(truth.nests) + 1):
            p = plate.fk(e, smr=np.full(N_CHECK, k - 1))[:, :3, 3]
            p = p @ world_T_tracker[:3, :3].T + world_T_tracker[:3, 3]
            true_p = truth.chain.fk(e, smr=np.full(N_CHECK, k))[:, :3, 3]
            error.append(np.linalg.norm(tcp - p, axis=1) - np.linalg.norm(true_tcp - true_p, axis=1))
        error = np.abs(np.concatenate(error))
    return float(np.sqrt(np.mean(error**2))) * 1e3


def main() -> None:
    for nests in (True, False):
        nominal = cell(nests)
        rows, ratios = [], []
        for seed in SEEDS:
            sim = rc.simulate_cell(nominal, N_ARM, N_TABLE, noise_mm=0.02, seed=seed)
            held = rc.simulate_cell(nominal, N_ARM, N_TABLE, truth=sim.truth, tracker=sim.tracker,
                                    noise_mm=0.02, seed=seed + 1000)
            cal = rc.calibrate(nominal, sim.data, validation=held.data)
            floor, after = held.noise_floor_mm, cal.validation["rms"]
            ratios.append(after / floor)
            per_body = [cal.results[b].validation["rms"] / _floor_mm(held.noise[b]) for b in ("arm", "STN1")]
            before = cal.results["STN1"].validation_before["rms"]
            (relation,) = cal.relations
            rows.append([seed, f"{cal.results['arm'].validation_before['rms']:.3f}", f"{before:.3f}",
                         f"{floor:.4f}", f"{after:.4f}", f"{after / floor:.3f}", f"{per_body[0]:.3f}",
                         f"{per_body[1]:.3f}", f"{coordinated_error_mm(nominal, sim, cal, seed):.4f}",
                         f"{relation.sigma[:3].max():.4f}", f"{relation.sigma[3:].max():.5f}"])
        label = "nests known" if nests else "SMR places unknown"
        table(f"IRB 2600 + 2-axis positioner, plate {label}: {N_ARM} arm + {N_TABLE} table poses, as many "
              "held out (mm)",
              ["seed", "arm nominal", "table nominal", "noise floor", "held-out RMS", "ratio", "arm ratio",
               "table ratio", "SMR vs plate, RMS", "relation sigma mm", "relation sigma deg"], rows,
              key="nests" if nests else "no_nests")
        key = "worst_ratio_nests" if nests else "worst_ratio_no_nests"
        print(f"  worst held-out ratio ({label}, goal <= {GOAL}):", figure(key, f"{max(ratios):.3f}"))


if __name__ == "__main__":
    main()
