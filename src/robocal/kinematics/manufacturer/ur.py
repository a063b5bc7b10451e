"""Universal Robots' factory calibration and the ROS driver's calibration YAML, both ways.

Two formats, one entry each way (`import_calibration`, `to_ur_calibration`):

* ``calibration.conf`` (on the controller, ``/root/.urcontrol``): an INI-style ``[mounting]``
  section with ``delta_theta``, ``delta_a``, ``delta_d``, ``delta_alpha`` (six values each, m and
  rad), checksums and ``calibration_status``. The controller's model is standard DH, each value
  nominal + delta (nominal theta 0): joint i is ``Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``,
  base = the controller's ``base`` frame, DH frame 6 = the flange (ROS-Industrial ``tool0``). Nearly
  parallel axes (joints 2, 3, 4) carry d of metres to hundreds of metres and theta deltas of
  radians there: the DH description of axes that are almost, not exactly, parallel.
* the ``ur_calibration`` YAML (Universal_Robots_ROS_Driver): ``kinematics: {shoulder, upper_arm,
  forearm, wrist_1, wrist_2, wrist_3: {x, y, z, roll, pitch, yaw}, hash}``, which ur_description's
  xacro composes as joint origins ``T(x, y, z) Rz(yaw) Ry(pitch) Rx(roll)`` (URDF rpy), each
  followed by the joint's ``Rz(q)``, in the controller's ``base`` frame; ``tool0`` is fixed on
  ``wrist_3_link`` by the flange joints (`XACRO_TOOL0`).

Both are read exactly into MDH + beta (`mdh_beta_from_lines`): the joint lines at zero
joints, common normals between non-parallel axes and Hayati's construction (beta) between the
axes the nominal model flags parallel, so no d grows with near-parallelism. Every conversion is
checked against the composition it came from (`SELF_CHECK_M`, `SELF_CHECK_RAD`).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.escape import comment_text
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, read_text, write_all
from robocal.core.yaml_load import load_yaml
from robocal.kinematics.catalog import catalog_entry, catalog_names
from robocal.kinematics.convert import (
    _DIST_TOL,
    PARALLEL_TOL,
    _frame,
    _last_frame,
    _normal_feet,
    _perp,
    _unit,
    first_frame,
)
from robocal.kinematics.model import MAX_ANGLE_RAD, Robot
from robocal.kinematics.model_file import dump_model
from robocal.kinematics.transforms import make_transform, rot_x, rot_y, rot_z
from robocal.kinematics.ur import nearest_ur_links
from robocal.kinematics.urdf_read import matrix_to_rpy, rpy_to_matrix

LINK_NAMES = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
ORIGIN_KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
DELTA_KEYS = ("delta_theta", "delta_a", "delta_d", "delta_alpha")
LINEARISED = 2  # calibration_status of a finished factory calibration (0 not initialised, 1 not linearised)
MAX_DELTA_M = 10_000.0  # |delta_a|, |delta_d| beyond this: not a calibration file (real ones reach ~500 m)
MAX_ORIGIN_M = 100.0  # a ur_calibration joint origin farther than this from its parent: not a UR
# How far the imported arm may be from its nominal model (link lengths, angles) before the file is
# judged to belong to another robot model: factory deltas are well below a millimetre and a degree
NOMINAL_GAP_M = 0.02
NOMINAL_GAP_RAD = np.deg2rad(2.0)
# Every conversion is checked against the composition it came from at these joint vectors
SELF_CHECK_M = 1e-11
SELF_CHECK_RAD = 1e-12
SELF_CHECK_POSES = 64
# ... plus what floating point allows: a composition with lengths up to L (a DH d of kilometres on
# nearly parallel axes) places its lines to ~L eps, and a direction taken over a lever l to L eps / l
ROUND_SLACK_ULPS = 20
FLANGE_ON_AXIS_TOL = 1e-12  # m / rad: tool0 off joint 6's axis by more cannot be written for the xacro


# ur_description: wrist_3_link -> flange rpy (0, -pi/2, -pi/2), flange -> tool0 rpy (pi/2, 0, pi/2)
XACRO_TOOL0 = make_transform(rpy_to_matrix((0.0, -np.pi / 2, -np.pi / 2))
                             @ rpy_to_matrix((np.pi / 2, 0.0, np.pi / 2)), np.zeros(3))


@dataclass(frozen=True)
class DHTable:
    """A standard DH table (m, rad), each ``(6,)``: joint i is
    Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)."""

    theta: np.ndarray
    d: np.ndarray
    a: np.ndarray
    alpha: np.ndarray


@dataclass(frozen=True)
class URDeltas:
    """The ``[mounting]`` deltas of a calibration.conf (m, rad, each ``(6,)``) and its status."""

    theta: np.ndarray
    a: np.ndarray
    d: np.ndarray
    alpha: np.ndarray
    status: int | None = None


@dataclass(frozen=True)
class ImportedCalibration:
    """An imported factory calibration: the model, the format read and notes for the user.

    Attributes
    ----------
    robot : Robot
        The calibrated model (MDH + beta, the catalog robot's base and tool).
    kind : str
        The format read: "calibration.conf" or "ur_calibration YAML".
    notes : list of str
        What the user should know about the reading (one sentence each).
    warnings : list of str
        Always empty: what matters is in ``notes`` (the result protocol).

    See Also
    --------
    robocal.kinematics.manufacturer.ur.import_calibration : The import that returns it.

    Examples
    --------
    `import_calibration` returns one (its example writes a file and reads it back); by hand:

    >>> import robocal as rc
    >>> from robocal.kinematics.manufacturer.ur import ImportedCalibration
    >>> ImportedCalibration(rc.Robot.from_catalog("ur5e"), "ur_calibration YAML", []).kind
    'ur_calibration YAML'
    """

    robot: Robot
    kind: str  # "calibration.conf" or "ur_calibration YAML"
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # what matters is said in ``notes``: none

    def summary(self) -> str:
        """The format read and the notes, one line each.

        Returns
        -------
        str
            The summary text.
        """
        return "\n".join([f"{self.robot.name}: {self.kind} read (exact to its own composition)",
                          *(f"note: {note}" for note in self.notes)])

    def to_dict(self) -> dict:
        """The format read, the notes and the model YAML.

        Returns
        -------
        dict
            The format, the notes and the model YAML (JSON-ready).
        """
        return {"kind": self.kind, "notes": list(self.notes), "model_yaml": dump_model(self.robot)}

    def write(self, output) -> list[str]:
        """Write the model YAML (atomically); the paths written.

        Parameters
        ----------
        output : str or pathlib.Path
            The model YAML.

        Returns
        -------
        list of str
            The paths written.
        """
        write_all({output: dump_model(self.robot)})
        return [str(output)]


# ----------------------------------------------------------------- chains and lines
def dh_fk(table: DHTable, q: np.ndarray) -> np.ndarray:
    """Flange poses ``(N, 4, 4)`` (m) of the controller's DH chain for joints ``(N, 6)`` (rad)."""
    q = np.atleast_2d(np.asarray(q, float))
    T = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    for i in range(6):
        phi = table.theta[i] + q[:, i]
        c, s = np.cos(phi), np.sin(phi)
        ca, sa = np.cos(table.alpha[i]), np.sin(table.alpha[i])
        A = np.zeros((len(q), 4, 4))
        A[:, 0, 0], A[:, 0, 1], A[:, 0, 2], A[:, 0, 3] = c, -s * ca, s * sa, table.a[i] * c
        A[:, 1, 0], A[:, 1, 1], A[:, 1, 2], A[:, 1, 3] = s, c * ca, -c * sa, table.a[i] * s
        A[:, 2, 1], A[:, 2, 2], A[:, 2, 3] = sa, ca, table.d[i]
        A[:, 3, 3] = 1.0
        T = T @ A
    return T


def origins_fk(origins: np.ndarray, q: np.ndarray, tip: np.ndarray) -> np.ndarray:
    """Poses ``(N, 4, 4)`` of a URDF-style chain: ``origin_1 Rz(q_1) ... origin_n Rz(q_n) tip``."""
    q = np.atleast_2d(np.asarray(q, float))
    T = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
    for i, origin in enumerate(origins):
        Rz = np.broadcast_to(np.eye(4), (len(q), 4, 4)).copy()
        c, s = np.cos(q[:, i]), np.sin(q[:, i])
        Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1] = c, -s, s, c
        T = T @ origin @ Rz
    return T @ tip


def _dh_lines(table: DHTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint axes (unit ``(6, 3)``), a point on each ``(6, 3)`` and the flange at zero joints."""
    T = np.eye(4)
    u, p = [], []
    for i in range(6):
        u.append(T[:3, 2].copy())
        p.append(T[:3, 3].copy())
        T = T @ _dh_link(table, i)
    return np.array(u), np.array(p), T


def _dh_link(table: DHTable, i: int) -> np.ndarray:
    """The constant transform of DH row i at q = 0."""
    return (make_transform(rot_z(table.theta[i]), np.zeros(3))
            @ make_transform(np.eye(3), (0.0, 0.0, table.d[i]))
            @ make_transform(rot_x(table.alpha[i]), (table.a[i], 0.0, 0.0)))


def _origin_lines(origins: np.ndarray, tip: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Joint axes, points and the tip at zero joints of a URDF-style chain."""
    T = np.eye(4)
    u, p = [], []
    for origin in origins:
        T = T @ origin
        u.append(T[:3, 2].copy())
        p.append(T[:3, 3].copy())
    return np.array(u), np.array(p), T @ tip


def mdh_beta_from_lines(u: np.ndarray, p: np.ndarray, flange: np.ndarray, hayati) -> dict:
    """MDH + beta (alpha, a, beta, theta, d ``(n,)``, base, tool 4x4) of the chain whose joint i
    turns right-handedly about the line through ``p[i]`` along unit ``u[i]`` (world, m), with
    flange pose ``flange`` at zero joints.

    ``hayati[i]`` (axis i nominally parallel to axis i-1): frame {i-1} sits where the previous
    frame's x axis meets axis i-1 and its x axis points at the point where axis i crosses the plane
    through that origin normal to axis i-1 (Hayati), so a, d and beta stay of the arm's size however
    nearly parallel the axes are; elsewhere the common normal (beta = 0). The placement, signs
    (theta near 0) and the flange frame follow `robocal.kinematics.convert.mdh_from_axes`, so
    a nominal table converts to the catalog's values. Exact: the chain's joint lines and flange are
    those given.
    """
    n = len(u)
    hayati = np.asarray(hayati, bool)
    frames = [first_frame(u[0], p[0])]
    feet = [frames[0][:3, 3] + ((p[0] - frames[0][:3, 3]) @ frames[0][:3, 0]) * frames[0][:3, 0]]
    for i in range(n - 1):
        x_prev, z = frames[-1][:3, 0], u[i]
        w = np.cross(z, u[i + 1])
        if hayati[i + 1] or np.linalg.norm(w) < PARALLEL_TOL:
            o = feet[i]  # d_i = 0; the next axis crosses the plane normal to z through o at foot
            foot = p[i + 1] + ((o - p[i + 1]) @ z) / (u[i + 1] @ z) * u[i + 1]
        else:
            o, foot = _normal_feet(p[i], z, p[i + 1], u[i + 1], w)
        gap = foot - o
        if not (hayati[i + 1] or np.linalg.norm(w) < PARALLEL_TOL):
            # the common normal's direction from the axes (exact however short the normal)
            x = _unit(w) * (1.0 if gap @ w >= 0 else -1.0)
        else:
            x = _unit(gap) if np.linalg.norm(gap) > _DIST_TOL else _unit(_perp(x_prev, z))
        if x @ x_prev < -1e-9:  # prefer theta near 0: a may then be negative
            x = -x
        feet.append(o + (gap @ x) * x)
        frames.append(_frame(x, z, o))
    frames.append(_last_frame(p[-1], u[-1], flange, frames[-1][:3, 0]))
    alpha, a, beta, theta, d = (np.zeros(n) for _ in range(5))
    for i in range(n):
        R0, o0, R1, o1 = frames[i][:3, :3], frames[i][:3, 3], frames[i + 1][:3, :3], frames[i + 1][:3, 3]
        zl = R0.T @ R1[:, 2]
        beta[i] = np.arcsin(np.clip(zl[0], -1.0, 1.0)) if hayati[i] else 0.0
        alpha[i] = np.arctan2(-zl[1], zl[2])
        a[i] = (feet[i] - o0) @ R0[:, 0]
        inner = R0 @ rot_x(alpha[i]) @ rot_y(beta[i])
        theta[i] = np.arctan2(np.cross(inner[:, 0], R1[:, 0]) @ R1[:, 2], inner[:, 0] @ R1[:, 0])
        d[i] = (o1 - feet[i]) @ R1[:, 2]
    tool = np.linalg.solve(frames[-1], flange)
    tool[3] = (0.0, 0.0, 0.0, 1.0)
    return {"alpha": alpha, "a": a, "beta": beta, "theta": theta, "d": d, "base": frames[0], "tool": tool}


# ----------------------------------------------------------------- the nominal model
def nominal_dh(name: str) -> DHTable:
    """The controller's nominal DH table (SI) of catalog UR robot ``name`` (its ``dh`` entry)."""
    entry = catalog_entry(name)
    if "dh" not in entry or len(entry["dh"]["theta"]) != 6 or not name.startswith("ur"):
        raise ModelError(f"{name} is not a Universal Robots arm of the catalog (ur3, ur5e, ur10e, ...): "
                         "a UR factory calibration needs the controller's nominal DH table")
    length = LENGTH_UNITS[entry["units"]["length"]]
    angle = ANGLE_UNITS[entry["units"]["angle"]]
    dh = entry["dh"]
    return DHTable(np.array(dh["theta"], float) * angle, np.array(dh["d"], float) * length,
                   np.array(dh["a"], float) * length, np.array(dh["alpha"], float) * angle)


def _robot(mdh: dict, nominal: Robot, name: str, description: str) -> Robot:
    return Robot(alpha=mdh["alpha"], a=mdh["a"], beta=mdh["beta"], theta=mdh["theta"], d=mdh["d"],
                 base=mdh["base"], tool=mdh["tool"], limits=nominal.limits, parallel=nominal.parallel,
                 name=name, description=description)


def self_check_tolerance(magnitude: float, lever: float) -> tuple[float, float]:
    """The self-check bounds (m, rad) of a composition whose lengths reach ``magnitude`` (m) and
    whose shortest link (the lever a direction is taken over) is ``lever`` (m): `SELF_CHECK_M`,
    `SELF_CHECK_RAD` plus `ROUND_SLACK_ULPS` ulps of ``magnitude`` (over ``lever`` for angles)."""
    slack = ROUND_SLACK_ULPS * np.finfo(float).eps * magnitude
    return SELF_CHECK_M + slack, SELF_CHECK_RAD + slack / max(lever, SELF_CHECK_M)


def _lever(nominal: Robot) -> float:
    """The nominal arm's shortest non-zero link length (m): the lever of its directions."""
    lengths = np.abs(np.r_[nominal.a, nominal.d])
    return float(lengths[lengths > 0].min(initial=1.0))


def _check_against(robot: Robot, reference, what: str, magnitude: float, lever: float) -> None:
    """``robot.fk`` equals ``reference(q)`` (flange poses) at fixed joint vectors within
    `self_check_tolerance` of the composition's ``magnitude`` and ``lever`` (m), else ModelError."""
    q = np.random.default_rng(0).uniform(-2 * np.pi, 2 * np.pi, (SELF_CHECK_POSES, 6))
    mine, ref = robot.fk(q), reference(q)
    dp = np.abs(mine[:, :3, 3] - ref[:, :3, 3]).max()
    dr = np.abs(mine[:, :3, :3] - ref[:, :3, :3]).max()
    tol_m, tol_rad = self_check_tolerance(magnitude, lever)
    if dp > tol_m or dr > tol_rad:
        raise ModelError(f"internal: the MDH + beta model of the {what} differs from its composition by "
                         f"{dp:.3g} m / {dr:.3g} rad (bounds {tol_m:.3g} m / {tol_rad:.3g} rad); please "
                         "report this file")


def _largest_gap(robot: Robot, nominal: Robot) -> tuple[str, float, bool]:
    """The link parameter farthest from the nominal's (relative to NOMINAL_GAP_M / _RAD): its
    name, its gap (m or rad) and whether it is beyond what a factory calibration changes."""
    worst = ("", 0.0, 0.0)
    for i in range(6):
        for f in ("alpha", "a", "beta", "theta", "d"):
            gap = getattr(robot, f)[i] - getattr(nominal, f)[i]
            if f in ("a", "d"):
                ratio = abs(gap) / NOMINAL_GAP_M
            else:
                gap = (gap + np.pi) % (2 * np.pi) - np.pi
                ratio = abs(gap) / NOMINAL_GAP_RAD
            if ratio > worst[2]:
                worst = (f"{f}{i + 1}", float(gap), ratio)
    return worst[0], worst[1], worst[2] > 1.0


def _check_nominal(robot: Robot, nominal: Robot, source: str, fits) -> None:
    """The imported arm is the nominal model's within what a factory calibration changes; else
    ModelError naming the parameter and the catalog URs it fits (``fits(name)``: the file's arm
    for catalog robot ``name``, or None)."""
    name, gap, bad = _largest_gap(robot, nominal)
    if not bad:
        return
    length = robot.parameter_units()[robot.parameter_names.index(name)] == "m"  # the model's own units
    size = f"{gap * 1e3:+.1f} mm" if length else f"{np.rad2deg(gap):+.2f} deg"
    others = [other for other in _ur_names() if other != nominal.name
              and (arm := fits(other)) is not None and not _largest_gap(arm, Robot.from_catalog(other))[2]]
    hint = f"it fits {', '.join(others)}" if others else "it fits no UR of the catalog"
    raise ModelError(f"{source}: {name} is {size} from the nominal {nominal.name}'s, more than a factory "
                     f"calibration changes: is it the calibration of another robot model ({hint})?")


def _ur_names() -> list[str]:
    """The catalog's Universal Robots arms (those with a nominal DH table)."""
    return [n for n in catalog_names() if n.startswith("ur") and "dh" in catalog_entry(n)]


# ----------------------------------------------------------------- calibration.conf
_ENTRY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(.*?)\s*$")


def parse_calibration_conf(text: str, where: str) -> URDeltas:
    """The ``[mounting]`` deltas of calibration.conf text; ModelError naming ``where`` and the key
    for anything missing or malformed."""
    section, values = None, {}
    for number, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith("[") and line.endswith("]"):
            section = line[1:-1].strip()
            continue
        match = _ENTRY.match(line)
        if match is None:
            raise ModelError(f"{where} line {number}: expected `key = value` or `[section]`, got "
                             f"{raw.strip()[:60]!r}")
        if section == "mounting":
            if match.group(1) in values:  # which one the controller reads is not known: neither is taken
                raise ModelError(f"{where} line {number}: {match.group(1)} is given twice in [mounting] "
                                 f"(first at line {values[match.group(1)][0]}): keep the controller's one")
            values[match.group(1)] = (number, match.group(2))
    if section is None and not values:
        raise ModelError(f"{where}: no [mounting] section: not a UR calibration.conf")
    missing = [k for k in DELTA_KEYS if k not in values]
    if missing:
        raise ModelError(f"{where}: [mounting] lacks {', '.join(missing)}: not a complete UR "
                         "calibration.conf")
    deltas = {}
    for key in DELTA_KEYS:
        number, value = values[key]
        if not (value.startswith("[") and value.endswith("]")):
            raise ModelError(f"{where} line {number}: {key} must be a bracketed list of 6 numbers")
        try:
            arr = np.array([float(v) for v in value[1:-1].split(",")])
        except ValueError:
            raise ModelError(f"{where} line {number}: {key} holds a value that is not a number") from None
        if arr.shape != (6,) or not np.isfinite(arr).all():
            raise ModelError(f"{where} line {number}: {key} must hold 6 finite numbers, got {arr.size}")
        bound = MAX_ANGLE_RAD if key in ("delta_theta", "delta_alpha") else MAX_DELTA_M
        if np.abs(arr).max() > bound:
            raise ModelError(f"{where} line {number}: {key} has {np.abs(arr).max():.6g} beyond +-{bound:g} "
                             f"({'rad' if bound == MAX_ANGLE_RAD else 'm'}): not a calibration value")
        deltas[key] = arr
    status = None
    if "calibration_status" in values:
        number, value = values["calibration_status"]
        try:
            status = int(value)
        except ValueError:
            raise ModelError(f"{where} line {number}: calibration_status must be an integer") from None
        if status == 0:
            raise ModelError(f"{where}: calibration_status = 0 (not initialised): the controller holds no "
                             "factory calibration; use the nominal model")
    return URDeltas(deltas["delta_theta"], deltas["delta_a"], deltas["delta_d"], deltas["delta_alpha"],
                    status)


def controller_table(deltas: URDeltas, nominal: DHTable) -> DHTable:
    """The controller's calibrated DH table: nominal + delta (nominal theta is 0)."""
    return DHTable(nominal.theta + deltas.theta, nominal.d + deltas.d, nominal.a + deltas.a,
                   nominal.alpha + deltas.alpha)


def from_calibration_conf(text: str, nominal_name: str, where: str = "calibration.conf",
                          name: str | None = None) -> ImportedCalibration:
    """The factory-calibrated arm of a calibration.conf for catalog UR robot ``nominal_name``:
    flange (DH frame 6) in the controller's base frame, joints as the controller counts them."""
    deltas = parse_calibration_conf(text, where)

    def arm(catalog_name: str) -> Robot:
        cat = Robot.from_catalog(catalog_name)
        lines = _dh_lines(controller_table(deltas, nominal_dh(catalog_name)))
        mdh = mdh_beta_from_lines(*lines, cat.parallel)
        return _robot(mdh, cat, name or f"{catalog_name}-factory",
                      f"factory calibration of a {catalog_name} read from {Path(where).name} (the "
                      "controller's DH + deltas, converted exactly to MDH + beta)")

    table = controller_table(deltas, nominal_dh(nominal_name))
    nominal = Robot.from_catalog(nominal_name)
    robot = arm(nominal_name)
    _check_against(robot, lambda q: dh_fk(table, q), "controller's DH table",
                   float(np.abs(np.r_[table.a, table.d]).max()), _lever(nominal))
    _check_nominal(robot, nominal, where, arm)
    notes = []
    if deltas.status not in (None, LINEARISED):
        notes.append(f"calibration_status = {deltas.status} (1: not linearised): the controller may not use "
                     "these deltas as read here; check the robot's calibration state")
    return ImportedCalibration(robot, "calibration.conf", notes)


# ----------------------------------------------------------------- ur_calibration YAML
def _origin(link: dict, where: str) -> np.ndarray:
    if not isinstance(link, dict) or set(map(str, link)) != set(ORIGIN_KEYS):
        got = sorted(map(str, link)) if isinstance(link, dict) else type(link).__name__
        raise ModelError(f"{where}: expected the keys {', '.join(ORIGIN_KEYS)}, got {got}")
    vals = []
    for key in ORIGIN_KEYS:
        v = link[key]
        if isinstance(v, bool) or not isinstance(v, int | float) or not np.isfinite(v):
            raise ModelError(f"{where}.{key}: expected a number, got {v!r:.40}")
        bound = MAX_ORIGIN_M if key in "xyz" else MAX_ANGLE_RAD
        if abs(v) > bound:
            raise ModelError(f"{where}.{key} = {v:.6g} is beyond +-{bound:g}: not a UR joint origin (m, rad)")
        vals.append(float(v))
    return make_transform(rpy_to_matrix(vals[3:]), vals[:3])


def read_ur_calibration(data, where: str) -> tuple[np.ndarray, str | None]:
    """Joint origins ``(6, 4, 4)`` (m) as the xacro composes them and the hash of a ur_calibration
    mapping (``kinematics: {shoulder: {x, y, z, roll, pitch, yaw}, ..., hash}``)."""
    if not isinstance(data, dict) or "kinematics" not in data:
        raise ModelError(f"{where}: expected a `kinematics:` mapping (a ur_calibration YAML)")
    kin = data["kinematics"]
    if not isinstance(kin, dict):
        raise ModelError(f"{where}: kinematics must be a mapping of the six links and hash")
    unknown = sorted(set(map(str, kin)) - {*LINK_NAMES, "hash"})
    missing = [k for k in LINK_NAMES if k not in kin]
    if unknown or missing:
        raise ModelError(f"{where}: kinematics must give {', '.join(LINK_NAMES)} (and hash); "
                         f"missing {missing}, unknown {unknown}")
    origins = np.array([_origin(kin[k], f"{where}: kinematics.{k}") for k in LINK_NAMES])
    digest = kin.get("hash")
    return origins, None if digest is None else str(digest)


def from_ur_calibration(text: str, nominal_name: str, where: str = "calibration.yaml",
                        name: str | None = None) -> ImportedCalibration:
    """The arm a ur_calibration YAML describes, as ur_description's xacro composes it (what ROS
    uses): tool0 in the controller's base frame, for catalog UR robot ``nominal_name``."""
    nominal = Robot.from_catalog(nominal_name)
    nominal_dh(nominal_name)  # a UR of the catalog
    origins, digest = read_ur_calibration(load_yaml(text, where, ModelError), where)
    lines = _origin_lines(origins, XACRO_TOOL0)

    def arm(catalog_name: str) -> Robot:
        cat = Robot.from_catalog(catalog_name)
        return _robot(mdh_beta_from_lines(*lines, cat.parallel), cat, name or f"{catalog_name}-ros",
                      f"{catalog_name} as ur_description composes the ur_calibration YAML "
                      f"{Path(where).name}" + (f" (hash {digest})" if digest else ""))

    robot = arm(nominal_name)
    _check_against(robot, lambda q: origins_fk(origins, q, XACRO_TOOL0), "ur_calibration YAML",
                   float(np.abs(origins[:, :3, 3]).max()), _lever(nominal))
    _check_nominal(robot, nominal, where, arm)
    return ImportedCalibration(robot, "ur_calibration YAML", [
        "read as ur_description's xacro composes it (URDF rpy = Rz(yaw) Ry(pitch) Rx(roll), tool0 on "
        "wrist_3): what ROS computes, which can differ from the controller's own model (import the "
        "controller's calibration.conf for that)"])


def import_calibration(path, nominal_name: str, name: str | None = None) -> ImportedCalibration:
    """A UR factory calibration file -- calibration.conf or a ur_calibration YAML, told apart by
    their content -- as a robocal model for catalog UR robot ``nominal_name``.

    Parameters
    ----------
    path : str or path
        The calibration file: the controller's calibration.conf (a ``[mounting]`` section) or a
        ur_calibration YAML (a ``kinematics:`` mapping, as ROS's ur_calibration writes).
    nominal_name : str
        The catalog UR robot it calibrates (e.g. "ur5e"): base, tool and limits come from it.
    name : str, optional
        The model's name; by default derived from the file.

    Returns
    -------
    ImportedCalibration
        The model, exactly the composition the file describes (self-checked to
        ``SELF_CHECK_M`` m and ``SELF_CHECK_RAD`` rad), the format read and notes.

    Raises
    ------
    ModelError
        An unreadable or malformed file (either format, a line or key named), a nominal that is
        not a catalog UR arm, or values farther from the nominal than a factory calibration.

    See Also
    --------
    robocal.kinematics.manufacturer.ur.ImportedCalibration : What it returns.
    robocal.kinematics.manufacturer.ur.to_ur_calibration : The way back, for the controller.
    rc.load_model : Load the model it writes.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.kinematics.manufacturer.ur import import_calibration, to_ur_calibration
    >>> nominal = rc.Robot.from_catalog("ur5e")
    >>> real = nominal.with_values({"a2": nominal.get("a2") - 0.0005})  # upper arm 0.5 mm longer
    >>> path = os.path.join(tempfile.mkdtemp(), "ur5e_calibration.yaml")
    >>> with open(path, "w") as f:
    ...     _ = f.write(to_ur_calibration(real, nominal))
    >>> imported = import_calibration(path, "ur5e")
    >>> imported.kind, len(imported.notes) > 0
    ('ur_calibration YAML', True)
    >>> abs(imported.robot.get("a2") - real.get("a2")) < 1e-9  # m: the longer arm read back
    True
    >>> q = np.array([[0.1, -1.2, 1.0, -0.5, 0.3, 0.2]])  # rad
    >>> bool(np.allclose(imported.robot.fk(q), real.fk(q), atol=1e-12))  # the same arm, m
    True
    """
    text = read_text(path, "UR calibration file", ModelError)
    if re.search(r"^\s*\[mounting\]", text, re.MULTILINE):
        return from_calibration_conf(text, nominal_name, str(path), name)
    if re.search(r"^\s*kinematics\s*:", text, re.MULTILINE):
        return from_ur_calibration(text, nominal_name, str(path), name)
    raise ModelError(f"{path}: neither a UR calibration.conf ([mounting] section) nor a ur_calibration "
                     "YAML (kinematics: mapping)")


# ----------------------------------------------------------------- export
def xacro_origins(robot: Robot, nominal: Robot) -> np.ndarray:
    """The six joint origins ``(6, 4, 4)`` (m) with which the xacro composes ``robot``'s geometry
    from the controller's base (``nominal.base``: frame {0} there) to its flange (``nominal.tool``
    in frame {6}, ROS tool0); ModelError when that flange is off joint 6's axis (the xacro fixes
    tool0 on wrist_3_link, so the YAML cannot hold it).

    Joint i's origin is ``Rx(alpha_i) Tx(a_i) Ry(beta_i) Rz(theta_i) Tz(d_i)`` (``Tz(d_i)`` commutes
    with the joint's ``Rz(q_i)``), so link i's frame is the model's frame {i}: for a UR that is
    where ur_description and the driver put it (shoulder_link d1 above the base, ...), and the
    meshes attached to the links stay in place."""
    if robot.n_joints != 6 or nearest_ur_links(*robot.links) is None:
        raise ModelError(f"{robot.name} is not a Universal Robots arm (six joints, axes 2-4 parallel, offset "
                         "wrist): a ur_calibration YAML describes one")
    origins = [make_transform(rot_x(robot.alpha[i]) @ rot_y(robot.beta[i]) @ rot_z(robot.theta[i]),
                              rot_x(robot.alpha[i]) @ np.array([robot.a[i], 0.0, 0.0]))
               @ make_transform(np.eye(3), (0.0, 0.0, robot.d[i])) for i in range(6)]
    origins[0] = nominal.base @ origins[0]
    # what follows joint 6 up to tool0, moved before Rz(q6): possible when it turns about z only
    rest = nominal.tool @ np.linalg.inv(XACRO_TOOL0)
    off = max(np.abs(rest[:2, 3]).max(), np.abs(rest[2, :2]).max(), np.abs(rest[:2, 2]).max())
    if off > FLANGE_ON_AXIS_TOL:
        raise ModelError(f"the flange (tool0) of {nominal.name} is off joint 6's axis by {off:.3g} m/rad: "
                         "the xacro fixes tool0 on wrist_3_link, so a ur_calibration YAML cannot hold this "
                         "geometry")
    yaw = np.arctan2(rest[1, 0], rest[0, 0])
    origins[5] = origins[5] @ make_transform(rot_z(yaw), (0.0, 0.0, rest[2, 3]))
    return np.array(origins)


def ur_calibration_hash(origins: np.ndarray) -> str:
    """A ``calib_<digits>`` hash of the written origins (not the controller's: see the how-to)."""
    digest = hashlib.sha256(np.ascontiguousarray(origins[:, :3, :], dtype="<f8").tobytes()).digest()
    return f"calib_{int.from_bytes(digest[:8], 'big')}"


def not_representable(robot: Robot) -> str | None:
    """What a ur_calibration YAML cannot hold of ``robot`` (its joint-error terms), as a sentence.

    Parameters
    ----------
    robot : Robot
        The model to export.

    Returns
    -------
    str or None
        One sentence naming the joint-error terms lost in the export; None when there are none.

    See Also
    --------
    robocal.kinematics.manufacturer.ur.to_ur_calibration : Writes what it can hold.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.kinematics.manufacturer.ur import not_representable
    >>> nominal = rc.Robot.from_catalog("ur5e")
    >>> not_representable(nominal) is None  # rigid links, exact joints: all of it fits
    True
    >>> not_representable(nominal.with_joint_errors(["k2"]))[:37]
    'the joint-error terms k2 are not repr'
    """
    if robot.joint_errors is None:
        return None
    return (f"the joint-error terms {', '.join(robot.joint_errors.names)} are not representable in a "
            "ur_calibration YAML (rigid links, exact joints): ROS will compute the arm without them")


def to_ur_calibration(robot: Robot, nominal: Robot) -> str:
    """The ur_calibration YAML text whose xacro composition is ``robot``'s geometry from the
    controller's base to its flange (see `xacro_origins`; joint-error terms, the model's world
    frame and tool are not part of it: `not_representable`).

    Parameters
    ----------
    robot : Robot
        The calibrated model to export (a 6-axis UR geometry).
    nominal : Robot
        The catalog UR model it was calibrated from: its base is the controller's base frame,
        its tool the flange (tool0).

    Returns
    -------
    str
        ur_calibration YAML text: per link its origin ``x y z`` (m) and ``roll pitch yaw`` (rad),
        and a hash.

    Raises
    ------
    ModelError
        A flange off joint 6's axis (the xacro cannot hold it).

    See Also
    --------
    robocal.kinematics.manufacturer.ur.import_calibration : The way in.
    robocal.kinematics.manufacturer.ur.not_representable : What the controller's format cannot hold.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.kinematics.manufacturer.ur import to_ur_calibration
    >>> nominal = rc.Robot.from_catalog("ur5e")
    >>> text = to_ur_calibration(nominal, nominal)  # the nominal arm, exported
    >>> [line.strip() for line in text.splitlines() if line.startswith("  ") and not
    ...  line.startswith("    ")][:3]
    ['shoulder:', 'upper_arm:', 'forearm:']
    >>> "hash:" in text
    True
    """
    origins = xacro_origins(robot, nominal)
    lines = [f"# written by robocal from model {comment_text(robot.name)}: the calibrated geometry from the "
             "controller's",
             "# base to its flange (tool0), for ur_description's xacro (nominal "
             f"{comment_text(nominal.name)}).",
             "# The hash is robocal's: the ROS driver compares it with the robot's own and reports a",
             "# mismatch, which is expected for a calibration the controller does not run.",
             "kinematics:"]
    for link, T in zip(LINK_NAMES, origins, strict=True):
        values = [*T[:3, 3], *matrix_to_rpy(T[:3, :3])]
        lines.append(f"  {link}:")
        lines += [f"    {key}: {float(v) + 0.0!r}" for key, v in zip(ORIGIN_KEYS, values, strict=True)]
    lines.append(f"  hash: {ur_calibration_hash(origins)}")
    return "\n".join(lines) + "\n"
