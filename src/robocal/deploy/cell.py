"""Targets on a positioner's plate reached by an arm of a calibrated work cell.

A target ``T`` (4 x 4, m) is a pose of the arm's TCP in the plate frame of a positioner standing at
its axis values ``e``: the workpiece turns with the table, the target with it. On the calibrated
cell (`robocal.kinematics.workcell.Cell`, in the controller's world: `Cell.in_world`) the TCP must
reach the world pose ``X = calibrated_positioner.plate(e) @ T``; the arm's joints ``q`` are the
calibrated arm's inverse kinematics of ``X`` (`robocal.deploy.compensation.compensate`); the target
to program on the nominal controller (nominal arm, nominal positioner) is then
``T' = inv(nominal_positioner.plate(e)) @ nominal_arm.fk(q) @ tool``: the nominal controller sends
the real cell to the intended point on the workpiece. The positioner's values stay as given.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.kinematics.transforms import invert_transform, pose_error


def _one(names, what: str, given: str | None, cell) -> str:
    """The body ``given`` (resolved in ``cell``), or the only one of ``names``."""
    if given is not None:
        return cell.resolve(given)
    if len(names) != 1:
        raise DataError(f"the cell has {len(names)} {what}s ({', '.join(names) or 'none'}): name the one "
                        f"the targets are for")
    return next(iter(names))


@dataclass(eq=False)
class CellCompensation:
    """What `compensate_cell` returns.

    Attributes
    ----------
    arm, positioner : str
        The bodies: the arm that reaches, the positioner whose plate carries the targets.
    joints : numpy.ndarray, shape (N, n)
        The arm's joints to send to the controller, radians.
    positioner_values : numpy.ndarray, shape (N, k)
        The positioner's axes, as given (rad; m for a prismatic axis).
    corrected_targets : numpy.ndarray, shape (N, 4, 4)
        The targets to program on the nominal controller, in the plate frame, m.
    arm_compensation : Compensation
        The arm's compensation of the intended world poses (convergence, residuals, warnings).
    """

    arm: str
    positioner: str
    joints: np.ndarray
    positioner_values: np.ndarray
    corrected_targets: np.ndarray
    target_shift: np.ndarray
    arm_compensation: object
    warnings: list[str] = field(default_factory=list)

    def summary(self) -> str:
        mm = np.linalg.norm(self.target_shift[:, :3], axis=1) * 1e3
        deg = np.rad2deg(np.linalg.norm(self.target_shift[:, 3:], axis=1))
        reached = int(np.sum(self.arm_compensation.converged))
        return (f"{len(self.joints)} target(s) on the plate of {self.positioner} reached by {self.arm} on "
                f"the calibrated cell ({reached} reached exactly); corrections up to {mm.max():.4f} mm and "
                f"{deg.max():.4f} deg in the plate frame")

    def to_dict(self) -> dict:
        return {"arm": self.arm, "positioner": self.positioner,
                "joints_deg": np.rad2deg(self.joints).tolist(),
                "positioner_values": self.positioner_values.tolist(),
                "corrected_targets_m": self.corrected_targets.tolist(),
                "converged": self.arm_compensation.converged.tolist(), "warnings": list(self.warnings)}

    def write(self, json_path) -> list[str]:
        """Write `to_dict` as JSON (atomically); returns the path."""
        import json

        write_all({json_path: json.dumps(self.to_dict(), indent=1) + "\n"})
        return [str(json_path)]


def compensate_cell(calibrated, nominal, targets, positioner_values, compensate_arm: Callable, *,
                    arm: str | None = None, positioner: str | None = None, tool=None,
                    **options) -> CellCompensation:
    """Joints of a calibrated cell's arm for targets on a positioner's plate, and the targets to
    program on the nominal controller (module docstring).

    Parameters
    ----------
    calibrated, nominal : Cell
        The calibrated cell in the controller's world (`CellCalibration.calibrated`) and the nominal
        one (the controller's).
    targets : array_like, shape (N, 4, 4) or (4, 4)
        TCP poses in the plate frame, m.
    positioner_values : array_like, shape (N, k) or (k,)
        The positioner's axes at each target, rad (m for a prismatic axis).
    compensate_arm : callable
        `robocal.deploy.compensation.compensate`: the arm's compensation of world poses.
    arm, positioner : str, optional
        The bodies (default: the only arm, the only positioner).
    tool : array_like, shape (4, 4), optional
        The real tool on the arm's flange, m (default: the flange).
    **options
        Passed to the arm's compensation (branch, seeds, start, ...).

    Returns
    -------
    CellCompensation
    """
    arm = _one(calibrated.arms, "arm", arm, calibrated)
    positioner = _one(calibrated.positioners, "positioner", positioner, calibrated)
    targets = np.asarray(targets, float).reshape(-1, 4, 4)
    chain = nominal.positioners[positioner].chain
    e = np.asarray(positioner_values, float).reshape(len(targets), -1) if np.size(positioner_values) \
        else np.zeros((len(targets), 0))
    if e.shape[1] != chain.n_joints:
        raise DataError(f"{positioner} has {chain.n_joints} axes: give {chain.n_joints} values per target, "
                        f"got {e.shape[1]}")
    outside = np.flatnonzero(((e < chain.limits[:, 0]) | (e > chain.limits[:, 1])).any(axis=1))
    if outside.size:
        k = int(outside[0])
        shown = np.round(chain.joints_shown(e[k]), 6).tolist()
        raise DataError(f"target {k + 1}: {positioner}'s values {shown} are outside its axes' limits")
    world = calibrated.positioners[positioner].plate(e) @ targets
    comp = compensate_arm(calibrated.arms[arm], nominal.arms[arm], world, targets_frame="model", tool=tool,
                          **options)
    flange = nominal.arms[arm].with_frames(tool=nominal.arms[arm].tool if tool is None
                                           else nominal.arms[arm].tool @ np.asarray(tool, float))
    corrected = invert_transform(nominal.positioners[positioner].plate(e)) @ flange.fk(comp.joints)
    return CellCompensation(arm, positioner, comp.joints, e, corrected, pose_error(corrected, targets), comp,
                            list(comp.warnings))
