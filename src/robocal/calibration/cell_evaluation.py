"""A work cell judged on measurements: every body in ONE tracker frame fitted once.

A calibrated cell (`robocal.kinematics.workcell.Cell`, in the controller's world) predicts where
each SMR is at each row's joints: on an arm's flange (its offset unknown in a new campaign: SMRs are
put on again), on a positioner's plate (at its nests when the cell declares them, else at places
unknown in a new campaign). The tracker's frame is unknown too. `evaluate_cell` fits ONE rigid
transform world -> tracker for all the bodies' rows together, with each unknown SMR offset (on its
body's last frame), and reports what is left: the error of the bodies AND of their relation (a
positioner misplaced with respect to the arm cannot hide in a frame of its own). The fit alternates
a rigid fit (Umeyama) of the frame with the offsets' linear least squares (exact for each given the
other) until the frame moves less than `FRAME_STEP_TOL`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robocal.calibration.cell import check_declared_nests
from robocal.core.errors import DataError, IdentificationError
from robocal.core.io import write_all
from robocal.data.cell_measurements import CellMeasurements
from robocal.data.registration import smr_offsets_lsq, umeyama
from robocal.report.metrics import position_stats

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

FRAME_STEP_TOL = 1e-12  # m: the alternation stops when the frame's points move less than this
MAX_ALTERNATIONS = 500


@dataclass(frozen=True)
class _Rows:
    """One body's rows as the fit sees them: flange (last frame) rotations and origins in the world
    ``(N, 3, 3)``, ``(N, 3)``, the row's SMR index among the body's unknown offsets (-1: a known
    point, ``known`` ``(N, 3)`` world), the measured points ``(N, 3)`` (tracker frame)."""

    R: np.ndarray
    o: np.ndarray
    slot: np.ndarray
    known: np.ndarray
    measured: np.ndarray


def _rows(cell, name: str, data) -> tuple[_Rows, int]:
    """The fit's view of body ``name``'s rows, and how many unknown SMR offsets it has."""
    if data.kind != "point":
        raise DataError(f"{data.label}: a cell is judged on SMR points, not {data.kind} rows")
    chain = cell.body(name)
    flange = replace(chain, tool=np.eye(4), smr=np.zeros((0, 3)), nominal=None).fk(data.joints)
    R, o = flange[:, :3, :3], flange[:, :3, 3]
    known = np.zeros((len(data), 3))
    nests = cell.positioners[name].nests if name in cell.positioners else None
    if nests is not None:
        check_declared_nests(data, len(nests), name)
        plate = chain.fk(data.joints)
        known = np.einsum("nij,nj->ni", plate[:, :3, :3], np.asarray(nests)[data.smr - 1]) + plate[:, :3, 3]
        return _Rows(R, o, np.full(len(data), -1), known, data.points), 0
    numbers, slot = np.unique(data.smr, return_inverse=True)
    return _Rows(R, o, slot, known, data.points), len(numbers)


def _world_points(rows: _Rows, offsets: np.ndarray) -> np.ndarray:
    """``(N, 3)`` each row's SMR in the world: a known point, or its offset on the body's last frame."""
    moved = np.einsum("nij,nj->ni", rows.R, offsets[np.maximum(rows.slot, 0)]) + rows.o if len(offsets) \
        else rows.known
    return np.where((rows.slot >= 0)[:, None], moved, rows.known)


def _offsets(rows: _Rows, k: int, W: np.ndarray) -> np.ndarray:
    """Each unknown SMR's offset ``(k, 3)`` given the frame ``W`` (world -> tracker): the mean of
    ``R_i^T (W^-1 p_i - o_i)`` over its rows (exact least squares: the R_i are rotations)."""
    if not k:
        return np.zeros((0, 3))
    return smr_offsets_lsq(rows.R, rows.o, (rows.measured - W[:3, 3]) @ W[:3, :3], rows.slot, k)


@dataclass(eq=False)
class CellEvaluation:
    """A cell's errors on measurements (`evaluate_cell`): ``errors`` body -> ``(N,)`` m after the
    one frame fit, ``frame`` (4, 4) the world's pose in the tracker frame (world -> tracker), ``smr``
    body -> the fitted SMR offsets ``(k, 3)`` m on its last frame, and the statistics (mm)."""

    cell_name: str
    data_label: str
    errors: dict
    frame: np.ndarray
    smr: dict
    warnings: list[str] = field(default_factory=list)

    @property
    def stats(self) -> dict:
        """Every body's rows together: n, rms, mean, max, p95 (mm)."""
        return position_stats(np.concatenate(list(self.errors.values())))

    def summary(self) -> str:
        s = self.stats
        lines = [f"cell {self.cell_name} on {self.data_label or 'the data'} (one tracker frame for every "
                 f"body): n {s['n']}, rms {s['rms']:.4f}, max {s['max']:.4f} mm"]
        for name, e in self.errors.items():
            b = position_stats(e)
            lines.append(f"  {name}: n {b['n']}, rms {b['rms']:.4f}, max {b['max']:.4f} mm")
        return "\n".join(lines + [f"WARNING: {w}" for w in self.warnings])

    def to_dict(self) -> dict:
        return {"cell": self.cell_name, "data": self.data_label, **self.stats,
                "bodies": {n: position_stats(e) for n, e in self.errors.items()},
                "tracker_from_world_m": self.frame.tolist(),
                "smr_mm": {n: (v * 1e3).tolist() for n, v in self.smr.items()},
                "warnings": list(self.warnings)}

    def write(self, json_path) -> list[str]:
        """Write `to_dict` as JSON (atomically); returns the path."""
        import json

        write_all({json_path: json.dumps(self.to_dict(), indent=1) + "\n"})
        return [str(json_path)]


def evaluate_cell(cell: Cell, data: CellMeasurements) -> CellEvaluation:
    """Judge ``cell`` (a calibrated cell in its world, or a nominal one) on the SMR points ``data``
    of its bodies, in one tracker frame fitted once for all (module docstring).

    Parameters
    ----------
    cell : Cell
        The cell (every body's base in its world).
    data : CellMeasurements
        Point rows of its bodies (SMRs on the flanges and plates), one tracker frame.

    Returns
    -------
    CellEvaluation

    Raises
    ------
    DataError
        Rows that are not points, plate SMRs that are not declared nests.
    IdentificationError
        Too few rows to fix the frame and the SMR offsets.
    """
    if not isinstance(data, CellMeasurements):
        raise DataError(f"a cell is judged on CellMeasurements (rc.CellMeasurements.load(path, cell)), got "
                        f"{type(data).__name__}")
    parts = {name: _rows(cell, name, rows) for name, rows in data.bodies.items()}
    unknowns = 6 + 3 * sum(k for _, k in parts.values())
    if 3 * len(data) <= unknowns:
        raise IdentificationError(f"{len(data)} rows cannot fix the tracker frame and the {unknowns - 6} SMR "
                                  "offset coordinates: measure more poses")
    offsets = {name: np.zeros((k, 3)) for name, (_, k) in parts.items()}
    measured = np.concatenate([r.measured for r, _ in parts.values()])
    W = np.eye(4)
    for _ in range(MAX_ALTERNATIONS):
        world = np.concatenate([_world_points(r, offsets[n]) for n, (r, _) in parts.items()])
        W_new = umeyama(world, measured)
        offsets = {n: _offsets(r, k, W_new) for n, (r, k) in parts.items()}
        step = np.abs(world @ (W_new[:3, :3] - W[:3, :3]).T + (W_new[:3, 3] - W[:3, 3])).max()
        W = W_new
        if step < FRAME_STEP_TOL:
            break
    errors = {}
    for n, (r, _) in parts.items():
        p = _world_points(r, offsets[n]) @ W[:3, :3].T + W[:3, 3]
        errors[n] = np.linalg.norm(r.measured - p, axis=1)
    return CellEvaluation(cell.name, data.label, errors, W, offsets)
