"""Virtual laser tracker (and plane-contact probe): measurements of a known true robot.

The true robot is the given (nominal) robot plus random parameter errors (`perturbed`):
lengths a, d by 0.05-0.5 mm, angles alpha, theta (theta errors are the joint zero offsets) by
0.005-0.05 deg, beta by the same on nominally parallel axes; random signs, uniform magnitudes
(``error_scale`` multiplies them). The tracker stands at a random position ``TRACKER_DISTANCE_M``
(2-4 m) from the robot's base origin with a uniformly random orientation, so the truth's base
frame is tracker -> frame {0}. SMR 0 sits on the flange at a random offset (|xy| <= 50 mm,
z 50-120 mm); extra SMRs are 100-150 mm from SMR 0. Joints are uniform within the joint limits
(optionally kept only where the SMR is inside ``workspace_box``, robot base frame, m).
An arm on a track (:mod:`robocal.kinematics.cell`) also gets track errors: direction tilt, encoder
scale and mount (:func:`true_track_cell`); its carriage positions are uniform along the track.

Noise, added to each point in the tracker frame:

- ``isotropic``: N(0, noise_mm^2) on each axis;
- ``tracker``: the instrument's own model, radial (range, ADM) sigma = 10 um + 0.5 um/m * r and
  transverse (angle encoders) sigma = 2.5 urad * r on each of the two transverse axes
  (r = distance from the tracker, m). ``noise_mm`` is ignored.

A fraction ``outliers`` of the rows gets an extra gross error of uniform size ``OUTLIER_MM``
(1-5 mm) in a random direction. The *noise drawn* is the 3-D RMS (sqrt(mean |n|^2), mm) of the noise actually
added, outliers excluded: the figure a perfect calibration's RMS residual would reach on these rows
(this draw of the noise; it scatters by a few percent around the noise floor of the noise model,
:mod:`robocal.report.floor`, which the calibration and its report quote). It is in
``SimulationResult.noise_floor_mm``, in the data's source and the truth YAML's description ("noise
drawn") and in the sidecar JSON
that `write_simulation` writes next to the truth (``truth.yaml`` -> ``truth.sim.json``).

Kinds: ``point`` (n_smr SMRs per pose), ``pose`` (6-DOF probe; ``rotation_noise_deg`` per axis),
``plane`` (a probe tip touching ``n_planes`` planes with random normals; the world frame is the
robot base, only joints are recorded, with ``joint_noise_deg`` reading noise; probe noise: each
true tip lies ``noise_mm`` (1-sigma, along the normal) off its plane, so the noise floor is that
distance's RMS; plane coefficients go to the sidecar), ``flush`` (the tool face pressed flush
on ``n_planes`` planes with random normals, world = robot base, joints only: each true face
centre lies ``noise_mm`` (1 sigma) off its plane along the normal, and its normal is tilted by
``rotation_noise_deg`` per axis, by default ``noise_mm`` over the 50 mm rim length; the noise floor
is the RMS of the contacts' error: height and rim lifts), ``distance`` (``n_poses`` placements of
a scale bar of certified length ``bar_length_m`` touched by the probe tip at its two nests: the
two rows of a pair record the certified length, the true tips are that length plus noise_mm
(1-sigma) apart; no tracker, the world frame is the robot base).

``as_is=True`` measures the given robot exactly as it is (no errors drawn, its own base and
tool): a second data set of the truth of an earlier simulation (e.g. the scale bar of a plane
campaign: ``--robot truth.yaml --as-is``). ``joint_noise_deg`` adds reading noise to
the recorded joints of every kind.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import robocal.data.simulated_physics as physics
from robocal.core.errors import DataError, UnreachableError
from robocal.core.io import write_all
from robocal.core.magnitudes import check_tool
from robocal.data.kinds import FLUSH_TILT_LENGTH_M, KINDS, OBSERVED
from robocal.data.measurements import Measurements, approach_from_order, robot_reach, travel_from_order
from robocal.kinematics.cell import arm_model, carriage_frames, is_track_cell
from robocal.kinematics.cell_file import TRACK_SCALE
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.model import Robot, track_chain
from robocal.kinematics.model_file import dump_model
from robocal.kinematics.transforms import invert_transform, make_transform, rotvec_to_matrix, transform_points

TRACKER_RADIAL_MM = 0.010        # ADM range noise at zero distance (1 sigma)
TRACKER_RADIAL_UM_PER_M = 0.5    # growth of the range noise with distance
TRACKER_ANGULAR_URAD = 2.5       # angle-encoder noise (1 sigma, each transverse axis)
NOISE_MODELS = ("isotropic", "tracker")
TRACKER_DISTANCE_M = (2.0, 4.0)  # a random tracker stands this far from the robot's base origin, m
OUTLIER_MM = (1.0, 5.0)          # size of a gross error (uniform), mm
SCALE_BAR_M = 0.5  # default certified length of a simulated scale bar (distance kind), m
MIN_BAR_ANGLE_DEG = 20.0  # the two poses of a bar placement differ by at least this much (joint 1 or 2)
# A true arm on a track (error_scale 1): the track's direction tilted, the encoder's scale and the
# mount (carriage -> robot base) off by these (a rack-and-pinion track as installed, uncompensated).
TRACK_TILT_DEG = 0.04
TRACK_SCALE_ERROR = 2e-4
MOUNT_ERROR_MM = 1.0
MOUNT_ERROR_DEG = 0.05


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """``data``: the measurements; ``truth``: the true robot (tracker frame as base, SMR 0 as tool,
    extra SMRs in ``truth.smr``); ``noise`` (N, 3) m the noise added to each point (zeros for
    plane data); ``noise_floor_mm`` (see module docstring); ``outlier_rows`` row indices with a
    gross error; ``true_joints`` (N, n) rad before joint reading noise; ``planes`` (P, 4) unit
    normal and offset (n.p = c, m) of plane and flush data (world = robot base), else None; ``info`` the
    settings and seed.

    Returned by `robocal.simulate_tracker`.

    Attributes
    ----------
    data : Measurements
        The simulated measurements.
    truth : Robot
        The true robot (tracker frame as base, SMR 0 as tool, extra SMRs in ``truth.smr``).
    noise : numpy.ndarray, shape (N, 3)
        The noise added to each point, metres (flush data: the face centre's height along the
        plane's normal plus its two tilts times the 50 mm rim length, along the plane's axes).
    noise_floor_mm : float
        RMS of the noise added (outliers excluded), mm: what a perfect calibration reaches.
    outlier_rows : numpy.ndarray of int
        Rows given a gross error.
    true_joints : numpy.ndarray, shape (N, n)
        The joints before the reading noise, radians.
    planes : numpy.ndarray, shape (P, 4), optional
        Unit normal and offset (n.p = c, m) of each plane (plane and flush data; world = robot
        base; for flush data the normal is along the tool's z at the contacts).
    info : dict
        The settings and the seed.
    warnings : list of str
        Always empty: a simulation measures what it is told (the result protocol).

    See Also
    --------
    rc.simulate_tracker : The simulation that returns it.
    rc.Measurements : Its ``data``.

    Examples
    --------
    >>> import robocal as rc
    >>> sim = rc.simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 20, outliers=0.1, seed=4)
    >>> len(sim.outlier_rows), sim.noise.shape  # 10 % of 20 rows got a gross error
    (2, (20, 3))
    >>> sim.info["seed"]
    4
    """

    data: Measurements
    truth: object
    noise: np.ndarray
    noise_floor_mm: float
    outlier_rows: np.ndarray
    true_joints: np.ndarray
    planes: np.ndarray | None
    info: dict
    warnings: list[str] = field(default_factory=list)  # a simulation measures what it is told: none

    def summary(self) -> str:
        """Observations, poses, the noise floor (mm) and the outliers.

        Returns
        -------
        str
            The summary text.
        """
        info = self.info
        return (f"simulated {len(self.data)} {info['kind']} observations of {info['n_poses']} poses; "
                f"noise drawn {self.noise_floor_mm:.4f} mm RMS; {len(self.outlier_rows)} outlier(s)")

    def to_dict(self) -> dict:
        """The settings and seed, the outliers' file lines and the planes (the sidecar JSON).

        Returns
        -------
        dict
            The sidecar JSON's content (JSON-ready).
        """
        side = dict(self.info)
        side["outlier_rows"] = (self.outlier_rows + 2).tolist()  # file line numbers
        side["planes"] = None if self.planes is None else [
            {"normal": row[:3].tolist(), "offset_m": float(row[3])} for row in self.planes]
        return side

    def write(self, data_path, truth_path) -> list[str]:
        """Write the data CSV, the truth model YAML and the sidecar JSON ``TRUTH.sim.json`` (all
        three or none); the paths written.

        Parameters
        ----------
        data_path : str or pathlib.Path
            The measurement CSV.
        truth_path : str or pathlib.Path
            The true model's YAML; the sidecar JSON is written next to it.

        Returns
        -------
        list of str
            The paths written.
        """
        return [str(data_path), str(truth_path), str(write_simulation(self, data_path, truth_path))]


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random rotation matrix ``(3, 3)`` (scipy, from a normal 4-vector read as w, x, y,
    z)."""
    return Rotation.from_quat(rng.standard_normal(4), scalar_first=True).as_matrix()


def random_directions(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` uniformly random unit vectors ``(n, 3)``."""
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def perturbed(robot: Robot, seed: int | np.random.Generator | None = None, *, scale: float = 1.0,
              length_mm: tuple[float, float] = (0.05, 0.5),
              angle_deg: tuple[float, float] = (0.005, 0.05)) -> Robot:
    """A realistic 'true' robot around ``robot``: every link length a, d displaced by a random sign
    times a magnitude uniform in ``length_mm``, every angle alpha, theta (and beta on nominally
    parallel axes) likewise in ``angle_deg``, all times ``scale``. The nominal vector is kept."""
    rng = np.random.default_rng(seed)
    n = robot.n_joints

    def draw(lo, hi):
        return rng.uniform(lo, hi, n) * rng.choice([-1.0, 1.0], n) * scale

    mm, deg = 1e-3, np.pi / 180
    lengths = [v * mm for v in length_mm]
    angles = [v * deg for v in angle_deg]
    return replace(robot, alpha=robot.alpha + draw(*angles), a=robot.a + draw(*lengths),
                   beta=robot.beta + np.where(robot.parallel, draw(*angles), 0.0),
                   theta=robot.theta + draw(*angles), d=robot.d + draw(*lengths))


def sample_joints(robot, n: int, rng: np.random.Generator, workspace_box=None, tool=None) -> np.ndarray:
    """``(n, dof)`` joints uniform in the limits; with ``workspace_box`` ((3,), (3,)) m in the
    robot base frame, only poses whose tool point lies inside (batched rejection sampling)."""
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    if workspace_box is None:
        return rng.uniform(lo, hi, (n, robot.n_joints))
    box = np.asarray(workspace_box, float)
    if box.shape != (2, 3) or (box[0] >= box[1]).any():
        raise DataError("workspace_box must be ((xmin, ymin, zmin), (xmax, ymax, zmax)) in m with min < max")
    local = replace(robot, base=np.eye(4), tool=robot.tool if tool is None else tool)
    kept = []
    count = 0
    for _ in range(200):
        q = rng.uniform(lo, hi, (max(4 * n, 256), robot.n_joints))
        p = local.fk(q)[:, :3, 3]
        ok = ((p >= box[0]) & (p <= box[1])).all(axis=1)
        kept.append(q[ok])
        count += int(ok.sum())
        if count >= n:
            return np.concatenate(kept)[:n]
    raise UnreachableError(f"only {count} of {n} poses found inside the workspace box {box.tolist()} m "
                           "(robot base frame): enlarge the box or check its units")


def check_tracker_position(position) -> np.ndarray:
    """A tracker position as a finite ``(3,)`` array in m (DataError otherwise)."""
    pos = np.asarray(position, dtype=float).reshape(-1)
    if pos.shape != (3,) or not np.isfinite(pos).all():
        raise DataError("the tracker position must be three finite coordinates (m)")
    return pos


def smr_in_link_frame(robot: Robot, smr: np.ndarray) -> np.ndarray:
    """SMR positions ``(k, 3)`` m given in the flange frame (the robot's ``tool``), in the last
    link frame."""
    return transform_points(robot.tool, smr)


def _tracker_noise(p: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    r = np.linalg.norm(p, axis=1, keepdims=True)
    u = p / r
    helper = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(u, e1)
    z = rng.standard_normal((len(p), 3))
    radial = (TRACKER_RADIAL_MM * 1e-3 + TRACKER_RADIAL_UM_PER_M * 1e-6 * r) * z[:, :1]
    transverse = TRACKER_ANGULAR_URAD * 1e-6 * r
    return radial * u + transverse * (z[:, 1:2] * e1 + z[:, 2:3] * e2)


def _move_tips(robot, q: np.ndarray, target: np.ndarray, normal: np.ndarray | None = None,
               iterations: int = 30, damping: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Joints near ``q (N, n)`` whose tips are at ``target (N, 3)`` (m), or with ``normal (N, 3)``
    (unit) on the planes ``normal . p = target`` (``target (N,)``, m): damped minimum-norm
    Gauss-Newton on the joints (the joint Jacobian is the identification Jacobian's columns of
    `Robot.joint_params`: theta_i, a prismatic joint's d_i; projected on the normal for planes).
    Returns the joints and the distance ``(N,)`` left to the target."""
    names = robot.joint_params

    def residual(q):  # (N, 3) from the points, (N, 1) from the planes
        p = robot.fk(q)[:, :3, 3]
        return p - target if normal is None else (np.einsum("ni,ni->n", normal, p) - target)[:, None]

    for _ in range(iterations):
        r = residual(q)
        if np.abs(r).max() < 1e-13:
            break
        J = robot.jacobian(q, names, kind="point")  # (N, 3, n)
        if normal is not None:
            J = np.einsum("ni,nij->nj", normal, J)[:, None]
        A = np.einsum("nik,njk->nij", J, J) + damping * np.eye(r.shape[1])
        q = q - np.einsum("nik,ni->nk", J, np.linalg.solve(A, r[:, :, None])[:, :, 0])
    return q, np.linalg.norm(residual(q), axis=1)


def _check(kind, noise_model, n_poses, n_smr, n_planes, outliers, noise_mm, joint_noise_deg,
           rotation_noise_deg) -> None:
    if kind not in KINDS:
        raise DataError(f"unknown simulation kind {kind!r}: use one of {', '.join(KINDS)}")
    if noise_model not in NOISE_MODELS:
        raise DataError(f"unknown noise model {noise_model!r}: use 'isotropic' or 'tracker'")
    if int(n_poses) < 1 or int(n_smr) < 1 or int(n_planes) < 1:
        raise DataError("n_poses, n_smr and n_planes must be >= 1")
    if not 0.0 <= outliers < 1.0 or noise_mm < 0 or joint_noise_deg < 0 or rotation_noise_deg < 0:
        raise DataError("outliers must be in [0, 1) and noise levels >= 0")
    if not OBSERVED[kind].several_smrs and n_smr != 1:
        raise DataError(f"{kind} simulation uses one tool point: set n_smr = 1")


def _true_robot(robot: Robot, rng: np.random.Generator, kind: str, n_smr: int, error_scale: float,
                smr_offsets=None, tracker_position=None) -> Robot:
    """The perturbed robot with its SMRs (or probe) on the flange and, for tracker data, the
    tracker frame as base; its nominal is the given robot's links with these frames."""
    true = true_arm(robot, rng, error_scale)
    tool0, extra = flange_smrs(rng, n_smr)
    if smr_offsets is not None:
        placed = smr_in_link_frame(robot, smr_offsets)
        tool0, extra = placed[0], placed[1:]
    tool_R = random_rotation(rng) if OBSERVED[kind].sees_orientation else robot.tool[:3, :3]
    # the tracker frame: random position 2-4 m from the base origin, random orientation
    if not OBSERVED[kind].sees_position:
        base = robot.base.copy()
    else:
        c = random_directions(rng, 1)[0] * rng.uniform(*TRACKER_DISTANCE_M)
        if tracker_position is not None:
            c = robot.base[:3, :3] @ tracker_position + robot.base[:3, 3]
        base = invert_transform(make_transform(random_rotation(rng), c)) @ robot.base
    true = replace(true, base=base, tool=make_transform(tool_R, tool0), smr=extra, nominal=None)
    nominal = true.nominal.copy()
    nominal[: 5 * robot.n_joints] = robot.nominal[: 5 * robot.n_joints]
    return replace(true, nominal=nominal)


def true_arm(robot: Robot, rng: np.random.Generator, error_scale: float) -> Robot:
    """A true arm around ``robot``: `true_track_cell` for an arm on a track, else `perturbed`
    (frames as ``robot``'s)."""
    return true_track_cell(robot, rng, error_scale) if is_track_cell(robot) else \
        perturbed(robot, rng, scale=error_scale)


def flange_smrs(rng: np.random.Generator, n_smr: int) -> tuple[np.ndarray, np.ndarray]:
    """``n_smr`` SMRs on a flange, m: SMR 0 ``(3,)`` at a random offset (|x|, |y| <= 50 mm, z 50-120
    mm) and the others ``(n_smr - 1, 3)`` 100-150 mm from it in random directions."""
    tool0 = np.array([*rng.uniform(-0.05, 0.05, 2), rng.uniform(0.05, 0.12)])
    extra = np.zeros((0, 3))
    if n_smr > 1:
        directions = random_directions(rng, n_smr - 1)
        extra = tool0 + directions * rng.uniform(0.10, 0.15, (n_smr - 1, 1))
    return tool0, extra


def true_track_cell(robot: Robot, rng: np.random.Generator, error_scale: float) -> Robot:
    """A true arm on a track: the arm perturbed as :func:`perturbed` does, the track direction tilted
    by TRACK_TILT_DEG about a random normal, the mount off by MOUNT_ERROR_MM / MOUNT_ERROR_DEG
    (random directions), the encoder scale off by TRACK_SCALE_ERROR (random sign), all times
    ``error_scale``; rebuilt exactly as a cell file's chain (:func:`robocal.kinematics.model.track_chain`)."""
    arm = arm_model(robot).with_frames(base=carriage_frames(robot, 0.0)[0])
    moved = perturbed(arm, rng, scale=error_scale)
    u = robot.fk(np.zeros((1, robot.n_joints)), frames=True)[1][0, 1, :3, 2]  # the track's direction
    normal = np.cross(u, random_directions(rng, 1)[0])
    tilt = rotvec_to_matrix(normal / np.linalg.norm(normal) * np.deg2rad(TRACK_TILT_DEG) * error_scale)
    mount = make_transform(rotvec_to_matrix(random_directions(rng, 1)[0] * np.deg2rad(MOUNT_ERROR_DEG)
                                            * error_scale),
                           random_directions(rng, 1)[0] * MOUNT_ERROR_MM * 1e-3 * error_scale)
    true = track_chain(moved, tilt @ u, mount, robot.limits[0], name=robot.name)
    scale = TRACK_SCALE_ERROR * error_scale * rng.choice([-1.0, 1.0])
    return true.with_values({TRACK_SCALE: scale})


def _tracker_readings(kind: str, T: np.ndarray, rng: np.random.Generator, noise_mm: float,
                      noise_model: str, outliers: float, rotation_noise_deg: float):
    """What the tracker reads of TCP poses ``T (N, 4, 4)``: the observation arrays, the noise
    added ``(N, 3)`` and the outlier rows."""
    N, p = len(T), T[:, :3, 3]
    noise = (rng.standard_normal((N, 3)) * noise_mm * 1e-3 if noise_model == "isotropic"
             else _tracker_noise(p, rng))
    n_out = int(round(outliers * N))
    outlier_rows = np.sort(rng.choice(N, n_out, replace=False)) if n_out else np.zeros(0, np.int64)
    gross = np.zeros((N, 3))
    gross[outlier_rows] = random_directions(rng, n_out) * rng.uniform(*OUTLIER_MM, (n_out, 1)) * 1e-3
    kw = {"points": p + noise + gross}
    if OBSERVED[kind].sees_orientation:
        dR = rotvec_to_matrix(rng.standard_normal((N, 3)) * np.deg2rad(rotation_noise_deg))
        kw["rotations"] = dR @ T[:, :3, :3]
    return kw, noise, outlier_rows


def simulate_tracker(robot, n_poses: int | None = None, *, noise_mm: float = 0.02,
                     noise_model: str = "isotropic", outliers: float = 0.0, n_smr: int = 1,
                     workspace_box=None, seed: int = 0, kind: str = "point", n_planes: int = 1,
                     joint_noise_deg: float = 0.0, rotation_noise_deg: float = 0.0,
                     error_scale: float = 1.0, joints=None, visible=None, smr_offsets=None,
                     tracker_position=None, bar_length_m: float = SCALE_BAR_M,
                     as_is: bool = False, payloads=None, temperatures=None,
                     payload_com=None, thermal_k=None) -> SimulationResult:
    """Simulate ``n_poses`` measured poses of a perturbed copy of ``robot`` (see module docstring).

    The true robot is ``robot`` plus random parameter errors, seen from a randomly placed
    tracker; the robot errors drawn for a seed do not depend on the options that choose poses,
    SMRs or the tracker's position. The same arguments and seed give identical results.

    Parameters
    ----------
    robot : Robot
        The nominal model the truth is drawn around (or, with ``as_is``, the truth itself).
    n_poses : int, optional
        Number of poses (random within the joint limits); not needed with ``joints``. For
        ``distance``: the number of scale-bar placements.
    noise_mm : float, default 0.02
        Measurement noise, 1 sigma per axis, millimetres (ignored by the ``tracker`` model).
    noise_model : {'isotropic', 'tracker'}
        Isotropic noise, or the laser tracker's range and angle noise growing with distance.
    outliers : float, default 0
        Fraction of the rows given a gross error of 1-5 mm.
    n_smr : int, default 1
        SMRs measured at each pose (``point``).
    workspace_box : tuple of array_like, shape (3,) each, optional
        (lower, upper) corners of a box in the robot's base frame, metres: random poses are kept
        inside it.
    seed : int, default 0
        The random seed.
    kind : {'point', 'pose', 'plane', 'flush', 'distance'}
        What is measured (see the module docstring).
    n_planes : int, default 1
        Planes touched by the probe (``plane``) or the tool face (``flush``).
    joint_noise_deg : float, default 0
        Reading noise on the recorded joints, degrees (1 sigma).
    rotation_noise_deg : float, default 0
        Orientation noise of ``pose`` data, degrees per axis (1 sigma); for ``flush`` the tilt
        of each contact's face (default: ``noise_mm`` over the 50 mm rim length
        `robocal.data.kinds.FLUSH_TILT_LENGTH_M`).
    error_scale : float, default 1
        Multiplies the drawn robot errors.
    joints : array_like, shape (N, n), optional
        Measure these poses (a planned campaign) instead of random ones, radians.
    visible : array_like of bool, shape (N, k), optional
        The SMRs the tracker sees at each pose (default all; k sets ``n_smr``).
    smr_offsets : array_like, shape (k, 3), optional
        The SMR positions in the flange (tool) frame instead of random ones, metres (k SMRs, the
        first is the tool).
    tracker_position : array_like, shape (3,), optional
        The tracker's position in the robot's base frame, metres, instead of a random one (its
        orientation stays random).
    bar_length_m : float, default 0.5
        Certified length of the scale bar (``distance``), metres.
    as_is : bool, default False
        Measure ``robot`` exactly as it is: no errors drawn, its own base and tool.
    payloads : sequence of float, optional
        Payload masses, kg, one block of poses each (working conditions: point and pose data,
        `robocal.data.simulated_physics`).
    temperatures : tuple of float, optional
        ``(lo, hi)`` arm temperatures, deg C, drawn per pose.
    payload_com : array_like, shape (3,), optional
        The payload's centre of mass in the flange frame, metres.
    thermal_k : float or dict, optional
        The true thermal expansion, 1/K: one k for the arm, or ``{group: k}`` per link group
        (base, upper_arm, forearm, wrist; ``"all"``: the others); default steel, 11.5e-6.

    Returns
    -------
    SimulationResult
        ``data`` (the `Measurements`), ``truth`` (the true robot, the tracker frame as its
        base), ``noise`` ``(N, 3)`` m, ``noise_floor_mm`` (the RMS of the noise added, mm: what a
        perfect calibration's residual reaches), ``outlier_rows``, ``true_joints`` ``(N, n)``
        rad, ``planes`` and ``info`` (settings and seed).

    Raises
    ------
    DataError
        Invalid counts, fractions, noise levels or shapes of the given arrays.
    UnreachableError
        Too few poses found inside ``workspace_box``, scale-bar placements or plane contacts.

    See Also
    --------
    rc.simulate_markers : Markers on links seen by motion capture.
    rc.simulate_camera : A camera's board poses.
    rc.simulate_cell : A work cell's campaign.
    robocal.data.simulate.SimulationResult : What it returns: the data, the truth, the noise.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(robot, 30, noise_mm=0.02, seed=1)
    >>> sim.data.kind, sim.data.points.shape
    ('point', (30, 3))
    >>> sim.truth  # the true robot the data were measured on
    Robot('abb_irb2600_true', 6 joints)
    >>> p = sim.truth.fk(sim.data.joints)[:, :3, 3]  # the truth plus the noise is what was measured
    >>> bool(np.allclose(p + sim.noise, sim.data.points, atol=1e-12))
    True
    >>> round(float(np.sqrt((sim.noise ** 2).sum(axis=1).mean()) * 1000), 4) == round(sim.noise_floor_mm, 4)
    True
    """
    joints, visible, smr_offsets, n_poses, n_smr = _check_given(
        robot, n_poses, n_smr, kind, joints, visible, smr_offsets)
    if tracker_position is not None:
        tracker_position = check_tracker_position(tracker_position)
    _check(kind, noise_model, n_poses, n_smr, n_planes, outliers, noise_mm, joint_noise_deg,
           rotation_noise_deg)
    payloads, temperatures = physics.check(payloads, temperatures)
    thermal_k = physics.check_thermal_k(thermal_k)
    if thermal_k is not None and temperatures is None:
        raise DataError("a true thermal expansion coefficient needs temperatures to act at")
    spec = OBSERVED[kind]
    if (payloads is not None or temperatures is not None) and not spec.sees_position:
        raise DataError("payloads and temperatures are simulated for point and pose data")
    if kind == "distance" and not 0 < bar_length_m < 10:
        raise DataError(f"the scale bar's length must be between 0 and 10 m, got {bar_length_m} m")
    rng = np.random.default_rng(seed)
    true = robot if as_is else _true_robot(robot, rng, kind, n_smr, error_scale, smr_offsets,
                                           tracker_position)
    planes = None
    if kind == "plane":
        q, plane_idx, planes = _plane_poses(true, n_poses, int(n_planes), rng, workspace_box)
    elif kind == "flush":
        tilt_sigma = (np.deg2rad(rotation_noise_deg) if rotation_noise_deg
                      else noise_mm * 1e-3 / FLUSH_TILT_LENGTH_M)
        q, plane_idx, planes, contact_noise = _flush_poses(true, n_poses, int(n_planes), rng, workspace_box,
                                                           noise_mm * 1e-3, tilt_sigma)
    elif kind == "distance":
        q, bar_noise = _bar_placements(true, n_poses, bar_length_m, noise_mm, rng, workspace_box)
    elif joints is not None:
        q = joints
    else:
        q = sample_joints(true, n_poses, rng, workspace_box, tool=true.tool)
    per_pose = n_smr if spec.several_smrs else spec.rows_per_placement
    smr = np.tile(np.arange(n_smr), n_poses) if spec.several_smrs else np.zeros(n_poses * per_pose, np.int64)
    pose_id = np.repeat(np.arange(n_poses), n_smr) if spec.several_smrs else np.arange(n_poses * per_pose)
    if visible is not None:
        seen = visible.reshape(-1)
        smr, pose_id = smr[seen], pose_id[seen]
    q_rows = q[pose_id]
    N = len(q_rows)
    approach = approach_from_order(q_rows, pose_id)  # the poses are measured in this order
    travel = travel_from_order(q_rows, pose_id)
    payload, temperature = physics.schedule(n_poses, payloads, temperatures, payload_com)
    if payload is None and temperature is None:
        T = true.fk(q_rows, smr=smr, conditions=Conditions(approach, travel))
    else:  # the conditions' physics, independent of the fitting code; the truth then carries them
        payload, temperature = (None if x is None else x[pose_id] for x in (payload, temperature))
        coefficients = physics.true_terms(true, payloads, temperatures, robot_reach(robot),
                                             np.random.default_rng([seed, 35]), thermal_k)
        t_ref = float(np.mean(temperature)) if temperature is not None else 20.0
        if true.joint_errors is not None and any(nm.startswith("thermal") for nm in true.joint_errors.names):
            t_ref = true.joint_errors.reference_temperature_c
        T = physics.measured_poses(true, q_rows, smr, Conditions(approach, travel, payload, temperature),
                                   coefficients, t_ref)
        true = true.with_joint_errors([*true.joint_error_names, *coefficients]).with_values(
            coefficients).with_reference_temperature(t_ref)
    if spec.sees_position:
        kw, noise, outlier_rows = _tracker_readings(kind, T, rng, noise_mm, noise_model, outliers,
                                                    rotation_noise_deg)
    elif kind == "distance":  # the two nests of a placement: the bar's certified length on both rows
        kw = {"pair": np.repeat(np.arange(n_poses), 2), "distance": np.full(N, float(bar_length_m))}
        outlier_rows, noise = np.zeros(0, np.int64), np.zeros((N, 3))
        noise[:, 0] = np.repeat(bar_noise, 2)  # both rows: the true tips' distance minus the certified
    elif kind == "flush":  # the true faces placed with the contact's noise (height, tilt): _flush_poses
        kw, outlier_rows = {"plane": plane_idx}, np.zeros(0, np.int64)
        noise = contact_noise
    else:  # probe noise: each true tip ends up noise_mm (1-sigma) off its plane, along the normal
        kw, outlier_rows = {"plane": plane_idx}, np.zeros(0, np.int64)
        normal, offset = planes[plane_idx, :3], planes[plane_idx, 3]
        off_plane = rng.standard_normal(N) * noise_mm * 1e-3
        q_rows, _ = _move_tips(true, q_rows, offset + off_plane, normal)
        noise = normal * off_plane[:, None]
    joint_noise = rng.standard_normal(q_rows.shape) * np.deg2rad(joint_noise_deg) * ~robot.prismatic
    clean = np.ones(N, bool)
    clean[outlier_rows] = False
    floor = float(np.sqrt(np.mean(np.sum(noise[clean] ** 2, axis=1)))) * 1e3 if clean.any() else 0.0
    info = {"seed": int(seed), "kind": kind, "n_poses": n_poses, "n_smr": int(n_smr),
            "noise_model": noise_model, "noise_mm": float(noise_mm), "outliers": float(outliers),
            "outlier_mm": list(OUTLIER_MM), "joint_noise_deg": float(joint_noise_deg),
            "rotation_noise_deg": float(rotation_noise_deg), "error_scale": float(error_scale),
            "noise_floor_mm": floor}
    source = f"simulated by robocal: robot {robot.name}, seed {seed}, {kind}, noise drawn {floor:.6g} mm RMS"
    data = Measurements.from_arrays(kind, q_rows + joint_noise, smr=smr, pose_id=pose_id,
                                    conditions=Conditions(approach, travel, payload, temperature),
                                    source_row=np.arange(2, N + 2), source=source,
                                    linear=robot.prismatic, external=robot.external_axes, **kw)
    truth = replace(true, name=f"{robot.name}_true",
                    description=f"true robot of a robocal simulation (seed {seed}); noise drawn "
                                f"{floor:.6g} mm (3-D RMS of the added noise)")
    return SimulationResult(data=data, truth=truth, noise=noise, noise_floor_mm=floor,
                            outlier_rows=outlier_rows, true_joints=q_rows, planes=planes, info=info)


def _check_given(robot, n_poses, n_smr, kind, joints, visible, smr_offsets):
    """Validate the planned-campaign options; returns them as arrays with ``n_poses``, ``n_smr``."""
    spec = OBSERVED.get(kind)  # None: an unknown kind, refused by _check
    if joints is not None:
        if spec is None or not spec.sees_position:
            raise DataError(f"{kind} measurements place their own poses; given joints work for point "
                            "and pose measurements")
        joints = robot.check_joints(joints)
        if n_poses is not None and int(n_poses) != len(joints):
            raise DataError(f"n_poses = {n_poses} but {len(joints)} joint rows are given")
        n_poses = len(joints)
    if n_poses is None:
        raise DataError("give the number of poses or the joints to measure")
    if smr_offsets is not None:
        smr_offsets = np.asarray(smr_offsets, dtype=float).reshape(-1, 3)
        if not np.isfinite(smr_offsets).all() or not len(smr_offsets):
            raise DataError("smr_offsets must be finite (k, 3) positions in m")
        if n_smr not in (1, len(smr_offsets)):
            raise DataError(f"n_smr = {n_smr} but {len(smr_offsets)} SMR offsets are given")
        n_smr = len(smr_offsets)
    if visible is not None:
        visible = np.asarray(visible, dtype=bool)
        if visible.ndim == 2 and n_smr == 1:  # the SMR count from the visibility columns
            n_smr = visible.shape[1]
        if spec is None or not spec.several_smrs or joints is None or visible.shape != (len(joints), n_smr):
            raise DataError(f"visible must be ({n_poses}, {n_smr}) booleans for given joints of "
                            "point measurements (one per pose and SMR)")
        blind = np.flatnonzero(~visible.any(axis=1))
        if blind.size:
            raise DataError(f"pose(s) {blind[:10].tolist()} see no SMR: drop them or make an SMR visible")
    return joints, visible, smr_offsets, int(n_poses), int(n_smr)


def _bar_placements(true, n: int, length: float, noise_mm: float, rng: np.random.Generator,
                    workspace_box) -> tuple[np.ndarray, np.ndarray]:
    """Joints ``(2n, dof)`` of ``n`` scale-bar placements (rows 2i, 2i+1: the two nests) whose true
    tips are ``length`` plus noise ``(n,)`` (m, 1-sigma ``noise_mm``) apart: the second pose of a
    pair is moved on the true robot until its tip sits that far from the first's, along a random
    direction."""
    q_out, noise_out = [], []
    for _ in range(100):
        m = 4 * (n - len(noise_out))
        qa = sample_joints(true, m, rng, workspace_box, tool=true.tool)
        qb = sample_joints(true, m, rng, workspace_box, tool=true.tool)
        noise = rng.standard_normal(m) * noise_mm * 1e-3
        target = true.fk(qa)[:, :3, 3] + random_directions(rng, m) * (length + noise)[:, None]
        qb, miss = _move_tips(true, qb, target)
        apart = np.abs(qa[:, :2] - qb[:, :2]).max(axis=1) > np.deg2rad(MIN_BAR_ANGLE_DEG)
        ok = np.flatnonzero((miss < 1e-12) & true.within_limits(qb) & apart)[: n - len(noise_out)]
        q_out += [np.stack([qa[ok], qb[ok]], axis=1).reshape(-1, true.n_joints)]
        noise_out += noise[ok].tolist()
        if len(noise_out) == n:
            return np.concatenate(q_out), np.array(noise_out)
    raise UnreachableError(f"could place the {length} m scale bar only {len(noise_out)} of {n} times in "
                           "the workspace: use a shorter bar, fewer placements or a larger workspace box")


def _random_planes(true, n_poses: int, n_planes: int, rng: np.random.Generator,
                   workspace_box) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n_planes`` random planes through the middle of the true tip's workspace: unit normals
    ``(P, 3)``, offsets ``(P,)`` (n.p = c, m, within 0.1 m of the median tip), and the plane of
    each of ``n_poses`` contacts ``(n_poses,)`` (in turn)."""
    normals = random_directions(rng, n_planes)
    q0 = sample_joints(true, 2048, rng, workspace_box, tool=true.tool)
    centre = np.median(true.fk(q0)[:, :3, 3], axis=0)
    offsets = normals @ centre + rng.uniform(-0.1, 0.1, n_planes)
    return normals, offsets, np.arange(n_poses) % n_planes


def _fill_slots(todo: np.ndarray, plane_idx: np.ndarray, ok: np.ndarray, k: np.ndarray,
                n_planes: int) -> tuple[np.ndarray, np.ndarray]:
    """Each plane's open contact slots (``todo``, of plane ``plane_idx``) filled in order by the
    usable candidates (``ok``) drawn for that plane (``k``): the slots filled ``(m,)`` and the
    candidates filling them ``(m,)`` (indices; a loop over planes only)."""
    slots, take = [], []
    for plane in range(n_planes):
        open_slots = todo[plane_idx[todo] == plane]
        usable = np.flatnonzero(ok & (k == plane))[: open_slots.size]
        slots.append(open_slots[: usable.size])
        take.append(usable)
    return np.concatenate(slots), np.concatenate(take)


def _plane_poses(true, n_poses: int, n_planes: int, rng: np.random.Generator, workspace_box):
    """Joints putting the true tip on one of ``n_planes`` random planes through the workspace."""
    normals, offsets, plane_idx = _random_planes(true, n_poses, n_planes, rng, workspace_box)
    chosen = np.zeros((n_poses, true.n_joints))
    filled = np.zeros(n_poses, bool)
    for _ in range(100):
        todo = np.flatnonzero(~filled)
        if todo.size == 0:
            break
        q = sample_joints(true, 4 * todo.size, rng, workspace_box, tool=true.tool)
        k = plane_idx[np.resize(todo, len(q))]
        dist = np.einsum("ni,ni->n", normals[k], true.fk(q)[:, :3, 3]) - offsets[k]
        near = np.abs(dist) < 0.15
        q, k = q[near], k[near]
        if not len(q):  # no sample near a plane this round: draw again
            continue
        q, res = _move_tips(true, q, offsets[k], normals[k])
        ok = (res < 1e-12) & true.within_limits(q)
        slots, take = _fill_slots(todo, plane_idx, ok, k, n_planes)
        chosen[slots], filled[slots] = q[take], True
    if not filled.all():
        raise UnreachableError(f"could place only {int(filled.sum())} of {n_poses} plane contacts: "
                               "use fewer poses or a larger workspace")
    return chosen, plane_idx, np.column_stack([normals, offsets])


FLUSH_START_COS = 0.3  # a random pose whose face normal is within ~73 deg of a plane's starts a contact
FLUSH_START_HEIGHT_M = 0.2  # ... and whose face centre is this close to the plane


def _move_faces(robot, q: np.ndarray, normal: np.ndarray, height: np.ndarray, direction: np.ndarray,
                iterations: int = 50, damping: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Joints near ``q (N, n)`` whose TCP lies on the planes ``normal . p = height`` (``normal``
    ``(N, 3)`` unit, ``height (N,)`` m) with its z axis along ``direction (N, 3)`` (unit): damped
    Gauss-Newton on the joints as :func:`_move_tips`. Returns the joints and the residual norm ``(N,)``."""
    names = robot.joint_params

    def residual(q):  # (N, 4): height, then the face normal's difference
        T = robot.fk(q)
        return np.concatenate([(np.einsum("ni,ni->n", normal, T[:, :3, 3]) - height)[:, None],
                               T[:, :3, 2] - direction], axis=1), T[:, :3, 2]

    for _ in range(iterations):
        r, z = residual(q)
        if np.abs(r).max() < 1e-13:
            break
        J6 = robot.jacobian(q, names, kind="pose")  # (N, 6, n): dp, world rotations w
        J = np.concatenate([np.einsum("ni,nij->nj", normal, J6[:, :3])[:, None],
                            np.cross(J6[:, 3:], z[:, :, None], axis=1)], axis=1)  # dz = w x z
        A = np.einsum("nik,njk->nij", J, J) + damping * np.eye(4)
        q = q - np.einsum("nik,ni->nk", J, np.linalg.solve(A, r[:, :, None])[:, :, 0])
    return q, np.linalg.norm(residual(q)[0], axis=1)


def _flush_poses(true, n_poses: int, n_planes: int, rng: np.random.Generator, workspace_box,
                 height_sigma: float, tilt_sigma: float):
    """Joints putting the true tool face flush on one of ``n_planes`` random planes through the
    workspace, each contact off by its noise: the face centre ``height_sigma`` (m, 1 sigma) along
    the normal, the face normal tilted by ``tilt_sigma`` (rad, 1 sigma, each of two axes).
    Returns the joints ``(n_poses, n)``, the plane of each, the planes ``(P, 4)`` (unit normal
    along the tool's z at contact, offset n.p = c, m) and each contact's noise ``(n_poses, 3)`` m:
    the height along the normal plus the two tilts times the rim length FLUSH_TILT_LENGTH_M
    along the plane's axes (its norm is the contact's error at the truth)."""
    normals, offsets, plane_idx = _random_planes(true, n_poses, n_planes, rng, workspace_box)
    e1 = np.cross(normals, np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(normals, e1)
    chosen, noise = np.zeros((n_poses, true.n_joints)), np.zeros((n_poses, 3))
    filled = np.zeros(n_poses, bool)
    for _ in range(100):
        todo = np.flatnonzero(~filled)
        if todo.size == 0:
            break
        q = sample_joints(true, 16 * todo.size, rng, workspace_box, tool=true.tool)
        k = plane_idx[np.resize(todo, len(q))]
        T = true.fk(q)
        height = np.einsum("ni,ni->n", normals[k], T[:, :3, 3]) - offsets[k]
        near = (np.einsum("ni,ni->n", normals[k], T[:, :3, 2]) > FLUSH_START_COS) & \
            (np.abs(height) < FLUSH_START_HEIGHT_M)
        q, k = q[near], k[near]
        if not len(q):
            continue
        dh = rng.standard_normal(len(q)) * height_sigma
        tilt = rng.standard_normal((len(q), 2)) * tilt_sigma
        direction = normals[k] + tilt[:, :1] * e1[k] + tilt[:, 1:] * e2[k]
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        q, res = _move_faces(true, q, normals[k], offsets[k] + dh, direction)
        ok = (res < 1e-12) & true.within_limits(q)
        slots, take = _fill_slots(todo, plane_idx, ok, k, n_planes)
        chosen[slots], filled[slots] = q[take], True
        noise[slots] = (dh[take, None] * normals[k[take]] + FLUSH_TILT_LENGTH_M
                        * (tilt[take, :1] * e1[k[take]] + tilt[take, 1:] * e2[k[take]]))
    if not filled.all():
        raise UnreachableError(f"could place only {int(filled.sum())} of {n_poses} flush contacts: "
                               "use fewer poses or a larger workspace")
    return chosen, plane_idx, np.column_stack([normals, offsets]), noise


TRACKER_MIN_DISTANCE_M = 0.3  # a tracker closer to the robot's base is inside the robot (a unit slip)


def probe_and_tracker(smr_mm=None, tool_mm=None,
                      tracker_mm=None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The SMRs ``(k, 3)`` (or the probe tip, SMR 0) and the tracker ``(3,)`` in m of a simulation,
    given in mm (None: random), refused when their magnitudes say metres.

    Raises
    ------
    DataError
        Both SMRs and a probe tip, or a tracker inside the robot.
    UnitError
        An SMR or tip no tool has (e.g. given in metres).
    """
    if tool_mm is not None and smr_mm:
        raise DataError("give the probe either as --tool-mm or as --smr-mm, not both")
    given = smr_mm or ([tool_mm] if tool_mm is not None else None)
    for smr in given or []:
        shown = ",".join(f"{v:g}" for v in smr)
        check_tool(np.asarray(smr, dtype=float) * 1e-3, "mm", f"--smr-mm/--tool-mm {shown}")
    tracker = None if tracker_mm is None else np.array(tracker_mm) * 1e-3
    if tracker is not None and np.linalg.norm(tracker) < TRACKER_MIN_DISTANCE_M:
        raise DataError(f"--tracker-mm {','.join(f'{v:g}' for v in tracker_mm)}: a tracker "
                        f"{np.linalg.norm(tracker) * 1e3:.3g} mm from the robot's base is inside the robot; "
                        "the values look like metres: give mm (e.g. 2500,500,300)")
    return (None if given is None else np.array(given) * 1e-3), tracker


def write_simulation(result: SimulationResult, data_path, truth_path) -> Path:
    """Write the data CSV, the truth model YAML and the sidecar JSON (returned path): all three
    or none."""
    truth_path = Path(truth_path)
    sidecar = truth_path.with_suffix(".sim.json")
    side = result.to_dict()
    side["data"] = str(data_path)
    side["truth"] = str(truth_path)
    write_all({data_path: result.data.to_csv(), truth_path: dump_model(result.truth),
               sidecar: json.dumps(side, indent=2) + "\n"})
    return sidecar
