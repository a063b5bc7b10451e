"""A robot on a linear track (a 7th axis): the cell file and the chain it stands for.

The cell file is a model file next to a robot (docs/model-yaml.md)::

    units: {length: mm, angle: deg}
    name: kr210 on a 6 m track
    robot: kuka_kr210_r2700            # a catalog name or a model file (relative to this file)
    track: {direction: [1, 0, 0], limits: [0, 6000]}   # unit vector in the world frame; e1 range
    mount: {xyz: [0, 0, 0], rpy: [0, 0, 0]}            # carriage at e1 = 0 -> robot base

Its forward kinematics is ``world_T_tcp = [I, direction * e1] @ mount @ robot_fk(q)`` (robot_fk
with the robot's own base and tool frames). The cell is a chain like any other
(:class:`robocal.kinematics.model.Robot`, built by
:func:`robocal.kinematics.model.track_chain`, joints ``(e1, q1..q6)``): joint 1 is prismatic along
the track, so forward kinematics, the identification Jacobian, calibration and the files come
for free. The chain is built exactly:

- frame {0} (the model's base frame) has z along the track and its origin where the track line
  through the arm's first joint frame meets it (where a translation's line lies is free);
- link 1 is the prismatic joint with every constant zero (its d is the track's zero);
- link 2 is the arm's first joint re-expressed from frame {1}: alpha the angle from the track to
  the joint-1 axis about their common normal, theta the turn that puts the arm's frame {1} back,
  d the arm's own d1; links 3..7 are the arm's links 2..6 unchanged, and the tool is the arm's;
- a ``scale1`` joint-error term (the track encoder's scale, nominally 0) is declared.

Identifiability: the cell file's ``direction`` and ``mount`` rotation describe overlapping freedom
(turning the track direction and counter-turning the mount leaves the arm where it was), so a
calibration identifies the chain's parameters instead: the base frame (the track's direction and
position in the tracker frame), the track scale ``scale1``, and the mount as the arm's first
axis seen from the carriage (``alpha2``, ``theta2``); ``theta1``, ``d1``, ``a2`` and ``d2`` (where the
carriage frame sits on the track) are confounded with the base frame and dropped, which the result
reports. The calibrated cell is written as that chain (a model file
with ``type: prismatic`` on joint 1), which every command reads.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, short_repr
from robocal.kinematics.convert import PARALLEL_TOL, default_parallel
from robocal.kinematics.fk import LinkArrays
from robocal.kinematics.model_file import (
    MAX_DESCRIPTION,
    MAX_NAME,
    _frame,
    _mapping,
    _numbers,
    _text,
    _units,
    on_disk,
)
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z

CELL_KEYS = {"format", "name", "description", "units", "robot", "track", "mount"}
WORKCELL_KEYS = ("robots", "positioner", "positioners")  # any: a work cell (robocal.kinematics.workcell)
ARM_KEYS = {"model", "base", "unit", "track", "flange"}
SINGLE_ARM = "arm"  # the body name of the arm a work cell gives with ``robot:``
DIRECTION_TOL = 1e-6  # |norm - 1| of the track direction: a unit vector written to 6 digits
TRACK_SCALE = "scale1"  # the track encoder's scale error (a joint-error term of joint 1)


class CellFile(NamedTuple):
    """What a cell file says (module docstring), in SI units."""

    robot: str  # the arm: a catalog name, or a model file's path (resolved from the cell file's folder)
    direction: np.ndarray  # (3,) unit vector, world frame
    mount: np.ndarray  # (4, 4) carriage at e1 = 0 -> robot base, m
    limits: np.ndarray  # (2,) e1 range, m
    name: str | None  # None: "<arm's name> on a track"
    description: str
    length_unit: str = "m"  # the file's length unit (its offsets are checked in it against the arm's size)


def _resolve(spec, path: Path | None, where: str) -> str:
    """A catalog name, or a model file's path resolved from the cell file's folder."""
    if not isinstance(spec, str) or not spec.strip():
        raise ModelError(f"{where}: expected a catalog name or a model file, got {short_repr(spec)}")
    local = (path.parent if path is not None else Path(".")) / spec
    return str(local) if local.suffix or on_disk(local) else spec


def placement(spec, length_unit: str, angle: float, where: str) -> np.ndarray | None:
    """A body's placement in a cell (an arm's ``base``, a track's or a positioner's ``mount``) as
    `_frame` reads it in the file's length unit. Its size is judged against the arm's once the arm
    is known (`robocal.core.magnitudes.check_cell_offset`): a 500 mm riser written 0.5 in a file in
    mm is refused there, naming the unit it fits."""
    return _frame(spec, LENGTH_UNITS[length_unit], angle, where)


def _track(spec, length: float, where: str = "track") -> tuple[np.ndarray, np.ndarray]:
    """(unit direction (3,), e1 limits (2,) m) of a ``track`` mapping."""
    track = _mapping(spec, where, {"direction", "limits"}, {"direction", "limits"})
    direction = _numbers(track["direction"], f"{where}.direction", 3)
    if abs(np.linalg.norm(direction) - 1.0) > DIRECTION_TOL:
        raise ModelError(f"{where}.direction {direction.tolist()} is not a unit vector (norm "
                         f"{np.linalg.norm(direction):.6g}): give the track's direction in the world frame "
                         "with norm 1")
    limits = _numbers(track["limits"], f"{where}.limits", 2) * length
    if not limits[0] < limits[1]:
        raise ModelError(f"{where}.limits: lower {limits[0]:g} m is not below upper {limits[1]:g} m")
    return direction / np.linalg.norm(direction), limits


def read_cell(data: dict, path: Path | None = None) -> CellFile:
    """The contents of a cell mapping (the module docstring's file); ``robot:`` is a catalog name or
    a model file relative to ``path``'s folder. ModelError names the key."""
    _mapping(data, "the cell", CELL_KEYS, {"units", "robot", "track"})
    length_unit, angle_unit = _units(data)
    length = LENGTH_UNITS[length_unit]
    angle = ANGLE_UNITS[angle_unit]
    robot = _resolve(data["robot"], path, "robot")
    direction, limits = _track(data["track"], length)
    mount = placement(data.get("mount"), length_unit, angle, "mount")  # `mount:` left empty: none, as base:
    mount = np.eye(4) if mount is None else mount
    name = data.get("name")
    return CellFile(robot, direction, mount, limits,
                    None if name is None else _text(name, "name", MAX_NAME),
                    _text(data.get("description", ""), "description", MAX_DESCRIPTION), length_unit)


def named(value, where: str) -> dict:
    """A mapping of named entries (``robots:``, ``positioners:``), its names as text; ModelError for
    anything else."""
    if not isinstance(value, dict):
        raise ModelError(f"{where}: expected a mapping {{name: {{...}}}}, got {short_repr(value)}")
    return {str(k): v for k, v in value.items()}


def is_workcell(data) -> bool:
    """Whether a loaded model mapping is a work cell (several arms or a positioner:
    `robocal.kinematics.workcell`, or one ``robot:`` placed by its ``mount:`` without a track), not
    one robot (nor a robot on a track alone)."""
    return isinstance(data, dict) and (any(k in data for k in WORKCELL_KEYS)
                                       or ("robot" in data and "track" not in data))  # an arm on a riser


class ArmEntry(NamedTuple):
    """One arm of a work cell file, in SI units."""

    model: str | dict  # a catalog name, a model file's path (resolved), or an inline model mapping
    base: np.ndarray | None  # (4, 4) world -> the arm's base (with a track: carriage at e1 = 0 -> base)
    unit: str  # its mechanical unit in programs (ROB_1...); default its body name
    track: tuple[np.ndarray, np.ndarray] | None  # (unit direction (3,), e1 limits (2,) m) or None
    flange: np.ndarray | None = None  # (4, 4) the model's flange where its tool is not (a saved cell's)
    length_unit: str = "m"  # the file's length unit: ``base`` is checked in it against the arm's size
    key: str = "base"  # where ``base`` is in the file (robots.NAME.base, mount)


def read_arms(data: dict, path: Path | None = None) -> dict[str, ArmEntry]:
    """The arms of a work cell mapping, body name -> `ArmEntry`: ``robots: {name: {model, base,
    unit, track}}``, or one ``robot:`` (with ``track:`` and ``mount:`` as a track cell file; its
    body name ``arm``), or none (a positioner-only cell). ModelError names the key."""
    _mapping(data, "the cell", CELL_KEYS | set(WORKCELL_KEYS), {"units"})
    length_unit, angle_unit = _units(data)
    length, angle = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit]
    if "robots" in data:
        clash = sorted({"robot", "track", "mount"} & set(data))
        if clash:
            raise ModelError(f"robots: give the arms either as robots: {{name: ...}} or as one robot:, "
                             f"not both (found {clash})")
        arms = named(data["robots"], "robots")
        if not arms:
            raise ModelError("robots: expected at least one arm {name: {model, base, unit}}")
        out = {}
        for name, spec in arms.items():
            where = f"robots.{name}"
            spec = _mapping(spec, where, ARM_KEYS, {"model"})
            model = spec["model"] if isinstance(spec["model"], dict) else \
                _resolve(spec["model"], path, f"{where}.model")
            track = None if spec.get("track") is None else _track(spec["track"], length, f"{where}.track")
            flange = _frame(spec.get("flange"), length, angle, f"{where}.flange")
            out[name] = ArmEntry(model, _frame(spec.get("base"), length, angle, f"{where}.base"),
                                 _text(spec.get("unit", str(name)), f"{where}.unit", MAX_NAME), track, flange,
                                 length_unit, f"{where}.base")
        return out
    if "robot" not in data:
        stray = sorted({"track", "mount"} & set(data))
        if stray:
            raise ModelError(f"{stray}: a track and its mount belong to an arm (robot:)")
        return {}
    track = None if data.get("track") is None else _track(data["track"], length)
    return {SINGLE_ARM: ArmEntry(_resolve(data["robot"], path, "robot"),
                                 _frame(data.get("mount"), length, angle, "mount"), SINGLE_ARM, track,
                                 length_unit=length_unit, key="mount")}


def count_positioners(data: dict) -> int:
    """How many positioners a work cell mapping declares (``positioner:`` one, ``positioners:`` its
    entries)."""
    if "positioner" in data and "positioners" in data:
        raise ModelError("give either positioner: (one) or positioners: {name: ...}, not both")
    if "positioners" in data:
        return len(named(data["positioners"], "positioners"))
    return int("positioner" in data)


def chain_arrays(links: LinkArrays, base: np.ndarray, tool: np.ndarray, parallel: np.ndarray,
                 smr: np.ndarray, direction, mount: np.ndarray) -> dict:
    """Links, base, tool, parallel flags and SMR offsets (`robocal.kinematics.model.Robot`'s
    arguments) of the cell chain (module docstring) of an arm with ``links`` ``(n,)`` each,
    ``base`` and ``tool`` ``(4, 4)``, ``parallel`` ``(n,)`` and SMR offsets ``smr`` on a track
    along unit ``direction`` (world frame) with ``mount`` ``(4, 4)`` (carriage at e1 = 0 -> robot
    base, m)."""
    u = np.asarray(direction, float)
    P = np.asarray(mount, float) @ base
    G = P.copy()  # the arm's joint-1 frame before its joint: Rx(alpha1) Tx(a1) Ry(beta1) Rz(theta1)
    G[:3, 3] += links.a[0] * P[:3, 0]
    G[:3, :3] = P[:3, :3] @ rot_x(links.alpha[0]) @ rot_y(links.beta[0]) @ rot_z(links.theta[0])
    gz = G[:3, 2]
    normal = np.cross(u, gz)
    if np.linalg.norm(normal) > PARALLEL_TOL:
        x1 = normal / np.linalg.norm(normal)
    else:  # the track is parallel to joint 1 (a lift): any normal; the arm's x keeps theta small
        x1 = G[:3, 0] - (G[:3, 0] @ u) * u
        x1 /= np.linalg.norm(x1)
    F1 = make_transform(np.column_stack([x1, np.cross(u, x1), u]), G[:3, 3])
    alpha2 = float(np.arctan2(np.cross(u, gz) @ x1, u @ gz))
    R = F1[:3, :3] @ rot_x(alpha2)
    theta2 = float(np.arctan2(np.cross(R[:, 0], G[:3, 0]) @ gz, R[:, 0] @ G[:3, 0]))
    chain = {"alpha": np.r_[0.0, alpha2, links.alpha[1:]], "a": np.r_[0.0, 0.0, links.a[1:]],
             "beta": np.r_[0.0, 0.0, links.beta[1:]], "theta": np.r_[0.0, theta2, links.theta[1:]],
             "d": np.r_[0.0, links.d[0], links.d[1:]]}
    chain_parallel = np.r_[False, default_parallel([0.0, alpha2])[1], parallel[1:]]
    return {**chain, "base": F1, "tool": tool, "parallel": chain_parallel, "smr": smr}
