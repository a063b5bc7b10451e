"""Flush contacts (a flat tool face pressed onto planes: height and two tilts per contact) against
point contacts of a probe tip, on simulated truth (issue 44).

An ABB IRB 2600 touches 3 random planes: 60 contacts for calibration and 30 held out, contact
noise 0.01 mm (the probe's height; for a flush face also 0.2 mrad of tilt per axis, the same
0.01 mm at the rim of a 50 mm face). The start model knows the tool (tip or face centre) to
1 mm, as taught; the flush face's mounting is also tilted by 2 mrad. Judged against the truth over
300 random poses after the best rigid motion (the base frame no contact sees): the TCP position
(mm) and the flange orientation (mdeg), and the held-out contacts' error against their own
noise. Flush + tip: the same 60 flush contacts and the 60 tip contacts together (the plates
numbered apart).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from common import rigid_error_mm
from results import figure, table
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.data.registration import umeyama
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.kinematics.transforms import rotvec_to_matrix

SEEDS = 5
ROBOT = rc.Robot.from_catalog("abb_irb2600")
NOISE_MM = 0.01
FACE_TILT_RAD = np.array([2e-3, -1e-3, 0.0])  # the start model's face mounting error


def orientation_error_mdeg(model, truth, q: np.ndarray) -> float:
    """RMS flange-orientation error (mdeg) of ``model`` against ``truth`` at joints ``q`` after the
    best rigid motion of the TCP positions and the mean remaining rotation."""
    A, B = model.fk(q), truth.fk(q)
    R = umeyama(A[:, :3, 3], B[:, :3, 3])[:3, :3]
    err = Rotation.from_matrix(np.swapaxes(B[:, :3, :3], 1, 2) @ (R @ A[:, :3, :3])).as_rotvec()
    return float(np.sqrt(np.mean(np.sum((err - err.mean(axis=0)) ** 2, axis=1)))) * 180e3 / np.pi


def held_out_ratio(result, floor_mm: float) -> float:
    return result.validation["rms"] / floor_mm


def main() -> None:
    rows, ratios = [], []
    for seed in range(SEEDS):
        flush = simulate_tracker(ROBOT, 90, kind="flush", n_planes=3, noise_mm=NOISE_MM, seed=seed)
        truth = flush.truth
        tip = simulate_tracker(truth, 90, kind="plane", n_planes=3, noise_mm=NOISE_MM, seed=50 + seed,
                               as_is=True)
        tip_data = replace(tip.data, plane=tip.data.plane + 3)  # the tip's plates numbered after the faces'
        tool = truth.tool.round(3)
        face = tool.copy()
        face[:3, :3] = rotvec_to_matrix(FACE_TILT_RAD) @ face[:3, :3]
        start_face, start_tip = ROBOT.with_frames(tool=face), ROBOT.with_frames(tool=tool)
        q = sample_joints(truth, 300, np.random.default_rng(1000 + seed))
        cal_f, val_f = flush.data.subset(np.arange(60)), flush.data.subset(np.arange(60, 90))
        cal_t, val_t = tip_data.subset(np.arange(60)), tip_data.subset(np.arange(60, 90))
        floor_f = float(np.sqrt(np.mean(np.sum(flush.noise[60:] ** 2, axis=1)))) * 1e3
        floor_t = float(np.sqrt(np.mean(np.sum(tip.noise[60:] ** 2, axis=1)))) * 1e3
        by_tip = rc.calibrate(start_tip, cal_t, validation=val_t)
        by_face = rc.calibrate(start_face, cal_f, validation=val_f)
        both = rc.calibrate(start_face, [cal_f, cal_t], validation=[val_f, val_t])
        models = (by_tip.robot, by_face.robot, both.robot)
        rows.append([seed, rigid_error_mm(start_tip, truth, q),
                     *(rigid_error_mm(m, truth, q) for m in models),
                     orientation_error_mdeg(start_face, truth, q),
                     *(orientation_error_mdeg(m, truth, q) for m in models),
                     held_out_ratio(by_tip, floor_t), held_out_ratio(by_face, floor_f)])
        ratios.append(rows[-1][-1])
    table("3 planes, 60 contacts + 30 held out, noise 0.01 mm: TCP position (mm) and flange orientation "
          "(mdeg) against the truth after a rigid fit over 300 random poses, held-out contacts / their noise",
          ["seed", "pos nominal", "pos tip", "pos flush", "pos flush+tip", "orient nominal", "orient tip",
           "orient flush", "orient flush+tip", "held-out / floor, tip", "/ floor, flush"],
          [[r[0], *(f"{v:.4f}" for v in r[1:5]), *(f"{v:.1f}" for v in r[5:9]), *(f"{v:.3f}" for v in r[9:])]
           for r in rows], key="contacts")
    r = np.array(rows, dtype=float)
    figure("orientation_flush_mdeg", f"{np.median(r[:, 7]):.1f}")
    figure("orientation_tip_mdeg", f"{np.median(r[:, 6]):.1f}")
    print(f"median over seeds: position nominal {np.median(r[:, 1]):.4f} mm, tip {np.median(r[:, 2]):.4f}, "
          f"flush {np.median(r[:, 3]):.4f}, flush+tip {np.median(r[:, 4]):.4f}; orientation nominal "
          f"{np.median(r[:, 5]):.1f} mdeg, tip {np.median(r[:, 6]):.1f}, flush {np.median(r[:, 7]):.1f}, "
          f"flush+tip {np.median(r[:, 8]):.1f}; held-out flush / floor {min(ratios):.3f}-{max(ratios):.3f}")


if __name__ == "__main__":
    main()
