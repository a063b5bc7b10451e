"""The ABB IRB 120 laser-tracker campaign published with Wu, Yang, Chen, Ren, "A minimal POE-based
model for robotic kinematic calibration with only position measurements", IEEE T-ASE 12(2) 2015,
758-763: github.com/drliaowu/Minimal_Robot_Calibration_Using_Position, folder
``MinimalPositionCalibration`` (MATLAB .mat files and the paper's ``Experiment.m``).

The repository carries no licence file: like the project's other public tracker data it is read
for evaluation from a folder the user names (``--liao DIR`` of ``bench_peers.py`` or
``$ROBOCAL_LIAO_DATA``: the ``MinimalPositionCalibration`` folder, or the repository holding it),
credited, and never copied into the project.

What it holds (mm, degrees; the tracker frame):

- ``CaliJointAngles.mat`` (36 x 6) and ``CaliPosition.mat`` (108 x 3): 36 calibration poses, three
  SMRs each (rows point1_1, point2_1, point3_1, point1_2, ...);
- ``TestJointAngles.mat`` (10 x 6) / ``TestPosition.mat`` and ``TestJointAngles2.mat`` (30 x 6) /
  ``TestPosition2.mat``: 40 test poses of a test point on the end-effector (mounted twice: 10, then
  30 poses);
- ``Experiment.m``: the test point's position measured at the zero-reference configuration for
  each mount (``TestPoint_Meas``, ``TestPoint_Meas2``), which the paper's method uses to place the
  test point on the calibrated end-effector. robocal uses the same: the point's offset on the
  flange is the calibrated model's flange frame at q = 0 applied backwards to that measurement.

The paper's own figures on the 40 test points: 0.266 mm mean, 0.525 mm max (issue 44).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

import robocal as rc

DATA_ENV = "ROBOCAL_LIAO_DATA"
FOLDER = "MinimalPositionCalibration"
SMRS = 3
TEST_POINT = re.compile(r"^(TestPoint_Meas2?)\s*=\s*\[([^\]]+)\]", re.M)


class LiaoUnavailableError(RuntimeError):
    """The campaign's files are not where they were looked for (the message says where)."""


class LiaoCampaign(NamedTuple):
    """The nominal model, the 36 x 3 calibration measurements and the 40 test poses: joints
    ``(40, 6)`` rad, measured test-point positions ``(40, 3)`` m (tracker frame), and the test
    point measured at q = 0 for each test pose's mount ``(40, 3)`` m."""

    robot: rc.Robot
    calibration: rc.Measurements
    test_joints: np.ndarray
    test_points: np.ndarray
    test_point_at_zero: np.ndarray
    description: str


def folder_of(folder: str | os.PathLike | None = None) -> Path:
    """The folder with the .mat files: ``folder`` or ``$ROBOCAL_LIAO_DATA`` (either the folder
    itself or the repository holding it). Raises LiaoUnavailableError naming where it looked."""
    tried = []
    for path in (folder, os.environ.get(DATA_ENV)):
        if not path:
            continue
        for p in (Path(path).expanduser(), Path(path).expanduser() / FOLDER):
            if (p / "CaliPosition.mat").is_file():
                return p
        tried.append(str(path))
    raise LiaoUnavailableError(f"the IRB 120 campaign of Wu et al. 2015 was not found (looked at: "
                               f"{', '.join(tried) or 'nothing'}); give --liao DIR or ${DATA_ENV}")


def _mat(folder: Path, name: str) -> np.ndarray:
    from scipy.io import loadmat

    return np.asarray(loadmat(folder / f"{name}.mat")[name], dtype=float)


def load(folder: str | os.PathLike | None = None) -> LiaoCampaign:
    """The campaign read from its folder (see :func:`folder_of`), in SI units."""
    where = folder_of(folder)
    q = np.deg2rad(_mat(where, "CaliJointAngles"))
    points = _mat(where, "CaliPosition") * 1e-3
    n = len(q)
    if points.shape != (SMRS * n, 3):
        raise LiaoUnavailableError(f"{where}: CaliPosition is {points.shape}, expected ({SMRS * n}, 3)")
    cal = rc.Measurements.from_arrays("point", np.repeat(q, SMRS, axis=0), points=points,
                                      pose_id=np.repeat(np.arange(n), SMRS), smr=np.tile(np.arange(SMRS), n),
                                      source="Wu et al. 2015 IRB 120 calibration poses (CaliPosition.mat)")
    found = dict(TEST_POINT.findall((where / "Experiment.m").read_text()))
    zero = {k: np.array(v.split(), dtype=float) * 1e-3 for k, v in found.items()}
    if set(zero) != {"TestPoint_Meas", "TestPoint_Meas2"}:
        raise LiaoUnavailableError(f"{where / 'Experiment.m'}: TestPoint_Meas and TestPoint_Meas2 not found")
    tq, tp, t0 = [], [], []
    for suffix, key in (("", "TestPoint_Meas"), ("2", "TestPoint_Meas2")):
        joints = np.deg2rad(_mat(where, f"TestJointAngles{suffix}"))
        tq.append(joints)
        tp.append(_mat(where, f"TestPosition{suffix}") * 1e-3)
        t0.append(np.tile(zero[key], (len(joints), 1)))
    tq, tp, t0 = (np.vstack(a) for a in (tq, tp, t0))
    return LiaoCampaign(rc.Robot.from_catalog("abb_irb120"), cal, tq, tp, t0,
                        f"IRB 120 (Wu et al. 2015): {n} poses x {SMRS} SMRs calibrate, {len(tq)} test points "
                        "judge")


def test_errors_mm(model: rc.Robot, campaign: LiaoCampaign) -> np.ndarray:
    """Each test point's 3-D error (mm) with ``model`` (tracker frame fitted): its flange offset
    from the model's flange frame at q = 0 and the point measured there, as the paper places it."""
    _, f0 = model.fk(np.zeros((1, model.n_joints)), frames=True)
    flange0 = f0[0, -1]
    at_zero = np.c_[campaign.test_point_at_zero, np.ones(len(campaign.test_joints))]
    offset = (np.linalg.inv(flange0) @ at_zero.T).T
    _, frames = model.fk(campaign.test_joints, frames=True)
    pred = np.einsum("nij,nj->ni", frames[:, -1], offset)[:, :3]
    return np.linalg.norm(pred - campaign.test_points, axis=1) * 1e3
