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

import csv
import io
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, read_text, write_all
from robocal.kinematics.transforms import invert_transform, pose_error
from robocal.trust.output_marker import mark_csv

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell, Positioner


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
    prismatic: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # its axes that slide

    def summary(self) -> str:
        ok = np.asarray(self.arm_compensation.converged, bool)
        head = (f"{len(self.joints)} target(s) on the plate of {self.positioner} for {self.arm} on the "
                f"calibrated cell: {int(ok.sum())} reached")
        if not ok.any():  # an unreached target's shift is the solver's miss, not a correction
            return head + "; none corrected (each one's miss is in the warnings)"
        mm = np.linalg.norm(self.target_shift[ok, :3], axis=1) * 1e3
        deg = np.rad2deg(np.linalg.norm(self.target_shift[ok, 3:], axis=1))
        missed = f"; {int((~ok).sum())} not reached (converged 0)" if not ok.all() else ""
        return (f"{head}, corrections up to {mm.max():.4f} mm and {deg.max():.4f} deg in the plate "
                f"frame{missed}")

    def to_dict(self) -> dict:
        return {"arm": self.arm, "positioner": self.positioner,
                "joints_deg": np.rad2deg(self.joints).tolist(),
                "positioner_values": self.positioner_values.tolist(),
                "corrected_targets_m": self.corrected_targets.tolist(),
                "converged": self.arm_compensation.converged.tolist(), "warnings": list(self.warnings)}

    def to_csv(self, joint_columns: list[str], positioner_columns: list[str]) -> str:
        """The commands: the arm's joints (deg; mm for a prismatic joint), the positioner's values as
        given, the corrected targets in the plate frame (mm, quaternion w, x, y, z), converged (1/0)."""
        arm = self.arm_compensation.corrected_model
        q = arm.joints_shown(self.joints)
        e = np.where(self.prismatic, self.positioner_values * 1e3, np.rad2deg(self.positioner_values))
        quat = Rotation.from_matrix(self.corrected_targets[:, :3, :3]).as_quat(scalar_first=True)
        pose = np.column_stack([self.corrected_targets[:, :3, 3] * 1e3, quat])
        columns = [*joint_columns, *positioner_columns, "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz",
                   "converged"]
        lines = [",".join(columns)] + [  # the positioner's values to 10 digits: as given, not deg->rad->deg
            ",".join([*(repr(float(v)) for v in qk), *(f"{v:.10g}" for v in ek),
                      *(repr(float(v)) for v in pk), str(int(ok))])
            for qk, ek, pk, ok in zip(q, e, pose, self.arm_compensation.converged, strict=True)]
        return mark_csv("\n".join(lines) + "\n", arm)

    def write(self, output, joint_columns: list[str], positioner_columns: list[str]) -> list[str]:
        """Write `to_csv` (atomically, marked with the calibrated arm's fingerprint); the path."""
        write_all({output: self.to_csv(joint_columns, positioner_columns)})
        return [str(output)]


def compensate_cell(calibrated: Cell, nominal: Cell, targets: np.ndarray, positioner_values: np.ndarray,
                    compensate_arm: Callable, *,
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
    try:
        arm, positioner = calibrated.pick("arm", arm), calibrated.pick("positioner", positioner)
    except DataError as exc:
        raise DataError(f"{exc} (the targets' body)") from None
    targets = np.asarray(targets, float).reshape(-1, 4, 4)
    chain = nominal.positioners[positioner].chain
    e = np.asarray(positioner_values, float).reshape(len(targets), -1) if np.size(positioner_values) \
        else np.zeros((len(targets), 0))
    if e.shape[1] != chain.n_joints:
        raise DataError(f"{positioner} has {chain.n_joints} axes: give {chain.n_joints} values per target, "
                        f"got {e.shape[1]}")
    outside = np.flatnonzero(chain.outside_limits(e).any(axis=1))
    if outside.size:
        k = int(outside[0])
        shown = np.round(chain.joints_shown(e[k]), 6).tolist()
        raise DataError(f"target {k + 1}: {positioner}'s values {shown} are outside its axes' limits")
    world = calibrated.positioners[positioner].plate(e) @ targets
    tool0 = nominal.flange(arm)  # the flange, not the SMR the cell's model calls its tool
    comp = compensate_arm(calibrated.arms[arm].with_frames(tool=tool0), nominal.controller_arm(arm), world,
                          targets_frame="model", tool=tool, **options)
    flange = nominal.arms[arm].with_frames(tool=tool0 if tool is None else tool0 @ np.asarray(tool, float))
    corrected = invert_transform(nominal.positioners[positioner].plate(e)) @ flange.fk(comp.joints)
    return CellCompensation(arm, positioner, comp.joints, e, corrected, pose_error(corrected, targets), comp,
                            list(comp.warnings), chain.prismatic.copy())


def read_positioner_values(path: str | Path, positioner: Positioner) -> np.ndarray:
    """The values ``(N, k)`` (rad; m for a prismatic axis) of ``positioner``'s axes in a targets
    CSV: its columns (``e1_deg``, ``e2_rad``, ``e3_mm``...), one value per row (rows as the targets
    reader counts them: leading ``#`` lines and blank lines skipped); DataError naming the column
    or the line."""
    path = Path(path)
    lines = read_text(path, "targets CSV file").splitlines()
    body = [(k + 1, ln) for k, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise DataError(f"{path} is empty")
    header = [h.strip().lower() for h in next(csv.reader([body[0][1]]))]
    index, scale = [], []
    for spec in positioner.joints:
        units = LENGTH_UNITS if spec.prismatic else ANGLE_UNITS
        found = [(h, units[h.rsplit("_", 1)[1]]) for h in header
                 if h.rsplit("_", 1)[0] == spec.name and "_" in h and h.rsplit("_", 1)[1] in units]
        if len(found) != 1:
            raise DataError(f"{path}: targets on the plate of {positioner.unit} need one column for its axis "
                            f"{spec.name} ({spec.column}); header is {header}")
        index.append(header.index(found[0][0]))
        scale.append(found[0][1])
    out = np.empty((len(body) - 1, len(index)))
    for r, (ln, text) in enumerate(body[1:]):
        cells = next(csv.reader(io.StringIO(text)))
        try:
            out[r] = [float(cells[i]) * s for i, s in zip(index, scale, strict=True)]
        except (ValueError, IndexError):
            raise DataError(f"{path}, line {ln}: the positioner's values must be numbers") from None
    return out
