"""Measurements: joints plus what the tracker (or probe) saw, and their canonical CSV file.

One `Measurements` holds one observation kind for all its rows:

- ``point``: ``points (N, 3)`` m, an SMR position in the tracker frame;
- ``pose``: ``points (N, 3)`` m and ``rotations (N, 3, 3)``, a 6-DOF probe pose in the tracker frame;
- ``plane``: ``plane (N,)`` int, the index of the plane the probe tip touched (no coordinates);
- ``flush``: ``plane (N,)`` int, the index of the plane the tool face lay flush on (CSV column
  ``flush_plane``; no coordinates: the contact fixes the face's height and two angles);
- ``distance``: ``pair (N,)`` int and ``distance (N,)`` m. The two rows that share a ``pair`` id are
  the two ends (two joint vectors / SMRs) of one measured distance, and both carry the same
  measured distance (ball bar length, or distance between two tracker readings);
- ``marker``: ``points (N, 3)`` m, a motion-capture marker in the capture frame, and ``link (N,)``
  int, the frame of the model carrying it (CSV column ``link``; without it, the flange);
- ``eye_to_hand`` / ``eye_in_hand``: ``points (N, 3)`` m and ``rotations (N, 3, 3)``, a board's pose
  in a camera's frame, the camera fixed in the cell or on the flange (CSV line ``# kind: NAME``).

A set may name the ``instrument`` that took it (CSV line ``# instrument: NAME``;
`robocal.data.instruments`).

Every row also has ``approach (N, n)`` in {-1, 0, +1}: the direction each joint moved to reach
the row's pose from the previous pose (the rows are in measurement order; 0 for the first pose
and joints that did not move) — what a backlash model needs — and ``travel (N, n)`` rad, the signed
move of each joint from the previous pose to this one (0 for the first pose) — what the travel
model needs. Both are derived from the row order when the data are created and travel with
subsets, so random splits and cross-validation folds keep the true measuring order's values.
Every row also has ``joints (N, n)`` rad, ``pose_id (N,)`` (rows sharing one commanded pose: the
SMRs of one pose, or repeated readings kept without averaging), ``smr (N,)`` (0 = the tool,
s > 0 = ``Robot.smr[s - 1]``), an optional ``sigma (N,)`` m, and ``source_row (N,)``: the 1-based
line number of the row in the file it came from (for an import, the line in the raw file that
held its joints, or the first reading of an averaged group).

Optional per-row working conditions (None when the file has none): ``payload (N, 4)``, the
payload's mass (kg) and its centre of mass (m) in the flange frame tool0 (the frame of ``--tool``
and of the controllers' tool data, not the measured SMR's), and ``temperature (N,)`` deg C, the
arm's temperature. The payload and thermal error terms (:mod:`robocal.kinematics.load`,
:mod:`robocal.kinematics.thermal`) use them; any other model ignores them
(:meth:`Measurements.unused_conditions` says so).

Canonical CSV (DESIGN.md "Files"): optional leading ``#`` comment lines (the first one is kept as
``source``, the provenance text), then a header, then one line per row. Column names carry their
units: ``q1_deg..qn_deg`` or ``q1_rad..qn_rad`` (a prismatic joint's ``q{i}_mm`` / ``q{i}_m``); external
axes ``e1_mm`` / ``e1_m`` (a linear track) or ``e1_deg`` / ``e1_rad``, which come first in ``joints``
(a track carries the arm: joints ``(e1, q1..q6)``); ``x_mm y_mm z_mm`` or ``x_m y_m z_m``; optional
``smr``, ``sigma_mm``/``sigma_m``, ``qw qx qy qz`` (pose), ``plane`` (plane contacts, then no
x/y/z), ``flush_plane`` (flush contacts of the tool face, then no x/y/z), ``pair`` and
``distance_mm``/``distance_m`` (distance), ``pose_id``, ``source_row``,
``approach1..approachn`` and ``travel1_rad..traveln_rad`` (or ``_deg``) (each written only where
it differs from what the row order implies), ``payload_kg`` with optional ``payload_x_mm,
payload_y_mm, payload_z_mm`` (or ``_m``; all three or none, default 0: at the flange) and
``temperature_c``.
`Measurements.save` writes SI columns (``_rad``, ``_m``) with 17 significant digits, so a
save/load round trip is exact (rotations through the quaternion to 1e-15).
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError, UnitError
from robocal.core.escape import line_text
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, read_text, write_atomic
from robocal.core.magnitudes import MASS_SCALES_KG, MASS_WORDS, check_payload, fitting_units, temperature_note
from robocal.data.csv_table import csv_rows, read_table, text_lines
from robocal.data.instruments import check_instrument
from robocal.data.kinds import OBSERVED, KindSpec, kind_spec
from robocal.kinematics.conditions import UNKNOWN, Conditions
from robocal.kinematics.joint_errors import assumed_conditions, condition_terms
from robocal.kinematics.link_names import is_frame_number
from robocal.kinematics.model import links_length
from robocal.kinematics.transforms import ROTATION_TOL

_ARRAY_FIELDS = ("joints", "pose_id", "smr", "source_row", "sigma", "points", "rotations", "plane",
                 "pair", "distance", "approach", "travel", "payload", "temperature", "link")  # row-indexed
_LENGTH_COLUMNS = ("x", "y", "z", "sigma", "distance")
_PLAIN_COLUMNS = ("smr", "plane", "flush_plane", "pair", "pose_id", "source_row", "qw", "qx", "qy", "qz",
                  "link")
# comment lines ``# NAME: value`` that declare what the columns cannot say (read and written back)
_DIRECTIVES = ("instrument", "kind")
# A laser tracker's range is below ~80 m; anything farther is a unit mistake whatever the robot.
MAX_TRACKER_RANGE_M = 100.0
MAX_PAYLOAD_KG = 5000.0  # no arm carries more; a larger value is a unit mistake (g, lb)
TEMPERATURE_RANGE_C = (-40.0, 120.0)  # an arm's working temperature in deg C (K or F are mistakes)
MAX_JOINT_RAD = 4 * np.pi  # no joint turns more than two turns either way
# One robot's measured points span at most MAX_SPAN_REACHES times its reach (both sides of the
# base) plus SPAN_MARGIN_M; a wider span is a length unit mistake or a bigger robot's data.
MAX_SPAN_REACHES = 2.0
SPAN_MARGIN_M = 0.5
# Consecutive rows whose joints all agree within this (rad) are readings of one pose (a tracker
# export that repeats each reading, or the SMRs of one pose) when the file has no pose_id: a
# robot standing still reads its encoders to well below it; two planned poses never differ less.
REPEAT_JOINT_TOL_RAD = np.deg2rad(1e-3)
# Consecutive poses closer than this (rad, every joint) but beyond the tolerance above look like
# repeated readings with a jittering joint reading: worth a warning (a backlash model needs to know).
NEAR_REPEAT_RAD = np.deg2rad(0.05)


def _int_array(values, name: str, n: int) -> np.ndarray:
    arr = np.asarray(values)
    if arr.shape != (n,):
        raise DataError(f"{name} must have shape ({n},), got {arr.shape}")
    if arr.dtype.kind == "f":
        if not np.isfinite(arr).all() or (arr != np.round(arr)).any():
            raise DataError(f"{name} must hold integers")
    elif arr.dtype.kind not in "iub":
        raise DataError(f"{name} must hold integers, got dtype {arr.dtype}")
    return arr.astype(np.int64)


def _link_array(values, n: int) -> np.ndarray:
    """A marker ``link`` column ``(n,)``: frame numbers (int >= 0), or, when a row names its link,
    every row's text (str: a link name or a number; `Robot.link_numbers` resolves them)."""
    arr = np.asarray(values)
    if arr.dtype.kind in "UOS":
        if arr.shape != (n,):
            raise DataError(f"link must have shape ({n},), got {arr.shape}")
        texts = np.array([str(v).strip() for v in arr], dtype=str)
        if (texts == "").any():
            raise DataError(f"row {int(np.argmax(texts == ''))}: a marker's link is empty: give its frame "
                            "number or its link's name")
        numeric = is_frame_number(texts)
        if not numeric.all():
            if (np.char.startswith(texts[numeric], "-")).any():
                raise DataError("link indices must be >= 0 (0 is the robot's base frame, n its flange)")
            return texts
        arr = texts.astype(np.int64)
    out = _int_array(arr, "link", n)
    if out.min() < 0:
        raise DataError("link indices must be >= 0 (0 is the robot's base frame, n its flange)")
    return out


def _float_array(values, name: str, shape: tuple) -> np.ndarray:
    try:
        arr = np.array(values, dtype=float)  # a copy: caller edits cannot bypass validation
    except (TypeError, ValueError):
        raise DataError(f"{name} must be numeric") from None
    if arr.shape != shape:
        raise DataError(f"{name} must have shape {shape}, got {arr.shape}")
    if not np.isfinite(arr).all():
        rows = np.flatnonzero(~np.isfinite(arr.reshape(shape[0], -1)).all(axis=1)) if arr.ndim else []
        raise DataError(f"{name} contains NaN or infinite values (row indices {list(rows[:10])})")
    return arr


@dataclass(frozen=True, eq=False)
class Measurements:
    """One kind of observation for N rows; see the module docstring for every field's meaning.

    Immutable (its arrays are read-only); build it with `from_arrays` or `load`, select rows
    with `subset`, `split_poses` or `first_poses`, write it with `save`.

    Attributes
    ----------
    kind : {'point', 'pose', 'plane', 'flush', 'distance'}
        What each row observed.
    joints : numpy.ndarray, shape (N, n)
        Commanded joints, radians.
    pose_id : numpy.ndarray of int, shape (N,)
        Rows that share one commanded pose (the SMRs of one pose, repeated readings).
    smr : numpy.ndarray of int, shape (N,)
        The SMR of each row: 0 the tool, s > 0 ``Robot.smr[s - 1]``.
    source_row : numpy.ndarray of int, shape (N,)
        The row's 1-based line number in the file it came from.
    sigma : numpy.ndarray, shape (N,), optional
        Each row's measurement uncertainty (1 sigma), metres.
    points : numpy.ndarray, shape (N, 3), optional
        SMR or probe positions in the tracker frame, metres (``point``, ``pose``).
    rotations : numpy.ndarray, shape (N, 3, 3), optional
        Probe orientations in the tracker frame (``pose``).
    plane : numpy.ndarray of int, shape (N,), optional
        The plane the probe tip touched (``plane``).
    pair, distance : numpy.ndarray, shape (N,), optional
        The pair id and the measured distance, metres (``distance``): the two rows of a pair are
        the two ends of one distance.
    source : str
        The provenance text (the file's first ``#`` comment).
    approach : numpy.ndarray of int, shape (N, n)
        Each joint's approach direction (-1, 0, +1) from the previous pose, for a backlash model.
    travel : numpy.ndarray, shape (N, n)
        Each joint's signed move from the previous pose, radians, for a travel model.
    file : str
        The file it was read from ("" when built from arrays).
    notes : tuple of str
        How the reader interpreted the file (e.g. repeated readings).
    link : numpy.ndarray of int or str, shape (N,), optional
        The frame of the model carrying each row's marker (``marker``; None: the flange): frame
        numbers (int), or when the rows name links, their texts (str: a model's link names, e.g. a
        URDF's ``arm_left_4_link``, or numbers), which `Robot.link_numbers` resolves.
    instrument : str
        The instrument that took the rows (``tracker``, ``mocap``, ``camera``;
        `robocal.data.instruments`); "" when the data do not say.
    payload : numpy.ndarray, shape (N, 4), optional
        Payload of each row: kg, then the centre of mass x, y, z (m) in the flange frame.
    temperature : numpy.ndarray, shape (N,), optional
        Temperature of each row (deg C).
    linear : numpy.ndarray of bool, shape (n,), optional
        Joints in length units (m: prismatic); None: every joint an angle.
    external : int
        The first ``external`` joints are external axes (``e1``..: a track carrying the arm).

    See Also
    --------
    rc.CellMeasurements : A work cell's measurements, per body.
    rc.register : The tracker -> robot base frame of measurements.
    rc.simulate_tracker : Simulated measurements of a known true robot.
    rc.calibrate : Calibrate a robot with them.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> q = np.array([[0.0, 0.1, 0.2, 0.0, 0.3, 0.0], [0.4, 0.2, 0.1, 0.1, 0.2, 0.3]])  # rad
    >>> data = rc.Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3])
    >>> len(data), data.n_poses, data.kind
    (2, 2, 'point')
    >>> data.approach[1]  # the direction each joint moved to reach the second pose
    array([ 1,  1, -1,  1, -1,  1])
    """

    kind: str
    joints: np.ndarray
    pose_id: np.ndarray
    smr: np.ndarray
    source_row: np.ndarray
    sigma: np.ndarray | None = None
    points: np.ndarray | None = None
    rotations: np.ndarray | None = None
    plane: np.ndarray | None = None
    pair: np.ndarray | None = None
    distance: np.ndarray | None = None
    source: str = ""
    approach: np.ndarray | None = None
    travel: np.ndarray | None = None
    payload: np.ndarray | None = None  # (N, 4): kg, then centre of mass x, y, z (m) in tool0
    temperature: np.ndarray | None = None  # (N,) deg C
    file: str = ""  # the file it was read from (set by :meth:`load`)
    notes: tuple[str, ...] = ()  # how the reader interpreted the file (e.g. repeated readings)
    linear: np.ndarray | None = None  # (n,) bool: joints in length units (m: prismatic); None: all angles
    external: int = 0  # the first ``external`` joints are external axes (e1..): a track carrying the arm
    link: np.ndarray | None = None  # (N,) int: the frame {0..n} carrying each marker (``marker``); str: names
    instrument: str = ""  # the instrument that took the rows (`robocal.data.instruments`); "" undeclared

    @property
    def spec(self) -> KindSpec:
        """What the rows' kind observes (`robocal.data.kinds`)."""
        return OBSERVED[self.kind]

    @property
    def conditions(self) -> Conditions:
        """The rows' approach directions, moves, payloads and temperatures as one `Conditions`."""
        return Conditions(self.approach, self.travel, self.payload, self.temperature)

    @property
    def label(self) -> str:
        """How messages and reports name the set: its file, else its provenance text."""
        return self.file or self.source

    def __post_init__(self) -> None:
        if self.linear is not None:
            self.linear.flags.writeable = False
        for f in _ARRAY_FIELDS:  # frozen all the way down: the validated arrays cannot change
            value = getattr(self, f)
            if value is not None:
                value = np.array(value)
                value.flags.writeable = False
                object.__setattr__(self, f, value)

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_arrays(cls, kind: str, joints, *, points=None, rotations=None, plane=None, pair=None,
                    distance=None, smr=None, sigma=None, pose_id=None, source_row=None,
                    source: str = "", conditions: Conditions = UNKNOWN, linear=None,
                    external: int = 0, link=None, instrument: str = "") -> Measurements:
        """Validated measurements from arrays in SI units (rad, m).

        Parameters
        ----------
        kind : {'point', 'pose', 'plane', 'flush', 'distance'}
            What each row observed; it says which of the arrays below are required.
        joints : array_like, shape (N, n)
            Commanded joints, radians, in measurement order.
        points : array_like, shape (N, 3), optional
            Measured positions in the tracker frame, metres (``point`` and ``pose``).
        rotations : array_like, shape (N, 3, 3), optional
            Measured orientations, rotation matrices (``pose``).
        plane : array_like of int, shape (N,), optional
            Index of the touched plane (``plane``, ``flush``).
        pair : array_like of int, shape (N,), optional
            Pair id, two rows each (``distance``).
        distance : array_like, shape (N,), optional
            Measured distance of each row's pair, metres (``distance``).
        smr : array_like of int, shape (N,), optional
            Each row's SMR (default 0, the tool).
        sigma : array_like, shape (N,), optional
            Each row's uncertainty (1 sigma), metres.
        pose_id : array_like of int, shape (N,), optional
            Rows of one commanded pose (default: one pose per row, ``0..N-1``).
        source_row : array_like of int, shape (N,), optional
            The rows' line numbers in their source file (default ``1..N``).
        source : str
            Provenance text, kept in the CSV's first comment line.
        conditions : Conditions, optional
            The rows' conditions (`robocal.kinematics.conditions.Conditions`): joint approach
            directions (default: from the row order, `approach_from_order`), joint moves from the
            previous pose, radians (default: from the row order, `travel_from_order`), payloads
            (mass kg and centre of mass in the flange frame m; None: not recorded) and arm
            temperatures (deg C; None: not recorded).
        linear : array_like of bool, shape (n,), optional
            Joints in metres (prismatic, e.g. a track).
        external : int, optional
            How many leading joints are external axes (written as e1.. columns).
        link : array_like of int or str, shape (N,), optional
            The frame carrying each row's marker (``marker``): 0 the robot's base frame {0}, i the
            frame after joint i, n the flange (the default; see
            `robocal.identify.observations.marker`), or the name of its link in the model
            (`robocal.kinematics.model.Robot.link_frames`, a URDF's link names).
        instrument : str, optional
            The instrument that took the rows (`robocal.data.instruments`: tracker, mocap, camera).

        Returns
        -------
        Measurements

        Raises
        ------
        DataError
            An unknown kind, a missing or extra array for the kind, wrong shapes, NaN, or a
            distance pair without exactly two rows.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> q = np.zeros((2, 6))
        >>> data = rc.Measurements.from_arrays("point", q, points=[[1.0, 0.0, 0.5], [1.0, 0.0, 0.6]])
        >>> data.pose_id, data.smr, data.source_row
        (array([0, 1]), array([0, 0]), array([1, 2]))
        >>> rc.Measurements.from_arrays("point", q)
        Traceback (most recent call last):
        ...
        robocal.core.errors.DataError: ...
        """
        spec = kind_spec(kind)
        joints = np.asarray(joints, dtype=float) if not isinstance(joints, np.ndarray) else joints
        if joints.ndim != 2 or joints.shape[0] < 1 or joints.shape[1] < 1:
            raise DataError(f"joints must have shape (N, n) with N, n >= 1, got {joints.shape}")
        N, n = joints.shape
        joints = _float_array(joints, "joints", (N, n))
        need = set(spec.arrays)
        given = {k for k, v in (("points", points), ("rotations", rotations), ("plane", plane),
                                ("pair", pair), ("distance", distance), ("link", link)) if v is not None}
        if need - given:
            raise DataError(f"{kind} measurements need {sorted(need - given)}")
        if given - need - set(spec.optional):
            raise DataError(f"{kind} measurements do not take {sorted(given - need - set(spec.optional))}")
        kw = {}
        if points is not None:
            kw["points"] = _float_array(points, "points", (N, 3))
        if rotations is not None:
            R = _float_array(rotations, "rotations", (N, 3, 3))
            err = np.abs(R @ np.swapaxes(R, 1, 2) - np.eye(3)).max(axis=(1, 2))
            bad = np.flatnonzero((err > ROTATION_TOL) | (np.linalg.det(R) < 0))
            if bad.size:
                raise DataError(f"rotations of row index(es) {bad[:10].tolist()} are not proper rotations")
            kw["rotations"] = R
        if plane is not None:
            kw["plane"] = _int_array(plane, spec.column or "plane", N)
            if kw["plane"].min() < 0:
                raise DataError(f"{spec.column or 'plane'} indices must be >= 0 (the plane each contact "
                                "touched)")
        if pair is not None:
            kw["pair"] = _int_array(pair, "pair", N)
            kw["distance"] = _float_array(distance, "distance", (N,))
            ids, counts = np.unique(kw["pair"], return_counts=True)
            if (counts != 2).any():
                raise DataError(f"every distance pair needs exactly 2 rows (its two ends); pair(s) "
                                f"{ids[counts != 2][:10].tolist()} have {counts[counts != 2][:10].tolist()}")
            order = np.argsort(kw["pair"], kind="stable")
            d2 = kw["distance"][order].reshape(-1, 2)
            if (d2[:, 0] != d2[:, 1]).any() or (d2 <= 0).any():
                raise DataError("both rows of a distance pair must carry the same positive distance")
        if link is not None:
            kw["link"] = _link_array(link, N)
        smr = np.zeros(N, np.int64) if smr is None else _int_array(smr, "smr", N)
        if smr.min() < 0:
            raise DataError("smr indices must be >= 0 (0 is the tool)")
        pose_id = np.arange(N) if pose_id is None else _int_array(pose_id, "pose_id", N)
        source_row = np.arange(1, N + 1) if source_row is None else _int_array(source_row, "source_row", N)
        if sigma is not None:
            sigma = _float_array(sigma, "sigma", (N,))
            if (sigma <= 0).any():
                raise DataError("sigma must be positive (m)")
        approach, travel = conditions.approach, conditions.travel
        if approach is None:
            approach = approach_from_order(joints, pose_id)
        else:
            approach = np.asarray(approach)
            if approach.shape != (N, n):
                raise DataError(f"approach must have shape ({N}, {n}), got {approach.shape}")
            approach = _int_array(approach.reshape(-1), "approach", N * n).reshape(N, n)
            if np.abs(approach).max(initial=0) > 1:
                raise DataError("approach directions must be -1, 0 or +1")
        travel = travel_from_order(joints, pose_id) if travel is None else \
            _float_array(travel, "travel", (N, n))
        linear = None if linear is None or not np.any(linear) else np.array(linear, bool).reshape(-1)
        if linear is not None and linear.shape != (n,):
            raise DataError(f"linear (prismatic joint flags) must have {n} values")
        if not 0 <= int(external) <= n:
            raise DataError(f"external axes must be 0..{n}, got {external}")
        kw.update(_conditions(conditions.payload, conditions.temperature, N))
        return cls(kind=kind, joints=joints, pose_id=pose_id, smr=smr, source_row=source_row,
                   sigma=sigma, source=str(source).replace("\n", " "), approach=approach,
                   travel=travel, linear=linear, external=int(external),
                   instrument=check_instrument(str(instrument), kind), **kw)

    # ----------------------------------------------------------------- views
    def missing_conditions(self, robot) -> list[str]:
        """Warnings for ``robot``'s payload / thermal terms these data have no column for, naming
        the default the model assumes (no payload; its reference temperature).

        Parameters
        ----------
        robot : Robot
            The model the data calibrate.

        Returns
        -------
        list of str
            One warning a missing condition (empty: none).
        """
        errors = robot.joint_errors
        if errors is None:
            return []
        present = replace(errors, payload=None if self.payload is None else (0.0,) * 4,
                          temperature_c=None if self.temperature is None else 0.0)
        hints = ("the payload_kg column", "the temperature_c column")
        return [f"WARNING: {self.label or 'the data'}: {w}"
                for w in assumed_conditions(replace(robot, joint_errors=present), hints)]

    def unused_conditions(self, robot) -> str | None:
        """A note naming the recorded conditions (payload, temperature) ``robot``'s error model
        has no term for, or None when it uses every one recorded.

        Parameters
        ----------
        robot : Robot
            The model the data calibrate.

        Returns
        -------
        str or None
            The note.
        """
        used = condition_terms(robot)
        unused = [c for c, term in (("payload", "payload"), ("temperature", "thermal"))
                  if getattr(self, c) is not None and term not in used]
        if not unused:
            return None
        terms = " or ".join("thermal" if c == "temperature" else c for c in unused)
        return (f"{self.label or 'the data'}: the {' and '.join(unused)} column(s) were read but the model "
                f"of {robot.name} has no {terms} term: not used")

    def __len__(self) -> int:
        return self.joints.shape[0]

    @property
    def n_joints(self) -> int:
        """The number of joint columns n."""
        return self.joints.shape[1]

    @property
    def n_poses(self) -> int:
        """Number of distinct commanded poses (distinct ``pose_id``)."""
        return int(np.unique(self.pose_id).size)

    @property
    def n_smr(self) -> int:
        """Number of SMRs referenced (max index + 1)."""
        return int(self.smr.max()) + 1

    def subset(self, index) -> Measurements:
        """Rows selected by an integer index array or a boolean mask ``(N,)``.

        Parameters
        ----------
        index : array_like of int, shape (k,), or array_like of bool, shape (N,)
            Row indices (negative ones count from the end) or a row mask.

        Returns
        -------
        Measurements
            The selected rows, with their ``approach`` and ``travel`` of the full set.

        Raises
        ------
        DataError
            An empty selection, an index out of range, a mask of the wrong shape, or a distance
            subset that splits a pair.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> q = np.zeros((3, 6))
        >>> data = rc.Measurements.from_arrays("point", q, points=[[1, 0, 0.2], [1, 0, 0.5], [1, 0, 0.9]])
        >>> high = data.subset(data.points[:, 2] > 0.3)
        >>> len(high), high.source_row
        (2, array([2, 3]))
        """
        index = np.asarray(index)
        if index.dtype == bool:
            if index.shape != (len(self),):
                raise DataError(f"a row mask must have shape ({len(self)},), got {index.shape}")
            index = np.flatnonzero(index)
        index = index.astype(np.int64).reshape(-1)
        if index.size == 0:
            raise DataError("the selection is empty: keep at least one row")
        if index.min() < -len(self) or index.max() >= len(self):
            raise DataError(f"row index out of range for {len(self)} rows")
        take = {f: (None if getattr(self, f) is None else getattr(self, f)[index]) for f in _ARRAY_FIELDS}
        if self.spec.group == "pair":
            ids, counts = np.unique(take["pair"], return_counts=True)
            if (counts != 2).any():
                raise DataError("a distance subset must keep both rows of every pair")
        return replace(self, **take)

    def _groups(self) -> np.ndarray:
        """Group label of each row: rows that must stay together when splitting."""
        return getattr(self, self.spec.group)

    def split_poses(self, fraction: float | int = 0.5, seed: int = 0) -> tuple[Measurements, Measurements]:
        """Random split by pose (distance data: by pair) into (first, rest).

        ``fraction`` in (0, 1) is the share of poses in the first part; an int is a pose count.

        Parameters
        ----------
        fraction : float or int, default 0.5
            Share of the poses in the first part, or their number.
        seed : int, default 0
            Seed of the random choice.

        Returns
        -------
        tuple of Measurements
            ``(first, rest)``.

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> data = rc.simulate_tracker(robot, 30, noise_mm=0.01, seed=1).data
        >>> calibration, validation = data.split_poses(0.7, seed=0)  # 70 % of the poses to calibrate
        >>> calibration.n_poses, validation.n_poses
        (21, 9)
        """
        labels = np.unique(self._groups())
        k = int(fraction) if isinstance(fraction, int | np.integer) else int(round(fraction * labels.size))
        if not 0 < k < labels.size:
            raise DataError(f"cannot split {labels.size} poses with fraction/count {fraction}: "
                            "both parts need at least one pose")
        chosen = np.random.default_rng(seed).permutation(labels)[:k]
        mask = np.isin(self._groups(), chosen)
        return self.subset(mask), self.subset(~mask)

    def first_poses(self, k: int) -> Measurements:
        """Rows of the first ``k`` distinct poses in file order (e.g. a calibration half).

        Parameters
        ----------
        k : int
            Number of poses.

        Returns
        -------
        Measurements
            Their rows.

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> data = rc.simulate_tracker(robot, 30, noise_mm=0.01, seed=1).data
        >>> data.first_poses(5).n_poses
        5
        """
        _, first = np.unique(self._groups(), return_index=True)
        labels = self._groups()[np.sort(first)][:k]
        return self.subset(np.isin(self._groups(), labels))

    def check_against(self, robot, reach: float | None = None, path: str | None = None) -> Measurements:
        """Check joint count, SMR indices and unit plausibility (lengths against its reach, payload
        masses against its rated payload: `robocal.core.magnitudes.check_payload`) against a robot;
        returns self.

        Parameters
        ----------
        robot : Robot
            The model the data go with.
        reach : float, optional
            The robot's reach (m) for the unit check; default computed from the model.
        path : str, optional
            The file's name, for messages.

        Returns
        -------
        Measurements
            This object.

        Raises
        ------
        DataError
            A joint count or an SMR index that does not fit the robot.
        UnitError
            Lengths or masses in the wrong unit.
        """
        where = f"{path}: " if path else (f"{self.source}: " if self.source else "")
        if self.n_joints != robot.n_joints:
            k = robot.external_axes
            track = f" (e1 for its track, then q1..q{robot.n_joints - k})" if k else ""
            raise DataError(f"{where}the data have {self.n_joints} joint columns but {robot.name} has "
                            f"{robot.n_joints} joints{track}: use a file with {robot.n_joints} joint "
                            "columns or the matching robot model")
        linear = np.zeros(self.n_joints, bool) if self.linear is None else self.linear
        check_joint_kinds(linear, robot, [self.joint_column(k, "") for k in range(self.n_joints)], where)
        if reach is None:
            reach = robot_reach(robot)
        _check_plausible(self, reach, where)
        if self.payload is not None:  # kg typed in lb or g: against the robot's rated payload
            check_payload(self.payload[:, 0], getattr(robot, "payload_kg", None), robot.name,
                          f"{where}the payload_kg column")
        return self

    # ----------------------------------------------------------------- files
    @classmethod
    def load(cls, path, robot=None, reach: float | None = None) -> Measurements:
        """Read a canonical measurement CSV. ``robot`` (or ``reach`` in m) enables the joint count and
        length plausibility checks; every problem is a DataError/UnitError naming file and row.

        Parameters
        ----------
        path : str or path-like
            The CSV file (format: the measurement CSV reference page; units in the column names).
        robot : Robot, optional
            Check the joint count, the joints' kinds (angle or length columns) and SMR indices
            against this model, and that the points span no more than it can reach; the joints
            are then named as the model names them (`Robot.joints`: a track's carriage ``e1``,
            a gantry's first axis ``q1``), which `save` writes.
        reach : float, optional
            The reach used for the length plausibility check without a robot, metres.

        Returns
        -------
        Measurements
            In SI units, with ``file`` set to ``path``.

        Raises
        ------
        DataError
            A missing file, a malformed row or cell, or data that do not fit ``robot``.
        UnitError
            A column without a known unit, or lengths implausible for the robot's reach (mm
            read as m).

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> q = np.array([[0.0, 0.1, 0.2, 0.0, 0.3, 0.0], [0.4, 0.2, 0.1, 0.1, 0.2, 0.3]])
        >>> rc.Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3]).save("points.csv")
        >>> data = rc.Measurements.load("points.csv", robot=robot)
        >>> data.file, data.points.shape
        ('points.csv', (2, 3))
        """
        path = Path(path)
        text = read_text(path, "measurement file")
        data = replace(parse_csv(text, str(path), joint_range_rad(robot)), file=str(path))
        if robot is not None:
            data.check_against(robot, reach, str(path))
            if data.external != robot.external_axes:  # the model's names: e1.. (a track), then q1..
                data = replace(data, external=robot.external_axes)
        elif reach is not None:
            _check_plausible(data, reach, f"{path}: ")
        return data

    def joint_column(self, k: int, unit: str) -> str:
        """The CSV name of joint ``k`` (0-based) with ``unit`` (e.g. ``_rad``): ``e{k+1}`` for an
        external axis, else ``q{i}`` counted after them.

        Parameters
        ----------
        k : int
            The joint (0-based).
        unit : str
            The suffix (``_rad``, ``_deg``, ``_mm``...).

        Returns
        -------
        str
            The column name.
        """
        return f"e{k + 1}{unit}" if k < self.external else f"q{k - self.external + 1}{unit}"

    def to_csv(self) -> str:
        """Canonical CSV text in SI columns (exact round trip).

        Returns
        -------
        str
            The CSV text.
        """
        n = self.n_joints
        cols = {"pose_id": self.pose_id, "source_row": self.source_row}
        linear = np.zeros(n, bool) if self.linear is None else self.linear
        for i in range(n):
            cols[self.joint_column(i, "_m" if linear[i] else "_rad")] = self.joints[:, i]
        if self.points is not None:
            for k, c in enumerate("xyz"):
                cols[f"{c}_m"] = self.points[:, k]
        if self.rotations is not None:
            quat = Rotation.from_matrix(self.rotations).as_quat()  # x y z w
            quat *= np.where(quat[:, 3:] < 0, -1.0, 1.0)
            for k, c in enumerate(("qw", "qx", "qy", "qz")):
                cols[c] = quat[:, (3, 0, 1, 2)[k]]
        if self.plane is not None:
            cols[self.spec.column] = self.plane
        if self.link is not None:
            cols["link"] = self.link
        if self.pair is not None:
            cols["pair"] = self.pair
            cols["distance_m"] = self.distance
        cols["smr"] = self.smr
        if self.sigma is not None:
            cols["sigma_m"] = self.sigma
        if not np.array_equal(self.approach, approach_from_order(self.joints, self.pose_id)):
            for i in range(n):
                cols[f"approach{i + 1}"] = self.approach[:, i]
        if not np.array_equal(self.travel, travel_from_order(self.joints, self.pose_id)):
            for i in range(n):
                cols[f"travel{i + 1}_rad"] = self.travel[:, i]
        if self.payload is not None:
            cols.update(zip(("payload_kg", "payload_x_m", "payload_y_m", "payload_z_m"), self.payload.T,
                            strict=True))
        if self.temperature is not None:
            cols["temperature_c"] = self.temperature
        out = io.StringIO()
        if self.source:
            out.write(f"# {line_text(self.source)}\n")
        if self.instrument:
            out.write(f"# instrument: {line_text(self.instrument)}\n")
        if self.kind != _columns_kind(set(cols)):
            out.write(f"# kind: {self.kind}\n")
        out.write(",".join(cols) + "\n")
        fmt = [(lambda v: str(int(v))) if np.asarray(c).dtype.kind in "iu" else str
               if np.asarray(c).dtype.kind == "U" else (lambda v: repr(float(v))) for c in cols.values()]
        columns = list(cols.values())
        for r in range(len(self)):
            out.write(",".join(f(c[r]) for f, c in zip(fmt, columns, strict=True)) + "\n")
        return out.getvalue()

    def save(self, path) -> None:
        """Write the canonical CSV atomically.

        SI columns (``_rad``, ``_m``) with 17 significant digits: `load` gives the same values back.

        Parameters
        ----------
        path : str or path-like
            The CSV file to write.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> q = np.array([[0.1, 0.2, 0.3, 0.4, 0.5, 0.6]])
        >>> data = rc.Measurements.from_arrays("point", q, points=[[1.234567, -0.5, 0.75]])
        >>> data.save("one.csv")
        >>> bool(np.array_equal(rc.Measurements.load("one.csv").points, data.points))
        True
        """
        write_atomic(path, self.to_csv())


def joint_range_rad(robot=None) -> float:
    """The largest revolute joint value (rad) a reading of ``robot`` can have: two turns, or its
    widest finite revolute limit when that is wider (`robocal.kinematics.model.Robot.joints`)."""
    if robot is None:
        return MAX_JOINT_RAD
    limits = np.array([j.limits for j in robot.joints if not j.prismatic]).reshape(-1, 2)
    finite = np.abs(limits[np.isfinite(limits).all(axis=1)])
    return max(MAX_JOINT_RAD, float(finite.max(initial=0.0)))


def robot_reach(robot) -> float:
    """A generous reach (m) of a robot: its link lengths (`robocal.kinematics.model.links_length`)
    plus tool and SMR offsets, plus the travel of its prismatic joints (a track)."""
    tool = max([np.linalg.norm(robot.tool[:3, 3])] + [np.linalg.norm(s) for s in robot.smr])
    slides = robot.limits[robot.prismatic]
    travel = float(np.sum(np.where(np.isfinite(slides), np.abs(slides), 0.0).max(axis=1))) \
        if len(slides) else 0.0
    return links_length(robot) + float(tool) + travel


def _conditions(payload, temperature, N: int) -> dict:
    """Validated ``payload (N, 4)`` and ``temperature (N,)`` (None: not recorded) as keywords."""
    out = {}
    if payload is not None:
        payload = _float_array(payload, "payload", (N, 4))
        bad = np.flatnonzero((payload[:, 0] < 0) | (payload[:, 0] > MAX_PAYLOAD_KG))
        if bad.size:
            mass = float(payload[bad[0], 0])
            units = fitting_units(mass, MASS_SCALES_KG, 0.0, MAX_PAYLOAD_KG)
            like = "" if not units else " (it looks like " + " or ".join(
                f"{MASS_WORDS[u]}: {mass:.6g} {u} = {mass * MASS_SCALES_KG[u]:.4g} kg" for u in units) + ")"
            raise UnitError(f"payload mass {mass:.6g} kg (row index {bad[0]}) is outside "
                            f"0..{MAX_PAYLOAD_KG:g} kg{like}: give payload_kg in kilograms")
        far = np.flatnonzero(np.abs(payload[:, 1:]).max(axis=1) > MAX_TRACKER_RANGE_M)
        if far.size:
            raise UnitError(f"payload centre of mass {np.abs(payload[far[0], 1:]).max():.6g} m from the "
                            f"flange (row index {far[0]}): name the columns payload_x_mm.. for millimetres")
        out["payload"] = payload
    if temperature is not None:
        temperature = _float_array(temperature, "temperature", (N,))
        lo, hi = TEMPERATURE_RANGE_C
        bad = np.flatnonzero((temperature < lo) | (temperature > hi))
        if bad.size:
            raise UnitError(f"temperature {temperature[bad[0]]:.6g} (row index {bad[0]}) is outside "
                            f"{lo:g}..{hi:g} deg C: temperature_c is in degrees Celsius")
        out["temperature"] = temperature
    return out


def _check_plausible(data: Measurements, reach: float, where: str) -> None:
    """Unit plausibility: the measured points must span no more than the robot can reach."""
    if data.points is None or len(data) < 2:
        return
    extent = float((data.points.max(axis=0) - data.points.min(axis=0)).max())
    limit = MAX_SPAN_REACHES * reach + SPAN_MARGIN_M
    if extent > limit:
        row = int(data.source_row[np.argmax(np.abs(data.points - np.median(data.points, 0)).max(1))])
        raise UnitError(f"{where}the points span {extent:.4g} m but a robot of {reach:.3g} m reach can move "
                        f"an SMR over at most ~{limit:.3g} m (e.g. row {row}): the data belong to a bigger "
                        "robot, or the length unit is wrong (values in millimetres need the columns x_mm, "
                        "y_mm, z_mm)")


def travel_from_order(joints: np.ndarray, pose_id: np.ndarray) -> np.ndarray:
    """``(N, n)`` rad: each joint's signed move from the previous pose to this row's pose, poses
    taken in row order (consecutive rows with the same pose_id are one pose); 0 for the first pose."""
    new_pose = np.r_[True, pose_id[1:] != pose_id[:-1]]
    q = joints[new_pose]
    return np.diff(q, axis=0, prepend=q[:1])[np.cumsum(new_pose) - 1]


def repeat_groups(joints: np.ndarray) -> np.ndarray:
    """``(N,)`` pose ids from the row order: consecutive rows whose joints ``(N, n)`` agree within
    `REPEAT_JOINT_TOL_RAD` share one id (repeated readings, or several SMRs of one pose)."""
    same = np.r_[False, (np.abs(np.diff(joints, axis=0)) <= REPEAT_JOINT_TOL_RAD).all(axis=1)]
    return np.cumsum(~same) - 1


def approach_from_order(joints: np.ndarray, pose_id: np.ndarray) -> np.ndarray:
    """``(N, n)`` sign of each joint's move from the previous pose to this row's pose (the sign of
    `travel_from_order`); 0 for the first pose and joints that did not move."""
    return np.sign(travel_from_order(joints, pose_id)).astype(np.int64)


def check_joint_kinds(linear: np.ndarray, robot, columns: Sequence[str], where: str = "") -> None:
    """UnitError naming the first joint column (``columns``: each joint's column name) whose unit
    is a length where ``robot``'s joint is revolute, or an angle where it is prismatic (``linear``
    ``(n,)`` bool: the column in length units); ``where`` prefixes the message."""
    wrong = np.flatnonzero(np.asarray(linear, bool) != robot.prismatic)
    if wrong.size:
        k = int(wrong[0])
        joint = robot.joints[k]
        kind = "prismatic (give it in mm or m)" if joint.prismatic else "revolute (deg or rad)"
        raise UnitError(f"{where}joint column {k + 1} ({columns[k]}) is in "
                        f"{'length' if linear[k] else 'angle'} units but {robot.name}'s joint {k + 1} "
                        f"({joint.name}) is {kind}: its column is {joint.column}")


@dataclass(frozen=True)
class JointTable:
    """The joint columns of a CSV as read: ``joints (N, n)`` rad, ``header`` (lower-case names),
    ``joint_columns`` their indices (q1..qn), ``cells`` every row's text cells, ``lines`` each
    row's 1-based line number in the file."""

    joints: np.ndarray
    header: list[str]
    joint_columns: list[int]
    cells: list[list[str]]
    lines: np.ndarray

    def joints_of(self, robot, path) -> np.ndarray:
        """``joints`` checked against ``robot`` (their count, and each column's unit a length
        exactly where the joint is prismatic; ``path`` names the file in the UnitError)."""
        q = robot.check_joints(self.joints)
        names = [self.header[c] for c in self.joint_columns]
        check_joint_kinds([_is_length(h) for h in names], robot, [h.rpartition("_")[0] for h in names],
                          f"{path}: ")
        return q

    def column(self, name: str) -> list[str] | None:
        """The text cells of column ``name`` (None when absent)."""
        if name not in self.header:
            return None
        c = self.header.index(name)
        return [row[c] if c < len(row) else "" for row in self.cells]


def read_joint_table(path) -> JointTable:
    """Read the joint columns (q1_deg.. or _rad) of any CSV with a header, keeping the text of
    every cell (e.g. to copy joints exactly as given). Other columns are not interpreted."""
    path = Path(path)
    numbered = [(k, ln) for k, ln in enumerate(read_text(path, "joints CSV file").splitlines(), start=1)
                if ln.strip() and not ln.lstrip().startswith("#")]
    if not numbered:
        raise DataError(f"{path}: the file is empty; it needs a header (q1_deg,...) and joint rows")
    rows = list(csv.reader([ln for _, ln in numbered]))
    header = [h.strip().lower() for h in rows[0]]
    roles = {name: _header_role(name) for name in header if re.fullmatch(r"[qe]\d+_[a-z]+", name)}
    joint_cols = _joint_columns(roles, str(path))
    index, scale = [header.index(h) for h in joint_cols], np.array([roles[h][2] for h in joint_cols])
    n = len(index)
    q = np.empty((len(rows) - 1, n))
    for i, row in enumerate(rows[1:]):
        try:
            q[i] = np.array([float(row[c]) for c in index]) * scale
        except (ValueError, IndexError):
            raise DataError(f"{path}, line {numbered[i + 1][0]}: expected {n} numeric joint values") from None
    if len(q) == 0:
        raise DataError(f"{path}: no joint rows below the header")
    if not np.isfinite(q).all():
        bad = int(np.flatnonzero(~np.isfinite(q).all(axis=1))[0])
        raise DataError(f"{path}, line {numbered[bad + 1][0]}: joint values must be finite")
    return JointTable(joints=q, header=header, joint_columns=index,
                      cells=[[c.strip() for c in row] for row in rows[1:]],
                      lines=np.array([k for k, _ in numbered[1:]]))


def read_joints(path, robot=None) -> np.ndarray:
    """Only the joint columns (q1_deg.. or _rad) of a CSV, ``(N, n)`` rad — for planning a pose
    set before anything is measured. Other columns are ignored."""
    table = read_joint_table(path)
    return table.joints if robot is None else table.joints_of(robot, path)


def _header_role(name: str):
    """(role, index or None, scale) of one header name, or raise UnitError/None for unknown. A joint
    (``q``) or external-axis (``e``) column may be in length units (a prismatic joint, m)."""
    m = re.fullmatch(r"([qe])(\d{1,4})_([a-z]+)", name)
    if m and m.group(3) in LENGTH_UNITS:
        return m.group(1), int(m.group(2)), LENGTH_UNITS[m.group(3)]
    if m and m.group(3) not in ANGLE_UNITS:
        raise UnitError(f"unknown angle unit {m.group(3)!r} in column {name!r}: use _deg or _rad "
                        "(a prismatic joint or a track: _mm or _m)")
    if m:
        return m.group(1), int(m.group(2)), ANGLE_UNITS[m.group(3)]
    m = re.fullmatch(r"(travel)(\d{1,4})_([a-z]+)", name)
    if m:
        unit = m.group(3)
        if unit not in ANGLE_UNITS:
            raise UnitError(f"unknown angle unit {unit!r} in column {name!r}: use _deg or _rad")
        return m.group(1), int(m.group(2)), ANGLE_UNITS[unit]
    m = re.fullmatch(r"approach(\d{1,4})", name)
    if m:
        return "approach", int(m.group(1)), 1.0
    if name in ("payload_kg", "temperature_c"):
        return name.split("_")[0], None, 1.0
    m = re.fullmatch(r"(x|y|z|sigma|distance|payload_x|payload_y|payload_z)_([a-z]+)", name)
    if m:
        unit = m.group(2)
        if unit not in LENGTH_UNITS:
            raise UnitError(f"unknown length unit {unit!r} in column {name!r}: use _mm or _m")
        return m.group(1), None, LENGTH_UNITS[unit]
    if name in _PLAIN_COLUMNS:
        return name, None, 1.0
    if name in _LENGTH_COLUMNS or re.fullmatch(r"[qe]\d+", name):
        raise UnitError(f"column {name!r} has no unit: name it {name}_mm or {name}_m"
                        if name in _LENGTH_COLUMNS else f"column {name!r} has no unit: name it "
                        f"{name}_deg or {name}_rad")
    return None


def _directive(line: str) -> tuple[str, str] | None:
    """``(name, value)`` of a comment line ``# NAME: value`` with NAME in `_DIRECTIVES`, else None."""
    m = re.fullmatch(r"#\s*([a-z_]+)\s*:\s*(.*?)\s*", line.strip().lower())  # a wrong value: named
    return (m.group(1), m.group(2)) if m and m.group(1) in _DIRECTIVES else None


def _columns_kind(columns: set[str]) -> str:
    """The kind a canonical file's columns imply (what `_data_kind` reads without a ``# kind:``)."""
    marked = [spec.name for spec in OBSERVED.values() if spec.column and spec.column in columns]
    for column, kind in (("pair", "distance"), ("qw", "pose"), ("link", "marker")):
        if column in columns:
            marked.append(kind)
    return (marked or ["point"])[0]


def _coded_links(lines: Iterable[str], index: int, texts: dict[str, int]) -> Iterator[str]:
    """The CSV ``lines`` with the ``link`` field (column ``index``) of each data row replaced by the
    code of its text in ``texts`` (filled as the lines are read; a link name is no number for the
    numeric reader), as a row's other fields are."""
    for line in lines:
        fields = line.split(",")
        if len(fields) <= index or line.lstrip().startswith("#") or not line.replace(",", "").strip():
            yield line
            continue
        text = fields[index].strip().strip('"').strip()
        fields[index] = str(texts.setdefault(text, len(texts))) if text else ""
        yield ",".join(fields)


def _split_csv(text: str, name: str) -> tuple[str, dict, int, list[str], Iterator[str]]:
    """(provenance comment, the ``# NAME: value`` directives, header line number, the header row,
    the lines below it, read as they are consumed: no list of every line)."""
    lines = text_lines(text)
    source, directives = "", {}
    for start, line in enumerate(lines):
        if not (line.lstrip().startswith("#") or not line.strip()):
            return source, directives, start + 1, next(csv_rows([line], name), []), lines
        if (d := _directive(line)) is not None:
            directives[d[0]] = d[1]
        elif not source and line.lstrip().startswith("#"):
            source = line.lstrip()[1:].strip()
    raise DataError(f"{name}: the file is empty; a measurement CSV needs a header line "
                    "(e.g. q1_deg,...,q6_deg,x_mm,y_mm,z_mm) and data rows")


def _column_roles(header: list[str], name: str, header_line: int) -> dict:
    """Header name -> (role, index or None, unit scale); errors name the column."""
    seen = set()
    for h in header:
        if h in seen:
            raise DataError(f"{name}: column {h!r} appears twice in the header (line {header_line}); "
                            "remove the duplicate")
        seen.add(h)
    roles = {}
    for h in header:
        try:
            role = _header_role(h)
        except UnitError as exc:
            raise UnitError(f"{name}, line {header_line}: {exc}") from None
        if role is None:
            raise DataError(f"{name}, line {header_line}: unknown column {h!r}; known columns are "
                            "q1_deg..qn_deg (or _rad), e1_mm (a track), x_mm,y_mm,z_mm (or _m), smr, "
                            "sigma_mm, "
                            "qw,qx,qy,qz, "
                            "plane, flush_plane, pair, distance_mm, pose_id, source_row, approach1..n, "
                            "travel1_deg..n, payload_kg, payload_x_mm..payload_z_mm, temperature_c. "
                            "For another layout use `robocal import`")
        roles[h] = role
    return roles


def _is_length(header: str) -> bool:
    """Whether a joint or external-axis column is in length units (a prismatic joint)."""
    return header.rsplit("_", 1)[-1] in LENGTH_UNITS


def _joint_columns(roles: dict, name: str) -> list[str]:
    """The joint columns in ``joints`` order: external axes e1..ek, then q1..qn (no gaps; the
    angle columns in one unit)."""
    out = []
    for role in ("e", "q"):
        cols = sorted((r[1], h) for h, r in roles.items() if r[0] == role)
        if [i for i, _ in cols] != list(range(1, len(cols) + 1)):
            raise DataError(f"{name}: {'external axis' if role == 'e' else 'joint'} columns must be "
                            f"{role}1..{role}{len(cols)} without gaps, got {[h for _, h in cols]}")
        out += [h for _, h in cols]
    if not out:  # external axes alone are a chain of their own: a positioner's e1_deg, e2_deg
        raise DataError(f"{name}: no joint columns; add q1_deg..qn_deg (or q1_rad..qn_rad), or e1_deg.. "
                        "for a positioner's axes")
    if len({roles[h][2] for h in out if not _is_length(h)}) > 1:
        raise UnitError(f"{name}: joint columns mix _deg and _rad; use one unit for all joints")
    return out


def _data_kind(roles: dict, name: str) -> str:
    """The measurement kind the columns describe."""
    present = {r[0] for r in roles.values()}
    xyz = {"x", "y", "z"} & present
    if xyz and xyz != {"x", "y", "z"}:
        raise DataError(f"{name}: a point needs all of x, y, z; missing {sorted({'x', 'y', 'z'} - xyz)}")
    if xyz and len({roles[h][2] for h in roles if roles[h][0] in "xyz"}) > 1:
        raise UnitError(f"{name}: x, y, z columns mix units; use one length unit for all three")
    quat = {"qw", "qx", "qy", "qz"} & present
    if quat and len(quat) != 4:
        raise DataError(f"{name}: a pose needs all of qw, qx, qy, qz; missing "
                        f"{sorted({'qw', 'qx', 'qy', 'qz'} - quat)}")
    if "link" in present and not xyz:
        raise DataError(f"{name}: a 'link' column names the link carrying each marker: add x_mm,y_mm,z_mm")
    marked = [spec.name for spec in OBSERVED.values() if spec.column and spec.column in present]
    if len(marked) > 1:
        raise DataError(f"{name}: the columns {', '.join(OBSERVED[k].column for k in marked)} mark different "
                        f"kinds ({', '.join(marked)}): one file holds one kind of contact")
    if marked:
        column = OBSERVED[marked[0]].column
        if xyz or quat or "pair" in present:
            raise DataError(f"{name}: {marked[0]} contacts have only joints and '{column}'; remove x/y/z, "
                            "quaternion and pair columns")
        return marked[0]
    if "pair" in present or "distance" in present:
        if not {"pair", "distance"} <= present:
            raise DataError(f"{name}: distance data need both 'pair' and 'distance_mm' columns")
        if xyz or quat:
            raise DataError(f"{name}: distance data have no x/y/z or quaternion columns")
        return "distance"
    if quat:
        if not xyz:
            raise DataError(f"{name}: pose data need x, y, z columns with the quaternion")
        if "link" in present:
            raise DataError(f"{name}: a 'link' column marks marker positions: remove the quaternion")
        return "pose"
    if xyz:
        return "marker" if "link" in present else "point"
    raise DataError(f"{name}: no observation columns; add x_mm,y_mm,z_mm (points), "
                    "qw..qz (poses), plane (plane contacts) or pair,distance_mm")


def _declared_kind(columns_kind: str, declared: str | None, name: str) -> str:
    """The kind a ``# kind: NAME`` line declares (it must take the arrays the columns give, e.g.
    ``eye_in_hand`` for x, y, z and a quaternion), else the columns' kind."""
    if declared is None:
        return columns_kind
    try:
        spec = kind_spec(declared)
    except DataError as exc:
        raise DataError(f"{name}: '# kind: {declared}': {exc}") from None
    if spec.arrays != OBSERVED[columns_kind].arrays or spec.column != OBSERVED[columns_kind].column:
        raise DataError(f"{name}: '# kind: {declared}' needs the columns {spec.columns}, but the file has "
                        f"those of {columns_kind} rows ({OBSERVED[columns_kind].columns})")
    return declared


def _observed(kind: str, col: dict, roles: dict, line_no: list[int], name: str,
              link_texts: np.ndarray | None = None) -> dict:
    """The kind's observation arrays (SI) from the columns (a ``link`` column of names: its
    ``link_texts``, which the column's codes index: :func:`_coded_links`); unit errors name the
    line."""
    def length(c: str) -> np.ndarray:
        h = next(h for h in col if roles[h][0] == c)
        return col[h] * roles[h][2]

    kw, spec = {}, OBSERVED[kind]
    if "points" in spec.arrays:
        kw["points"] = np.stack([length(c) for c in "xyz"], axis=1)
        far = np.abs(kw["points"]).max(axis=1) > MAX_TRACKER_RANGE_M
        if far.any():
            ln = line_no[int(np.argmax(far))]
            raise UnitError(f"{name}, line {ln}: a point {np.abs(kw['points'][far][0]).max():.4g} m from the "
                            f"tracker is beyond any tracker's range: the length unit is probably wrong "
                            f"(values in mm must be in columns x_mm, y_mm, z_mm)")
    if "rotations" in spec.arrays:
        qv = np.stack([col["qx"], col["qy"], col["qz"], col["qw"]], axis=1)
        norm = np.linalg.norm(qv, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > ROTATION_TOL)
        if bad.size:
            raise DataError(f"{name}, line {line_no[bad[0]]}: quaternion norm {norm[bad[0]]:.6g} is not 1; "
                            "give a unit quaternion qw,qx,qy,qz")
        kw["rotations"] = Rotation.from_quat(qv).as_matrix()
    if "plane" in spec.arrays:
        kw["plane"] = col[spec.column].astype(np.int64)
    if "link" in spec.optional and "link" in col:
        kw["link"] = col["link"] if link_texts is None else link_texts[col["link"].astype(np.int64)]
    if "pair" in spec.arrays:
        kw["pair"] = col["pair"].astype(np.int64)
        kw["distance"] = length("distance")
    if "sigma" in {r[0] for r in roles.values()}:
        kw["sigma"] = length("sigma")
    return kw


def _per_joint(col: dict, roles: dict, role: str, n: int, name: str) -> np.ndarray | None:
    """``(N, n)`` values (SI) of the columns ``{role}1..{role}n`` (approach, travel), or None."""
    cols = sorted((r[1], h) for h, r in roles.items() if r[0] == role)
    if not cols:
        return None
    if [i for i, _ in cols] != list(range(1, n + 1)):
        raise DataError(f"{name}: {role} columns must be {role}1..{role}{n}, one per joint")
    return np.stack([col[h] * roles[h][2] for _, h in cols], axis=1)


def _condition_columns(col: dict, roles: dict, name: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``payload (N, 4)`` (kg, m) and ``temperature (N,)`` deg C from their columns, or None."""
    by_role = {r[0]: h for h, r in roles.items()}
    com = [by_role.get(f"payload_{c}") for c in "xyz"]
    if any(com) and not all(com):
        raise DataError(f"{name}: the payload's centre of mass needs all of payload_x, payload_y, payload_z; "
                        f"missing {[f'payload_{c}' for c, h in zip('xyz', com, strict=True) if h is None]}")
    if any(com) and "payload" not in by_role:
        raise DataError(f"{name}: payload centre-of-mass columns need the payload_kg column (the mass)")
    payload = None
    if "payload" in by_role:
        mass = col[by_role["payload"]]
        xyz = [col[h] * roles[h][2] if h else np.zeros_like(mass) for h in com]
        payload = np.stack([mass, *xyz], axis=1)
    temperature = col[by_role["temperature"]] if "temperature" in by_role else None
    return payload, temperature


def _repeats(joints: np.ndarray, line_no: np.ndarray, name: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """Pose ids of a file without a pose_id column (`repeat_groups`) and notes that say how
    the rows were grouped, or warn of consecutive poses that look like jittering repeats."""
    pose_id = repeat_groups(joints)
    n_poses = int(pose_id[-1]) + 1
    notes = ()
    if n_poses < len(joints):
        notes = (f"{name}: {len(joints)} rows hold {n_poses} poses (consecutive rows with the same joints, "
                 f"within {np.rad2deg(REPEAT_JOINT_TOL_RAD):g} deg, are repeated readings or the SMRs of "
                 "one pose); give a pose_id column to group the rows otherwise",)
    first = np.r_[True, pose_id[1:] != pose_id[:-1]]
    step = np.abs(np.diff(joints[first], axis=0)).max(axis=1)
    near = np.flatnonzero(step <= NEAR_REPEAT_RAD)
    if near.size:
        lines = ", ".join(map(str, line_no[first][near + 1][:5]))
        notes += (f"WARNING: {name}: {near.size} pose(s) (line(s) {lines}) differ from the previous one by "
                  f"at most {np.rad2deg(step[near].max()):.3g} deg: if they are repeated readings of one "
                  "pose, give a pose_id column (rows of one pose share it)",)
    return pose_id, notes


def parse_csv(text: str, name: str = "<text>", max_joint_rad: float = MAX_JOINT_RAD) -> Measurements:
    """Parse canonical CSV text; ``name`` is used in error messages. Radian joint values beyond
    ``max_joint_rad`` (default two turns; wider for a robot whose joints turn further,
    `joint_range_rad`) are read as degrees under the wrong header and refused."""
    source, directives, header_line, header_row, rows = _split_csv(text, name)
    header = [h.strip().lower() for h in header_row]
    if header[0].startswith("format: robocal-"):
        kind = header[0].split("-", 1)[1].split("/")[0]
        raise DataError(f"{name} is a robocal {kind} file, not measurements: give it to the option that "
                        "takes it (a model: --robot, or the command's model argument)")
    if len(header) == 1 and ";" in header[0]:
        raise DataError(f"{name}, line {header_line}: the columns are separated by ';' (a decimal-comma "
                        "export): save the file comma-separated with '.' as the decimal separator")
    roles = _column_roles(header, name, header_line)
    joint_cols = _joint_columns(roles, name)
    kind = _declared_kind(_data_kind(roles, name), directives.get("kind"), name)
    texts: dict[str, int] = {}
    if "link" in header:  # markers' links may be named: the reader sees their codes
        rows = _coded_links(rows, header.index("link"), texts)
    table, line_no = read_table(rows, header, name, header_line)
    col = {h: table[:, i] for i, h in enumerate(header)}
    joints = np.stack([col[h] * roles[h][2] for h in joint_cols], axis=1)
    linear = np.array([_is_length(h) for h in joint_cols])
    angles = np.abs(np.where(linear, 0.0, joints))
    if angles.max() > max_joint_rad and any(roles[h][2] == 1.0 for h in joint_cols if not _is_length(h)):
        ln = line_no[int(np.argmax(angles.max(axis=1)))]
        turns = f"> {max_joint_rad / (2 * np.pi):g} turns"
        raise UnitError(f"{name}, line {ln}: joint values up to {np.abs(joints).max():.4g} rad ({turns}): "
                        "these look like degrees; name the columns q1_deg..")
    kw = _observed(kind, col, roles, line_no, name, np.array(list(texts), dtype=str) if texts else None)
    approach = _per_joint(col, roles, "approach", len(joint_cols), name)
    approach = None if approach is None else approach.astype(np.int64)
    travel = _per_joint(col, roles, "travel", len(joint_cols), name)
    payload, temperature = _condition_columns(col, roles, name)
    ints = {c: (col[c].astype(np.int64) if c in col else None) for c in ("smr", "pose_id")}
    source_row = col["source_row"].astype(np.int64) if "source_row" in col else np.array(line_no)
    notes = ()
    if ints["pose_id"] is None and OBSERVED[kind].group == "pose_id":
        ints["pose_id"], notes = _repeats(joints, np.array(line_no), name)
    hot = None if temperature is None else temperature_note(temperature, name)
    notes += (f"WARNING: {hot}",) if hot else ()
    try:
        data = Measurements.from_arrays(kind, joints, smr=ints["smr"], pose_id=ints["pose_id"],
                                        source_row=source_row, source=source,
                                        conditions=Conditions(approach, travel, payload, temperature),
                                        linear=linear, external=sum(roles[h][0] == "e" for h in joint_cols),
                                        instrument=directives.get("instrument", ""), **kw)
    except DataError as exc:
        raise DataError(f"{name}: {exc}") from None
    return replace(data, notes=notes)
