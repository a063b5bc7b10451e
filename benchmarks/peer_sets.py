"""FIGAROH's public example data as robocal inputs, with fixed calibration / held-out splits.

FIGAROH (github.com/thanhndv212/figaroh, figaroh-examples, figaroh-plus; Apache-2.0) ships real
measurement sets with its examples. Each loader here reads one of them from a folder the user
names and returns a :class:`PeerSet`: ``(robot, calibration, held_out, description)``, the nominal
robocal model read from the example's URDF, the calibration and held-out `robocal.Measurements`,
and a sentence saying what was loaded and how it was split. Nothing is copied into the project.

The data folder holds the three repositories side by side (``figaroh-examples/``,
``figaroh-plus/``, ``figaroh/``, as cloned or unpacked). It is found by :func:`data_root`: the
folder given, else ``$ROBOCAL_FIGAROH_DATA``, else a cache the benchmark downloads into; when none
holds the data, :class:`DataUnavailableError` says why.

Splits are fixed and numbered (``split`` = 0, 1, ..; no randomness beyond fixed seeds). Split 0,
the default: within one session, every ``HOLD_EVERY``-th usable pose of the file (0-based index
``i % HOLD_EVERY == HOLD_EVERY - 1`` among the poses :func:`usable` keeps: mislabelled
motion-capture markers and corrupted joint readings are dropped first) is held out and the others
calibrate; split ``k >= 1`` holds out as many poses (``n // HOLD_EVERY``), drawn at random with the
generator seeded ``(SPLIT_SEED, k)`` (:func:`held_out_mask`): the same poses on every machine and
run, different from split to split. "Next day" calibrates on one session and judges on another,
the measurement frame being fitted again (a rigid motion, nothing else) on the judging session,
since a mobile robot and its motion capture are not where they were (`REFIT_FRAME`); its even
splits calibrate on the first day and judge the second, its odd splits the other way round
(judged on the markers the calibrating day saw): it has two distinct splits (:func:`n_splits`).

Sets (``SETS``; robocal's data model: a chain of joints from the URDF root to a tip link, SMRs
(markers) on the tip link, one measurement frame):

- ``talos``: TALOS torso (2 joints) + left arm (7), base ``universe`` (the URDF root), tip
  ``gripper_left_base_link``; one marker position per pose (m), 61 poses, file
  ``figaroh-examples/examples/talos/data/talos_left_arm_02_10_contact.csv``.
- ``tiago``: TIAGo prismatic torso lift + 7-joint arm (``tiago_48_schunk.urdf``, root to
  ``wrist_ft_tool_link``, FIGAROH's chain and tip frame), motion-capture markers on the hand,
  within one session: ``figaroh-examples/examples/tiago/data/calibration/mocap/
  qualysis_base_hand_calibration.csv`` (34 poses; columns x4..z4 repeat x3..z3, so 3 distinct
  markers: the repeated one is dropped).
- ``tiago_next_day``: the same robot, calibrated on 26 Nov, ``figaroh/data/tiago/exp_data_nov_64
  _2611.csv`` (the space is in the name: the corrected copy of ``exp_data_nov_64_2611.csv``, whose
  typed joints carry typos such as arm3 signs flipped, -0.36 for -0.036 and one 9551), 40 poses, 4
  markers; judged on 30 Nov, the qualysis file above (the corrected cut of
  ``exp_data_nov_64_3011.csv``: 34 of its 37 poses; its x3..z3 is the 26 Nov file's marker 4, found
  from the marker-to-marker distances), with the frame fitted again on 30 Nov.
- ``ur10_pose``: UR10 (``ur10_robot.urdf``, root to ``wrist_3_link``) with a camera and a
  checkerboard, ``figaroh-examples/examples/ur10/data/calibration.csv`` (23 poses): 6-D poses,
  x, y, z (m) and phix, phiy, phiz (rad) in FIGAROH's convention, roll-pitch-yaw
  (``pinocchio.rpy``: R = Rz(phiz) Ry(phiy) Rx(phix)). robocal has no camera-on-flange kind yet:
  the observation is loaded as a 6-DOF probe pose (the checkerboard-to-camera transform taken as
  the tool pose in a fixed camera's frame, which is what FIGAROH's model assumes as well: a world
  frame and a marker frame on the flange, both fitted).
- ``ur10_point``: the same poses, positions only.
- ``mate``: the MATE 3-joint arm (``figaroh-plus/examples/mate``, root ``Base`` to
  ``end_effector``), ``data/transformed_poses.csv`` (10 poses, joints in degrees, positions m).
  robocal's default refuses it: joint q1's sign looks flipped (the file counts it the other way).
- ``mate_q1_flipped``: the same file with q1's sign turned over, as that check says.

Markers on several bodies, a camera on the flange observing a fixed board (hand-eye) and a
contact measuring a tilt are not robocal kinds yet: where FIGAROH's example measures more than a
position or pose of the tip link's markers, the nearest robocal form is loaded as said above.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.kinematics.urdf_read import urdf_kwargs

DATA_ENV = "ROBOCAL_FIGAROH_DATA"
CACHE = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "robocal" / "figaroh"
REPOS = ("figaroh-examples", "figaroh-plus", "figaroh")
HOLD_EVERY = 3  # within a session: a third of the poses is held out (split 0: every third)
SPLIT_SEED = 44  # the random splits' generator is seeded (SPLIT_SEED, split): fixed, documented splits
REPEAT_TOL_M = 1e-9  # a marker column equal to an earlier one within this is a repeated column
LIMIT_SLACK = 0.05  # rad or m: a reading further past a URDF limit is corrupted (one at its stop reads on it)
RIGID_TOL_M = 5e-3  # m: marker-to-marker distances further from the median: mislabelled markers
TYPO_M = 0.03  # m: a judged pose of another session the nominal model misses by more (its worst honest
# pose: 14 mm) carries a typed joint's typo (the 26 Nov TIAGo file: 43 and 122 mm): not judged


class DataUnavailableError(RuntimeError):
    """FIGAROH's example data are not where they were looked for (the message says where)."""


class PeerSet(NamedTuple):
    """One benchmark set: the nominal model, calibration and held-out measurements, what they are."""

    robot: rc.Robot
    calibration: rc.Measurements
    held_out: rc.Measurements
    description: str


@dataclass(frozen=True)
class Session:
    """One file's poses in SI units: joints ``(N, n)`` rad or m (prismatic), marker positions
    ``(N, M, 3)`` m, orientations ``(N, 3, 3)`` (6-D sets) or None; ``rows`` the 1-based CSV
    line of each pose."""

    joints: np.ndarray
    markers: np.ndarray
    rotations: np.ndarray | None
    rows: np.ndarray
    file: Path
    ids: tuple[int, ...]  # each marker's identity (its SMR index), the same physical marker in every file

    def take(self, index: np.ndarray) -> Session:
        rot = None if self.rotations is None else self.rotations[index]
        return Session(self.joints[index], self.markers[index], rot, self.rows[index], self.file, self.ids)

    def with_markers(self, ids: tuple[int, ...]) -> Session:
        """The same poses with only the markers whose identity is in ``ids``, renumbered by their
        place in ``ids`` (robocal numbers the SMRs a calibration sees 0..k-1)."""
        keep = [k for k, i in enumerate(self.ids) if i in ids]
        return Session(self.joints, self.markers[:, keep], self.rotations, self.rows, self.file,
                       tuple(ids.index(self.ids[k]) for k in keep))


@dataclass(frozen=True)
class Spec:
    """Where a set's model and files are (relative to the data root) and how it is read."""

    urdf: str
    tip: str
    joint_columns: tuple[str, ...]
    files: tuple[str, ...]  # one file: split within it; two: calibrate on the first, judge on the second
    pose_6d: bool = False
    joints_deg: bool = False
    example: str = ""  # FIGAROH's example folder (its config, for the peer's run)
    config: str = ""
    marker_ids: tuple[tuple[int, ...] | None, ...] = ()  # per file: the marker behind x1, x2..; () 0, 1..
    flip: tuple[int, ...] = ()  # joints (0-based) whose file sign is turned over


TIAGO_JOINTS = ("torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8)))
OLD_NAMES = {"torso": "torso_lift_joint", **{f"arm{k}": f"arm_{k}_joint" for k in range(1, 8)}}
SPECS: dict[str, Spec] = {
    "talos": Spec("figaroh-examples/examples/talos/urdf/talos_full_v2.urdf", "gripper_left_base_link",
                  ("torso_1_joint", "torso_2_joint", *(f"arm_left_{k}_joint" for k in range(1, 8))),
                  ("figaroh-examples/examples/talos/data/talos_left_arm_02_10_contact.csv",),
                  example="figaroh-examples/examples/talos", config="config/talos_config.yaml"),
    "tiago": Spec("figaroh-examples/examples/tiago/urdf/tiago_48_schunk.urdf", "wrist_ft_tool_link",
                  TIAGO_JOINTS,
                  ("figaroh-examples/examples/tiago/data/calibration/mocap/qualysis_base_hand_calibration.csv",),
                  example="figaroh-examples/examples/tiago", config="config/tiago_config_mocap.yaml"),
    "tiago_next_day": Spec("figaroh-examples/examples/tiago/urdf/tiago_48_schunk.urdf", "wrist_ft_tool_link",
                           TIAGO_JOINTS,
                           ("figaroh/data/tiago/exp_data_nov_64 _2611.csv",
                            "figaroh-examples/examples/tiago/data/calibration/mocap/"
                            "qualysis_base_hand_calibration.csv"),
                           marker_ids=(None, (0, 1, 3, 3)),
                           example="figaroh-examples/examples/tiago",
                           config="config/tiago_config_mocap.yaml"),
    "ur10_pose": Spec("figaroh-examples/examples/ur10/urdf/ur10_robot.urdf", "wrist_3_link",
                      ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                       "wrist_2_joint", "wrist_3_joint"),
                      ("figaroh-examples/examples/ur10/data/calibration.csv",), pose_6d=True,
                      example="figaroh-examples/examples/ur10", config="config/ur10_config_new.yaml"),
    "ur10_point": Spec("figaroh-examples/examples/ur10/urdf/ur10_robot.urdf", "wrist_3_link",
                       ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                        "wrist_2_joint", "wrist_3_joint"),
                       ("figaroh-examples/examples/ur10/data/calibration.csv",),
                       example="figaroh-examples/examples/ur10", config="config/ur10_config_new.yaml"),
    "mate": Spec("figaroh-plus/examples/mate/urdf/mate.urdf", "end_effector", ("q_1", "q_2", "q_3"),
                 ("figaroh-plus/examples/mate/data/transformed_poses.csv",), joints_deg=True,
                 example="figaroh-plus/examples/mate", config="config/mate.yaml"),
    "mate_q1_flipped": Spec("figaroh-plus/examples/mate/urdf/mate.urdf", "end_effector",
                            ("q_1", "q_2", "q_3"),
                            ("figaroh-plus/examples/mate/data/transformed_poses.csv",), joints_deg=True,
                            example="figaroh-plus/examples/mate", config="config/mate.yaml", flip=(0,)),
}
REFIT_FRAME = frozenset({"tiago_next_day"})  # judged in another session's measurement frame


def data_root(folder: str | os.PathLike | None = None) -> Path:
    """The folder holding FIGAROH's repositories: ``folder``, else ``$ROBOCAL_FIGAROH_DATA``, else
    the download cache. Raises DataUnavailableError naming every place looked at."""
    tried = []
    for where, path in (("--data", folder), (f"${DATA_ENV}", os.environ.get(DATA_ENV)), ("cache", CACHE)):
        if path is None or str(path) == "":
            continue
        path = Path(path).expanduser()
        if all((path / r).is_dir() for r in REPOS):
            return path
        tried.append(f"{where} {path}")
    raise DataUnavailableError("FIGAROH's example data not found (looked at: "
                               + (", ".join(tried) or "nothing")
                               + f"); give --data DIR or ${DATA_ENV} with the folders {', '.join(REPOS)}")


def _read_csv(path: Path) -> tuple[list[str], list[list[str]]]:
    if not path.is_file():
        raise DataUnavailableError(f"{path} is missing: the data folder lacks this FIGAROH example's file")
    with path.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and any(c.strip() for c in r)]
    return [h.strip() for h in rows[0]], rows[1:]


def read_session(path: Path, spec: Spec, ids: tuple[int, ...] | None = None) -> Session:
    """One FIGAROH CSV as a :class:`Session`: marker columns ``x1, y1, z1, ...`` (and
    ``phix1..phiz1`` for a 6-D set), the joint columns of ``spec``; a marker whose columns repeat
    an earlier marker's is dropped; poses with a missing value are left out. ``ids``: the marker
    behind each column group (default 0, 1, ..). Joint columns are found by the spec's names or,
    in FIGAROH's older TIAGo files, as ``torso, arm1..arm7``."""
    header, cells = _read_csv(path)
    header = [OLD_NAMES.get(h, h) for h in header]
    index = {h: i for i, h in enumerate(header)}
    n_markers = sum(1 for k in range(1, 100) if f"x{k}" in index)
    names = [f"{c}{k}" for k in range(1, n_markers + 1) for c in "xyz"] + list(spec.joint_columns)
    if spec.pose_6d:
        names += ["phix1", "phiy1", "phiz1"]
    missing = [n for n in names if n not in index]
    if missing or n_markers == 0:
        raise DataUnavailableError(f"{path}: columns {missing or ['x1']} missing")
    values = np.array([[float(r[index[n]]) if index[n] < len(r) and r[index[n]].strip() else np.nan
                        for n in names] for r in cells])
    lines = np.arange(2, 2 + len(cells))
    ok = np.isfinite(values).all(axis=1)
    values, lines = values[ok], lines[ok]
    markers = values[:, :3 * n_markers].reshape(len(values), n_markers, 3)
    keep = [m for m in range(n_markers)
            if not any(np.abs(markers[:, m] - markers[:, k]).max() < REPEAT_TOL_M for k in range(m))]
    joints = values[:, 3 * n_markers:3 * n_markers + len(spec.joint_columns)]
    if spec.joints_deg:
        joints = np.deg2rad(joints)
    joints[:, list(spec.flip)] *= -1
    rotations = None
    if spec.pose_6d:
        phi = values[:, -3:]
        rotations = Rotation.from_euler("ZYX", phi[:, ::-1]).as_matrix()  # Rz(phiz) Ry(phiy) Rx(phix)
    ids = tuple(range(n_markers)) if ids is None else ids
    return Session(joints, markers[:, keep], rotations, lines, path, tuple(ids[m] for m in keep))


def usable(s: Session, robot: rc.Robot) -> tuple[Session, list[str]]:
    """The poses of ``s`` an instrument check and the robot's joint limits accept, and a note per
    rule that dropped some: markers on one rigid body keep their distances, so a pose whose
    marker-to-marker distances differ from the file's median by more than `RIGID_TOL_M` has a
    mislabelled or ghost marker (motion capture); a joint reading `LIMIT_SLACK` beyond the URDF's limits is a
    corrupted value (e.g. 9551 rad in one row of the 26 Nov TIAGo file). Neither looks at a model's
    fit: both tools get the same poses."""
    notes, keep = [], np.ones(len(s.joints), bool)
    M = s.markers.shape[1]
    if M > 1:
        i, j = np.triu_indices(M, 1)
        d = np.linalg.norm(s.markers[:, i] - s.markers[:, j], axis=2)
        bad = np.abs(d - np.median(d, axis=0)).max(axis=1) > RIGID_TOL_M
        if bad.any():
            notes.append(f"{s.file.name}: CSV lines {', '.join(map(str, s.rows[bad]))} dropped (marker "
                         f"distances off by more than {RIGID_TOL_M * 1e3:g} mm: mislabelled markers)")
        keep &= ~bad
    lim = np.asarray(robot.limits)
    out = ((s.joints < lim[:, 0] - LIMIT_SLACK) | (s.joints > lim[:, 1] + LIMIT_SLACK)).any(axis=1) & keep
    if out.any():
        notes.append(f"{s.file.name}: CSV lines {', '.join(map(str, s.rows[out]))} dropped (joints beyond "
                     "the URDF's limits)")
    return s.take(np.flatnonzero(keep & ~out)), notes


def without_typos(s: Session, robot: rc.Robot, pose_6d: bool) -> tuple[Session, list[str]]:
    """The poses of a judging session (another day's) whose markers the nominal model, its frame
    registered on that session, places within `TYPO_M`, and a note naming the others: a typo in a
    typed joint. Both tools are judged on the same poses; a calibrating session keeps every pose
    (the calibration's own gross-error handling is part of what is compared)."""
    m = measurements(s.with_markers(s.ids), robot, pose_6d)  # its markers numbered 0..k-1
    err = np.linalg.norm(rc.register(robot, m).fk(m.joints, smr=m.smr)[:, :3, 3] - m.points, axis=1)
    bad = err.reshape(len(s.joints), -1).max(axis=1) > TYPO_M
    if not bad.any():
        return s, []
    return s.take(np.flatnonzero(~bad)), [
        f"{s.file.name}: CSV lines {', '.join(map(str, s.rows[bad]))} not judged (the nominal model misses "
        f"them by more than {TYPO_M * 1e3:g} mm: typed joints with a typo)"]


def held_out_mask(n: int, split: int = 0) -> np.ndarray:
    """The fixed within-session split number ``split`` of ``n`` poses: True for the held-out ones.
    Split 0: every `HOLD_EVERY`-th pose; split k >= 1: ``n // HOLD_EVERY`` poses drawn without
    replacement by ``numpy.random.default_rng((SPLIT_SEED, k))``."""
    if split < 0:
        raise ValueError(f"split must be >= 0, got {split}")
    if split == 0:
        return np.arange(n) % HOLD_EVERY == HOLD_EVERY - 1
    mask = np.zeros(n, bool)
    mask[np.random.default_rng((SPLIT_SEED, split)).choice(n, n // HOLD_EVERY, replace=False)] = True
    return mask


def n_splits(name: str, wanted: int) -> int:
    """How many distinct splits set ``name`` has among the first ``wanted``: all of them within a
    session, at most two (which day calibrates) for a set of two sessions."""
    return min(wanted, 2) if len(SPECS[name].files) == 2 else wanted


def sessions(name: str, root: Path, robot: rc.Robot, split: int = 0) -> tuple[Session, Session, list[str]]:
    """The calibration and held-out poses of set ``name`` under ``root`` (the :func:`usable`
    ones) for split number ``split`` (module docstring), and the notes of what was dropped."""
    spec = SPECS[name]
    ids = spec.marker_ids or (None,) * len(spec.files)
    first, notes = usable(read_session(root / spec.files[0], spec, ids[0]), robot)
    if len(spec.files) == 2:
        second, more = usable(read_session(root / spec.files[1], spec, ids[1]), robot)
        if split % 2:  # the second day calibrates: judge the markers it saw
            first, second = second, first
        judged, typos = without_typos(second.with_markers(first.ids), robot, spec.pose_6d)
        return first.with_markers(first.ids), judged, notes + more + typos
    held = held_out_mask(len(first.joints), split)
    return first.take(np.flatnonzero(~held)), first.take(np.flatnonzero(held)), notes


def measurements(s: Session, robot: rc.Robot, pose_6d: bool) -> rc.Measurements:
    """A session as robocal measurements: one row per pose and marker (SMR index = marker),
    ``pose`` rows for a 6-D set (one marker), ``point`` rows otherwise."""
    N, M = s.markers.shape[:2]
    linear = np.asarray(robot.prismatic, bool)
    common = dict(pose_id=np.repeat(np.arange(N), M), smr=np.tile(np.array(s.ids), N),
                  source_row=np.repeat(s.rows, M), source=f"FIGAROH example data {s.file.name}",
                  linear=linear if linear.any() else None)
    joints = np.repeat(s.joints, M, axis=0)
    if pose_6d:
        return rc.Measurements.from_arrays("pose", joints, points=s.markers[:, 0], rotations=s.rotations,
                                           **common)
    return rc.Measurements.from_arrays("point", joints, points=s.markers.reshape(-1, 3), **common)


def nominal(name: str, root: Path) -> rc.Robot:
    """The set's nominal model: the URDF chain from its root link to the set's tip link."""
    spec = SPECS[name]
    return rc.Robot(**urdf_kwargs(root / spec.urdf, tip=spec.tip, name=name))


def load(name: str, folder: str | os.PathLike | None = None, split: int = 0) -> PeerSet:
    """Set ``name`` (one of `SETS`) read from the data folder (see :func:`data_root`), split
    number ``split`` (module docstring; 0: the default split)."""
    if name not in SPECS:
        raise KeyError(f"unknown peer set {name!r}; sets: {', '.join(SPECS)}")
    root = data_root(folder)
    spec = SPECS[name]
    robot = nominal(name, root)
    cal, held, notes = sessions(name, root, robot, split)
    if len(spec.files) == 2:
        days = spec.files[::-1] if split % 2 else spec.files
        how = (f"calibrate on {Path(days[0]).name} ({len(cal.joints)} poses), judge on "
               f"{Path(days[1]).name} ({len(held.joints)} poses) with the frame fitted again")
    elif split == 0:
        how = (f"{Path(spec.files[0]).name}: every {HOLD_EVERY}rd pose held out ({len(cal.joints)} "
               f"calibrate, {len(held.joints)} judge)")
    else:
        how = (f"{Path(spec.files[0]).name}: split {split}, a random third held out (seed "
               f"{SPLIT_SEED}, {split}: {len(cal.joints)} calibrate, {len(held.joints)} judge)")
    what = "6-D poses" if spec.pose_6d else f"{cal.markers.shape[1]} marker position(s) per pose"
    description = "; ".join([f"{name}: {robot.n_joints} joints to {spec.tip}, {what}", how, *notes])
    return PeerSet(robot, measurements(cal, robot, spec.pose_6d), measurements(held, robot, spec.pose_6d),
                   description)


def _loader(name: str) -> Callable[..., PeerSet]:
    def loader(folder: str | os.PathLike | None = None, split: int = 0) -> PeerSet:
        return load(name, folder, split)

    loader.__name__ = name
    loader.__doc__ = f"Set ``{name}`` (module docstring); ``folder``: the data folder (:func:`data_root`)."
    return loader


SETS: dict[str, Callable[..., PeerSet]] = {name: _loader(name) for name in SPECS}
