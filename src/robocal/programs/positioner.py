"""Programs whose targets are on a positioner's plate (coordinated motion): targets corrected for
the calibrated cell.

A target T in a work object W that a mechanical unit carries (:attr:`Program.carried`: RAPID
``ufmec``, a KRL base on an external kinematic, an INFORM station frame, FANUC coordinated
motion) is a pose on the plate: the controller puts it in the world at the positioner's values
e (its external-axis values, :attr:`Target.axes`) with its nominal positioner,
``nominal_plate(e) @ W @ T``, and solves its nominal arm there. The real cell (the calibrated
one, in the controller's world: :func:`robocal.deploy.compensation.controller_model` for the
arm, the positioner's calibrated base re-expressed in the same world) has the plate at
``calibrated_plate(e)``, so the intended world pose is

    X = calibrated_plate(e) @ W @ T,

the arm's joints q that reach it are the calibrated arm's IK of X (seeded by the nominal
controller's joints, in the target's configuration), and the corrected target is

    T' = inv(W) @ inv(nominal_plate(e)) @ nominal_arm.fk(q) (@ tool),

which the nominal controller (nominal arm, nominal positioner) turns into q at the same e: the
real cell goes to the intended point on the workpiece. The positioner's values, the
configuration data (unless the correction crosses a configuration boundary, as for any target)
and every byte outside the pose numbers stay as they are.

A positioner here is a :class:`Station`: its mechanical unit, its chain as a
:class:`~robocal.kinematics.model.Robot` (base = the mount in the world, tool = the plate frame,
joints = its axes) nominal and calibrated, and the controller's logical external-axis numbers of
its axes, which the program's dialect names (:meth:`Dialect.positioner_axes
<robocal.programs.dialects.base.Dialect.positioner_axes>`): a target's values are found under
those names in :attr:`Target.axes`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robocal.core.errors import DataError, ModelError
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform, pose_error
from robocal.kinematics.workcell import Cell
from robocal.programs.dialects.base import Dialect
from robocal.programs.external import UNNAMED, coordinated_unit
from robocal.programs.model import Program, Target

MM = 1e-3  # prismatic positioner values in programs are millimetres
# A calibrated plate further than this from the nominal one is more than a cell file's placement
# error (a layout drawing's mount, a plate frame by eye): said, the targets moving that much.
PLATE_MOVED_MM, PLATE_MOVED_DEG = 25.0, 2.0


@dataclass(frozen=True)
class Station:
    """A positioner as a program filter uses it: ``unit`` (the mechanical unit's name in programs,
    ``STN1``), its ``nominal`` chain (what the controller computes with) and its ``calibrated``
    one in the controller's world (both :class:`~robocal.kinematics.model.Robot`: base = mount,
    tool = plate frame), and ``external_axes``: the controller's logical external-axis numbers of
    its joints in order (the cell file's ``external_axes``; ``(2, 3)``: a robtarget's ``eax_b``,
    ``eax_c``), which a program's dialect names (:meth:`axes`)."""

    unit: str
    nominal: Robot
    calibrated: Robot
    external_axes: tuple[int, ...]

    def __post_init__(self) -> None:
        n = self.nominal.n_joints
        if len(self.external_axes) != n or self.calibrated.n_joints != n:
            raise DataError(f"positioner {self.unit}: {n} axes, {len(self.external_axes)} external axes, "
                            f"{self.calibrated.n_joints} calibrated axes: they must agree")

    def axes(self, dialect: Dialect) -> tuple[str, ...]:
        """The names ``dialect``'s programs give its joints, in order (:attr:`Target.axes`' keys)."""
        return dialect.positioner_axes(self.external_axes)

    def values(self, t: Target, axes: tuple[str, ...]) -> np.ndarray | str:
        """Target ``t``'s positioner values ``(n,)`` SI (rad; m for a prismatic axis) under the
        program's names ``axes`` of its joints (:meth:`axes`), or why it has none (an axis without
        a value)."""
        missing = [a for a in axes if a not in t.axes]
        if missing:
            return (f"coordinated with {self.unit}, but the target gives no value for its axis "
                    f"{', '.join(missing)}: where the plate is depends on the motion before")
        raw = np.array([t.axes[a] for a in axes], float)
        return np.where(self.nominal.prismatic, raw * MM, np.deg2rad(raw))

    def check_limits(self, t: Target, e: np.ndarray, axes: tuple[str, ...]) -> None:
        """Refuse values ``e`` (SI) outside the positioner's axis limits (one line naming the target
        and the axis by its program name, ``axes``)."""
        outside = self.nominal.outside_limits(e[None])[0]
        for spec, value, name, bad in zip(self.nominal.joints, e, axes, outside, strict=True):
            if bad:
                shown = spec.describe(float(value)).split(" = ", 1)[1]
                raise DataError(f"{t.where}: {self.unit} axis {name} = {shown}: outside the positioner's "
                                "limits in the cell file (another positioner, or a wrong axis letter)")

    def plates(self, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(nominal, calibrated)`` plate frames in the world ``(N, 4, 4)`` (m) at values ``e``
        ``(N, n)`` SI."""
        return self.nominal.fk(e), self.calibrated.fk(e)


@dataclass
class CoordinatedProgram:
    """The positioners of a cell (unit -> :class:`Station`) and the values (SI) of each target on
    one of their plates."""

    stations: dict[str, Station]
    e: dict[int, np.ndarray] = field(default_factory=dict)  # id(target) -> positioner values, SI
    unit: dict[int, str] = field(default_factory=dict)  # id(target) -> its station's unit
    in_world: set[int] = field(default_factory=set)  # id(target): taught in the world (Program.in_world)

    def take(self, program: Program, warnings: list[str], dialect: Dialect) -> frozenset[int]:
        """Record the values of every target in a frame a unit carries, under the names ``dialect``
        (the program's language) gives the positioner's axes; refuse a unit the cell
        does not have and values outside the axis limits (DataError, nothing written); name the
        targets without values for every axis (removed from ``program.targets``). Returns the
        ids of the targets taken (:func:`robocal.programs.external.sort_external` leaves them)."""
        kept = []
        for t in program.targets:
            unit = coordinated_unit(program, t)
            if unit is None:
                kept.append(t)
                continue
            station = self._station(unit, t, warnings)
            axes = station.axes(dialect)
            e = station.values(t, axes)
            if isinstance(e, str):
                program.not_corrected[id(t)] = e
                warnings.append(f"{t.where}: not corrected: {e}")
                program.uncorrected.append(f"{t.where}: not corrected: {e}")
                continue
            station.check_limits(t, e, axes)
            self.e[id(t)], self.unit[id(t)] = e, station.unit
            if t.frame in program.in_world:
                self.in_world.add(id(t))
            kept.append(t)
        program.targets = kept
        warnings += self._far_plates()
        return frozenset(self.e)

    def _far_plates(self) -> list[str]:
        """A warning for each positioner whose calibrated plate is, at this program's values, further
        from the nominal plate than a placement error of the cell file explains."""
        out = []
        for unit, station in self.stations.items():
            e = np.array([v for k, v in self.e.items() if self.unit[k] == unit])
            if not e.size:
                continue
            moved = pose_error(*station.plates(e)[::-1])
            mm, deg = np.linalg.norm(moved[:, :3], axis=1).max() * 1e3, np.rad2deg(
                np.linalg.norm(moved[:, 3:], axis=1).max())
            if mm > PLATE_MOVED_MM or deg > PLATE_MOVED_DEG:
                out.append(f"the calibrated {unit}'s plate is up to {mm:.1f} mm / {deg:.2f} deg from the "
                           "nominal cell's at this program's values: its targets move that much; check that "
                           "the calibrated cell is this cell's calibration")
        return out

    def _station(self, unit: str, t: Target, warnings: list[str]) -> Station:
        if unit.startswith(UNNAMED) and len(self.stations) == 1:  # the program does not name it
            (only,) = self.stations.values()
            said = f"the program moves with a unit it does not name ({unit[1:]}): taken as the cell's only " \
                   f"positioner, {only.unit}"
            if said not in warnings:
                warnings.append(said)
            return only
        found = self.stations.get(unit) or next((s for k, s in self.stations.items()
                                                 if k.upper() == unit.upper()), None)
        if found is None:
            unit = f"{unit[1:]}, which it does not name and" if unit.startswith(UNNAMED) else unit
            raise DataError(f"{t.where}: the program moves with mechanical unit {unit}, which is not in the "
                            f"cell (its positioners: {', '.join(sorted(self.stations)) or 'none'}); give the "
                            "cell file of this program's cell")
        return found

    def frames(self, targets: list[Target], W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The frames of ``targets`` in the world ``(N, 4, 4)`` (m) from their frames ``W``
        ``(N, 4, 4)``: ``(as the nominal controller puts them, where the calibrated cell has
        them)``; a frame on a plate is ``plate(e) @ W``, any other is ``W`` in both. A target
        taught in the world at e (:attr:`Program.in_world`) is on the plate at
        ``inv(nominal_plate(e)) @ W``: the controller has it at ``W``, the calibrated cell at
        ``calibrated_plate(e) @ inv(nominal_plate(e)) @ W``."""
        nominal, real = W.copy(), W.copy()
        for unit, station in self.stations.items():
            rows = np.array([i for i, t in enumerate(targets) if self.unit.get(id(t)) == unit], dtype=int)
            if rows.size:
                e = np.array([self.e[id(targets[i])] for i in rows])
                plate_nominal, plate_real = station.plates(e)
                world = np.array([id(targets[i]) in self.in_world for i in rows])
                on_plate = np.where(world[:, None, None], invert_transform(plate_nominal) @ W[rows], W[rows])
                nominal[rows] = plate_nominal @ on_plate
                real[rows] = plate_real @ on_plate
        return nominal, real


def cell_models(calibrated: Robot | Cell, nominal: Robot | Cell, arm: str | None = None
                ) -> tuple[Robot, Robot, CoordinatedProgram | None]:
    """``(calibrated arm, nominal arm, the cell's positioners)`` of the models a program is
    filtered with. Arms alone: as given, no positioner (None). Cells (the nominal cell file and
    the calibrated cell its calibration wrote, bodies in the tracker frame): the program's arm
    (``arm``: a body name or unit; default the cell's only arm) and each positioner, nominal and
    calibrated in the controller's world, which the anchor arm's identified frame {0} defines
    (:meth:`Cell.in_world`: ``world_T_tracker = nominal_anchor.base @ inv(calibrated_anchor.base)``):
    the anchor's calibrated base is its nominal one, another arm's is where the calibration found
    it in that world (:func:`robocal.deploy.compensation.controller_model` with the identity as
    the controller's base keeps it).

    Raises
    ------
    DataError
        One model a cell and the other not, a cell with several arms and no ``arm``, an ``arm``
        that is not one, an arm on a track with a positioner, a calibrated cell without the
        nominal cell's bodies.
    """
    cells = [isinstance(m, Cell) for m in (calibrated, nominal)]
    if not any(cells):
        return calibrated, nominal, None
    if not all(cells):
        given, missing = ("calibrated", "nominal") if cells[0] else ("nominal", "calibrated")
        raise DataError(f"the {given} model is a cell and the {missing} one is not: give both cell files "
                        "(the nominal cell, and the calibrated cell its calibration wrote)")
    arm = _program_arm(nominal, arm)
    if nominal.arms[arm].external_axes and nominal.positioners:
        raise DataError(f"the cell {nominal.name!r} has an arm on a track and a positioner: programs of such "
                        "a cell are not filtered yet (an arm on a track alone, or an arm with positioners)")
    missing = sorted(set(nominal.bodies) - set(calibrated.bodies))
    if missing:
        raise DataError(f"the calibrated cell {calibrated.name!r} has no body {missing[0]!r} of the cell "
                        f"{nominal.name!r} (it has {', '.join(calibrated.bodies)}): give this cell's "
                        "calibration")
    try:
        world = nominal.in_world({name: calibrated.body(name) for name in nominal.bodies})
    except ModelError as exc:
        raise DataError(f"the calibrated cell does not fit the cell {nominal.name!r}: {exc}") from None
    stations = {p.unit: Station(p.unit, p.chain, world.positioners[name].chain, p.external_axes)
                for name, p in nominal.positioners.items()}
    # the controller's flange carries the program's tool data, not the SMR the cell's model calls its tool
    return world.controller_arm(arm), nominal.controller_arm(arm), CoordinatedProgram(stations)


def _program_arm(cell: Cell, arm: str | None) -> str:
    """The body name of the arm a program drives: ``arm`` (a body name or unit), else the only one
    (`Cell.pick`, its refusal said with the option and the arms' units)."""
    try:
        return cell.pick("arm", arm)
    except DataError as exc:
        arms = ", ".join(f"{n} ({cell.arm_units[n]})" for n in cell.arms) or "none"
        if arm is None:
            raise DataError(f"the cell {cell.name!r} has arms {arms}: name the arm whose program this is "
                            "(--arm NAME or its unit)") from None
        raise DataError(f"--arm {arm}: not an arm of the cell {cell.name!r} (its arms: {arms}): "
                        f"{exc}") from None
