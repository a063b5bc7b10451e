"""Motion capture and cameras as instruments (issue 44): what the new kinds recover, and what they do
on FIGAROH's real sets.

Simulated (known truth, UR10 catalog model, seeds fixed): the hand-eye frame of a camera on the
flange and the board's frame (no robot error: the frames alone, error against the truth), the
offsets of markers on links 3, 4 and 6, the position and rotation noise a camera's 6-D poses are
given (variance components; "drawn": the RMS per axis of the position noise the draw gave), and
the flange error over the workspace after calibrating on markers with 3 % swapped markers (robust,
the mocap default, against lsq).

Real (when `peer_sets` -- benchmarks/peer_sets.py, FIGAROH's example data with fixed splits -- and
the data are present: ``ROBOCAL_FIGAROH_DATA`` names their folder; else said): FIGAROH's UR10
robocal's default on each set as bench_peers runs it, without and with the set's instrument
declared (mocap for TALOS and TIAGo, camera for the UR10: the one line ``# instrument: NAME`` of
a file), judged as bench_peers judges it; and the UR10 camera set read as a fixed camera watching
a board on the flange (``eye_to_hand``; ``eye_in_hand``, the wrong mounting, for contrast), the
TIAGo motion-capture set as markers on the hand (``marker``). Held-out RMS (mm) of the board's /
markers' positions, the split of `peer_sets`.
"""

from __future__ import annotations

import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from results import figure, table

import robocal as rc
from robocal.data.registration import umeyama

sys.path.insert(0, str(Path(__file__).resolve().parent))
ROBOT = rc.Robot.from_catalog("ur10")


def _angle_deg(A: np.ndarray, B: np.ndarray) -> float:
    return float(np.rad2deg(np.arccos(np.clip((np.trace(A[:3, :3] @ B[:3, :3].T) - 1) / 2, -1.0, 1.0))))


def simulated() -> None:
    rows = []
    for mount in ("cell", "flange"):
        sim = rc.simulate_camera(ROBOT, 40, mount=mount, noise_mm=0.5, noise_deg=0.2, error_scale=0.0, seed=7)
        res = rc.calibrate(ROBOT, sim.data, params=[], method="lsq")
        got = res.problem.observation.frames(res.state.nuisance)
        want = {k: np.array(v) for k, v in sim.info["frames"].items()}
        for name, T in got.items():
            ref = want[name.split("_")[0]]
            rows.append([sim.data.kind, name, f"{np.linalg.norm(T[:3, 3] - ref[:3, 3]) * 1e3:.3f}",
                         f"{_angle_deg(T, ref):.4f}"])
    table("camera frames recovered (40 poses, 0.5 mm / 0.2 deg noise, no robot error)",
          ["kind", "frame", "position error mm", "angle error deg"], rows, key="frames")
    sim = rc.simulate_markers(ROBOT, 40, links=[6, 6, 4, 3], noise_mm=0.3, error_scale=0.0, seed=9)
    res = rc.calibrate(ROBOT, sim.data, params=[], method="lsq")
    off = res.state.nuisance[6:].reshape(-1, 3) - np.array(sim.info["frames"]["markers"])
    print("  marker offsets (links 6, 6, 4, 3; 40 poses, 0.3 mm noise): largest error "
          + figure("marker_offset_mm", f"{np.abs(off).max() * 1e3:.3f}") + " mm")
    rows = []
    for noise_mm, noise_deg in ((0.5, 0.2), (0.2, 1.0), (1.0, 0.05)):
        sim = rc.simulate_camera(ROBOT, 150, noise_mm=noise_mm, noise_deg=noise_deg, seed=3)
        (c,) = rc.calibrate(ROBOT, sim.data, method="lsq").variance_components
        rows.append([f"{noise_mm:g} / {noise_deg:g}", f"{sim.noise_floor_mm / np.sqrt(3):.3f}",
                     f"{c.sigma_m * 1e3:.3f} / {np.rad2deg(c.sigma_rad):.3f}",
                     f"{noise_mm * 1e-3 / np.deg2rad(noise_deg):.4f}", f"{c.length_scale:.4f}", c.rounds])
    table("variance components of a camera's 6-D poses (150 poses, eye-to-hand)",
          ["true mm / deg", "drawn mm", "estimated mm / deg", "true ratio m/rad", "estimated", "fits"], rows,
          key="vce")
    sim = rc.simulate_markers(ROBOT, 60, links=[6, 6, 6, 4], noise_mm=0.3, outliers=0.03, outlier_mm=10,
                              seed=10)
    q = np.random.default_rng(0).uniform(-2, 2, (500, 6))
    true = sim.truth.fk(q, frames=True)[1][:, 6, :3, 3]
    rows = []
    for method in ("lsq", "robust"):
        res = rc.calibrate(ROBOT, sim.data, method=method, force=True)
        got = res.robot.fk(q, frames=True)[1][:, 6, :3, 3]
        T = umeyama(got, true)
        err = np.linalg.norm(got @ T[:3, :3].T + T[:3, 3] - true, axis=1) * 1e3
        rows.append([method, f"{np.sqrt(np.mean(err**2)):.3f}"])
    table("flange error over the workspace after markers with 3 % swapped (10 mm), 60 poses",
          ["method", "RMS mm (rigidly aligned)"], rows, key="outliers")


# the instrument that took each of FIGAROH's sets (its example configs: sensor_type mocap; a camera
# and a checkerboard for the UR10)
FIGAROH_INSTRUMENTS = {"talos": "mocap", "tiago": "mocap", "tiago_next_day": "mocap", "ur10_pose": "camera",
                       "ur10_point": "camera"}


def _declared(s, instrument: str):
    """A `peer_sets.PeerSet` whose measurements declare ``instrument`` (the file's one line)."""
    return s._replace(calibration=replace(s.calibration, instrument=instrument),
                      held_out=replace(s.held_out, instrument=instrument))


def real() -> None:
    folder = os.environ.get("ROBOCAL_FIGAROH_DATA")
    if not folder:
        print("  FIGAROH's sets skipped: set ROBOCAL_FIGAROH_DATA to the folder holding figaroh-examples")
        return
    try:
        import bench_peers as bp
        import peer_sets as ps
        sets = {name: ps.load(name, folder) for name in FIGAROH_INSTRUMENTS}
    except Exception as exc:  # noqa: BLE001 - the loader or the data are absent: say so, run the rest
        print(f"  FIGAROH's sets skipped: {type(exc).__name__}: {str(exc)[:160]}")
        return
    rows = []
    for name, instrument in FIGAROH_INSTRUMENTS.items():  # judged as bench_peers judges robocal's default
        refit = name in ps.REFIT_FRAME
        plain = bp.run_robocal(sets[name], refit)
        said = bp.run_robocal(_declared(sets[name], instrument), refit)
        rows.append([name, f"{plain['rms']:.3f}", plain["result"].method, instrument, f"{said['rms']:.3f}",
                     said["result"].method, "forced" if plain["note"] or said["note"] else ""])
    table("FIGAROH's sets (peer_sets splits, judged as bench_peers): held-out RMS (mm), robocal's default "
          "without and with the instrument declared",
          ["set", "undeclared", "method", "instrument", "declared", "method", "note"], rows,
          key="figaroh_declared")

    def camera(d, kind):
        return rc.Measurements.from_arrays(kind, d.joints, points=d.points, rotations=d.rotations,
                                           pose_id=d.pose_id, source=d.source)

    def markers(d):  # no link column: every marker on the flange
        return rc.Measurements.from_arrays("marker", d.joints, points=d.points, smr=d.smr, pose_id=d.pose_id,
                                           source=d.source, linear=d.linear)

    def held(robot, cal, val, **kw):
        try:
            return f"{rc.calibrate(robot, cal, validation=val, **kw).validation['rms']:.3f}"
        except rc.RobocalError as exc:
            return f"refused ({type(exc).__name__})"

    ur10, tiago = sets["ur10_pose"], sets["tiago"]
    rows = [["ur10 6-D", "eye_to_hand (default: robust)",
             held(ur10.robot, camera(ur10.calibration, "eye_to_hand"), camera(ur10.held_out, "eye_to_hand"))],
            ["ur10 6-D", "eye_to_hand, lsq",
             held(ur10.robot, camera(ur10.calibration, "eye_to_hand"), camera(ur10.held_out, "eye_to_hand"),
                  method="lsq")],
            ["ur10 6-D", "eye_in_hand (the wrong mounting)",
             held(ur10.robot, camera(ur10.calibration, "eye_in_hand"), camera(ur10.held_out, "eye_in_hand"))],
            ["tiago", "marker on the flange (default: robust)",
             held(tiago.robot, markers(tiago.calibration), markers(tiago.held_out))],
            ["tiago", "marker, lsq",
             held(tiago.robot, markers(tiago.calibration), markers(tiago.held_out), method="lsq")]]
    table("FIGAROH's sets read as the instrument kinds: held-out RMS, mm",
          ["set", "read as", "held-out RMS mm"], rows, key="figaroh_kinds")


def main() -> None:
    simulated()
    real()


if __name__ == "__main__":
    main()
