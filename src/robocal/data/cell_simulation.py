"""A virtual laser tracker measuring a work cell: SMRs on the arms' flanges and on the positioners'
plates, in one tracker frame.

The true cell (`true_cell`) is the nominal cell plus random errors:

- each arm: its links as `robocal.data.simulate.perturbed` draws them (a track cell: the track's
  errors too); an arm that is not the anchor is also placed off its nominal base by
  ``BODY_PLACEMENT_MM`` / ``BODY_PLACEMENT_DEG`` (random directions): the anchor defines the world;
- each positioner: its axes' directions (alpha, beta) and zero offsets (theta) off by
  ``POSITIONER_ANGLE_DEG``, their origins (a, d) by ``POSITIONER_LENGTH_MM`` (random signs, uniform
  magnitudes), its mount off by ``BODY_PLACEMENT_MM`` / ``BODY_PLACEMENT_DEG`` and its plate frame by
  ``PLATE_ERROR_MM`` / ``PLATE_ERROR_DEG``;

all times ``error_scale``. SMRs: SMR 0 on each arm's flange at a random offset (|xy| <= 50 mm, z
50-120 mm; more SMRs 100-150 mm from it), as `robocal.simulate_tracker` puts them; on a plate, in its
nests when the cell declares them, else at ``plate_smr`` (default `PLATE_SMR_M`): the truth's
positioner carries them as its nests (where they really are), SMR k at nest k.

Poses: each arm's joints uniform within its limits, all its SMRs read at each; each positioner's
axes uniform within their limits (``table_poses`` of them), all its plate SMRs read at each (the
tracker is assumed to see every SMR: plan the poses with `robocal poses` for line of sight). The
tracker stands 2-4 m from the anchor's base with a random orientation; noise N(0, noise_mm^2) on
each axis of each point. The noise floor is the 3-D RMS of the noise added (all rows).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.core.yaml_load import dump_yaml
from robocal.data.cell_measurements import CellMeasurements
from robocal.data.measurements import Measurements
from robocal.data.simulate import (
    TRACKER_DISTANCE_M,
    flange_smrs,
    perturbed,
    random_directions,
    random_rotation,
    sample_joints,
    true_arm,
)
from robocal.kinematics.transforms import invert_transform, make_transform, rotvec_to_matrix

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

POSITIONER_LENGTH_MM = (0.1, 0.2)  # a positioner's axis origins (a, d): machined, not mastered
POSITIONER_ANGLE_DEG = (0.025, 0.05)  # its axis directions (alpha, beta) and zero offsets (theta)
PLATE_ERROR_MM = 0.2  # the plate frame on the last axis (a plate bolted on its flange)
PLATE_ERROR_DEG = 0.05
BODY_PLACEMENT_MM = 1.0  # a body placed in the world by the cell's drawing (not the anchor)
BODY_PLACEMENT_DEG = 0.05
# three SMRs on a plate without declared nests, m in the plate frame (120 degrees apart, 20 mm up)
PLATE_SMR_M = np.array([[0.2, 0.0, 0.02], [-0.1, 0.1732, 0.02], [-0.1, -0.1732, 0.02]])


def _off(rng: np.random.Generator, mm: float, deg: float) -> np.ndarray:
    """A rigid error ``(4, 4)``: ``mm`` along a random direction, ``deg`` about a random axis."""
    return make_transform(rotvec_to_matrix(random_directions(rng, 1)[0] * np.deg2rad(deg)),
                          random_directions(rng, 1)[0] * mm * 1e-3)


def _true_arm(arm, rng: np.random.Generator, scale: float, anchor: bool, n_smr: int):
    true = true_arm(arm, rng, scale)
    if not anchor:
        true = replace(true, base=_off(rng, BODY_PLACEMENT_MM * scale, BODY_PLACEMENT_DEG * scale) @ arm.base)
    tool0, extra = flange_smrs(rng, n_smr)
    return replace(true, tool=make_transform(arm.tool[:3, :3], tool0), smr=extra, nominal=None,
                   name=f"{arm.name}_true")


def _true_positioner(positioner, rng: np.random.Generator, scale: float, plate_smr):
    chain = replace(positioner.chain, smr=np.zeros((0, 3)), nominal=None)
    true = perturbed(chain, rng, scale=scale, length_mm=POSITIONER_LENGTH_MM, angle_deg=POSITIONER_ANGLE_DEG)
    true = replace(true, base=_off(rng, BODY_PLACEMENT_MM * scale, BODY_PLACEMENT_DEG * scale) @ chain.base,
                   tool=chain.tool @ _off(rng, PLATE_ERROR_MM * scale, PLATE_ERROR_DEG * scale),
                   name=f"{chain.name}_true")
    nests = positioner.nests if positioner.nests is not None else plate_smr
    return replace(positioner, chain=true, nests=np.array(nests, float))


def true_cell(cell: Cell, seed: int | np.random.Generator | None = 0, *, error_scale: float = 1.0,
              n_smr: int = 1, plate_smr=None) -> Cell:
    """A true cell around ``cell`` (module docstring): the errors drawn for ``seed``, the SMRs on
    each arm's flange (``n_smr`` of them: the arm's tool is SMR 0) and on each plate (its nests, or
    ``plate_smr`` ``(K, 3)`` m in the plate frame, default `PLATE_SMR_M`) as the positioner's nests."""
    rng = np.random.default_rng(seed)
    if int(n_smr) < 1:
        raise DataError("n_smr must be >= 1 (the SMRs on each arm's flange)")
    plate_smr = PLATE_SMR_M if plate_smr is None else np.asarray(plate_smr, float)
    if plate_smr.ndim != 2 or plate_smr.shape[1] != 3 or not len(plate_smr) \
            or not np.isfinite(plate_smr).all():
        raise DataError(f"plate SMRs must be a finite (K, 3) array of plate positions (m), got shape "
                        f"{plate_smr.shape}")
    arms = {n: _true_arm(a, rng, error_scale, n == cell.anchor, int(n_smr)) for n, a in cell.arms.items()}
    positioners = {n: _true_positioner(p, rng, error_scale, plate_smr) for n, p in cell.positioners.items()}
    return replace(cell, arms=arms, positioners=positioners, name=f"{cell.name} (true)",
                   description="true cell of a robocal simulation")


@dataclass(frozen=True, eq=False)
class CellSimulation:
    """What `simulate_cell` returns.

    Attributes
    ----------
    data : CellMeasurements
        The rows of every body in the tracker frame.
    truth : Cell
        The true cell in the world (each arm's tool its SMR 0, each plate's SMRs its nests).
    tracker : numpy.ndarray, shape (4, 4)
        The tracker's pose in the world (world -> tracker frame), m.
    noise : dict of str to numpy.ndarray
        Body -> the noise added to each of its rows ``(N, 3)``, m (tracker frame).
    noise_floor_mm : float
        3-D RMS of all the noise added, mm: what a perfect calibration's residual reaches.
    info : dict
        The settings and the seed.
    """

    data: CellMeasurements
    truth: object
    tracker: np.ndarray
    noise: dict
    noise_floor_mm: float
    info: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def summary(self) -> str:
        rows = ", ".join(f"{b}: {len(d)} rows ({d.n_poses} poses)" for b, d in self.data.bodies.items())
        return f"simulated cell {self.truth.name}: {rows}; noise drawn {self.noise_floor_mm:.4f} mm RMS"

    def to_dict(self) -> dict:
        return {"info": self.info, "noise_floor_mm": self.noise_floor_mm,
                "tracker_in_world": {"matrix_m": self.tracker.tolist()},
                "rows": {b: len(d) for b, d in self.data.bodies.items()}}

    def write(self, data_path, truth_path) -> list[str]:
        """Write the measurements (CSV), the true cell (YAML) and ``TRUTH.sim.json`` (the noise floor,
        the tracker's pose, the settings), all or none; returns the paths."""
        sidecar = Path(truth_path).with_suffix(".sim.json")
        outputs = {data_path: self.data.to_csv(), truth_path: dump_yaml(self.truth.to_dict()),
                   sidecar: json.dumps(self.to_dict(), indent=1) + "\n"}
        write_all(outputs)
        return [str(p) for p in outputs]


def _tracker_pose(cell, rng: np.random.Generator) -> np.ndarray:
    """A tracker 2-4 m from the anchor's base origin, randomly turned (its pose in the world)."""
    anchor = cell.body(cell.anchor).base
    centre = anchor[:3, 3] + random_directions(rng, 1)[0] * rng.uniform(*TRACKER_DISTANCE_M)
    return make_transform(random_rotation(rng), centre)


def simulate_cell(cell: Cell, n_poses: int = 40, table_poses: int = 30, *, truth=None, tracker=None,
                  noise_mm: float = 0.02, n_smr: int = 1, plate_smr=None, error_scale: float = 1.0,
                  seed: int = 0) -> CellSimulation:
    """Simulate a tracker campaign on a work cell (module docstring).

    Parameters
    ----------
    cell : Cell
        The nominal cell (which bodies, their names and columns; the truth is drawn around it).
    n_poses : int, default 40
        Arm poses per arm, each reading every SMR on its flange.
    table_poses : int, default 30
        Positioner poses per positioner, each reading every SMR on its plate.
    truth : Cell, optional
        Measure this true cell (e.g. the ``truth`` of an earlier simulation: a second, held-out set
        of the same campaign) instead of drawing one.
    tracker : array_like, shape (4, 4), optional
        The tracker's pose in the world (default: drawn; pass an earlier simulation's to share its
        frame).
    noise_mm : float, default 0.02
        Isotropic noise, 1 sigma per axis, mm.
    n_smr : int, default 1
        SMRs on each arm's flange (a drawn truth).
    plate_smr : array_like, shape (K, 3), optional
        SMR places on plates without nests, m in the plate frame (a drawn truth).
    error_scale : float, default 1
        Multiplies the drawn errors.
    seed : int, default 0
        The random seed (the same seed gives the same result).

    Returns
    -------
    CellSimulation

    See Also
    --------
    rc.Cell : The cell simulated.
    rc.CellMeasurements : The simulated data.
    rc.simulate_tracker : One robot's campaign.
    rc.CellCalibration : The calibration of the simulated data.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> mount = np.eye(4)
    >>> mount[0, 3] = 1.5  # the table 1.5 m in front of the arm
    >>> nests = [[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]]  # m, on the plate
    >>> table = rc.Positioner.from_catalog("abb_irbp_a250", "STN1", mount, nests=nests)
    >>> cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")}, {"STN1": table})
    >>> sim = rc.simulate_cell(cell, 30, 20, seed=1)
    >>> {body: len(rows) for body, rows in sim.data.bodies.items()}  # the plate: 3 nests x 20
    {'arm': 30, 'STN1': 60}
    """
    if int(n_poses) < 1 or int(table_poses) < 1:
        raise DataError("n_poses and table_poses must be >= 1")
    if not (np.isfinite(noise_mm) and noise_mm >= 0):
        raise DataError(f"the noise must be >= 0 mm, got {noise_mm}")
    rng = np.random.default_rng(seed)
    truth = true_cell(cell, rng, error_scale=error_scale, n_smr=n_smr, plate_smr=plate_smr) if truth is None \
        else truth
    tracker = _tracker_pose(cell, rng) if tracker is None else np.asarray(tracker, float)
    to_tracker = invert_transform(tracker)
    bodies, noise, row = {}, {}, 2
    for name in cell.bodies:
        if name in cell.arms:
            chain = truth.arms[name]
            k = len(chain.smr) + 1
            q = sample_joints(chain, int(n_poses), rng)
            smr = np.tile(np.arange(k), int(n_poses))
        else:
            chain = truth.positioners[name].chain  # its SMRs: the nests seen from its last frame
            k = len(chain.smr)
            q = sample_joints(chain, int(table_poses), rng)
            smr = np.tile(np.arange(1, k + 1), int(table_poses))
        pose_id = np.repeat(np.arange(len(q)), k)
        world = chain.fk(q[pose_id], smr=smr)[:, :3, 3]
        noise[name] = rng.standard_normal(world.shape) * noise_mm * 1e-3
        points = world @ to_tracker[:3, :3].T + to_tracker[:3, 3] + noise[name]
        bodies[name] = Measurements.from_arrays(
            "point", q[pose_id], points=points, smr=smr, pose_id=pose_id,
            source_row=np.arange(row, row + len(smr)), linear=chain.prismatic, external=chain.external_axes)
        row += len(smr)
    every = np.concatenate(list(noise.values()))
    floor = float(np.sqrt(np.mean(np.sum(every**2, axis=1)))) * 1e3
    source = f"simulated by robocal: cell {cell.name}, seed {seed}, noise drawn {floor:.6g} mm RMS"
    data = CellMeasurements.from_bodies(cell, bodies, source=source)
    info = {"seed": int(seed), "n_poses": int(n_poses), "table_poses": int(table_poses), "n_smr": int(n_smr),
            "noise_mm": float(noise_mm), "error_scale": float(error_scale), "noise_floor_mm": floor}
    return CellSimulation(data=data, truth=truth, tracker=tracker, noise=noise, noise_floor_mm=floor,
                          info=info)
