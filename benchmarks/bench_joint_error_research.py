"""The joint-error terms tried and not kept (issue 16), with the figures that decided.

On each real data set the model auto chose is calibrated (IRB 120: compliance, gear, backlash,
travel; Meca500: the same plus cyclic), then one candidate term at a time is added as extra
columns of the problem linearised at that fit, and the model is refitted (one Gauss-Newton step,
as in the model selection) on the calibration poses: calibration RMS, 5-fold cross-validated RMS
(folds by pose, the calibration part only) and held-out RMS (mm). A term would be kept only if
cross-validation on the calibration data keeps it (CV RMS lower by more than its standard error)
and it helps the held-out set; the held-out column is only judged, never used to choose.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocal import Robot
from robocal.calibration.model_selection import _folds
from robocal.calibration.pipeline import calibrate
from robocal.data.datasets import irb120, meca500
from robocal.identify.linalg import ScaledSVD
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.fk import chain_frames

DS = Path(__file__).resolve().parents[2] / "shared" / "datasets"
FOLDS = 5


class _Linear:
    """Weighted Jacobian, residuals and theta columns of a calibrated model on one data set."""

    def __init__(self, result, data) -> None:
        state = result.state  # the estimate: the chosen joint-error terms included
        problem = CalibrationProblem(state.robot, data)
        n = result.robot.n_joints
        self.data, self.n = data, n
        self.A = problem.jacobian(state, result.space)
        self.r = problem.residuals(state)
        self.Jtheta = problem.jacobian(state, ParameterSpace([f"theta{i + 1}" for i in range(n)]))
        self.q_reached = state.robot.reached_joints(data.joints, Conditions(data.approach, data.travel))
        self.robot = state.robot

    def joint_columns(self, f: np.ndarray) -> np.ndarray:
        """Columns d(TCP)/d(theta_i) * f_i for a joint-error basis ``f (N, n)``."""
        return self.Jtheta * np.repeat(f, 3, axis=0)

    def frames(self):
        tcp, F = chain_frames(self.robot.links, self.robot.base, self.robot.tools_for(self.data.smr),
                              self.q_reached, frames=True)
        return tcp[:, :3, 3], F


def _torques(lin: _Linear, F: np.ndarray, points=None) -> np.ndarray:
    """(N, n, 3) gravity moment about each joint's origin of unit weights at all distal frames."""
    g = -F[:, 0, :3, 2]
    n = lin.n
    out = np.zeros((F.shape[0], n, 3))
    for i in range(n):
        o = F[:, i + 1, :3, 3]
        targets = [F[:, j, :3, 3] for j in range(i + 2, n + 1)] if points is None else [points]
        out[:, i] = sum(np.cross(p - o, g) for p in targets) if targets else 0.0
    return out


def _families(lin: _Linear) -> dict[str, np.ndarray]:
    q = lin.data.joints
    tcp, F = lin.frames()
    moment = _torques(lin, F)
    z = np.stack([F[:, i + 1, :3, 2] for i in range(lin.n)], axis=1)
    torque = np.einsum("nij,nij->ni", z, moment)
    tool_torque = np.einsum("nij,nij->ni", z, _torques(lin, F, points=tcp))

    def coupled(pairs):
        cols = []
        for i, j, s in pairs:
            for fn in (np.sin, np.cos):
                for tgt in (i, j):
                    f = np.zeros_like(q)
                    f[:, tgt] = fn(q[:, i] + s * q[:, j])
                    cols.append(lin.joint_columns(f)[:, tgt])
        return np.stack(cols, axis=1)

    def link_compliance():
        cols = []
        for i in range(1, lin.n):
            o = F[:, i, :3, 3]
            for axis in (0, 1):
                u = F[:, i, :3, axis]
                tau = np.einsum("ij,ij->i", u, moment[:, i - 1])
                cols.append((np.cross(u, tcp - o) * tau[:, None]).reshape(-1))
        return np.stack(cols, axis=1)

    def wobble():
        cols = []
        for i in range(lin.n):
            o = F[:, i + 1, :3, 3]
            for axis in (0, 1):
                u = F[:, i + 1, :3, axis]
                for move in (u, np.cross(u, tcp - o)):
                    for fn in (np.sin, np.cos):
                        cols.append((move * fn(q[:, i])[:, None]).reshape(-1))
        return np.stack(cols, axis=1)

    def cross_travel():
        m = lin.data.travel
        cols = []
        for i in range(lin.n):
            for j in range(lin.n):
                if i != j:
                    f = np.zeros_like(q)
                    f[:, i] = m[:, j]
                    cols.append(lin.joint_columns(f)[:, i])
        return np.stack(cols, axis=1)

    m = lin.data.travel
    return {
        "backlash by the sign of the gravity torque": lin.joint_columns(np.sign(torque)),
        "compliance of a payload at the tool point": lin.joint_columns(tool_torque),
        "coupled gears J2/J3 (q2 +- q3)": coupled([(1, 2, 1), (1, 2, -1)]),
        "coupled wrist gears (q4 +- q5, q5 +- q6, q4 +- q6)": coupled(
            [(3, 4, 1), (3, 4, -1), (4, 5, 1), (4, 5, -1), (3, 5, 1), (3, 5, -1)]),
        "cross-joint gear ratio coupling (q_j on joint i)": np.stack(
            [lin.joint_columns(np.where(np.arange(lin.n) == j, q[:, [i]], 0.0))[:, j]
             for i, j in [(1, 2), (2, 1), (3, 4), (4, 5), (3, 5), (4, 3), (5, 4), (5, 3)]], axis=1),
        "link compliance (bending about x_i, y_i)": link_compliance(),
        "bearing wobble (frame i moved by sin/cos q_i)": wobble(),
        "travel, quadratic (m |m|)": lin.joint_columns(m * np.abs(m)),
        "travel of the other joints": cross_travel(),
    }


def _drift(lin: _Linear, tau: float, first_order: int | None) -> np.ndarray:
    """Joint offsets decaying as exp(-k / tau) over the measuring order k (a warm-up). The poses'
    k start at ``first_order`` (IRB 120 held out: they follow the 500 calibration poses); None:
    measured at an unknown time, predicted settled (offset 0)."""
    first = np.r_[True, lin.data.pose_id[1:] != lin.data.pose_id[:-1]]
    order = np.cumsum(first) - 1
    e = np.zeros(order.size) if first_order is None else np.exp(-(order + first_order) / tau)
    return lin.joint_columns(np.repeat(e[:, None], lin.n, axis=1))


def _fit(cal: _Linear, val: _Linear, Xc: np.ndarray, Xv: np.ndarray, fold: np.ndarray) -> tuple:
    A, Av = np.hstack([cal.A, Xc]), np.hstack([val.A, Xv])

    def rms(e):
        return float(np.sqrt(np.mean(np.sum(e.reshape(-1, 3) ** 2, axis=1))) * 1e3)

    x = ScaledSVD.of(A).solve(cal.r)
    rows = np.repeat(fold, 3)
    squares, per_fold = [], []
    for f in range(FOLDS):
        tr, te = rows != f, rows == f
        e = (cal.r[te] - A[te] @ ScaledSVD.of(A[tr]).solve(cal.r[tr])).reshape(-1, 3)
        squares.append(np.sum(e**2, axis=1))
        per_fold.append(np.sqrt(squares[-1].mean()) * 1e3)
    cv = float(np.sqrt(np.mean(np.concatenate(squares))) * 1e3)
    return rms(cal.r - A @ x), cv, float(np.std(per_fold, ddof=1) / np.sqrt(FOLDS)), rms(val.r - Av @ x)


def main() -> None:
    if not DS.is_dir():
        print("real data sets not found: nothing to measure")
        return
    sets = [("IRB 120", "abb_irb120", *irb120(DS)), ("Meca500", "meca500", *meca500(DS))]
    print(f"{'data':9s} {'added to the chosen model':52s} {'cal RMS':>8s} {'CV RMS':>8s} {'+- SE':>7s} "
          f"{'held-out':>9s}")
    for label, name, cal_data, val_data in sets:
        result = calibrate(Robot.from_catalog(name), cal_data, nongeometric="auto")
        cal, val = _Linear(result, cal_data), _Linear(result, val_data)
        fold = _folds(cal_data.pose_id, FOLDS, 0)
        base = _fit(cal, val, np.zeros((cal.r.size, 0)), np.zeros((val.r.size, 0)), fold)
        print(f"{label:9s} {'(auto: ' + ', '.join(result.model_selection['chosen_terms']) + ')':52s} "
              f"{base[0]:8.4f} {base[1]:8.4f} {base[2]:7.4f} {base[3]:9.4f}")
        fc, fv = _families(cal), _families(val)
        held_out_order = cal_data.n_poses if name == "abb_irb120" else None
        for tau in (100.0, 300.0):
            fc[f"drift: joint offsets x exp(-k / {tau:g} poses)"] = _drift(cal, tau, 0)
            fv[f"drift: joint offsets x exp(-k / {tau:g} poses)"] = _drift(val, tau, held_out_order)
        for family in fc:
            c, cv, se, v = _fit(cal, val, fc[family], fv[family], fold)
            print(f"{label:9s} {family:52s} {c:8.4f} {cv:8.4f} {se:7.4f} {v:9.4f}")


if __name__ == "__main__":
    main()
