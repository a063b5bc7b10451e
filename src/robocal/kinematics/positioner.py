"""A positioner (a tilt-and-turn table, a turntable, a headstock) as a robocal chain.

A positioner is 1-3 revolute or prismatic axes given the way a URDF gives joints: each axis
``{type, axis, origin, rpy, limits}`` with ``origin`` (m) and ``rpy`` (rad, URDF's fixed-axis
roll-pitch-yaw) the pose of the axis' frame in the previous axis' frame at zero (the first axis'
in the positioner's base frame, the mount), ``axis`` the unit direction it turns about (right hand)
or slides along in its own frame. Its forward kinematics is::

    world_T_plate(e) = mount @ O_1 @ J_1(e_1) @ O_2 @ J_2(e_2) ... @ plate

with ``O_i`` the origin transform and ``J_i`` the joint motion (a rotation by ``e_i`` about the axis,
or a translation by ``e_i`` along it). `positioner_chain` converts it exactly to modified DH +
beta (`robocal.kinematics.urdf_read.lines_to_chain`, the URDF import's conversion: common normals,
Hayati's beta on nearly parallel consecutive axes), so the positioner is a `Robot`: its base is the
mount (world -> frame {0}), its tool the plate frame, its joints its axes. Forward kinematics, the
identification Jacobian, priors and the model files come with it.

Refused, with one line naming the cause: no axis or more than `MAX_AXES`, a zero axis, an axis
that is not a unit vector beyond `robocal.kinematics.cell_file.DIRECTION_TOL` (within it the
axis is normalised), two consecutive revolute axes on one line (coaxial: the second adds no
motion, hence no information), two consecutive prismatic axes along one direction, reversed limits,
a prismatic axis without limits.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import short_repr
from robocal.kinematics.cell_file import DIRECTION_TOL
from robocal.kinematics.model import Robot
from robocal.kinematics.prior_spec import POSITIONER_CLASS, PriorSpec
from robocal.kinematics.transforms import make_transform, transform_points
from robocal.kinematics.urdf_read import HAYATI_DEG, lines_to_chain, rpy_to_matrix

MAX_AXES = 3
AXIS_KEYS = {"type", "axis", "origin", "rpy", "limits"}
AXIS_TYPES = ("revolute", "prismatic")
ZERO_AXIS = 1e-9  # norm of an axis vector below which it has no direction
COAXIAL_TOL = 1e-6  # |sin| of the angle and distance (m) under which two axes are one line
DEFAULT_TURN = (-2 * np.pi, 2 * np.pi)  # rad: a revolute axis without limits (a turn table's +-1 turn)


def _vector(value, count: int, where: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: expected {count} numbers, got {short_repr(value)}") from None
    if arr.shape != (count,) or not np.isfinite(arr).all():
        raise ModelError(f"{where}: expected {count} finite numbers, got {short_repr(value)}")
    return arr


def _axis(spec: Mapping, where: str) -> tuple[bool, np.ndarray, np.ndarray, np.ndarray | None]:
    """(prismatic, unit axis (3,), origin transform (4, 4), limits (2,) or None) of one axis (SI)."""
    if not isinstance(spec, Mapping):
        raise ModelError(f"{where}: expected a mapping {{type, axis, origin, rpy, limits}}, got "
                         f"{short_repr(spec)}")
    unknown = sorted(set(map(str, spec)) - AXIS_KEYS)
    if unknown:
        raise ModelError(f"{where}: unknown key(s) {unknown}; known: {sorted(AXIS_KEYS)}")
    missing = sorted({"type", "axis"} - set(spec))
    if missing:
        raise ModelError(f"{where}: missing key(s) {missing}")
    if spec["type"] not in AXIS_TYPES:
        raise ModelError(f"{where}.type: expected revolute or prismatic, got {short_repr(spec['type'])}")
    prismatic = spec["type"] == "prismatic"
    axis = _vector(spec["axis"], 3, f"{where}.axis")
    norm = float(np.linalg.norm(axis))
    if norm < ZERO_AXIS:
        raise ModelError(f"{where}: zero axis {axis.tolist()}: give the direction it "
                         f"{'slides along' if prismatic else 'turns about'}")
    if abs(norm - 1.0) > DIRECTION_TOL:
        raise ModelError(f"{where}: axis {axis.tolist()} is not a unit vector (norm {norm:.6g})")
    origin = make_transform(rpy_to_matrix(_vector(spec.get("rpy", [0, 0, 0]), 3, f"{where}.rpy")),
                            _vector(spec.get("origin", [0, 0, 0]), 3, f"{where}.origin"))
    limits = None if spec.get("limits") is None else _vector(spec["limits"], 2, f"{where}.limits")
    return prismatic, axis / norm, origin, limits


def _check_lines(P: np.ndarray, Z: np.ndarray, prismatic: np.ndarray, where: str) -> None:
    """Refuse consecutive revolute axes on one line and consecutive prismatic axes along one
    direction (points ``P``, unit directions ``Z`` ``(n, 3)``, mount frame)."""
    for i in range(len(Z) - 1):
        parallel = np.linalg.norm(np.cross(Z[i], Z[i + 1])) < COAXIAL_TOL
        if not parallel or prismatic[i] != prismatic[i + 1]:
            continue
        if prismatic[i]:
            raise ModelError(f"{where} axes {i + 1} and {i + 2}: both prismatic along one direction "
                             "(the second adds no motion)")
        gap = P[i + 1] - P[i]
        if np.linalg.norm(gap - (gap @ Z[i]) * Z[i]) < COAXIAL_TOL:
            raise ModelError(f"{where} axes {i + 1} and {i + 2}: consecutive revolute axes are coaxial "
                             "(one line: the second adds no motion and no information)")


def check_chain(robot: Robot, where: str) -> None:
    """Refuse a chain that is no positioner: more than `MAX_AXES` joints, consecutive
    revolute axes on one line, consecutive prismatic axes along one direction (its joint lines at
    zero, whatever form it was given in: axes, a DH or MDH table, joints rows)."""
    if robot.n_joints > MAX_AXES:
        raise ModelError(f"{where}: a positioner has 1 to {MAX_AXES} axes, got {robot.n_joints}")
    frames = robot.fk(np.zeros((1, robot.n_joints)), frames=True)[1][0, 1:]  # joint i turns about {i+1}'s z
    _check_lines(frames[:, :3, 3], frames[:, :3, 2], robot.prismatic, where)


def positioner_chain(axes: Sequence[Mapping], mount: np.ndarray | None = None,
                     plate: np.ndarray | None = None, limits=None, name: str = "positioner",
                     description: str = "") -> Robot:
    """The `Robot` of a positioner given by its axes (the module docstring's form), exactly.

    Parameters
    ----------
    axes : sequence of mapping
        1-3 axes, each ``{"type": "revolute" | "prismatic", "axis": (3,), "origin": (3,) m,
        "rpy": (3,) rad, "limits": (2,)}`` (``origin``, ``rpy`` default zero; ``limits`` rad, m for a
        prismatic axis; a revolute axis without limits gets +-1 turn, a prismatic one needs them).
    mount : numpy.ndarray, shape (4, 4), optional
        World -> the positioner's base frame (m); default the identity.
    plate : numpy.ndarray, shape (4, 4), optional
        The last axis' frame -> the plate frame where the workpiece sits (m); default the identity.
    limits : array_like, shape (n, 2), optional
        The axes' limits (rad; m for prismatic), instead of each axis' ``limits``.
    name, description : str
        The chain's name and description.

    Returns
    -------
    Robot
        ``base`` the mount (composed with frame {0} on the first axis), ``tool`` the plate frame,
        joints the axes in order: ``robot.fk(e)`` is the plate's world pose.

    Raises
    ------
    ModelError
        One line naming the axis and the cause (see the module docstring).

    See Also
    --------
    rc.Positioner : A positioner built on the chain.
    rc.Robot : The chain is a robot of the positioner's axes.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.kinematics.positioner import positioner_chain
    >>> table = positioner_chain([
    ...     {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9]},    # tilt
    ...     {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25]}])  # turn
    >>> table.fk(np.zeros((1, 2)))[0, :3, 3].round(3)  # plate at zero, m
    array([0.  , 0.  , 1.15])
    >>> table.fk(np.array([[np.pi / 2, 0.0]]))[0, :3, 3].round(3)  # tilted 90 deg about x
    array([ 0.  , -0.25,  0.9 ])
    """
    if not isinstance(axes, Sequence) or isinstance(axes, str) or not 1 <= len(axes) <= MAX_AXES:
        count = len(axes) if isinstance(axes, Sequence) else short_repr(axes)
        raise ModelError(f"{name}: a positioner has 1 to {MAX_AXES} axes, got {count}")
    parsed = [_axis(spec, f"{name} axis {i + 1}") for i, spec in enumerate(axes)]
    prismatic = np.array([p[0] for p in parsed])
    if limits is not None:
        if any(p[3] is not None for p in parsed):
            raise ModelError(f"{name}: give the limits either per axis or as limits=, not both")
        lims = np.asarray(limits, dtype=float)
        if lims.shape != (len(axes), 2):
            raise ModelError(f"{name}: limits must be {len(axes)} (lower, upper) pairs, got shape "
                             f"{lims.shape}")
    else:
        lims = np.array([DEFAULT_TURN if p[3] is None and not p[0] else
                         (np.full(2, np.nan) if p[3] is None else p[3]) for p in parsed])
    for i, (lo, hi) in enumerate(lims):
        if prismatic[i] and np.isnan([lo, hi]).any():
            raise ModelError(f"{name} axis {i + 1}: a prismatic axis needs its limits (its travel)")
        if not lo < hi:
            raise ModelError(f"{name} axis {i + 1}: limits reversed: lower {lo:g} is not below upper {hi:g}")
    T = np.eye(4)  # the axes' frames at zero, in the mount frame (a joint at zero moves nothing)
    P, Z = [], []
    for _, axis, origin, _ in parsed:
        T = T @ origin
        P.append(T[:3, 3].copy())
        Z.append(T[:3, :3] @ axis)
    P, Z = np.array(P), np.array(Z)
    _check_lines(P, Z, prismatic, name)
    tip = T if plate is None else T @ np.asarray(plate, float)
    kw = lines_to_chain(P, Z, tip, lims, name, np.sin(np.deg2rad(HAYATI_DEG)), prismatic)
    base = kw["base"] if mount is None else np.asarray(mount, float) @ kw["base"]
    return Robot(**{**kw, "base": base, "description": description})



def with_positioner_priors(chain: Robot) -> Robot:
    """``chain`` with the positioner prior class (`robocal.kinematics.prior_spec.POSITIONER_CLASS`)
    where its priors name no class (a 3-axis positioner is no arm either); the chain's own scales
    and estimate kept. The one place the calibration of a positioner and its campaign plan take
    their priors from."""
    spec = chain.priors
    if spec is not None and spec.robot_class is not None:
        return chain
    return chain.with_priors(PriorSpec(POSITIONER_CLASS) if spec is None else
                             PriorSpec(POSITIONER_CLASS, spec.scales, spec.estimate))


def nests_in_last_frame(chain: Robot, nests: np.ndarray) -> np.ndarray:
    """The SMR offsets ``(K, 3)`` (m) of nests ``(K, 3)`` (m, plate frame) seen from the chain's last
    frame {n} (``tool @ nest``): how a positioner's chain carries its nests (SMR k is nest k, so
    ``chain.fk(e, smr=k)`` is nest k's world pose)."""
    return transform_points(chain.tool, nests)
