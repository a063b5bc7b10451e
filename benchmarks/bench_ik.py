"""IK benchmark: rc.ik.solve_all (numpy kernels, and the compiled numba kernels of the ``fast`` extra)
vs py-opw-kinematics Robot.reach on 100,000 random abb_irb2600 poses (all 8 branches), one thread
each (the headline) and all threads, wall clock and CPU time, same run; branch coverage and FK
accuracy; first-call (compile) cost; plan_path on 10,000 waypoints x 8 candidates; numeric IK
(rc.ik.solve) of 10,000 targets of a calibrated model with a tool, seeded by the nominal closed form;
the closed-form UR solver on every UR of the catalog against ur-analytic-ik (20,000 random joint vectors
each: FK, solutions, misses, recovery, per-pose time against the peer called pose by pose from Python)."""

from __future__ import annotations

import numpy as np
from results import figure, table
from timing import best_time, first_call, interleaved, kernel_choices, print_times, py_opw_robot

import robocal as rc
from robocal.ik.opw_ik import check_poses, opw_form
from robocal.kinematics.kernels import use_kernels
from robocal.kinematics.transforms import pose_error

REPEAT = 5


def _solver(robot: rc.Robot, T: np.ndarray, kernels: str, threads: int | None):
    def run():
        with use_kernels(kernels):
            return rc.ik.solve_all(robot, T, threads=threads)
    return run


def _speed(robot: rc.Robot, T: np.ndarray, n: int, kernels: list[str], peer) -> None:
    """One thread each (headline), then all threads, interleaved, ratios against the peer."""
    from scipy.spatial.transform import RigidTransform

    poses = RigidTransform.from_matrix(np.linalg.inv(robot.base) @ T)  # catalog TCP = OPW flange
    for threads, label in ((1, "one thread each"), (None, "all threads")):
        fns = {k: _solver(robot, T, k, threads) for k in kernels}
        if peer is not None:
            fns["py-opw"] = lambda th=threads or 0: peer.reach(poses, threads=th)
        if threads == 1:  # the input check every solve_all call starts with
            fns["check_poses"] = lambda: check_poses(T)
        best = interleaved(fns, REPEAT)
        print(f"  {label} (best of {REPEAT}, interleaved; CPU time counts every thread):")
        rows = {k: f"    solve_all ({k:5s})" for k in kernels}
        if peer is not None:
            rows["py-opw"] = "    py-opw reach      "
        print_times(best, rows, n, "us", "py-opw" if peer is not None else None,
                    f"solve_all, {n:,} poses of {robot.name}, all 8 branches, {label}")
        if threads == 1:
            check = best["check_poses"][1]
            print(f"    of which check_poses (pose validation): {check / n * 1e6:.2f} us/pose CPU, "
                  + ", ".join(f"{check / best[k][1]:.0%} of solve_all ({k})" for k in kernels))


def _coverage(robot: rc.Robot, T: np.ndarray, kernels: list[str], peer) -> None:
    """Every returned solution re-checked by robot.fk; branches against py-opw, slot by slot."""
    from scipy.spatial.transform import RigidTransform

    theirs = None
    if peer is not None:
        theirs = peer.reach(RigidTransform.from_matrix(np.linalg.inv(robot.base) @ T)).joints
    for k in kernels:
        sols = _solver(robot, T, k, None)()
        ok = np.isfinite(sols).all(axis=2)
        ni, bi = np.nonzero(ok)
        e = pose_error(T[ni], robot.fk(sols[ni, bi]))
        print(f"  {k}: {ok.sum()} solutions ({ok.sum(axis=1).mean():.2f} per pose); FK error of every "
              f"solution: max position {np.linalg.norm(e[:, :3], axis=1).max():.2e} m, "
              f"max rotation {np.linalg.norm(e[:, 3:], axis=1).max():.2e} rad")
        if theirs is not None:
            found = np.isfinite(theirs).all(axis=2)
            d = np.abs(np.remainder(sols - theirs + np.pi, 2 * np.pi) - np.pi).max(axis=2)
            print(f"    branches py-opw finds: {found.sum()}; also found by solve_all in the same slot "
                  f"(mod 2 pi): {(found & (d < 1e-7)).sum()}; missing: {(found & ~(d < 1e-7)).sum()}; "
                  f"only in solve_all: {(ok & ~found).sum()}")


def _plan(robot: rc.Robot, waypoints: int) -> None:
    """plan_path: a smooth path, limits +-180 deg so each waypoint has <= 8 candidates."""
    o = opw_form(robot)
    r8 = rc.Robot.from_opw(o.a1, o.a2, o.b, o.c1, o.c2, o.c3, o.c4, offsets=o.offsets, signs=o.signs,
                           limits=np.tile([-np.pi, np.pi], (6, 1)), name="irb2600_pm180")
    t = np.linspace(0, 1, waypoints)[:, None]
    qp = np.array([0.8, 0.3, 0.4, 2.5, 0.9, 3.0]) * np.sin(2 * np.pi * np.array([1, 2, 1, 3, 2, 1]) * t
                                                          + np.arange(6))
    Tp = r8.fk(qp)
    t_plan, path = best_time(lambda: rc.ik.plan_path(r8, Tp), repeat=2)
    print(f"plan_path: {waypoints} waypoints, {path.candidates.mean():.2f} candidates each (max "
          f"{path.candidates.max()}), {t_plan:.3f} s; optimal cost {path.cost:.4f}, greedy "
          f"{path.greedy_cost:.4f}")


def main(n: int = 100_000, waypoints: int = 10_000) -> None:
    robot = rc.Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    T = robot.fk(rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (n, 6)))
    kernels = kernel_choices("robocal.ik.opw_numba")
    peer = py_opw_robot(robot)
    print(f"solve_all vs py-opw-kinematics reach: {n:,} random {robot.name} poses, all 8 branches")
    if peer is None:
        print("  py-opw-kinematics not installed (pip install -e '.[bench]'): no peer comparison")
    _coverage(robot, T, kernels, peer)  # also compiles (or loads) the numba kernels
    _speed(robot, T, n, kernels, peer)
    costs = first_call("import numpy as np, robocal as rc\n"
                       "from robocal.kinematics.kernels import use_kernels\n"
                       "r = rc.Robot.from_catalog('abb_irb2600')\n"
                       "with use_kernels('numpy'):\n    T = r.fk(np.zeros((10, 6)))", "rc.ik.solve_all(r, T)")
    if costs is not None:
        print(f"  first solve_all with numba in a new process (import numba + compile): {costs[0]:.2f} s "
              f"with an empty cache, {costs[1]:.2f} s with the on-disk cache")
    _plan(robot, waypoints)
    _numeric(robot, 10_000)
    _ur(20_000)


def _ur(n: int) -> None:
    """Every UR of the catalog: n random joint vectors in [-pi, pi); FK and IK against ur-analytic-ik
    (a C++ UR solver), the peer called pose by pose from Python (its API takes one pose)."""
    from robocal.kinematics.catalog import catalog_names

    try:
        import ur_analytic_ik as peer
    except ImportError:
        print("UR IK: ur-analytic-ik not installed (pip install -e '.[bench]'): no peer comparison")
        return
    kernels = kernel_choices("robocal.ik.ur_numba")
    names = [nm for nm in catalog_names() if rc.Robot.from_catalog(nm).has_ur_form and hasattr(peer, nm)]
    print(f"UR closed form vs ur-analytic-ik: {n:,} random joint vectors per arm; solve_all batched "
          f"(one thread) vs the peer's inverse_kinematics called per pose from Python (goal >= 3x)")
    rows, stats = [], {"fk": [], "err": [], "peer": [], "missed": [], "recovered": [], "t_peer": []}
    for name in names:
        robot, model = rc.Robot.from_catalog(name), getattr(peer, name)
        q = np.random.default_rng(21).uniform(-np.pi, np.pi, (n, 6))
        T = robot.fk(q)
        fk_diff = max(np.abs(model.forward_kinematics(*row) - T[i]).max() for i, row in enumerate(q))
        t_peer, theirs = best_time(lambda m=model, T=T: [m.inverse_kinematics(t) for t in T], 2)
        times = {}
        for k in kernels:
            run = _solver(robot, T, k, 1)
            run()  # compile / warm up
            times[k], ours = best_time(run, 3)
        owner = np.repeat(np.arange(n), [len(s) for s in theirs])
        flat = np.array([row for s in theirs for row in s]).reshape(-1, 6)
        real = np.abs(robot.fk(flat) - T[owner]).max(axis=(1, 2)) <= 1e-9
        d = np.abs(np.remainder(ours[owner] - flat[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=2)
        missed = int((real & ~(np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-7)).sum())
        ok = np.isfinite(ours).all(axis=2)
        ni, bi = np.nonzero(ok)
        e = pose_error(T[ni], robot.fk(ours[ni, bi]))
        back = np.abs(np.remainder(ours - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=2)
        recovered = int((np.nanmin(np.where(np.isfinite(back), back, np.inf), axis=1) < 1e-7).sum())
        err = max(np.linalg.norm(e[:, :3], axis=1).max(), np.linalg.norm(e[:, 3:], axis=1).max())
        for key, value in (("fk", fk_diff), ("err", err), ("peer", len(flat)), ("missed", missed),
                           ("recovered", recovered), ("t_peer", t_peer / n * 1e6)):
            stats[key].append(value)
        for k in kernels:
            stats.setdefault(k, []).append(times[k] / n * 1e6)
            stats.setdefault(k + "_ratio", []).append(t_peer / times[k])
        rows.append([name, f"{fk_diff:.1e}", int(ok.sum()), f"{err:.1e}", len(flat), int((~real).sum()),
                     missed,
                     f"{recovered}/{n}", f"{t_peer / n * 1e6:.2f}",
                     *(f"{times[k] / n * 1e6:.2f} ({t_peer / times[k]:.1f}x)" for k in kernels)])
    table(f"UR closed form vs ur-analytic-ik, {n:,} random joint vectors per arm, one thread",
          ["arm", "FK max |diff|", "solutions", "FK error max", "peer solutions", "peer not FK-exact",
           "missed", "original recovered", "peer us/pose",
           *(f"solve_all {k} us/pose (vs peer)" for k in kernels)], rows, key="ur")
    figure("ur_poses", f"{n:,}")
    figure("ur_fk_diff", f"{max(stats['fk']):.1e}")
    figure("ur_fk_error", f"{max(stats['err']):.1e}")
    figure("ur_peer_solutions", f"{min(stats['peer']):,}-{max(stats['peer']):,}")
    figure("ur_missed", str(sum(stats["missed"])))
    figure("ur_recovered", f"{min(stats['recovered']):,}")
    figure("ur_peer_us", f"{min(stats['t_peer']):.3g}-{max(stats['t_peer']):.3g}")
    for k in kernels:
        figure(f"ur_{k}_us", f"{min(stats[k]):.3g}-{max(stats[k]):.3g}")
        figure(f"ur_{k}_ratio", f"{min(stats[k + '_ratio']):.2g}-{max(stats[k + '_ratio']):.2g}x")


def _numeric(robot: rc.Robot, n: int) -> None:
    """rc.ik.solve on a calibrated IRB 2600 (random errors) with a real tool: targets the joints in
    the limits reach; each asked in its own branch, and with no branch (the preferred one)."""
    from robocal.data.simulate import perturbed
    from robocal.ik.opw_ik import branch_slot
    from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

    tool = make_transform(rotvec_to_matrix([0.1, -0.2, 0.3]), [0.05, 0.02, 0.2])
    nominal, calibrated = robot.with_frames(tool=tool), perturbed(robot, 1).with_frames(tool=tool)
    q = np.random.default_rng(5).uniform(robot.limits[:, 0], robot.limits[:, 1], (n, 6))
    T = calibrated.fk(q)
    slots = branch_slot(robot.opw, q)

    def in_branches():
        ok = 0
        for s in np.unique(slots):
            rows = slots == s
            ok += int(rc.ik.solve(calibrated, T[rows], branch=int(s), nominal=nominal).converged.sum())
        return ok

    t_branch, ok_branch = best_time(in_branches, 3)
    t_any, res = best_time(lambda: rc.ik.solve(calibrated, T, nominal=nominal), 3)
    print(f"numeric IK (rc.ik.solve), calibrated abb_irb2600 with a tool, {n:,} targets in the joint limits "
          f"(goal < 2 s): in their branches {t_branch:.2f} s, {ok_branch} converged; preferred branch "
          f"{t_any:.2f} s, {int(res.converged.sum())} converged")


if __name__ == "__main__":
    main()
