"""The ROS-Industrial 2-axis positioner data set as robocal inputs, with a fixed held-out split.

robot_cal_tools (github.com/Jmeyer1292/robot_cal_tools, Apache-2.0; its successor
ros-industrial/industrial_calibration ships the same file) publishes 205 real 6-D poses of a target
carried by a tilt-and-turn positioner, seen by a fixed sensor (no arm): ``SOURCE``. The file is
small, so a verbatim copy with its licence is kept in ``benchmarks/data/rosi_positioner/``
(README there); :func:`data_file` finds it, or the same file in a folder the user names.

Why a converter here and not an importer in ``robocal.data``: the file is the serialisation of
industrial_calibration's ``KinematicMeasurement`` set (two DH chains, ``camera_joints`` and
``target_joints``, joined by fixed frames), whose meaning depends on the example that wrote it (which
chain carries what); its only public instance is this data set, and robocal's canonical CSV already
carries 6-D poses with external-axis columns. So the one-off format is read here and written as that
CSV (``e1_deg, e2_deg, x_mm.., qw..qz``), which ``robocal calibrate`` reads like any other.

The nominal chain (``CELL``, ``benchmarks/data/rosi_positioner/cell.yaml``: a positioner-only
robocal cell file) is the repository's ``createTwoAxisPositioner()`` (standard DH rows
``(d, theta, r, alpha)``: axis 1 ``(0, 0, 0, -pi/2)``, axis 2 ``(-0.475 m, -pi/2, 0, 0)``, base
``T(2.2, 0, 1.6) Rx(pi/2)`` in the world) with the example's initial guesses
(``kinematic_calibration_example.launch``: the sensor at ``T(2.2, 0.7, 1.075)`` in the world, the
target at ``(0.17, -0.65, 0.5)``, quaternion ``(0.547419, 0.447585, -0.547419, -0.447585)`` on the
last DH frame). robocal's model of it (:func:`nominal_positioner`): the cell's positioner chain, a
2-joint `robocal.Robot` whose ``base`` is the positioner's DH base seen from the SENSOR (the
measurement frame) and whose ``tool`` is the target (the plate) on the turn axis' frame.

Split (``hold_out_mask``): pose ``i`` (0-based, in the file's order, which is time order) is held
out when ``i % HOLD_EVERY == HOLD_EVERY - 1``: 41 held out, 164 calibrate.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.core.errors import DataError

SOURCE = ("github.com/Jmeyer1292/robot_cal_tools @2089a06d11b13323cf6c358a89524231801e5b06 "
          "rct_examples/data/positioner_kinematic_measurements.yaml (Apache-2.0)")
FIXTURE = Path(__file__).resolve().parent / "data" / "rosi_positioner"
CELL = FIXTURE / "cell.yaml"  # the nominal positioner as a positioner-only cell file
POSITIONER = "rosi_positioner"  # its body name there
FILE_NAMES = ("measurements.yaml", "positioner_kinematic_measurements.yaml")  # industrial_calibration, rct
DATA_ENV = "ROBOCAL_ROSI_DATA"
HOLD_EVERY = 5  # every 5th pose is held out
QUATERNION_TOL = 1e-6  # |q| - 1 beyond this is not a rotation written to double precision: refused
REPOSITORY_MEAN_MM, REPOSITORY_MEAN_DEG = 2.0, 0.2  # what the repository's test asserts, in-sample

# the repository's nominal chain and initial guesses, SI (m, rad): CELL transcribes them (tested)
DH_D, DH_THETA, DH_R, DH_ALPHA = (0.0, -0.475), (0.0, -np.pi / 2), (0.0, 0.0), (-np.pi / 2, 0.0)
WORLD_T_POSITIONER = ((2.2, 0.0, 1.6), (np.pi / 2, 0.0, 0.0))  # translation, rotation vector
WORLD_T_SENSOR = ((2.2, 0.7, 1.075), (0.0, 0.0, 0.0))
MOUNT_T_TARGET = ((0.17, -0.65, 0.5), (0.447585, -0.547419, -0.447585, 0.547419))  # xyz, quaternion x,y,z,w


class DataUnavailableError(RuntimeError):
    """The data file is in none of the places looked at (the message says which)."""


def _frame(xyz, rotation: Rotation) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rotation.as_matrix()
    T[:3, 3] = xyz
    return T


def data_file(folder: str | Path | None = None) -> Path:
    """The measurements file: in ``folder`` (or ``$ROBOCAL_ROSI_DATA``) under one of its two
    repository names, else the copy kept in ``benchmarks/data/rosi_positioner``."""
    folder = folder or os.environ.get(DATA_ENV)
    places = [Path(folder)] if folder else [FIXTURE]
    for place in places:
        for name in FILE_NAMES:
            for path in (place / name, place / "rct_examples" / "data" / name,
                         place / "examples" / "data" / "kinematic_calibration" / name):
                if path.is_file():
                    return path
    raise DataUnavailableError(f"no {' or '.join(FILE_NAMES)} in {', '.join(map(str, places))} (the copy of "
                               f"{SOURCE} is expected there)")


def read_measurements(path: str | Path) -> rc.Measurements:
    """The file's observations as robocal ``pose`` measurements, in the file's order.

    Returns ``Measurements`` of kind ``pose``: joints ``(205, 2)`` rad (the positioner's axes,
    written ``e1_deg, e2_deg``), points ``(205, 3)`` m and rotations ``(205, 3, 3)``: the target
    in the sensor frame; ``source_row`` is the observation's index (1-based) in the file.
    Raises DataError (naming the observation) for a sensor on a moving chain (``camera_joints``
    not empty), a missing field, a joint count other than 2 or a quaternion that is not unit.
    """
    path = Path(path)
    try:
        entries = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise DataError(f"{path}: not a readable YAML file ({exc})") from None
    if not isinstance(entries, dict) or not entries:
        raise DataError(f"{path}: expected a mapping of observations (stamp: {{target_joints, pose}})")
    joints, xyz, quat = [], [], []
    for stamp, entry in entries.items():
        where = f"{path}, observation {stamp}"
        try:
            if entry.get("camera_joints"):
                raise DataError(f"{where}: the sensor moves (camera_joints {entry['camera_joints']}): only a "
                                "fixed sensor observing the positioner is read")
            q = [float(v) for v in entry["target_joints"]]
            pose = entry["pose"]
            xyz.append([float(pose[k]) for k in ("x", "y", "z")])
            quat.append([float(pose[k]) for k in ("qx", "qy", "qz", "qw")])
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise DataError(f"{where}: missing or non-numeric field ({exc})") from None
        if len(q) != 2:
            raise DataError(f"{where}: {len(q)} target joints, a 2-axis positioner has 2")
        if abs(np.linalg.norm(quat[-1]) - 1) > QUATERNION_TOL:
            raise DataError(f"{where}: quaternion norm {np.linalg.norm(quat[-1]):.9f} is not 1")
        joints.append(q)
    return rc.Measurements.from_arrays(
        "pose", np.array(joints), points=np.array(xyz), rotations=Rotation.from_quat(quat).as_matrix(),
        external=2, source=f"{SOURCE}: target on a 2-axis positioner in a fixed sensor's frame")


def nominal_cell() -> rc.Cell:
    """The positioner-only cell file ``CELL`` (the repository's chain and guesses in its world)."""
    return rc.load_cell(CELL)


def nominal_positioner() -> rc.Robot:
    """The cell's positioner as a 2-joint robocal Robot in the measurement frame: base = its DH
    base in the sensor frame (the cell's mount seen from the sensor), tool = the target (plate)."""
    chain = nominal_cell().positioners[POSITIONER].chain
    world_sensor = _frame(WORLD_T_SENSOR[0], Rotation.from_rotvec(WORLD_T_SENSOR[1]))
    return chain.with_frames(base=np.linalg.inv(world_sensor) @ chain.base)


def hold_out_mask(n: int) -> np.ndarray:
    """``(n,)`` bool: the held-out poses (every ``HOLD_EVERY``-th, 0-based ``i % 5 == 4``)."""
    return np.arange(n) % HOLD_EVERY == HOLD_EVERY - 1


def load(folder: str | Path | None = None) -> tuple[rc.Robot, rc.Measurements, rc.Measurements]:
    """``(nominal, calibration, held_out)``: the nominal positioner and the fixed split."""
    data = read_measurements(data_file(folder))
    held = hold_out_mask(len(data))
    return nominal_positioner(), data.subset(np.flatnonzero(~held)), data.subset(np.flatnonzero(held))


def write_inputs(folder: str | Path, robot: rc.Robot, cal: rc.Measurements,
                 held: rc.Measurements) -> tuple[Path, Path, Path]:
    """``robocal calibrate``'s inputs in ``folder``: the calibration and held-out CSVs and the
    nominal model YAML (``rosi_cal.csv``, ``rosi_held.csv``, ``rosi_positioner.yaml``)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = folder / "rosi_cal.csv", folder / "rosi_held.csv", folder / "rosi_positioner.yaml"
    cal.save(paths[0])
    held.save(paths[1])
    robot.save(paths[2])
    return paths


def main(argv: list[str] | None = None) -> None:
    """``python benchmarks/rosi_positioner.py OUT_DIR [--data DIR]``: write the split and the
    nominal model for ``robocal calibrate OUT_DIR/rosi_cal.csv --robot OUT_DIR/rosi_positioner.yaml
    --validate OUT_DIR/rosi_held.csv``."""
    parser = argparse.ArgumentParser(description=main.__doc__.split("\n")[0])
    parser.add_argument("out_dir")
    parser.add_argument("--data", help="folder holding the measurements file (default: the kept copy)")
    args = parser.parse_args(argv)
    for path in write_inputs(args.out_dir, *load(args.data)):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
