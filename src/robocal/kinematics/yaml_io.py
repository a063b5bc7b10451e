"""Robot model YAML: SI values written with full precision (exact round trip), units declared.

Hand-written files may declare ``units: {length: mm, angle: deg}``; base/tool may be given as
``xyz`` plus ``rotation`` (3x3 rows), ``rpy`` (fixed-axis X-Y-Z, i.e. extrinsic xyz) or ``rotvec``.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import yaml

from robocal.errors import DataError, ModelError
from robocal.kinematics.model import LINK_FIELDS, Robot
from robocal.kinematics.transforms import make_transform, rotvec_to_matrix

FORMAT = "robocal-model/1"
_LENGTH = {"m": 1.0, "mm": 1e-3}
_ANGLE = {"rad": 1.0, "deg": np.pi / 180.0}


def write_atomic(path, text: str) -> None:
    """Write text to ``path`` via a temporary file and rename (never a half-written file)."""
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent or ".", prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise DataError(f"cannot write {path}: {exc.strerror} (does its folder exist and is it "
                        "writable?)") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes the file private; outputs follow the umask
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _frame_dict(T: np.ndarray) -> dict:
    return {"xyz": T[:3, 3].tolist(), "rotation": T[:3, :3].tolist()}


def robot_to_dict(robot: Robot) -> dict:
    """Plain-data form of a robot (SI units)."""
    joints = []
    for i in range(robot.n_joints):
        j = {f: float(getattr(robot, f)[i]) for f in LINK_FIELDS}
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
        "nominal": dict(zip(robot.parameter_names, robot.nominal.tolist(), strict=True)),
    }
    if len(robot.smr):
        out["smr"] = robot.smr.tolist()
    if robot.opw is not None:
        out["opw"] = robot.opw
    if robot.joint_errors is not None:
        out["joint_errors"] = robot.joint_errors.to_dict()
    return out


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelError(f"{where}: expected a number, got {value!r}")
    return float(value)


def _parse_frame(spec, length: float, angle: float, where: str) -> np.ndarray:
    if spec is None:
        return np.eye(4)
    if not isinstance(spec, dict):
        raise ModelError(f"{where}: expected a mapping with xyz and rotation/rpy/rotvec")
    xyz = np.array([_number(v, f"{where}.xyz") for v in spec.get("xyz", [0, 0, 0])]) * length
    if xyz.shape != (3,):
        raise ModelError(f"{where}.xyz must have 3 values")
    keys = [k for k in ("rotation", "rpy", "rotvec") if k in spec]
    if len(keys) > 1:
        raise ModelError(f"{where}: give only one of rotation, rpy, rotvec")
    if not keys:
        R = np.eye(3)
    elif keys[0] == "rotation":
        R = np.array([[_number(v, f"{where}.rotation") for v in row] for row in spec["rotation"]])
        if R.shape != (3, 3):
            raise ModelError(f"{where}.rotation must be 3 rows of 3 numbers")
    else:
        v = np.array([_number(x, f"{where}.{keys[0]}") for x in spec[keys[0]]]) * angle
        if v.shape != (3,):
            raise ModelError(f"{where}.{keys[0]} must have 3 values")
        if keys[0] == "rotvec":
            R = rotvec_to_matrix(v)
        else:
            from scipy.spatial.transform import Rotation

            R = Rotation.from_euler("xyz", v).as_matrix()
    return make_transform(R, xyz)


def robot_from_dict(data) -> Robot:
    """Robot from the plain-data form; every problem is a ModelError naming the field."""
    if not isinstance(data, dict):
        raise ModelError("a robot model file must be a YAML mapping with 'joints'")
    units = data.get("units", {})
    if not isinstance(units, dict) or "length" not in units or "angle" not in units:
        raise ModelError("the model must declare units: {length: m|mm, angle: rad|deg}")
    if units["length"] not in _LENGTH or units["angle"] not in _ANGLE:
        raise ModelError(f"unknown units {units}: length m|mm, angle rad|deg")
    length, angle = _LENGTH[units["length"]], _ANGLE[units["angle"]]
    joints = data.get("joints")
    if not isinstance(joints, list) or not joints:
        raise ModelError("the model needs a non-empty list 'joints'")
    cols = {f: [] for f in LINK_FIELDS}
    limits, parallel = [], []
    for i, j in enumerate(joints, 1):
        if not isinstance(j, dict):
            raise ModelError(f"joints[{i}] must be a mapping")
        unknown = set(j) - set(LINK_FIELDS) - {"parallel_to_previous", "limits"}
        if unknown:
            raise ModelError(f"joints[{i}]: unknown key(s) {sorted(unknown)}")
        for f in LINK_FIELDS:
            scale = length if f in ("a", "d") else angle
            cols[f].append(_number(j.get(f, 0.0), f"joints[{i}].{f}") * scale)
        lim = j.get("limits", [-np.pi / angle, np.pi / angle])
        if not isinstance(lim, list) or len(lim) != 2:
            raise ModelError(f"joints[{i}].limits must be [lower, upper]")
        limits.append([_number(v, f"joints[{i}].limits") * angle for v in lim])
        parallel.append(bool(j.get("parallel_to_previous", False)))
    smr = data.get("smr")
    if smr is not None:
        if not isinstance(smr, list) or any(not isinstance(r, list) or len(r) != 3 for r in smr):
            raise ModelError("smr must be a list of [x, y, z] flange-frame offsets")
        smr = np.array([[_number(v, "smr") for v in r] for r in smr]) * length
    base = _parse_frame(data.get("base"), length, angle, "base")
    tool = _parse_frame(data.get("tool"), length, angle, "tool")
    robot = Robot(**cols, base=base, tool=tool, limits=np.array(limits),
                  parallel=np.array(parallel), name=str(data.get("name", "robot")),
                  description=str(data.get("description", "")), opw=data.get("opw"), smr=smr)
    nominal = data.get("nominal")
    if nominal is not None:
        if not isinstance(nominal, dict) or set(nominal) != set(robot.parameter_names):
            raise ModelError("'nominal' must map every parameter name to its nominal value (SI)")
        vec = np.array([_number(nominal[k], f"nominal.{k}") for k in robot.parameter_names])
        from dataclasses import replace

        robot = replace(robot, nominal=vec)
    if data.get("joint_errors") is not None:
        from dataclasses import replace

        from robocal.kinematics.joint_errors import JointErrorModel

        robot = replace(robot, joint_errors=JointErrorModel.from_dict(data["joint_errors"], robot.n_joints))
    return robot


def save_robot(robot: Robot, path) -> None:
    """Save as YAML atomically."""
    write_atomic(path, yaml.safe_dump(robot_to_dict(robot), sort_keys=False))


def load_robot(path) -> Robot:
    """Load a model YAML safely (``yaml.safe_load``); errors name the file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ModelError(f"cannot read model file {path}: {exc.strerror}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ModelError(f"{path}: not valid (safe) YAML: {exc}") from None
    try:
        return robot_from_dict(data)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from None
