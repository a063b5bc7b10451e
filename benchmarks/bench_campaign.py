"""Planned calibration campaigns (``rc.plan_poses``) against random poses, on simulated robots
(true model error) and on the real Meca500 data; and the planner's speed.

1. Simulated ABB IRB 2600, tracker noise 0.02 mm per axis, SMR at (20, -30, 80) mm on the flange:
   for each seed, a robot with random errors measures the planned poses and random poses
   (uniform in the joint limits, several draws per seed); lsq calibrates each; the true model
   error is the 3-D RMS of the calibrated TCP against the truth, noise free, over 2000 random
   poses. Also the continuous I-optimal design (multiplicative algorithm) on 5,000 candidates
   drawn as the planner draws them (uniform within the limits less the 1 deg margin; not the
   plan's own draw) and a region of 2,000 random poses: ``trace(M^-1 A) / N`` of it bounds from
   below what any N poses of such candidates can reach.
2. Meca500 (real, FARO): 12, 20 and 30 of the 490 calibration poses chosen by the planner from the
   measured candidates (SMR assumed on the flange axis 50 mm out; with the defaults, the region of
   interest is the candidates and the unmodelled error what their calibration shows; or the joint
   limits, i.e. the workspace sample of the predicted accuracy, for the noise alone, the earlier
   defaults), calibrated by the default calibration, judged on the 70 validation poses; against
   random 12 / 20 / 30 and all 490. UR5 (simulated, its real campaign being held back): 20 planned
   of 400 candidates against 30 random, mean 3-D error on 70 held-out poses. ABB IRB 120 (real,
   FARO, 3 SMRs): 20 and 40 of its 500 calibration poses planned with the noise alone, with the
   unmodelled error stated (``unmodelled_mm``: the geometric calibration's own unmodelled figure
   on all 500) and with the defaults (the error the measured candidates show), against random
   ones, the default calibration judged on the 500 held-out poses.
3. Speed: ``plan_poses`` 20 of 5,000 and 100 of 20,000 candidates; one candidate scan with the
   Woodbury forms against direct evaluation of every candidate's criterion (solve per candidate);
   3 SMRs (9 rows per pose), 30 of 5,000, and one Woodbury update of that design, with the
   search on one BLAS thread (threadpoolctl, as ``plan_poses`` runs it) and with the BLAS
   library's own threads (the machine's load average is printed: the difference is what a busy
   machine makes of many small threaded products).
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import results
from common import model_error_mm
from threadpoolctl import threadpool_limits
from timing import best_time

import robocal as rc
from robocal.campaign import exchange
from robocal.campaign.exchange import _Design, criterion_value
from robocal.campaign.information import candidate_data, candidate_information
from robocal.data.simulate import simulate_tracker
from robocal.trust.coverage import WORKSPACE_SAMPLES, WORKSPACE_SEED, workspace_sample
from robocal.trust.posterior import Noise

SEEDS = 40
PLANNER_SEEDS = 6  # Meca500: the planner's seed picks among near-equal designs; their median
RANDOM_DRAWS = 5
RANDOM_MECA = 25  # Meca500: random designs per pose count
IRB120_UNMODELLED_MM = 0.55  # the geometric calibration of all 500 IRB 120 poses: its unmodelled error
RANDOM_IRB = 6  # IRB 120: random designs per pose count
UR5_SEEDS = 5  # simulated UR5 robots
UR5_CANDIDATES, UR5_HELD_OUT = 400, 70
UPDATE_RUNS = 20  # Woodbury updates timed per setting
NOISE_MM = 0.02
SMR = np.array([0.02, -0.03, 0.08])
SMR3 = np.array([[0.02, -0.03, 0.08], [-0.06, 0.05, 0.07], [0.07, 0.06, 0.05]])  # flange, m
DATASETS = Path(__file__).resolve().parents[2] / "shared" / "datasets"


def true_error(robot, joints, seed, q_eval) -> float:
    sim = simulate_tracker(robot, joints=joints, smr_offsets=SMR, noise_mm=NOISE_MM, seed=seed)
    return model_error_mm(rc.calibrate(robot, sim.data, nongeometric=None).robot, sim.truth, q_eval)


def continuous_bound(G: np.ndarray, A: np.ndarray, prior: np.ndarray, n: int,
                     iterations: int = 1000) -> float:
    """min over approximate designs of ``n`` poses (weights on the candidates, summing to 1) of
    trace((n M(w) + P^-1)^-1 A), the posterior's I-criterion: the multiplicative algorithm
    w <- w sqrt(trace(G_j B A B G_j^T)), normalised, with B the posterior covariance."""
    C, r, p = G.shape
    flat = G.reshape(C * r, p)
    w = np.full(C, 1.0 / C)

    def posterior(w):
        return np.linalg.inv(n * flat.T @ (flat * np.repeat(w, r)[:, None]) + np.diag(prior))

    for _ in range(iterations):
        B = posterior(w)
        d = n * np.sum((flat @ (B @ A @ B)) * flat, axis=1).reshape(C, r).sum(axis=1)
        if d.max() <= np.sum(w * d) * 1.0005:  # equivalence theorem: optimal within 0.05 %
            break
        w *= np.sqrt(d)
        w /= w.sum()
    return float(np.trace(posterior(w) @ A))


def simulated() -> None:
    robot = rc.Robot.from_catalog("abb_irb2600")
    lo, hi = robot.limits.T
    q_eval = np.random.default_rng(999).uniform(lo, hi, (2000, 6))
    plans = {"I-optimal, 12": rc.plan_poses(robot, 12, smr=SMR, noise_mm=NOISE_MM),
             "I-optimal, 20": rc.plan_poses(robot, 20, smr=SMR, noise_mm=NOISE_MM),
             "D-optimal, 20": rc.plan_poses(robot, 20, smr=SMR, noise_mm=NOISE_MM, criterion="D"),
             "I-optimal, 30": rc.plan_poses(robot, 30, smr=SMR, noise_mm=NOISE_MM)}
    achieved = {name: [] for name in plans}
    randoms = {12: [], 20: [], 30: []}
    for seed in range(SEEDS):
        for name, plan in plans.items():
            achieved[name].append(true_error(robot, plan.joints, seed, q_eval))
        rng = np.random.default_rng([seed, 7])
        for n, errors in randoms.items():
            errors += [true_error(robot, rng.uniform(lo, hi, (n, 6)), seed, q_eval)
                       for _ in range(RANDOM_DRAWS)]
    print(f"simulated abb_irb2600, noise {NOISE_MM} mm per axis, {SEEDS} robots; true model error (mm) over "
          "2000 random poses")
    print(f"{'poses':<22}{'median':>9}{'RMS':>9}{'predicted':>11}{'RMS / predicted':>17}")
    for n, errors in randoms.items():
        print(f"{f'random, {n} ({RANDOM_DRAWS}/robot)':<22}{np.median(errors):9.4f}"
              f"{np.sqrt(np.mean(np.square(errors))):9.4f}")
    for name, errors in achieved.items():
        rms = np.sqrt(np.mean(np.square(errors)))
        pred = plans[name].predicted_rms_mm
        print(f"{name:<22}{np.median(errors):9.4f}{rms:9.4f}{pred:11.4f}{rms / pred:17.3f}")
    med = {name: np.median(v) for name, v in achieved.items()}
    print(f"planned 20 / random 30 (medians): {med['I-optimal, 20'] / np.median(randoms[30]):.3f}; "
          f"planned 12 / random 20: {med['I-optimal, 12'] / np.median(randoms[20]):.3f}; "
          f"I-20 / D-20: {med['I-optimal, 20'] / med['D-optimal, 20']:.3f}")
    # the limit any design on such candidates can reach (drawn like the plan's, not the same ones)
    plan_robot = plans["I-optimal, 20"].robot
    q = np.random.default_rng(0).uniform(lo + 0.0175, hi - 0.0175, (5000, 6))
    info = candidate_information(plan_robot, candidate_data(plan_robot, "point", q, np.ones((5000, 1), bool)),
                                 Noise(sigma_m=NOISE_MM * 1e-3))
    A = info.region_matrix(plan_robot, np.random.default_rng(1).uniform(lo, hi, (2000, 6)))
    random_pred = {n: np.sqrt(np.median([criterion_value(info.G, A, np.random.default_rng([n, k]).choice(
        5000, n, replace=False), "I", info.prior) for k in range(200)])) * 1e3 for n in (20, 30)}
    print("lower bound for any design (continuous I-optimal design on 5000 candidates, with the priors): "
          + f"20 poses {np.sqrt(continuous_bound(info.G, A, info.prior, 20)) * 1e3:.4f} mm"
          + f"; predicted median of random designs: 20 poses {random_pred[20]:.4f}, 30 poses "
          f"{random_pred[30]:.4f} mm")


def meca500() -> None:
    if not DATASETS.is_dir():
        print(f"Meca500: data sets not found at {DATASETS}; skipped")
        return
    from robocal.data.datasets import meca500 as load

    robot = rc.Robot.from_catalog("meca500")
    cal, val = load(DATASETS)

    def judged(index) -> float:  # the default calibration, judged on the 70 held-out poses
        chosen = cal.subset(np.flatnonzero(np.isin(cal.pose_id, cal.pose_id[index])))
        return rc.calibrate(robot, chosen, validation=val).validation["rms"]

    smr = [0.0, 0.0, 0.05]
    workspace = workspace_sample(robot, WORKSPACE_SAMPLES, WORKSPACE_SEED)  # the earlier default region
    rng = np.random.default_rng(5)
    rows = []
    for n in (12, 20, 30):
        for label, kw in (("defaults (the candidates, their unmodelled error)", {}),
                          ("the joint limits, noise only", {"region": workspace, "unmodelled_mm": 0.0})):
            plans = [rc.plan_poses(robot, n, candidates=cal, smr=smr, seed=s, **kw)
                     for s in range(PLANNER_SEEDS)]
            v = [judged(p.candidate_index) for p in plans]
            rows.append([f"planned {n}, {label}", f"{np.median(v):.4f}", f"{v[0]:.4f}",
                         f"{np.min(v):.4f}-{np.max(v):.4f}", f"{plans[0].predicted_rms_mm:.4f}"])
            if n == 20 and not kw:
                results.figure("meca500_planned20_mm", f"{np.median(v):.4f}")
                results.figure("meca500_planned20_seed0_mm", f"{v[0]:.4f}")
        v = [judged(rng.choice(cal.n_poses, n, replace=False)) for _ in range(RANDOM_MECA)]
        rows.append([f"random {n} ({RANDOM_MECA} draws)", f"{np.median(v):.4f}", "",
                     f"{np.min(v):.4f}-{np.max(v):.4f}", ""])
        if n == 30:
            results.figure("meca500_random30_mm", f"{np.median(v):.4f}")
    rows.append(["all 490", f"{judged(np.arange(cal.n_poses)):.4f}", "", "", ""])
    results.table(f"Meca500 (real, FARO): n of the 490 calibration poses chosen by the planner from the "
                  f"measured candidates (SMR assumed 50 mm out on the flange axis, noise 0.02 mm; by default "
                  f"the region is the candidates and the unmodelled error their calibration shows), the "
                  f"default calibration, RMS on the 70 held-out poses (mm); planned: median of planner seeds "
                  f"0-{PLANNER_SEEDS - 1} and seed 0",
                  ["poses", "held-out RMS", "seed 0", "range", "predicted"], rows, key="meca500")


def irb120() -> None:
    """Where the robot's unmodelled error dwarfs the noise: the noise-optimal plan against the
    plan for the unmodelled error (``unmodelled_mm``) and random poses, held out."""
    if not DATASETS.is_dir():
        print(f"IRB 120: data sets not found at {DATASETS}; skipped")
        return
    from robocal.data.datasets import irb120 as load

    robot = rc.Robot.from_catalog("abb_irb120")
    cal, val = load(DATASETS)
    poses = np.unique(cal.pose_id)

    def judged(index) -> float:  # the default calibration, judged on the 500 held-out poses
        return rc.calibrate(robot, cal.subset(np.flatnonzero(np.isin(cal.pose_id, poses[index]))),
                            validation=val).validation["rms"]

    rng = np.random.default_rng(7)
    rows = []
    for n in (20, 40):
        u_mm = IRB120_UNMODELLED_MM
        for label, u in (("noise only", 0.0), (f"unmodelled {u_mm} mm", u_mm),
                         ("defaults: the error the candidates show", None)):
            plans = [rc.plan_poses(robot, n, candidates=cal, seed=s, unmodelled_mm=u) for s in range(3)]
            v = [judged(p.candidate_index) for p in plans]
            rows.append([f"planned {n}, {label}", f"{np.median(v):.4f}", f"{np.min(v):.4f}-{np.max(v):.4f}",
                         f"{np.median([p.predicted_rms_mm for p in plans]):.4f}"])
            if n == 20:
                key = "irb120_noise_only20_mm" if u == 0.0 else "irb120_planned20_mm" if u else \
                    "irb120_defaults20_mm"
                results.figure(key, f"{np.median(v):.4f}")
        v = [judged(rng.choice(len(poses), n, replace=False)) for _ in range(RANDOM_IRB)]
        rows.append([f"random {n} ({RANDOM_IRB} draws)", f"{np.median(v):.4f}",
                     f"{np.min(v):.4f}-{np.max(v):.4f}", ""])
        if n == 20:
            results.figure("irb120_random20_mm", f"{np.median(v):.4f}")
    results.table("ABB IRB 120 (real, FARO, 3 SMRs): n of the 500 calibration poses chosen from their joints "
                  "alone, the default calibration, RMS on the 500 held-out poses (mm); planned: median of "
                  "planner seeds 0-2", ["poses", "held-out RMS", "range", "predicted"], rows, key="irb120")


def ur5_simulated() -> None:
    """UR5 (simulated: the real UR5 campaign is held back): a perturbed UR5 measures
    ``UR5_CANDIDATES`` random candidate poses and ``UR5_HELD_OUT`` held-out ones; 20 planned from
    the candidates' joints against 30 random candidates, the default calibration; the mean 3-D
    error on the held-out measurements (tracker noise included) and the true model error (RMS,
    noise free) at the held-out poses; the planner's predicted RMS for 20 planned and 30 random."""
    robot = rc.Robot.from_catalog("ur5")
    lo, hi = robot.limits.T
    rows, planned, random, true_p, true_r = [], [], [], [], []
    for seed in range(UR5_SEEDS):
        q = np.random.default_rng([seed, 11]).uniform(lo, hi, (UR5_CANDIDATES + UR5_HELD_OUT, 6))
        sim = simulate_tracker(robot, joints=q, smr_offsets=SMR, noise_mm=NOISE_MM, seed=seed)
        cal = sim.data.subset(np.flatnonzero(sim.data.pose_id < UR5_CANDIDATES))
        val = sim.data.subset(np.flatnonzero(sim.data.pose_id >= UR5_CANDIDATES))

        def judged(index, cal=cal, val=val, truth=sim.truth) -> tuple[float, float]:
            chosen = cal.subset(np.flatnonzero(np.isin(cal.pose_id, cal.pose_id[index])))
            result = rc.calibrate(robot, chosen, validation=val)
            return result.validation["mean"], model_error_mm(result.robot, truth, val.joints)

        plan = rc.plan_poses(robot, 20, candidates=cal, smr=[SMR], noise_mm=NOISE_MM, seed=0, curve=[20, 30])
        p, tp = judged(plan.candidate_index)
        r, tr = zip(*[judged(np.random.default_rng([seed, k]).choice(UR5_CANDIDATES, 30, replace=False))
                      for k in range(RANDOM_DRAWS)], strict=True)
        planned.append(p)
        random += r
        true_p.append(tp)
        true_r += tr
        rows.append([seed, f"{p:.4f}", f"{np.median(r):.4f}", f"{tp:.4f}", f"{np.median(tr):.4f}",
                     f"{plan.curve[0].predicted_rms_mm:.4f}", f"{plan.curve[1].random_median_mm:.4f}"])
    rows.append(["mean", f"{np.mean(planned):.4f}", f"{np.median(random):.4f}", f"{np.mean(true_p):.4f}",
                 f"{np.median(true_r):.4f}", "", ""])
    results.figure("ur5_planned20_mm", f"{np.mean(planned):.4f}")
    results.figure("ur5_random30_mm", f"{np.median(random):.4f}")
    results.table(f"UR5 (simulated; the real campaign is held back): {UR5_CANDIDATES} random candidate "
                  f"poses in the joint limits, {UR5_HELD_OUT} held out, noise {NOISE_MM} mm, SMR at "
                  "(20, -30, 80) mm, the default calibration: 20 planned (seed 0) against 30 random "
                  f"({RANDOM_DRAWS} draws, median); mean 3-D error on the held-out measurements, true model "
                  "error (RMS, noise free) at the held-out poses and the planner's predicted RMS (mm)",
                  ["robot seed", "held-out mean, planned 20", "random 30", "true RMS, planned 20",
                   "random 30",
                   "predicted, planned 20", "random 30"], rows, key="ur5_simulated")


def speed() -> None:
    robot = rc.Robot.from_catalog("abb_irb2600")
    t20, r20 = best_time(lambda: rc.plan_poses(robot, 20, smr=SMR, n_candidates=5000), repeat=3)
    t100, r100 = best_time(lambda: rc.plan_poses(robot, 100, smr=SMR, n_candidates=20000), repeat=2)
    print(f"plan_poses 20 of 5,000 candidates: {t20:.2f} s (goal < 2 s); 100 of 20,000: {t100:.1f} s "
          "(goal < 30 s), best of 3 / 2")
    lo, hi = robot.limits.T
    q = np.random.default_rng(0).uniform(lo, hi, (5000, 6))
    plan_robot = r20.robot
    info = candidate_information(plan_robot, candidate_data(plan_robot, "point", q, np.ones((5000, 1), bool)),
                                 Noise(sigma_m=2e-5))
    A = info.region_matrix(plan_robot, q[:2000])
    design = _Design(info.G, A, "I", lambda j: np.eye(1, 5000, j, dtype=np.int64)[0])
    design.reset(list(range(20)))
    allowed = design.allowed()
    t_scan, fast = best_time(lambda: design.add_values(allowed), repeat=5)

    def direct():
        G = info.G
        M = design.M[None] + np.einsum("cik,cil->ckl", G, G)
        return np.einsum("ckl,lk->c", np.linalg.inv(M), A)

    t_direct, slow = best_time(direct, repeat=3)
    ok = np.isfinite(fast)
    assert np.allclose(fast[ok], slow[ok], rtol=1e-6)
    print(f"one scan of 5,000 candidates: Woodbury {t_scan * 1e3:.1f} ms, direct inverse per candidate "
          f"{t_direct * 1e3:.0f} ms ({t_direct / t_scan:.0f}x)")
    several_smrs(robot, q)


@contextmanager
def blas_threads():
    """``plan_poses`` / ``exchange_search`` without their one-BLAS-thread limit."""
    saved = exchange.threadpool_limits
    exchange.threadpool_limits = None
    try:
        yield
    finally:
        exchange.threadpool_limits = saved


def several_smrs(robot, q: np.ndarray) -> None:
    load = os.getloadavg()[0]

    def plan():
        return rc.plan_poses(robot, 30, smr=SMR3, n_candidates=5000)

    t_one, one = best_time(plan, repeat=1)
    with blas_threads():
        t_many, many = best_time(plan, repeat=1)
    assert np.array_equal(one.joints, many.joints)
    plan_robot = one.robot
    data = candidate_data(plan_robot, "point", q, np.ones((len(q), 3), bool))
    info = candidate_information(plan_robot, data, Noise(sigma_m=2e-5))
    A = info.region_matrix(plan_robot, q[:2000])
    design = _Design(info.G, A, "I", lambda j: np.eye(1, len(q), j, dtype=np.int64)[0])
    design.reset(list(range(30)))
    with threadpool_limits(1, user_api="blas"):
        u_one = median_time(lambda: design._updated(30, 1.0))
    u_many = median_time(lambda: design._updated(30, 1.0))
    print(f"3 SMRs (9 rows per pose), plan_poses 30 of 5,000: {t_one:.1f} s on one BLAS thread, "
          f"{t_many:.1f} s with the BLAS library's threads ({t_many / t_one:.1f}x); one Woodbury update "
          f"{u_one * 1e3:.1f} ms against {u_many * 1e3:.1f} ms (median of {UPDATE_RUNS}); load average "
          f"{load:.1f} -> {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


def median_time(fn) -> float:
    """Median seconds of ``UPDATE_RUNS`` calls (a busy machine's typical cost, not its best)."""
    times = []
    for _ in range(UPDATE_RUNS):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main() -> None:
    simulated()
    meca500()
    irb120()
    ur5_simulated()
    speed()


if __name__ == "__main__":
    main()
