"""The robot catalog and one robot model as text (what ``robocal robots`` prints): each catalog
robot's reach, payload and class; a model's MDH + beta table (mm, deg), frames, limits and the
flange pose at a few joint sets."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.kinematics.catalog import catalog_descriptions, catalog_specs, positioner_names
from robocal.kinematics.cell_file import is_workcell
from robocal.kinematics.model import Robot, load_model
from robocal.kinematics.model_file import read_model_data
from robocal.kinematics.workcell import Cell, catalog_positioner, load_cell

SHOW_JOINTS_DEG = np.array([[0, 0, 0, 0, 0, 0], [30, -20, 15, 45, -60, 90], [-90, 40, -30, -120, 30, 0]],
                           dtype=float)
PAYLOAD_CLASSES = ((3.0, "light"), (20.0, "small"), (80.0, "medium"), (300.0, "heavy"))


def payload_class(kg: float | None) -> str:
    """The payload class of a vendor payload (kg): light <= 3, small <= 20, medium <= 80, heavy
    <= 300, else very heavy; '-' when unknown."""
    if kg is None:
        return "-"
    return next((label for top, label in PAYLOAD_CLASSES if kg <= top), "very heavy")


def _figure(value, unit: str, width: int) -> str:
    return f"{'-' if value is None else f'{value:g}{unit}':>{width}s}"


def catalog_listing() -> str:
    """One line per catalog robot: name, reach (mm), payload (kg), payload class, description; then,
    under their own heading, one line per catalog positioner: name, axes, payload, its description's
    first sentence.

    Examples
    --------
    >>> from robocal.kinematics.listing import catalog_listing
    >>> catalog_listing().splitlines()[0].split()
    ['name', 'reach', 'mm', 'payload', 'class', 'description']
    """
    specs = catalog_specs()
    lines = [f"{'name':20s} {'reach mm':>8s} {'payload':>9s}  {'class':12s} description"]
    for name, text in catalog_descriptions().items():
        reach, payload = specs[name]
        lines.append(f"{name:20s} {_figure(reach, '', 8)} {_figure(payload, ' kg', 9)}  "
                     f"{payload_class(payload):12s} {text}")
    lines += ["", "positioners (a cell file's positioner: model: NAME)",
              f"{'name':20s} {'axes':>8s} {'payload':>9s}  description"]
    for name in positioner_names():
        chain, payload = catalog_positioner(name)
        kinds = "".join("P" if slides else "R" for slides in chain.prismatic)
        summary = chain.description.split(". ")[0]
        lines.append(f"{name:20s} {kinds:>8s} {_figure(payload, ' kg', 9)}  {summary}")
    return "\n".join(lines)


def describe(spec: str) -> str:
    """What ``robocal robots NAME`` prints: the `model_table` of a catalog positioner, `cell_table` of
    a work cell file, or the `model_table` of any model `load_model` reads (a catalog robot, a model
    file, a track cell file, a URDF)."""
    if spec in positioner_names():
        return model_table(catalog_positioner(spec)[0])
    path = Path(spec)
    if path.suffix.lower() in (".yaml", ".yml") and path.is_file() and is_workcell(read_model_data(path)):
        return cell_table(load_cell(path))
    return model_table(load_model(spec))


def cell_table(cell: Cell) -> str:
    """Each body of ``cell``: its name, kind, program unit and joint columns, then its `model_table`
    (its base in the cell's world)."""
    parts = [f"{cell.name}: {cell.description}".rstrip(": ") + f" (anchor: {cell.anchor})"]
    for name in cell.bodies:
        kind = "arm" if name in cell.arms else "positioner"
        columns = ", ".join(j.column for j in cell.joints(name))
        parts.append(f"\n== {kind} {name} (unit {cell.unit_of(name)}; columns {columns})\n"
                     + model_table(cell.body(name)))
    return "\n".join(parts)


def model_table(robot: Robot) -> str:
    """``robot``'s parameter table (mm, deg), base and tool frames, and the flange pose at a few
    joint sets (prismatic joints at 0).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.kinematics.listing import model_table
    >>> model_table(rc.Robot.from_catalog("kuka_kr16_2")).splitlines()[0].startswith("kuka_kr16_2: ")
    True
    """
    lines = [f"{robot.name}: {robot.description}",
             "\nmodified DH + beta (T_i = Rx(alpha) Tx(a) Ry(beta) Rz(theta + q) Tz(d))",
             f"{'joint':>5} {'alpha deg':>10} {'a mm':>10} {'beta deg':>9} {'theta deg':>10} {'d mm':>10}"
             f"  {'limits deg (mm)':>17}  parallel"]
    for i in range(robot.n_joints):
        slide = robot.prismatic[i]  # a prismatic joint: limits in mm, its value adds to d
        lo, hi = robot.limits[i] * 1e3 if slide else np.rad2deg(robot.limits[i])
        lines.append(f"{i + 1:5d} {np.rad2deg(robot.alpha[i]):10.3f} {robot.a[i] * 1e3:10.3f} "
                     f"{np.rad2deg(robot.beta[i]):9.3f} {np.rad2deg(robot.theta[i]):10.3f} "
                     f"{robot.d[i] * 1e3:10.3f}  {lo:8.1f} {hi:8.1f}  {'yes' if robot.parallel[i] else ''}"
                     + ("  prismatic (mm)" if slide else ""))
    for label, T in (("base", robot.base), ("tool", robot.tool)):
        with warnings.catch_warnings():  # pitch +-90 deg (a positioner's horizontal axis): yaw set to 0
            warnings.simplefilter("ignore", UserWarning)
            rpy = Rotation.from_matrix(T[:3, :3]).as_euler("xyz", degrees=True)
        xyz = np.round(T[:3, 3] * 1e3, 3).tolist()
        lines.append(f"{label}: xyz {xyz} mm, rpy {np.round(rpy, 3).tolist()} deg")
    q = np.zeros((len(SHOW_JOINTS_DEG), robot.n_joints))
    turning = np.flatnonzero(~robot.prismatic)  # the sample angles go to the revolute joints
    k = min(turning.size, SHOW_JOINTS_DEG.shape[1])
    q[:, turning[:k]] = SHOW_JOINTS_DEG[:, :k]
    T = robot.fk(np.deg2rad(q))  # prismatic joints at 0
    with warnings.catch_warnings():  # gimbal lock at pitch +-90 deg: scipy then sets yaw to 0
        warnings.simplefilter("ignore", UserWarning)
        rpy = Rotation.from_matrix(T[:, :3, :3]).as_euler("xyz", degrees=True)
    lines.append("\ntool pose (x y z mm, fixed-axis roll pitch yaw deg)"
                 + ("; prismatic joints at 0" if robot.has_prismatic else ""))
    for j in range(len(q)):
        lines.append(f"q = {np.array2string(q[j], precision=1, separator=', ')} deg  ->  "
                     f"xyz {np.array2string(T[j, :3, 3] * 1e3, precision=3, separator=', ')}  "
                     f"rpy {np.array2string(rpy[j], precision=3, separator=', ')}")
    return "\n".join(lines)
