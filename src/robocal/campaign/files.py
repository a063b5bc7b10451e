"""Campaign files: candidate poses read from a CSV, the planned ``poses.csv``, and writing every
output of a run together (all files or none).

``poses.csv`` has the measurement CSV's joint columns, one row per pose in measuring order:
``q1_deg..qn_deg`` (degrees with up to 10 decimals; a prismatic joint in mm, ``q3_mm``, a track's
carriage ``e1_mm``: the robot's `robocal.kinematics.model.Robot.joints`; generated candidates
are rounded to 1e-4 deg or 1e-4 mm, so the file holds them exactly); with
candidates from a file, the file's own joint columns and the chosen rows' cells exactly as read,
plus ``source_row`` (the row's line in that file). With several SMRs, ``visible_smr0..`` (1/0)
say which SMRs the tracker sees at each pose; plane contacts and distances keep their ``plane``
and ``pair`` columns (one row per contact or distance end). The SMRs the plan assumed,
``smr{k}_x_mm, smr{k}_y_mm, smr{k}_z_mm`` (flange frame), and the tracker's position when one was
given, ``tracker_x_mm, tracker_y_mm, tracker_z_mm`` (robot base frame), repeat on every row, so a
rehearsal (``robocal simulate --joints``) measures the campaign that was planned.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robocal.campaign.programs import DEGREE_DECIMALS, fixed_point
from robocal.core.errors import DataError
from robocal.data.kinds import OBSERVED
from robocal.data.measurements import JointTable, Measurements, read_joint_table
from robocal.kinematics.model import JointSpec

VISIBLE_PREFIX = "visible_smr"
_POINT_COLUMN = re.compile(r"^x_[a-z]+$")  # a measured point's first column (x_mm, x_m, ...)
_XYZ = ("x", "y", "z")


@dataclass(frozen=True)
class CandidateFile:
    """Candidates read from a CSV: ``joints (C, n)`` rad (one per distinct pose, or the rows of
    contacts / distance ends for ``data``), ``rows (C,)`` the table row of each, ``table`` the
    file's joint table, ``data`` the Measurements (plane contacts and distances only),
    ``measured`` the file's measured points or poses when it has them (an earlier campaign: the
    planner reads the unmodelled error they show)."""

    joints: np.ndarray
    rows: np.ndarray
    table: JointTable
    data: Measurements | None = None
    path: str = ""
    measured: Measurements | None = None


def read_candidates(path, robot, kind: str = "point") -> CandidateFile:
    """Candidate poses from any measurement CSV or a joints-only CSV. Repeated readings (rows with
    one ``pose_id``, or consecutive rows with identical joints, e.g. several SMRs) are one pose.
    Plane contacts and distances must come from a measurement CSV of that kind (its plane or
    pair columns place them; the measured values are not used).

    Parameters
    ----------
    path : str or path-like
        A measurement CSV or a CSV with joint columns only (``q1_deg..`` or ``q1_rad..``).
    robot : Robot
        The model (checks the joint count).
    kind : {'point', 'pose', 'plane', 'flush', 'distance'}
        What will be measured.

    Returns
    -------
    CandidateFile
        ``joints`` ``(C, n)`` radians, one per distinct pose (or per contact / distance end),
        ``rows`` ``(C,)`` their rows in the file; give it to `robocal.plan_poses` as
        ``candidates``.

    Raises
    ------
    DataError
        A malformed file, a wrong joint count, or plane / distance candidates from a file of
        another kind.

    See Also
    --------
    rc.plan_poses : Chooses among the candidates.
    robocal.campaign.read_planned : Read a planned file.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.campaign import read_candidates
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> rc.simulate_tracker(robot, 30, n_smr=2, seed=0).data.save("earlier.csv")  # 2 SMRs a pose
    >>> candidates = read_candidates("earlier.csv", robot)
    >>> candidates.joints.shape  # 60 rows, 30 poses
    (30, 6)
    >>> plan = rc.plan_poses(robot, 12, candidates=candidates, region_size=50, starts=1)
    >>> bool(set(plan.candidate_index) <= set(range(30)))
    True
    """
    table = read_joint_table(path)
    q = table.joints_of(robot, path)
    spec = OBSERVED.get(kind)
    if spec is not None and not spec.sees_position:  # a fixture's contacts or pairs: from the file
        data = Measurements.load(path, robot=robot)
        if data.kind != kind or len(data) != len(q):
            raise DataError(f"{path}: {kind} candidates need a {kind} measurement CSV (joints with "
                            f"{spec.columns} column), got "
                            f"{data.kind} data")
        return CandidateFile(joints=q, rows=np.arange(len(q)), table=table, data=data, path=str(path))
    ids = table.column("pose_id")
    if ids is not None:
        try:
            key = np.array([int(float(v)) for v in ids])
        except ValueError:
            raise DataError(f"{path}: the pose_id column must hold integers") from None
        new = np.r_[True, key[1:] != key[:-1]]
    else:
        new = np.r_[True, (q[1:] != q[:-1]).any(axis=1)]
    first = np.flatnonzero(new)
    measured = Measurements.load(path, robot=robot) if any(_POINT_COLUMN.match(h) for h in table.header) \
        else None
    return CandidateFile(joints=q[first], rows=first, table=table, path=str(path),
                         measured=measured if measured is not None and measured.points is not None else None)


def _cells(values: np.ndarray) -> list[str]:
    return [fixed_point(v, DEGREE_DECIMALS) for v in values]


def poses_csv(joints: np.ndarray, visible: np.ndarray | None = None, source: CandidateFile | None = None,
              rows: np.ndarray | None = None, smr_mm=None, tracker_mm=None,
              spec: Sequence[JointSpec] = ()) -> str:
    """The text of ``poses.csv`` (see the module docstring) for ``joints (N, n)`` (rad; m for a
    prismatic joint) in measuring order, each under its joint's column in its unit (``spec``:
    the robot's `robocal.kinematics.model.Robot.joints`: ``q1_deg``, a quill's ``q3_mm``, a track's
    ``e1_mm``); ``source`` and ``rows (N,)`` (table rows) when the candidates came from a file;
    ``smr_mm (k, 3)`` and ``tracker_mm (3,)`` the planned SMRs and tracker position (mm)."""
    if source is None:
        header = [j.column for j in spec]
        shown = np.column_stack([j.shown(joints[:, i]) for i, j in enumerate(spec)])
        body = [_cells(row) for row in shown]
    else:
        t = source.table
        header = [t.header[c] for c in t.joint_columns] + ["source_row"]
        body = [[t.cells[r][c] for c in t.joint_columns] + [str(int(t.lines[r]))] for r in rows]
        for extra in [spec.column for spec in OBSERVED.values() if spec.column] + ["pair"]:
            cells = t.column(extra)
            if source.data is not None and cells is not None:
                header.append(extra)
                for line, r in zip(body, rows, strict=True):
                    line.append(cells[r])
    if visible is not None and visible.shape[1] > 1:
        header += [f"{VISIBLE_PREFIX}{k}" for k in range(visible.shape[1])]
        for line, seen in zip(body, visible, strict=True):
            line += ["1" if s else "0" for s in seen]
    points = [] if smr_mm is None else [(f"smr{k}", xyz) for k, xyz in enumerate(np.reshape(smr_mm, (-1, 3)))]
    points += [] if tracker_mm is None else [("tracker", tracker_mm)]
    fixed = [(f"{what}_{c}_mm", v) for what, xyz in points for c, v in zip(_XYZ, xyz, strict=True)]
    header += [name for name, _ in fixed]
    for line in body:
        line += [repr(float(v)) for _, v in fixed]
    return "\n".join([",".join(header)] + [",".join(line) for line in body]) + "\n"


@dataclass(frozen=True)
class Planned:
    """A planned ``poses.csv``: ``joints (N, n)`` rad, ``visible (N, k)`` bool (None without
    ``visible_smr*`` columns), ``smr (k, 3)`` m and ``tracker (3,)`` m as planned (None when the
    file does not carry them)."""

    joints: np.ndarray
    visible: np.ndarray | None
    smr: np.ndarray | None
    tracker: np.ndarray | None

    def measured_with(self, smr: np.ndarray | None, tracker: np.ndarray | None,
                      path) -> tuple[np.ndarray | None, np.ndarray | None, list[str]]:
        """(SMRs, tracker) to rehearse the campaign ``path`` with: the plan's unless given
        (``smr`` ``(k, 3)`` m, ``tracker`` ``(3,)`` m), and what to tell the user of them (a
        ``WARNING`` line when the given ones differ from the plan's)."""
        lines = []
        for what, mine, theirs, option in (("SMR positions", smr, self.smr, "--smr-mm"),
                                           ("tracker position", tracker, self.tracker, "--tracker-mm")):
            planned = None if theirs is None else np.round(theirs * 1e3, 4).tolist()  # mm
            if theirs is None:
                if mine is None:
                    lines.append(f"note: {path} does not carry a planned {what}: a random one is simulated")
            elif mine is None:
                lines.append(f"using the plan's {what} (mm): {planned} from {path}")
            elif np.shape(mine) != np.shape(theirs) or not np.allclose(mine, theirs, atol=1e-6):
                lines.append(f"WARNING: {option} {np.round(np.asarray(mine) * 1e3, 4).tolist()} differs from "
                             f"the {what} the campaign {path} was planned with ({planned} mm): the rehearsal "
                             "measures another campaign")
        return (self.smr if smr is None else smr), (self.tracker if tracker is None else tracker), lines


def _fixed_columns(table: JointTable, names: list[str], path) -> np.ndarray | None:
    """The one value per column ``names`` that every row repeats (m, from mm), or None when absent."""
    cells = [table.column(h) for h in names]
    if all(c is None for c in cells):
        return None
    if any(c is None for c in cells):
        raise DataError(f"{path}: columns {', '.join(names)} go together; one is missing")
    try:
        values = np.array(cells, dtype=float).T
    except ValueError:
        raise DataError(f"{path}: columns {', '.join(names)} must hold numbers (mm)") from None
    if not np.isfinite(values).all() or (values != values[0]).any():
        raise DataError(f"{path}: columns {', '.join(names)} must repeat one finite value on every row "
                        "(the plan's SMR or tracker position, mm)")
    return values[0] * 1e-3


def read_planned(path, robot) -> Planned:
    """A planned ``poses.csv`` (any joints CSV): its joints, the ``visible_smr*`` columns and the
    SMRs and tracker it was planned with (see the module docstring).

    Parameters
    ----------
    path : str or path-like
        The ``poses.csv`` `robocal.CampaignResult.poses_csv` wrote (or any joints CSV).
    robot : Robot
        The model (checks the joint count).

    Returns
    -------
    Planned
        ``joints`` ``(N, n)`` radians; ``visible`` ``(N, k)`` bool, ``smr`` ``(k, 3)`` m
        (flange frame) and ``tracker`` ``(3,)`` m (robot base frame), each None when the file
        does not carry it.

    Raises
    ------
    DataError
        A malformed file, a wrong joint count, or inconsistent visibility or SMR columns.

    See Also
    --------
    rc.CampaignResult : Writes the planned file.
    robocal.campaign.read_candidates : Read candidate poses.

    Examples
    --------
    >>> from pathlib import Path
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.campaign import read_planned
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> plan = rc.plan_poses(robot, 12, n_candidates=200, region_size=50, starts=1)
    >>> _ = Path("poses.csv").write_text(plan.poses_csv())
    >>> planned = read_planned("poses.csv", robot)
    >>> bool(np.allclose(planned.joints, plan.joints, atol=1e-5)), planned.smr  # SMR at the TCP, mm
    (True, array([[0., 0., 0.]]))
    """
    table = read_joint_table(path)
    q = table.joints_of(robot, path)
    smr = []
    while table.column(f"smr{len(smr)}_x_mm") is not None:
        smr.append(_fixed_columns(table, [f"smr{len(smr)}_{c}_mm" for c in _XYZ], path))
    tracker = _fixed_columns(table, [f"tracker_{c}_mm" for c in _XYZ], path)
    smr = np.array(smr) if smr else None
    names = sorted((h for h in table.header if h.startswith(VISIBLE_PREFIX)),
                   key=lambda h: int(h[len(VISIBLE_PREFIX):]) if h[len(VISIBLE_PREFIX):].isdigit() else -1)
    if not names:
        return Planned(q, None, smr, tracker)
    if names != [f"{VISIBLE_PREFIX}{k}" for k in range(len(names))]:
        raise DataError(f"{path}: visibility columns must be {VISIBLE_PREFIX}0..{VISIBLE_PREFIX}k, "
                        f"got {names}")
    cells = np.array([table.column(h) for h in names]).T
    if not np.isin(cells, ["0", "1"]).all():
        raise DataError(f"{path}: {VISIBLE_PREFIX}* values must be 0 or 1")
    visible = cells == "1"
    if smr is not None and len(smr) != visible.shape[1]:
        raise DataError(f"{path}: {visible.shape[1]} visible_smr columns but {len(smr)} planned SMRs")
    return Planned(q, visible, smr, tracker)


