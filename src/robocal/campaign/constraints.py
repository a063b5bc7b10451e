"""Where the robot may measure: the constraints on candidate poses and the tracker's line of sight.

Every constraint is optional; each removes candidate poses and the planner reports how many
(`Funnel`), so when nothing is left the error names the constraint that removed the last
candidates. Positions are in the model's world frame, which for a catalog robot is the robot's
base frame; SMR positions and facing directions are in the flange frame (``tool0``).

- joint limits with a margin (deg; mm on a prismatic joint) on both ends;
- Cartesian boxes: the TCP (the first SMR) must lie inside at least one box;
- singularity distances (`robocal.ik.singularity.classic_distances`), each a minimum: the
  wrist's (angle between the axes of joints 4 and 6, deg), the elbow's (arm stretched or folded,
  deg) and the shoulder's (m);
- the laser tracker (`Tracker`): an SMR is seen when it faces the tracker within the
  reflector's acceptance half-angle, its distance is inside the tracker's range and, when an
  arm radius is given, the beam clears the arm (the segments joining the origins of frames
  {0}..{4}, thickened by the radius); a pose that shows no SMR is not a candidate; the arm
  (the segments joining the origins of frames {0}..{n} and the SMRs) must also keep a clearance
  from the tracker head.

The minimum joint distance between chosen poses acts during the search (see
`conflict_rows`), not on single candidates.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from robocal.core.errors import DataError
from robocal.data.simulate import check_tracker_position
from robocal.ik.singularity import MEASURE_JOINTS, classic_distances
from robocal.kinematics.model import joints_in_units

DEFAULT_ACCEPTANCE_DEG = 30.0
DEFAULT_RANGE_M = (0.5, 40.0)      # a typical tracker's measuring range; set your instrument's
DEFAULT_CLEARANCE_M = 0.3          # free space kept between the arm's axis lines and the tracker
MAX_DISTANCE_DEG = 3600.0          # an angle or joint distance beyond ten turns is no constraint's
DEFAULT_MARGIN_DEG = 1.0           # generated poses stay this far inside the joint limits
BEAM_ARM_FRAME = 4                 # the arm that can block the beam: frames {0}..{4}


@dataclass(frozen=True)
class Tracker:
    """A laser tracker at ``position (3,)`` m (world frame) with its range ``(min, max)`` m, the
    SMRs' acceptance half-angle (deg), the clearance (m) the arm keeps from it, and an optional
    arm radius (m) for beam occlusion.

    Given to `Constraints` (``tracker=``), it keeps only the poses where the tracker sees an SMR.

    Attributes
    ----------
    position : array_like, shape (3,)
        The tracker's position in the model's world frame (a catalog robot's base frame), metres.
    acceptance_deg : float, default 30
        The SMR's acceptance half-angle, degrees: an SMR is seen when it faces the tracker
        within it.
    range_m : tuple of float, default (0.5, 40)
        The tracker's measuring range (min, max), metres.
    clearance_m : float, default 0.3
        The free space the arm (and the SMRs) keep from the tracker head, metres.
    arm_radius_m : float, optional
        The arm's radius, metres: with it, a pose whose beam passes through the arm (frames
        {0}..{4}) is removed.

    Raises
    ------
    DataError
        A non-finite position, ``range_m`` not 0 <= min < max, an acceptance angle outside
        (0, 90] degrees, a negative clearance or a non-positive arm radius.

    See Also
    --------
    rc.plan_poses : Plans in its line of sight.
    rc.Constraints : The robot's constraints.

    Examples
    --------
    >>> import robocal as rc
    >>> tracker = rc.Tracker(position=[3.0, 0.0, 0.5], acceptance_deg=25)
    >>> tracker.range_m
    (0.5, 40.0)
    >>> rc.Tracker(position=[3.0, 0.0, 0.5], range_m=(5, 1))
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: the tracker range must be 0 <= min < max (m), got (5, 1)
    """

    position: np.ndarray
    acceptance_deg: float = DEFAULT_ACCEPTANCE_DEG
    range_m: tuple[float, float] = DEFAULT_RANGE_M
    clearance_m: float = DEFAULT_CLEARANCE_M
    arm_radius_m: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", check_tracker_position(self.position))
        lo, hi = (float(v) for v in self.range_m)
        if not 0 <= lo < hi:
            raise DataError(f"the tracker range must be 0 <= min < max (m), got {self.range_m}")
        object.__setattr__(self, "range_m", (lo, hi))
        if not 0 < self.acceptance_deg <= 90:
            raise DataError("the SMR acceptance half-angle must be in (0, 90] deg, got "
                            f"{self.acceptance_deg}")
        if self.clearance_m < 0 or (self.arm_radius_m is not None and self.arm_radius_m <= 0):
            raise DataError("the tracker clearance must be >= 0 and the arm radius > 0 (m)")


@dataclass(frozen=True)
class Constraints:
    """The optional constraints (see the module docstring); lengths in m, angles in deg.
    ``margin_deg`` None: 1 deg for generated candidates, 0 for given ones (poses already taught
    or measured are known to be reachable, at a limit too).

    Each constraint removes candidate poses in `robocal.plan_poses`; the result's ``funnel``
    says how many each removed.

    Attributes
    ----------
    margin_deg : float, optional
        Distance kept from both joint limits, degrees (millimetres on a prismatic joint: a
        quill, a track).
    boxes : sequence of array_like, shape (2, 3) each
        Cartesian boxes ``((xmin, ymin, zmin), (xmax, ymax, zmax))`` in the world frame, metres:
        the TCP (the first SMR) must lie inside at least one.
    min_joint_distance_deg : float, default 0
        Smallest joint-space distance between two chosen poses, degrees (Euclidean over the
        joints; a prismatic joint counts in millimetres).
    min_wrist_deg : float, default 0
        Smallest angle between the axes of joints 4 and 6, degrees (less than 90).
    min_elbow_deg : float, default 0
        Smallest angle from the stretched or folded elbow, degrees (less than 90).
    min_shoulder_m : float, default 0
        Smallest shoulder distance (the origin of frame {5} from the plane through axis 1
        parallel to axis 2, see `robocal.ik.singularity`), metres.
    tracker : Tracker, optional
        The laser tracker whose line of sight, range and clearance a pose must respect.

    Raises
    ------
    DataError
        A box that is not ``(2, 3)`` with min < max, a negative or non-finite value, or a
        singularity angle of 90 degrees or more.

    See Also
    --------
    rc.plan_poses : Plans within them.
    rc.Tracker : The tracker's constraints.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> box = ((0.5, -1.0, 0.2), (2.0, 1.0, 1.8))  # m, robot base frame
    >>> limits = rc.Constraints(boxes=[box], tracker=rc.Tracker(position=[3.0, 0.0, 0.5]))
    >>> plan = rc.plan_poses(robot, 20, n_candidates=300, region_size=100, starts=1,
    ...                      constraints=limits)
    >>> tcp = robot.fk(plan.joints)[:, :3, 3]
    >>> bool(((tcp >= box[0]) & (tcp <= box[1])).all()), bool(plan.visible.all())
    (True, True)
    """

    margin_deg: float | None = None
    boxes: tuple = ()
    min_joint_distance_deg: float = 0.0
    min_wrist_deg: float = 0.0
    min_elbow_deg: float = 0.0
    min_shoulder_m: float = 0.0
    tracker: Tracker | None = None

    def __post_init__(self) -> None:
        boxes = []
        for box in self.boxes:
            b = np.asarray(box, dtype=float)
            if b.shape != (2, 3) or not np.isfinite(b).all() or (b[0] >= b[1]).any():
                raise DataError("a box is ((xmin, ymin, zmin), (xmax, ymax, zmax)) in m with min < max, "
                                f"got {np.asarray(box).tolist()}")
            boxes.append(b)
        object.__setattr__(self, "boxes", tuple(boxes))
        for name in ("margin_deg", "min_joint_distance_deg", "min_wrist_deg", "min_elbow_deg",
                     "min_shoulder_m"):
            value = getattr(self, name)
            if value is None and name == "margin_deg":
                continue
            if not np.isfinite(value) or value < 0:
                raise DataError(f"{name} must be a finite value >= 0, got {value}")
            if name.endswith("_deg") and value > MAX_DISTANCE_DEG:  # 1e308 overflowed (exit 3)
                raise DataError(f"{name} must be at most {MAX_DISTANCE_DEG:g} deg, got {value:g}")
        if self.min_wrist_deg >= 90 or self.min_elbow_deg >= 90:
            raise DataError("singularity angles are at most 90 deg from a singularity: use less than 90")


@dataclass
class Funnel:
    """How many candidates each constraint removed (``steps``: name -> count, in the order
    first applied)."""

    start: int = 0
    steps: dict[str, int] = field(default_factory=dict)

    def record(self, name: str, removed: int) -> None:
        self.steps[name] = self.steps.get(name, 0) + int(removed)

    @property
    def left(self) -> int:
        return self.start - sum(self.steps.values())

    def text(self) -> str:
        parts = [f"{self.start} candidate poses"]
        parts += [f"{name} removed {count}" for name, count in self.steps.items()]
        return "; ".join(parts) + f"; {self.left} left"

    def to_dict(self) -> dict:
        return {"candidates": self.start,
                "removed": [{"constraint": n, "count": c} for n, c in self.steps.items()],
                "left": self.left}


def in_joint_units(robot, value: float) -> np.ndarray:
    """``(n,)``: ``value`` taken in each joint's unit (deg on a revolute joint, mm on a prismatic
    one: `robocal.kinematics.model.JointSpec.unit`), in SI (rad, m)."""
    return np.where(robot.prismatic, value * 1e-3, np.deg2rad(value))


def margin_unit(robot) -> str:
    """The unit a joint margin or distance is in on ``robot``: ``deg``, ``mm`` (all joints
    prismatic) or e.g. ``deg, mm on q3`` (`in_joint_units`)."""
    sliding = [j.name for j in robot.joints if j.prismatic]
    if not sliding or len(sliding) == robot.n_joints:
        return "mm" if sliding else "deg"
    return f"deg, mm on {', '.join(sliding)}"


def limits_with_margin(robot, margin_deg: float) -> np.ndarray:
    """``(n, 2)`` joint limits (rad; m on a prismatic joint) shrunk by the margin, in each joint's
    unit (deg; mm on a prismatic joint: a quill's or a track's 1 mm, not 1 deg = 17 mm); DataError
    when a joint has no room."""
    m = in_joint_units(robot, margin_deg)
    lim = robot.limits + np.stack([m, -m], axis=1)
    tight = np.flatnonzero(lim[:, 0] > lim[:, 1])
    if tight.size:
        i = int(tight[0])
        joint = robot.joints[i]
        lo, hi = joint.shown(np.array(joint.limits))
        raise DataError(f"a joint-limit margin of {margin_deg:g} {joint.unit} leaves no room on joint "
                        f"{i + 1} (limits {lo:.4g} to {hi:.4g} {joint.unit}): lower the margin")
    return lim


def smr_geometry(robot, q: np.ndarray, smr: np.ndarray, normals: np.ndarray):
    """World positions and facing directions ``(N, k, 3)`` of SMRs ``smr (k, 3)`` (m) with facing
    directions ``normals (k, 3)`` in the flange frame, and the frames ``(N, n + 1, 4, 4)``."""
    _, frames = robot.fk(q, frames=True)
    flange = frames[:, -1] @ robot.tool
    R, t = flange[:, :3, :3], flange[:, :3, 3]
    pos = np.einsum("nij,kj->nki", R, smr) + t[:, None, :]
    nrm = np.einsum("nij,kj->nki", R, normals)
    return pos, nrm, frames


def _segment_point_distance(a: np.ndarray, b: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distance of point(s) ``p`` from segments ``a -> b`` (broadcast over leading dims)."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1)


def segment_segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Shortest distance (m, shape: the broadcast of the inputs but the last axis) between segments
    ``p1 -> q1`` and ``p2 -> q2`` (points ``(..., 3)`` m, broadcast), the
    clamped closest-point construction (Ericson, Real-Time Collision Detection 5.1.9)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.sum(d1 * d1, axis=-1)
    e = np.sum(d2 * d2, axis=-1)
    f = np.sum(d2 * r, axis=-1)
    c = np.sum(d1 * r, axis=-1)
    b = np.sum(d1 * d2, axis=-1)
    denom = a * e - b * b
    tiny = 1e-300
    s = np.where(denom > 1e-12 * a * e, np.clip((b * f - c * e) / np.maximum(denom, tiny), 0, 1), 0.0)
    t = (b * s + f) / np.maximum(e, tiny)
    s_low = np.clip(-c / np.maximum(a, tiny), 0, 1)       # t clamped to 0
    s_high = np.clip((b - c) / np.maximum(a, tiny), 0, 1)  # t clamped to 1
    s = np.where(t < 0, s_low, np.where(t > 1, s_high, s))
    t = np.clip(t, 0, 1)
    return np.linalg.norm(p1 + s[..., None] * d1 - p2 - t[..., None] * d2, axis=-1)


def check_tracker_placement(robot, tracker: Tracker, reach: float) -> None:
    """Refuse a tracker inside the robot's base or out of range of everything the robot reaches."""
    _, frames = robot.fk(np.zeros((1, robot.n_joints)), frames=True)
    base = robot.base[:3, 3]
    column_top = frames[0, 1, :3, 3]
    gap = float(_segment_point_distance(base, column_top, tracker.position))
    if gap < tracker.clearance_m:
        where = np.round(tracker.position * 1e3, 1).tolist()
        raise DataError(f"the tracker at {where} mm is inside the robot: {gap * 1e3:.0f} mm from its base "
                        f"column (clearance {tracker.clearance_m * 1e3:.0f} mm); place it outside the robot")
    distance = float(np.linalg.norm(tracker.position - base))
    lo, hi = tracker.range_m
    if distance - reach > hi:
        raise DataError(f"the tracker is {distance:.3g} m from the robot's base, beyond its range of "
                        f"{hi:g} m from anything the robot reaches ({reach:.3g} m): move it closer or give "
                        "its range")
    if distance + reach < lo:
        raise DataError(f"the tracker is {distance:.3g} m from the robot's base: every SMR position is "
                        f"closer than its minimum range of {lo:g} m")


def apply(robot, q: np.ndarray, constraints: Constraints, smr: np.ndarray, normals: np.ndarray,
          funnel: Funnel, limits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Apply the per-pose constraints to candidates ``q (N, n)`` rad.

    Returns ``keep (N,)`` and ``visible (N, k)`` (which SMRs the tracker sees; all when no
    tracker is given), and records the removals in ``funnel``.
    """
    keep = ((q >= limits[:, 0]) & (q <= limits[:, 1])).all(axis=1)
    margin = f" (margin {constraints.margin_deg:g} {margin_unit(robot)})" if constraints.margin_deg else ""
    funnel.record(f"the joint limits{margin}", int(np.sum(~keep)))
    pos, nrm, frames = smr_geometry(robot, q, smr, normals)

    def step(name: str, ok: np.ndarray) -> None:
        nonlocal keep
        funnel.record(name, int(np.sum(keep & ~ok)))
        keep = keep & ok

    if constraints.boxes:
        tcp = pos[:, 0]
        inside = np.zeros(len(q), bool)
        for b in constraints.boxes:
            inside |= ((tcp >= b[0]) & (tcp <= b[1])).all(axis=1)
        step("the TCP box" + ("es" if len(constraints.boxes) > 1 else ""), inside)
    mins = {"wrist_deg": constraints.min_wrist_deg, "elbow_deg": constraints.min_elbow_deg,
            "shoulder_mm": constraints.min_shoulder_m * 1e3}
    if any(mins.values()):
        measures = classic_distances(frames)
        for key, limit in mins.items():
            if not limit:
                continue
            kind, unit = key.split("_")
            if key not in measures:
                raise DataError(f"the {kind} singularity distance needs a chain of at least "
                                f"{MEASURE_JOINTS[key]} joints")
            step(f"the {kind} singularity distance (>= {limit:g} {unit})", measures[key] >= limit)
    visible = np.ones((len(q), len(smr)), bool)
    tracker = constraints.tracker
    if tracker is not None:
        d = tracker.position - pos                                  # SMR -> tracker (N, k, 3)
        dist = np.linalg.norm(d, axis=2)
        cos = np.sum(d * nrm, axis=2) / np.maximum(dist, 1e-300)
        visible = cos >= np.cos(np.deg2rad(tracker.acceptance_deg))
        step(f"the tracker line of sight (SMR facing the tracker within {tracker.acceptance_deg:g} deg)",
             visible.any(axis=1))
        lo, hi = tracker.range_m
        visible &= (dist >= lo) & (dist <= hi)
        step(f"the tracker range ({lo:g}-{hi:g} m)", visible.any(axis=1))
        origins = frames[:, :, :3, 3]                               # (N, n + 1, 3)
        if tracker.arm_radius_m is not None:
            arm = origins[:, : BEAM_ARM_FRAME + 1]
            gap = segment_segment_distance(arm[:, None, :-1], arm[:, None, 1:],
                                            pos[:, :, None], tracker.position)
            visible &= gap.min(axis=2) > tracker.arm_radius_m
            step(f"the arm blocking the beam (arm radius {tracker.arm_radius_m * 1e3:g} mm)",
                 visible.any(axis=1))
        if tracker.clearance_m > 0:
            chain = np.concatenate([origins, pos], axis=1)
            flange = np.repeat(origins[:, -1:], pos.shape[1], axis=1)  # flange -> each SMR
            start = np.concatenate([origins[:, :-1], flange], axis=1)
            near = _segment_point_distance(start, chain[:, 1:], tracker.position).min(axis=1)
            step(f"the tracker clearance (arm within {tracker.clearance_m * 1e3:g} mm of the tracker)",
                 near >= tracker.clearance_m)
    return keep, visible & keep[:, None]


def conflict_rows(q: np.ndarray, min_distance_deg: float, prismatic: np.ndarray | None = None):
    """``conflicts(j) -> (C,)`` 0/1: candidates ``q (C, n)`` (rad; m on a joint flagged in
    ``prismatic (n,)``, e.g. ``robot.prismatic``) closer than ``min_distance_deg`` to candidate
    ``j``, ``j`` included: the Euclidean joint-space distance over the joints in their units (deg;
    mm on a prismatic joint, 1 mm counting as 1 deg)."""
    qd = joints_in_units(q, False if prismatic is None else prismatic)
    limit = float(min_distance_deg) ** 2

    def conflicts(j: int) -> np.ndarray:
        near = np.sum((qd - qd[j]) ** 2, axis=1) < limit
        near[j] = True
        return near.astype(np.int64)

    return conflicts
