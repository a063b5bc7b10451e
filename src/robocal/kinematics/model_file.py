"""The robot model file (YAML, read by :func:`robocal.core.yaml_load.load_yaml`): one format for the
catalog, for the user's own robot and for :meth:`Robot.save`. docs/model-yaml.md documents it; in short::

    name: my_robot                      # optional: description, format
    reach_mm: 850                       # optional: the vendor's reach and payload, listed by
    payload_kg: 5                       #   `robocal robots` (the payload: payloads given are checked)
    units: {length: mm, angle: deg}     # required: the units of every number below
    # the geometry, exactly one of:
    opw:  {a1, a2, b, c1, c2, c3, c4, offsets: [6], signs: [6]}    # an OPW set
    dh:   {theta: [n], d: [n], a: [n], alpha: [n], type: [n]}      # standard DH table
    mdh:  {alpha: [n], a: [n], theta: [n], d: [n], beta: [n], type: [n]}  # modified DH (+ beta)
    joints: [{alpha, a, theta, d, beta, type, limits, parallel_to_previous}, ...]  # MDH rows (save)
    limits: [[lower, upper], ...]       # table forms (joints rows carry their own)
    base: {xyz: [3], rotation | rpy | rotvec: ...}   # optional, see below
    tool: {...}                         # optional
    smr: [[x, y, z], ...]               # optional extra SMR offsets on the flange
    nominal: {name: value, ...}         # optional: the nominal model (every parameter)
    joint_errors: {parameters: {name: value}}         # optional non-geometric terms (SI)
    priors: {class: service, zeros: 3deg, lengths: 10mm}  # optional: robocal.kinematics.prior_spec
    link_frames: {arm_left_4_link: 4, ...}  # optional: link names (a URDF's) -> frame 0..n

With a table form, ``base`` and ``tool`` wrap the frames the conversion produces (world ->
the table's base frame, the table's flange -> TCP); with ``joints`` rows they are the model's
frames themselves. ``opw`` next to ``joints`` is the OPW form of the nominal model (what
:meth:`Robot.save` writes for closed-form IK). Unknown and missing keys are errors that name the
key (and the joint).

``type`` (a row's, or a table's list with one entry per joint) is ``revolute`` (the default) or
``prismatic``: a prismatic joint's value (m) adds to its d, and its limits are lengths (the file's
length unit).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import ModelError, UnitError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, as_number, read_text, short_repr
from robocal.core.magnitudes import check_model_units
from robocal.core.yaml_load import dump_yaml, load_yaml
from robocal.kinematics.convert import default_parallel, dh_kwargs, mdh_kwargs, opw_kwargs, opw_parameters
from robocal.kinematics.joint_errors import JointErrorModel
from robocal.kinematics.link_names import check_link_frames
from robocal.kinematics.opw import GEOMETRY, OPWParameters
from robocal.kinematics.prior_spec import PriorSpec
from robocal.kinematics.transforms import make_transform, rotation_fault, rotvec_to_matrix

FORMAT = "robocal-model/1"
LINK_FIELDS = ("alpha", "a", "beta", "theta", "d")
FORMS = ("opw", "dh", "mdh", "joints")
# the vendor's figures (listed by `robocal robots`); payload_kg is also the model's rated payload
# (Robot.payload_kg), which payloads given are checked against: neither changes the geometry
INFO_KEYS = ("reach_mm", "payload_kg")
_TOP_KEYS = {"format", "name", "description", "units", "limits", "base", "tool", "smr", "nominal",
             "joint_errors", "priors", "link_frames", *INFO_KEYS, *FORMS}
_JOINT_KEYS = {*LINK_FIELDS, "type", "limits", "parallel_to_previous"}
JOINT_TYPES = ("revolute", "prismatic")
MAX_NAME = 200  # characters of a model's name
MAX_DESCRIPTION = 10_000
MAX_VALUES = 100_000  # YAML values in a model file once aliases are expanded (a model has hundreds)
_TABLE_KEYS = {"dh": ("theta", "d", "a", "alpha"), "mdh": ("alpha", "a", "theta", "d")}


def _text(value, where: str, max_len: int) -> str:
    """A name or description: a text (a plain number is read as its text) of at most ``max_len``."""
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise ModelError(f"{where}: expected a text, got a {type(value).__name__}")
    text = str(value)
    if len(text) > max_len:
        raise ModelError(f"{where}: {len(text)} characters, more than {max_len}")
    return text


def _numbers(values, where: str, count: int | None = None) -> np.ndarray:
    """A file's list of finite numbers as an array ``(count,)`` (as written: no unit applied);
    ModelError naming ``where`` otherwise."""
    if not isinstance(values, list):
        raise ModelError(f"{where}: expected a list of numbers, got {short_repr(values)}")
    if count is not None and len(values) != count:
        raise ModelError(f"{where}: expected {count} values, got {len(values)}")
    return np.array([as_number(v, f"{where}[{i}]", ModelError) for i, v in enumerate(values)])


def _mapping(value, where: str, allowed: set, required: set = frozenset()) -> dict:
    """A file's mapping with only ``allowed`` keys and every ``required`` one; ModelError naming
    ``where`` and the keys otherwise."""
    if not isinstance(value, dict):
        raise ModelError(f"{where}: expected a mapping, got {short_repr(value)}")
    unknown = sorted(set(map(str, value)) - allowed)
    if unknown:
        raise ModelError(f"{where}: unknown key(s) {unknown}; known: {sorted(allowed)}")
    missing = sorted(required - set(value))
    if missing:
        raise ModelError(f"{where}: missing key(s) {missing}")
    return value


def _frame(spec, length: float, angle: float, where: str) -> np.ndarray | None:
    """A file's frame ``{xyz, rotation | rpy | rotvec}`` as a transform ``(4, 4)`` (m), its values
    scaled by ``length`` (to m) and ``angle`` (to rad); None when not given."""
    if spec is None:
        return None
    spec = _mapping(spec, where, {"xyz", "rotation", "rpy", "rotvec"})
    xyz = _numbers(spec.get("xyz", [0, 0, 0]), f"{where}.xyz", 3) * length
    keys = [k for k in ("rotation", "rpy", "rotvec") if k in spec]
    if len(keys) > 1:
        raise ModelError(f"{where}: give only one of rotation, rpy, rotvec")
    if not keys:
        R = np.eye(3)
    elif keys[0] == "rotation":
        rows = spec["rotation"]
        if not isinstance(rows, list) or len(rows) != 3:
            raise ModelError(f"{where}.rotation must be 3 rows of 3 numbers")
        R = np.array([_numbers(r, f"{where}.rotation[{i}]", 3) for i, r in enumerate(rows)])
        fault = rotation_fault(R)
        if fault:
            raise ModelError(f"{where}.rotation is {fault}, no rotation: give a rotation matrix "
                             "(orthonormal, det +1), rpy or rotvec")
    else:
        v = _numbers(spec[keys[0]], f"{where}.{keys[0]}", 3) * angle
        R = rotvec_to_matrix(v) if keys[0] == "rotvec" else Rotation.from_euler("xyz", v).as_matrix()
    return make_transform(R, xyz)


def _limits(values, n: int, where: str) -> np.ndarray:
    """``(n, 2)`` limits as written (in the file's angle unit)."""
    if not isinstance(values, list) or len(values) != n:
        raise ModelError(f"{where}: expected {n} [lower, upper] pairs (one per joint)")
    return np.array([_numbers(v, f"{where}[{i}]", 2) for i, v in enumerate(values)])


def _joint_type(value, where: str) -> bool:
    """Whether a joint ``type`` entry says prismatic (revolute: False)."""
    if value not in JOINT_TYPES:
        raise ModelError(f"{where}: joint type must be one of {', '.join(JOINT_TYPES)}, got "
                         f"{short_repr(value)}")
    return value == "prismatic"


def _types(values, n: int, where: str) -> np.ndarray:
    """``(n,)`` prismatic flags of a table's ``type`` list."""
    if not isinstance(values, list) or len(values) != n:
        raise ModelError(f"{where}: expected {n} joint types (revolute or prismatic), one per joint")
    return np.array([_joint_type(v, f"{where}[{i}]") for i, v in enumerate(values)], bool)


def _units(data: dict) -> tuple[str, str]:
    """The file's (length, angle) unit names."""
    units = _mapping(data.get("units"), "units", {"length", "angle"}, {"length", "angle"}) \
        if "units" in data else None
    if units is None:
        raise ModelError("the model must declare its units: units: {length: m|mm, angle: rad|deg}")
    if not (isinstance(units["length"], str) and units["length"] in LENGTH_UNITS
            and isinstance(units["angle"], str) and units["angle"] in ANGLE_UNITS):
        raise ModelError(f"unknown units {units}: length m|mm, angle rad|deg")
    return units["length"], units["angle"]


def _opw(spec, length_unit: str, degrees: bool) -> OPWParameters:
    spec = _mapping(spec, "opw", {*GEOMETRY, "offsets", "signs"}, {*GEOMETRY, "offsets", "signs"})
    values = [as_number(spec[k], f"opw.{k}", ModelError) for k in GEOMETRY]
    return opw_parameters(*values, _numbers(spec["offsets"], "opw.offsets", 6),
                          _numbers(spec["signs"], "opw.signs", 6), degrees=degrees,
                          length_unit=length_unit)


def _joint_rows(rows, length: float, angle: float) -> dict:
    if not isinstance(rows, list) or not rows:
        raise ModelError("joints: expected a non-empty list of joint mappings")
    cols = {f: [] for f in LINK_FIELDS}
    limits, flags, prismatic = [], [], []
    for i, row in enumerate(rows, 1):
        where = f"joints[{i}] (joint {i})"
        row = _mapping(row, where, _JOINT_KEYS, {"alpha", "a", "theta", "d"})
        for f in LINK_FIELDS:
            scale = length if f in ("a", "d") else angle
            cols[f].append(as_number(row.get(f, 0.0), f"{where}.{f}", ModelError) * scale)
        prismatic.append(_joint_type(row.get("type", "revolute"), f"{where}.type"))
        lim = row.get("limits")
        default = [-np.inf, np.inf] if prismatic[-1] else [-np.pi, np.pi]
        limits.append(default if lim is None else
                      _numbers(lim, f"{where}.limits", 2) * (length if prismatic[-1] else angle))
        flag = row.get("parallel_to_previous")
        if flag is not None and not isinstance(flag, bool):
            raise ModelError(f"{where}.parallel_to_previous: expected true or false, got {short_repr(flag)}")
        flags.append(flag)
    kw = {f: np.array(v) for f, v in cols.items()}
    default = default_parallel(kw["alpha"])
    parallel = [bool(p) if f is None else f for f, p in zip(flags, default, strict=True)]
    return {**kw, "limits": np.array(limits), "parallel": np.array(parallel),
            "prismatic": np.array(prismatic)}


def _table(form: str, spec, length_unit: str, degrees: bool, n_limits, base, tool) -> dict:
    """Robot keyword arguments of a ``dh`` or ``mdh`` table (in the file's units), with the
    file's ``limits`` and frames (see the module docstring)."""
    keys = _TABLE_KEYS[form]
    optional = {"beta", "type"} if form == "mdh" else {"type"}
    spec = _mapping(spec, form, {*keys, *optional}, set(keys))
    n = len(spec[keys[0]]) if isinstance(spec[keys[0]], list) else 0
    cols = {k: _numbers(spec[k], f"{form}.{k}", n)
            for k in (*keys, *optional) if k in spec and k != "type"}
    if n == 0:
        raise ModelError(f"{form}: the table needs at least one joint")
    units = {"degrees": degrees, "length_unit": length_unit}
    prismatic = _types(spec["type"], n, f"{form}.type") if "type" in spec else np.zeros(n, bool)
    limits = None
    if n_limits is not None:  # in SI here: a prismatic joint's limits are lengths
        limits = _limits(n_limits, n, "limits") * np.where(prismatic, LENGTH_UNITS[length_unit],
                                                           ANGLE_UNITS["deg" if degrees else "rad"])[:, None]
    if form == "dh":
        kw = dh_kwargs(cols["theta"], cols["d"], cols["a"], cols["alpha"], **units, base=base, tool=tool)
    else:
        kw = mdh_kwargs(cols["alpha"], cols["a"], cols["theta"], cols["d"], cols.get("beta"), **units,
                        base=base, tool=tool)
    return {**kw, "limits": limits, "prismatic": prismatic}


def robot_kwargs(data) -> dict:
    """Keyword arguments of :class:`robocal.kinematics.model.Robot` from a model mapping (the
    module docstring's format); ModelError naming the key for anything malformed."""
    if not isinstance(data, dict):
        raise ModelError("a robot model must be a YAML mapping (see docs/model-yaml.md)")
    _mapping(data, "the model", _TOP_KEYS)
    for key in INFO_KEYS:
        if key in data and as_number(data[key], key, ModelError) <= 0:
            raise ModelError(f"{key} must be a positive number, got {data[key]!r}")
    length_unit, angle_unit = _units(data)
    length, angle, degrees = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit], angle_unit == "deg"
    forms = [f for f in ("joints", "mdh", "dh") if f in data] or (["opw"] if "opw" in data else [])
    if len(forms) != 1:
        raise ModelError("the model needs exactly one geometry: opw, dh, mdh or joints "
                         f"(found {[f for f in FORMS if f in data] or 'none'})")
    form = forms[0]
    opw = _opw(data["opw"], length_unit, degrees) if "opw" in data else None
    base = _frame(data.get("base"), length, angle, "base")
    tool = _frame(data.get("tool"), length, angle, "tool")
    if form == "joints":
        if "limits" in data:
            raise ModelError("limits: with joints rows, give each joint's limits in its row")
        kw = _joint_rows(data["joints"], length, angle)
        kw.update(base=base, tool=tool, opw=opw)
    elif form == "opw":
        limits = data.get("limits")
        kw = opw_kwargs(opw, degrees=degrees, base=base, tool=tool,
                        limits=None if limits is None else _limits(limits, 6, "limits"))
    else:
        kw = _table(form, data[form], length_unit, degrees, data.get("limits"), base, tool)
        kw["opw"] = opw
    n = len(kw["alpha"])
    given = "limits" in data or (form == "joints" and any(isinstance(r, dict) and "limits" in r
                                                          for r in data["joints"]))
    check_model_units(np.r_[kw["a"], kw["d"]], np.r_[kw["alpha"], kw["theta"], kw.get("beta", [])],
                      kw["limits"] if given else [], length_unit, angle_unit)
    if data.get("smr") is not None:
        smr = data["smr"]
        if not isinstance(smr, list):
            raise ModelError("smr: expected a list of [x, y, z] flange-frame offsets")
        kw["smr"] = np.array([_numbers(r, f"smr[{i}]", 3)
                              for i, r in enumerate(smr)]).reshape(-1, 3) * length
    if data.get("joint_errors") is not None:
        kw["joint_errors"] = JointErrorModel.from_dict(data["joint_errors"], n)
    if data.get("priors") is not None:
        kw["priors"] = PriorSpec.from_mapping(data["priors"])
    if data.get("link_frames") is not None:
        kw["link_frames"] = check_link_frames(data["link_frames"], n)
    if data.get("payload_kg") is not None:  # the rated payload: payloads given are checked against it
        kw["payload_kg"] = as_number(data["payload_kg"], "payload_kg", ModelError)
    kw["name"] = _text(data.get("name", "robot"), "name", MAX_NAME)
    kw["description"] = _text(data.get("description", ""), "description", MAX_DESCRIPTION)
    if data.get("nominal") is not None:  # a name -> value mapping (SI), resolved by the Robot
        nominal = data["nominal"]
        if not isinstance(nominal, dict):
            raise ModelError(f"nominal: expected a mapping {{parameter name: value (SI)}}, got "
                             f"{nominal!r:.60}")
        kw["nominal"] = {str(k): as_number(v, f"nominal.{k}", ModelError) for k, v in nominal.items()}
    return {k: v for k, v in kw.items() if v is not None}


def _frame_dict(T: np.ndarray) -> dict:
    return {"xyz": T[:3, 3].tolist(), "rotation": T[:3, :3].tolist()}


def robot_to_dict(robot) -> dict:
    """Plain-data form of a robot (SI units, ``joints`` rows: the calibrated MDH + beta)."""
    joints = []
    for i in range(robot.n_joints):
        j = {f: float(getattr(robot, f)[i]) for f in LINK_FIELDS}
        if robot.prismatic[i]:
            j["type"] = "prismatic"
        j["parallel_to_previous"] = bool(robot.parallel[i])
        j["limits"] = robot.limits[i].tolist()
        joints.append(j)
    out = {
        "format": FORMAT,
        "name": robot.name,
        "description": robot.description,
        "units": {"length": "m", "angle": "rad"},
        "joints": joints,
        "base": _frame_dict(robot.base),
        "tool": _frame_dict(robot.tool),
    }
    if len(robot.smr):
        out["smr"] = robot.smr.tolist()
    out["nominal"] = dict(zip(robot.geometry_names, robot.nominal.tolist(), strict=True))
    if robot.opw is not None:
        out["opw"] = robot.opw.to_dict()
    if robot.joint_errors is not None:
        out["joint_errors"] = robot.joint_errors.to_dict()
    if robot.priors is not None and (given := robot.priors.to_dict()):
        out["priors"] = given
    if robot.link_frames:
        out["link_frames"] = dict(robot.link_frames)
    if robot.payload_kg is not None:
        out["payload_kg"] = robot.payload_kg
    return out


def dump_model(robot) -> str:
    """The model YAML text (SI, full precision: an exact round trip); ModelError when the text
    would not read back as a model (a robot built in memory, e.g. from a URDF, beyond what a
    model file may hold: a file written then refused by ``Robot.load`` was exit 0 of export)."""
    text = dump_yaml(robot_to_dict(robot))
    try:
        robot_kwargs(load_yaml(text, "the model YAML", ModelError))
    except (ModelError, UnitError) as exc:
        raise ModelError(f"the model {robot.name!r} cannot be written as a model YAML: it would not read "
                         f"back ({exc})") from None
    return text


def is_cell(data) -> bool:
    """Whether a loaded model mapping is a cell file, a robot on a track (it names a ``robot`` and
    a ``track``: :mod:`robocal.kinematics.cell_file`)."""
    return isinstance(data, dict) and "track" in data and "robot" in data


def on_disk(path: Path, check=Path.exists) -> bool:
    """``check(path)`` (`Path.exists`, `Path.is_file`), False for a name no file system holds (a
    name of thousands of characters: OSError 'File name too long'): no file, a catalog name then."""
    try:
        return check(path)
    except OSError:
        return False


_OPEN: ContextVar[tuple[Path, ...]] = ContextVar("robocal_model_files_open", default=())


@contextmanager
def reading_model(path) -> Iterator[None]:
    """Mark the model or cell file ``path`` as being read while the block builds its model: a file
    that names itself, or two that name each other (a cell whose ``robot`` is the cell, a model file
    naming the cell that names it), is a ModelError naming the loop instead of a RecursionError."""
    key = Path(path).resolve()
    chain = _OPEN.get()
    if key in chain:
        loop = " -> ".join(p.name for p in (*chain[chain.index(key):], key))
        raise ModelError(f"a file that names itself ({loop}): give the arm's own model file or a "
                         "catalog name")
    token = _OPEN.set((*chain, key))
    try:
        yield
    finally:
        _OPEN.reset(token)


def read_model_data(path):
    """The parsed mapping of a model YAML file (:func:`robocal.core.yaml_load.load_yaml`: safe, YAML 1.2
    numbers, no duplicate keys, bounded)."""
    path = Path(path)
    return load_yaml(read_text(path, "robot model YAML file", ModelError), str(path), ModelError,
                     max_nodes=MAX_VALUES)
