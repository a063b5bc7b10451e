"""IK benchmark: rc.ik.solve_all vs py-opw-kinematics Robot.reach on 100,000 random abb_irb2600 poses
(all 8 branches), branch coverage and FK accuracy; plan_path on 10,000 waypoints x 8 candidates."""

from __future__ import annotations

import numpy as np
from timing import best_time

import robocal as rc
from robocal.kinematics.transforms import pose_error


def main(n: int = 100_000, waypoints: int = 10_000) -> None:
    robot = rc.Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (n, 6))
    T = robot.fk(q)
    t_ours, sols = best_time(lambda: rc.ik.solve_all(robot, T))
    ok = np.isfinite(sols).all(axis=2)
    ni, bi = np.nonzero(ok)
    e = pose_error(T[ni], robot.fk(sols[ni, bi]))
    print(f"solve_all: {n} poses in {t_ours:.3f} s ({t_ours / n * 1e6:.2f} us/pose), "
          f"{ok.sum()} solutions, {ok.sum(axis=1).mean():.2f} per pose")
    print(f"  FK error of every solution: max position {np.linalg.norm(e[:, :3], axis=1).max():.2e} m, "
          f"max rotation {np.linalg.norm(e[:, 3:], axis=1).max():.2e} rad")
    try:
        from py_opw_kinematics import KinematicModel, Robot
        from scipy.spatial.transform import RigidTransform
    except ImportError:
        print("py-opw-kinematics not installed (pip install -e '.[bench]'): no peer comparison")
    else:
        o = robot.opw
        model = KinematicModel(a1=o["a1"], a2=o["a2"], b=o["b"], c1=o["c1"], c2=o["c2"], c3=o["c3"],
                               c4=o["c4"], offsets=tuple(o["offsets"]),
                               flip_axes=tuple(s < 0 for s in o["signs"]))
        peer = Robot(model, degrees=False)
        poses = RigidTransform.from_matrix(np.linalg.inv(robot.base) @ T)
        for threads in (1, 0):
            t_peer, res = best_time(lambda th=threads: peer.reach(poses, threads=th))
            print(f"py-opw-kinematics reach (threads={threads or 'all'}): {t_peer:.3f} s; "
                  f"solve_all is {t_peer / t_ours:.2f}x faster")
        found = np.isfinite(res.joints).all(axis=2)
        d = np.abs(np.remainder(sols - res.joints + np.pi, 2 * np.pi) - np.pi).max(axis=2)
        missing = found & ~(d < 1e-7)
        print(f"  branches py-opw finds: {found.sum()}; also found by solve_all in the same slot "
              f"(mod 2 pi): {(found & (d < 1e-7)).sum()}; missing: {missing.sum()}; "
              f"only in solve_all: {(ok & ~found).sum()}")
    # plan_path: a smooth 10,000-waypoint path, limits +-180 deg so each waypoint has <= 8 candidates
    r8 = rc.Robot.from_opw(**{k: robot.opw[k] for k in ("a1", "a2", "b", "c1", "c2", "c3", "c4")},
                           offsets=robot.opw["offsets"], signs=robot.opw["signs"],
                           limits=np.tile([-np.pi, np.pi], (6, 1)), name="irb2600_pm180")
    t = np.linspace(0, 1, waypoints)[:, None]
    qp = np.array([0.8, 0.3, 0.4, 2.5, 0.9, 3.0]) * np.sin(2 * np.pi * np.array([1, 2, 1, 3, 2, 1]) * t
                                                          + np.arange(6))
    Tp = r8.fk(qp)
    t_plan, path = best_time(lambda: rc.ik.plan_path(r8, Tp), repeat=2)
    print(f"plan_path: {waypoints} waypoints, {path.candidates.mean():.2f} candidates each (max "
          f"{path.candidates.max()}), {t_plan:.3f} s; optimal cost {path.cost:.4f}, greedy "
          f"{path.greedy_cost:.4f}")


if __name__ == "__main__":
    main()
