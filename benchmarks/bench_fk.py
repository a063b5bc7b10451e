"""Forward kinematics speed: robocal ``Robot.fk`` (numpy kernels, and the compiled numba kernels of
the ``fast`` extra) vs py-opw-kinematics ``batch_forward`` (Rust) vs pinocchio (per-call loop), same
robot (ABB IRB 2600 from the catalog), same random joints, same run, one thread each. Also the
first-call (compile) cost of the numba kernel and the peak memory for 1,000,000 configurations."""

from __future__ import annotations

import resource
import tracemalloc

import numpy as np
from results import table
from timing import best_time, first_call, interleaved, kernel_choices, print_times, py_opw_robot

from robocal import Robot
from robocal.kinematics.fk import _POLY_MAX, FAST_CHUNK, _sin_cos
from robocal.kinematics.kernels import use_kernels

N = 200_000
N_PIN = 20_000
N_MEM = 1_000_000
REPEAT = 7


def _timed_fk(robot: Robot, q: np.ndarray, kernels: str):
    def run():
        with use_kernels(kernels):
            return robot.fk(q)
    return run


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


def _sin_cos_speed(rng: np.random.Generator, calls: int = 200) -> None:
    """The numpy kernel's sin/cos polynomial against np.sin + np.cos on one chunk of joint angles
    (6 x FAST_CHUNK), CPU time, best of REPEAT rounds of ``calls`` calls each, interleaved."""
    x = rng.uniform(-2 * np.pi, 2 * np.pi, (6, FAST_CHUNK))
    assert np.abs(x).max() <= _POLY_MAX
    c, s, work = np.empty_like(x), np.empty_like(x), np.empty((4,) + x.shape)

    def poly():
        for _ in range(calls):
            _sin_cos(x, c, s, work)

    def libm():
        for _ in range(calls):
            np.cos(x, out=c)
            np.sin(x, out=s)

    best = interleaved({"poly": poly, "libm": libm}, REPEAT)
    t_poly, t_libm = best["poly"][1] / calls, best["libm"][1] / calls
    _sin_cos(x, c, s, work)
    err = max(np.abs(c - np.cos(x)).max(), np.abs(s - np.sin(x)).max())
    print(f"  sin/cos of a 6 x {FAST_CHUNK} chunk (numpy kernel): polynomial {t_poly * 1e6:.0f} us, "
          f"np.sin + np.cos {t_libm * 1e6:.0f} us (CPU), {t_libm / t_poly:.1f}x faster, max |diff| {err:.1e}")


def main() -> None:
    robot = Robot.from_catalog("abb_irb2600")
    rng = np.random.default_rng(0)
    q = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (N, 6))
    print(f"forward kinematics, {robot.name}, {N:,} random configurations, one thread each, best of "
          f"{REPEAT} (all runs interleaved; CPU time counts every thread)")
    kernels = kernel_choices("robocal.kinematics.fk_numba")
    fns = {k: _timed_fk(robot, q, k) for k in kernels}
    ours = {k: fn() for k, fn in fns.items()}  # also compiles (or loads) the numba kernel
    opw = py_opw_robot(robot)
    if opw is not None:
        fns["py-opw"] = lambda: opw.batch_forward(q)
    best = interleaved(fns, REPEAT)
    rows = {k: f"  robocal Robot.fk ({k:5s})   " for k in kernels}
    if opw is not None:
        rows["py-opw"] = "  py-opw batch_forward (Rust)"
    print_times(best, rows, N, "ns", "py-opw" if opw is not None else None,
                f"forward kinematics, {N:,} configurations of {robot.name}, one thread each")
    if len(kernels) > 1:
        print(f"  numpy vs numba kernels: max |diff| {np.abs(ours['numpy'] - ours['numba']).max():.1e}")
    if opw is None:
        print("  py-opw-kinematics           not installed (pip install '.[bench]')")
    else:
        err = np.abs(opw.batch_forward(q).as_matrix() - ours["numpy"]).max()
        print(f"  max |diff| robocal vs py-opw {err:.1e}")
    costs = first_call("import numpy as np, robocal as rc\nr = rc.Robot.from_catalog('abb_irb2600')",
                       "r.fk(np.zeros((10, 6)))")
    if costs is not None:
        print(f"  first call of the numba kernel in a new process (import numba + compile): {costs[0]:.2f} s "
              f"with an empty cache, {costs[1]:.2f} s with the on-disk cache")

    _sin_cos_speed(rng)

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

        err = np.abs(pin_loop() - ours["numpy"][:N_PIN]).max()
        t_pin = best_time(pin_loop, 3)[0] / N_PIN * N
        ratios = ", ".join(f"{t_pin / best[k][0]:.1f}x ({k})" for k in kernels)
        print(f"  pinocchio per-call loop     {t_pin:7.3f} s  {t_pin / N * 1e9:5.0f} ns/pose   "
              f"robocal is {ratios} faster   (timed on {N_PIN:,} calls, max |diff| {err:.1e})")
        table(f"forward kinematics against pinocchio (C++, one call per pose from Python), {robot.name}",
              ["", "wall ns/item", "robocal faster", "max |diff|"],
              [["pinocchio per-call loop", f"{t_pin / N * 1e9:.2f}", "", f"{err:.1e}"],
               *([f"robocal Robot.fk ({k})", f"{best[k][0] / N * 1e9:.2f}", f"{t_pin / best[k][0]:.1f}x", ""]
                 for k in kernels)], key="pinocchio")

    q_big = rng.uniform(robot.limits[:, 0], robot.limits[:, 1], (N_MEM, 6))
    for k in kernels:
        tracemalloc.start()
        _timed_fk(robot, q_big, k)()
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        print(f"  memory for {N_MEM:,} poses ({k}): peak allocated {peak / 2**20:.0f} MiB (output alone "
              f"{N_MEM * 128 / 2**20:.0f} MiB, joints {N_MEM * 48 / 2**20:.0f} MiB)")
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  process max RSS {rss:.0f} MiB")


if __name__ == "__main__":
    main()
