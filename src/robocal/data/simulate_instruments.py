"""Simulated motion-capture and camera data with known truth (the instrument kinds' test bed).

- :func:`simulate_markers`: markers on chosen links of a perturbed robot seen by a capture system
  at a random place, each marker at a random offset on its link (``truth_frames``: the capture
  frame ``W`` and every offset), isotropic noise plus optional gross errors (a swapped marker);
- :func:`simulate_camera`: a camera's board poses, eye-to-hand (``mount='cell'``: camera fixed,
  board on the flange) or eye-in-hand (``mount='flange'``), with independent position noise
  (``noise_mm``, each axis) and rotation noise (``noise_deg``, each axis): their ratio is what the
  variance components must recover.

Both return a :class:`robocal.data.simulate.SimulationResult` whose ``info["frames"]`` holds the
true frames (4 x 4 lists, m) and whose ``truth`` is the true robot (its own base and tool frames:
the instrument's frames are in ``info``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.core.errors import DataError
from robocal.data.measurements import Measurements
from robocal.data.simulate import SimulationResult, perturbed, sample_joints
from robocal.kinematics.transforms import invert_transform, make_transform, rotvec_to_matrix

MARKER_OFFSET_M = 0.1  # a simulated marker sits up to this far (each axis) from its link frame's origin
CAMERA_DISTANCE_M = (0.4, 1.2)  # a simulated board is this far from the camera
MOUNTS = {"cell": "eye_to_hand", "flange": "eye_in_hand"}


def _random_frame(rng: np.random.Generator, spread_m: float) -> np.ndarray:
    rv = rng.standard_normal(3)
    return make_transform(rotvec_to_matrix(rv / np.linalg.norm(rv) * rng.uniform(0, np.pi)),
                          rng.uniform(-spread_m, spread_m, 3))


def _floor_mm(noise: np.ndarray) -> float:
    """The noise floor (mm): the 3-D RMS of the position noise ``(N, 3)`` m (gross errors aside)."""
    return float(np.sqrt(np.mean(np.sum(noise**2, axis=1)))) * 1e3


def _outliers(rng: np.random.Generator, N: int, share: float, size_mm: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Rows given a gross error and the errors ``(N, 3)`` m (zeros elsewhere)."""
    if not 0 <= share < 0.5:
        raise DataError(f"the share of outliers must be in [0, 0.5), got {share}")
    rows = np.sort(rng.choice(N, int(round(share * N)), replace=False))
    gross = np.zeros((N, 3))
    direction = rng.standard_normal((rows.size, 3))
    gross[rows] = direction / np.linalg.norm(direction, axis=1, keepdims=True) * size_mm * 1e-3
    return rows, gross


def simulate_markers(robot, n_poses: int = 40, *, links=None, noise_mm: float = 0.3, outliers: float = 0.0,
                     outlier_mm: float = 5.0, error_scale: float = 1.0, seed: int = 0,
                     instrument: str = "mocap") -> SimulationResult:
    """Markers on links seen by a motion-capture system (see the module).

    Parameters
    ----------
    robot : Robot
        The nominal model; the truth is a perturbed copy (`robocal.data.simulate.perturbed`).
    n_poses : int
        Poses; every marker is seen at every pose.
    links : sequence of int or str, optional
        The link frame of each marker (0 base .. n flange), or its link's name where the model names
        its links (a URDF's, `Robot.link_frames`); default three markers on the flange.
    noise_mm : float
        1-sigma noise of each coordinate, mm.
    outliers : float
        Share of rows with a gross error of ``outlier_mm`` (a swapped or occluded marker).
    error_scale, seed : float, int
        Size of the robot's errors (1: a realistic arm) and the random seed.
    instrument : str
        The instrument the data declare.
    outlier_mm : float
        Size of a gross error (mm).

    Returns
    -------
    SimulationResult
        ``info["frames"]``: ``capture`` (the robot's world in the capture frame) and
        ``markers`` (offsets ``(K, 3)`` m in their link frames).

    See Also
    --------
    rc.simulate_tracker : A laser tracker's points or poses.
    rc.simulate_camera : A camera's board poses.
    robocal.data.simulate.SimulationResult : What it returns.

    Examples
    --------
    >>> import robocal as rc
    >>> sim = rc.simulate_markers(rc.Robot.from_catalog("abb_irb2600"), 10, seed=0)
    >>> sim.data.kind, len(sim.data)  # three markers (the default links) at each of 10 poses
    ('marker', 30)
    """
    if links is not None and np.asarray(links).dtype.kind in "US":  # texts: link names or frame numbers
        links = robot.link_numbers(np.asarray(links))
    given = np.array([robot.n_joints] * 3 if links is None else links, float)
    links = given.astype(int)
    if given.ndim != 1 or links.size == 0 or (links != given).any() or links.min() < 0 \
            or links.max() > robot.n_joints:
        raise DataError(f"marker links must be frames 0..{robot.n_joints}, got {links.tolist()}")
    if not (noise_mm >= 0 and n_poses >= 1):
        raise DataError("the noise must be >= 0 mm and n_poses >= 1")
    rng = np.random.default_rng(seed)
    true = perturbed(robot, rng, scale=error_scale)
    W = _random_frame(rng, 2.0)
    offsets = rng.uniform(-MARKER_OFFSET_M, MARKER_OFFSET_M, (links.size, 3))
    q = sample_joints(true, n_poses, rng)
    K = links.size
    pose_id, smr = np.repeat(np.arange(n_poses), K), np.tile(np.arange(K), n_poses)
    link = links[smr]
    _, frames = true.fk(q[pose_id], frames=True)
    F = frames[np.arange(len(pose_id)), link]
    p = np.einsum("nij,nj->ni", F[:, :3, :3], offsets[smr]) + F[:, :3, 3]
    p = p @ W[:3, :3].T + W[:3, 3]
    noise = rng.standard_normal(p.shape) * noise_mm * 1e-3
    rows, gross = _outliers(rng, len(p), outliers, outlier_mm)
    floor = _floor_mm(noise)
    data = Measurements.from_arrays("marker", q[pose_id], points=p + noise + gross, link=link, smr=smr,
                                    pose_id=pose_id, instrument=instrument,
                                    source=f"simulated by robocal: robot {robot.name}, seed {seed}, "
                                           f"markers on links {links.tolist()}, noise {noise_mm:g} mm")
    info = {"seed": int(seed), "kind": "marker", "n_poses": int(n_poses), "noise_mm": float(noise_mm),
            "outliers": float(outliers), "noise_floor_mm": floor, "links": links.tolist(),
            "frames": {"capture": W.tolist(), "markers": offsets.tolist()}}
    return SimulationResult(data=data, truth=replace(true, name=f"{robot.name}_true"), noise=noise + gross,
                            noise_floor_mm=floor, outlier_rows=rows, true_joints=q[pose_id], planes=None,
                            info=info)


def simulate_camera(robot, n_poses: int = 40, *, mount: str = "cell", noise_mm: float = 1.0,
                    noise_deg: float = 0.3, outliers: float = 0.0, outlier_mm: float = 20.0,
                    error_scale: float = 1.0, seed: int = 0) -> SimulationResult:
    """A camera's board poses (see the module).

    Parameters
    ----------
    robot : Robot
        The nominal model; the truth is a perturbed copy.
    n_poses : int
        Poses (one board pose each).
    mount : {'cell', 'flange'}
        Camera fixed in the cell (kind ``eye_to_hand``) or on the flange (``eye_in_hand``).
    noise_mm, noise_deg : float
        1-sigma noise of each position coordinate (mm) and of each rotation axis (deg).
    outliers, outlier_mm : float
        Share of poses with a gross position error of ``outlier_mm`` (a misdetected board).
    error_scale, seed : float, int
        Size of the robot's errors and the random seed.

    Returns
    -------
    SimulationResult
        ``info["frames"]``: ``camera`` and ``board`` (the camera in the world and the board on the
        flange for 'cell'; the camera on the flange and the board in the world for 'flange').

    See Also
    --------
    rc.simulate_tracker : A laser tracker's points or poses.
    rc.simulate_markers : Markers on links seen by motion capture.
    robocal.data.simulate.SimulationResult : What it returns.

    Examples
    --------
    >>> import robocal as rc
    >>> sim = rc.simulate_camera(rc.Robot.from_catalog("abb_irb2600"), 10, seed=0)
    >>> sim.data.kind, len(sim.data)  # a camera fixed in the cell sees a board on the flange
    ('eye_to_hand', 10)
    """
    if mount not in MOUNTS:
        raise DataError(f"mount must be one of {', '.join(MOUNTS)}, got {mount!r}")
    if not (noise_mm >= 0 and noise_deg >= 0 and n_poses >= 3):
        raise DataError("the noise must be >= 0 and n_poses >= 3")
    rng = np.random.default_rng(seed)
    true = perturbed(robot, rng, scale=error_scale)
    q = sample_joints(true, n_poses, rng)
    F = replace(true, tool=np.eye(4)).fk(q)
    near = _random_frame(rng, 0.1)  # the camera on the flange, or the board on it
    if mount == "cell":  # a camera looking at the workspace from CAMERA_DISTANCE_M away
        camera = _random_frame(rng, 1.0)
        camera[:3, 3] = F[:, :3, 3].mean(axis=0) - camera[:3, 2] * np.mean(CAMERA_DISTANCE_M)
        C = invert_transform(camera) @ F @ near
        frames = {"camera": camera, "board": near}
    else:
        board = _random_frame(rng, 0.0)  # in the middle of the workspace
        board[:3, 3] = F[:, :3, 3].mean(axis=0)
        C = invert_transform(F @ near) @ board
        frames = {"camera": near, "board": board}
    noise = rng.standard_normal((n_poses, 3)) * noise_mm * 1e-3
    turn = rotvec_to_matrix(rng.standard_normal((n_poses, 3)) * np.deg2rad(noise_deg))
    rows, gross = _outliers(rng, n_poses, outliers, outlier_mm)
    floor = _floor_mm(noise)
    kind = MOUNTS[mount]
    data = Measurements.from_arrays(kind, q, points=C[:, :3, 3] + noise + gross,
                                    rotations=turn @ C[:, :3, :3], instrument="camera",
                                    source=f"simulated by robocal: robot {robot.name}, seed {seed}, {kind}, "
                                           f"noise {noise_mm:g} mm / {noise_deg:g} deg")
    info = {"seed": int(seed), "kind": kind, "n_poses": int(n_poses), "noise_mm": float(noise_mm),
            "noise_deg": float(noise_deg), "outliers": float(outliers), "noise_floor_mm": floor,
            "frames": {k: v.tolist() for k, v in frames.items()}}
    return SimulationResult(data=data, truth=replace(true, name=f"{robot.name}_true"), noise=noise + gross,
                            noise_floor_mm=floor, outlier_rows=rows, true_joints=q, planes=None, info=info)


INSTRUMENT_KINDS = ("marker", "eye_to_hand", "eye_in_hand")  # the kinds simulated here (simulate --kind)


def simulate_kind(robot, kind: str, n_poses: int, *, noise_mm: float, rotation_noise_deg: float,
                  outliers: float = 0.0, links=None, seed: int = 0) -> SimulationResult:
    """:func:`simulate_markers` (``kind='marker'``) or :func:`simulate_camera` (the camera kinds)
    with the command line's options; DataError for another kind."""
    if n_poses is None:
        raise DataError(f"simulated {kind} data need a number of poses (--poses), not planned joints")
    if kind == "marker":
        return simulate_markers(robot, n_poses, links=links, noise_mm=noise_mm, outliers=outliers, seed=seed)
    mount = {v: k for k, v in MOUNTS.items()}.get(kind)
    if mount is None:
        raise DataError(f"kind {kind!r} is not an instrument kind: {', '.join(INSTRUMENT_KINDS)}")
    if links is not None:
        raise DataError("--links places markers (kind marker), not a camera's board")
    return simulate_camera(robot, n_poses, mount=mount, noise_mm=noise_mm, noise_deg=rotation_noise_deg,
                           outliers=outliers, seed=seed)
