"""Forward kinematics speed: robocal vs py-opw-kinematics ``batch_forward`` (Rust) vs pinocchio
(per-call loop), same robot (ABB IRB 2600 from the catalog), same random joints, same run.
Also the peak memory of robocal for 1,000,000 configurations."""

from __future__ import annotations

import resource
import time
import tracemalloc

import numpy as np
from timing import best_time

from robocal import Robot

N = 200_000
N_PIN = 20_000
N_MEM = 1_000_000
REPEAT = 7


def _py_opw(robot: Robot):
    try:
        import py_opw_kinematics as po
    except ImportError:
        return None
    p = robot.opw
    model = po.KinematicModel(a1=p["a1"], a2=p["a2"], b=p["b"], c1=p["c1"], c2=p["c2"], c3=p["c3"],
                              c4=p["c4"], offsets=tuple(p["offsets"]),
                              flip_axes=tuple(s < 0 for s in p["signs"]))
    return po.Robot(model, degrees=False)


def _pinocchio(robot: Robot):
    """The same chain as a pinocchio Model: joint i placed at Rx(alpha) Tx(a) Ry(beta) Rz(theta)
    Tz(d) of link i (Rz(q) commutes with Tz(d)), revolute about its z axis; flange frame = tool."""
    try:
        import pinocchio as pin
    except ImportError:
        return None
    from robocal.kinematics.fk import chain_frames

    model = pin.Model()
    parent = 0
    for i in range(robot.n_joints):
        T = chain_frames(robot.links._replace(**{f: getattr(robot.links, f)[i : i + 1]
                                                 for f in robot.links._fields}),
                         robot.base if i == 0 else np.eye(4), np.eye(4), np.zeros((1, 1)))[0]
        parent = model.addJoint(parent, pin.JointModelRZ(), pin.SE3(T[:3, :3], T[:3, 3]), f"j{i + 1}")
    fid = model.addFrame(pin.Frame("flange", parent, 0, pin.SE3(robot.tool[:3, :3], robot.tool[:3, 3]),
                                   pin.FrameType.OP_FRAME))
    return pin, model, model.createData(), fid


def main() -> None:
    robot = Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (N, 6))
    print(f"forward kinematics, {robot.name}, {N:,} random configurations, best of {REPEAT} "
          "(robocal and py-opw runs interleaved)")
    ours = robot.fk(q)
    opw = _py_opw(robot)
    t_ours, t_opw, c_ours, c_opw = (np.inf,) * 4
    for _ in range(REPEAT):  # interleaved, so that a busy machine slows both alike
        t_ours = min(t_ours, best_time(lambda: robot.fk(q), 1)[0])
        c_ours = min(c_ours, best_time(lambda: robot.fk(q), 1, time.process_time)[0])
        if opw is not None:
            t_opw = min(t_opw, best_time(lambda: opw.batch_forward(q), 1)[0])
            c_opw = min(c_opw, best_time(lambda: opw.batch_forward(q), 1, time.process_time)[0])
    print(f"  robocal Robot.fk            {t_ours:7.3f} s  {t_ours / N * 1e9:7.0f} ns/pose   "
          f"(CPU time {c_ours:.3f} s)")
    if opw is None:
        print("  py-opw-kinematics           not installed (pip install '.[bench]')")
    else:
        err = np.abs(opw.batch_forward(q).as_matrix() - ours).max()
        print(f"  py-opw batch_forward (Rust) {t_opw:7.3f} s  {t_opw / N * 1e9:7.0f} ns/pose   "
              f"(CPU time {c_opw:.3f} s)   robocal is {t_opw / t_ours:.1f}x faster by wall clock, "
              f"{c_opw / c_ours:.1f}x by CPU time   (max |diff| {err:.1e})")

    pin_setup = _pinocchio(robot)
    if pin_setup is None:
        print("  pinocchio                   not installed (pip install '.[bench]')")
    else:
        pin, model, data, fid = pin_setup
        qs = q[:N_PIN]

        def pin_loop():
            out = np.empty((N_PIN, 4, 4))
            for k in range(N_PIN):
                pin.forwardKinematics(model, data, qs[k])
                out[k] = pin.updateFramePlacement(model, data, fid).homogeneous
            return out

        err = np.abs(pin_loop() - ours[:N_PIN]).max()
        t_pin = best_time(pin_loop, 3)[0] / N_PIN * N
        print(f"  pinocchio per-call loop     {t_pin:7.3f} s  {t_pin / N * 1e9:7.0f} ns/pose   "
              f"robocal is {t_pin / t_ours:.1f}x faster   (timed on {N_PIN:,} calls, "
              f"max |diff| {err:.1e})")

    q_big = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (N_MEM, 6))
    tracemalloc.start()
    robot.fk(q_big)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  memory for {N_MEM:,} poses: peak allocated {peak / 2**20:.0f} MiB (output alone "
          f"{N_MEM * 128 / 2**20:.0f} MiB, joints {N_MEM * 48 / 2**20:.0f} MiB); process max RSS "
          f"{rss:.0f} MiB")


if __name__ == "__main__":
    main()
