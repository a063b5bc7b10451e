"""A real tool's TCP on the calibrated model: the controllers' 4-point method with calibrated
kinematics.

The TCP touches one fixed point in N >= 4 flange orientations and the joints are recorded. With
``R_i, p_i`` the calibrated flange poses (controller base frame) and ``t`` the TCP in flange
coordinates, ``R_i t + p_i = P`` for the unknown fixed point ``P``: 3N linear equations in the
6 unknowns (t, P), solved by least squares. ``t`` is determined only if the orientations differ
about at least two axes; a set whose spread is below ``MIN_SPREAD_DEG`` is refused. The residual
of each pose says how well it touched the point (and how good the model is there).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import write_atomic
from robocal.deploy.compensation import controller_model, frame_to_text
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import make_transform

MIN_POSES = 4
MIN_SPREAD_DEG = 5.0  # smallest orientation spread about the weakest axis for a determined TCP
MAX_RESIDUAL_MM = 2.0  # poses further than this from one common point did not touch it


@dataclass(frozen=True)
class ToolCalibration:
    """The result of `robocal.identify_tcp`.

    Attributes
    ----------
    tcp : numpy.ndarray, shape (3,)
        The tool's TCP in the flange frame (ROS-I ``tool0``), metres.
    point : numpy.ndarray, shape (3,)
        The touched point in the controller's base frame, metres.
    residuals : numpy.ndarray, shape (N,)
        Distance of each pose's tip from the common point, metres.
    spread_deg : float
        The orientations' spread about their weakest axis, degrees.
    warnings : list of str
        None today: poses that do not determine the TCP are refused.

    See Also
    --------
    rc.identify_tcp : The identification that returns it.

    Examples
    --------
    >>> import numpy as np
    >>> from robocal.deploy.tcp import ToolCalibration
    >>> result = ToolCalibration(tcp=np.array([0.0, 0.0, 0.2]), point=np.array([1.0, 0.0, 0.5]),
    ...                          residuals=np.array([1e-5, 2e-5, 1e-5, 2e-5]), spread_deg=35.0)
    >>> round(result.rms_mm, 4)
    0.0158
    """

    tcp: np.ndarray
    point: np.ndarray
    residuals: np.ndarray
    spread_deg: float
    warnings: list[str] = field(default_factory=list)

    @property
    def rms_mm(self) -> float:
        """The RMS (mm) of the residuals of the touched poses."""
        return float(np.sqrt(np.mean(self.residuals**2)) * 1e3)

    def summary(self) -> str:
        """The TCP, the touched point (mm), the residuals' RMS (mm) and the spread (deg).

        Returns
        -------
        str
            The summary text.
        """
        t, p = self.tcp * 1e3, self.point * 1e3
        lines = [f"TCP in flange coordinates: x {t[0]:.3f} y {t[1]:.3f} z {t[2]:.3f} mm",
                 f"touched point (robot base): x {p[0]:.3f} y {p[1]:.3f} z {p[2]:.3f} mm",
                 f"residuals over {len(self.residuals)} poses: RMS {self.rms_mm:.3f} mm, max "
                 f"{self.residuals.max() * 1e3:.3f} mm; orientation spread {self.spread_deg:.1f} deg"]
        lines += [f"  pose {i + 1}: {r * 1e3:.3f} mm" for i, r in enumerate(self.residuals)]
        return "\n".join(lines)

    def option(self, name: str = "TOOL", rotation: np.ndarray | None = None) -> str:
        """The ``--tcp`` value ``NAME=x,y,z,rx,ry,rz`` (mm, deg) of this TCP with the tool's
        orientation ``rotation`` (3x3; default none): the 4-point method finds the position only.

        Parameters
        ----------
        name : str, default "TOOL"
            The tool's name.
        rotation : numpy.ndarray, shape (3, 3), optional
            The tool's orientation in the flange frame; default none (identity).

        Returns
        -------
        str
            ``NAME=x,y,z,rx,ry,rz`` (mm, deg).
        """
        T = make_transform(np.eye(3) if rotation is None else rotation, self.tcp)
        return f"{name}={frame_to_text(T)}"

    def to_dict(self, name: str = "TOOL", rotation: np.ndarray | None = None) -> dict:
        """The TCP and the touched point (mm), each pose's residual (mm), their RMS, the spread
        (deg) and the `option`.

        Parameters
        ----------
        name : str, default "TOOL"
            The tool's name in the `option`.
        rotation : numpy.ndarray, shape (3, 3), optional
            The tool's orientation in the flange frame.

        Returns
        -------
        dict
            The TCP result (JSON-ready).
        """
        return {"tcp_mm": (self.tcp * 1e3).tolist(), "point_mm": (self.point * 1e3).tolist(),
                "residuals_mm": (self.residuals * 1e3).tolist(), "rms_mm": self.rms_mm,
                "spread_deg": self.spread_deg, "tcp_option": self.option(name, rotation)}

    def write(self, json_path=None, name: str = "TOOL", rotation: np.ndarray | None = None) -> list[str]:
        """Write `to_dict` as JSON to ``json_path`` (atomically); the paths written.

        Parameters
        ----------
        json_path : str or pathlib.Path, optional
            The JSON file (None: nothing written).
        name : str, default "TOOL"
            The tool's name in the `option`.
        rotation : numpy.ndarray, shape (3, 3), optional
            The tool's orientation in the flange frame.

        Returns
        -------
        list of str
            The paths written.
        """
        if json_path is None:
            return []
        write_atomic(json_path, json.dumps(self.to_dict(name, rotation), indent=1) + "\n")
        return [str(json_path)]


def identify_tcp(calibrated: Robot, nominal: Robot, q, robot_base=None) -> ToolCalibration:
    """The TCP of a real tool on the calibrated flange, by the 4-point method.

    The tool's tip touches one fixed point from several orientations; the tip's offset on the
    flange and the point are the least-squares solution of ``R_k t + p_k = P`` over the poses,
    with the flange poses ``(R_k, p_k)`` of the calibrated model (see the module docstring).

    Parameters
    ----------
    calibrated : Robot
        The calibrated model.
    nominal : Robot
        The controller's nominal model (its flange, ROS-I ``tool0``, replaces the calibrated
        model's measured SMR).
    q : array_like, shape (N, 6)
        Joints at which the tip touched the point, radians; N >= 4, tilted about two axes.
    robot_base : array_like, shape (4, 4), optional
        The controller's base frame in the calibrated model's world, metres.

    Returns
    -------
    ToolCalibration
        The ``tcp`` (m, flange frame), the touched ``point`` (m, base frame), the residual per
        pose and the orientation spread.

    Raises
    ------
    DataError
        Fewer than 4 poses, orientations too alike to determine the TCP, or a pose far from the
        common point (a slipped tip), each named.

    See Also
    --------
    rc.ToolCalibration : What it returns.
    rc.compensate : Targets of a tool (its ``tool``).

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.kinematics.transforms import make_transform
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> tip = np.array([0.01, -0.02, 0.15])  # the tool's tip on the flange, m
    >>> tool = robot.with_frames(tool=make_transform(np.eye(3), tip))
    >>> q0 = np.array([0.1, 0.2, 0.1, 0.0, 0.5, 0.0])
    >>> target = tool.fk(q0[None])[0].copy()
    >>> turns = [np.eye(3), [[1, 0, 0], [0, .8, -.6], [0, .6, .8]],  # the tip stays on the point
    ...          [[.8, 0, .6], [0, 1, 0], [-.6, 0, .8]], [[.8, -.6, 0], [.6, .8, 0], [0, 0, 1]]]
    >>> poses = np.array([target @ make_transform(np.array(r, float), np.zeros(3)) for r in turns])
    >>> tilts = rc.ik.solve(tool, poses, seeds=np.tile(q0, (4, 1))).joints
    >>> result = rc.identify_tcp(robot, robot, tilts)
    >>> bool(np.allclose(result.tcp, tip, atol=1e-6))
    True
    """
    flange = controller_model(calibrated, nominal, robot_base)
    q = flange.check_joints(q)
    N = q.shape[0]
    if N < MIN_POSES:
        raise DataError(f"the 4-point method needs at least {MIN_POSES} poses touching one point, got {N}")
    F = flange.fk(q)
    R, p = F[:, :3, :3], F[:, :3, 3]
    A = np.concatenate([R, -np.broadcast_to(np.eye(3), R.shape)], axis=2).reshape(3 * N, 6)
    b = -p.reshape(-1)
    # how well the orientations determine t: the weakest direction of the centred rotations
    centred = (R - R.mean(axis=0)).reshape(3 * N, 3)
    spread = np.linalg.svd(centred, compute_uv=False)[-1] / np.sqrt(N)
    spread_deg = float(np.rad2deg(2 * np.arcsin(min(spread / np.sqrt(2), 1.0))))
    if spread_deg < MIN_SPREAD_DEG:
        raise DataError(f"the {N} poses' orientations differ by only {spread_deg:.2f} deg about their "
                        f"weakest axis (need >= {MIN_SPREAD_DEG:g}): the TCP is not determined. Touch the "
                        "point with the tool tilted about at least two different axes, by 30 deg or more")
    x, *_ = np.linalg.lstsq(A, b, rcond=None)
    t, P = x[:3], x[3:]
    residuals = np.linalg.norm(np.einsum("nij,j->ni", R, t) + p - P, axis=1)
    if residuals.max() * 1e3 > MAX_RESIDUAL_MM:
        bad = np.flatnonzero(residuals * 1e3 > MAX_RESIDUAL_MM) + 1
        raise DataError(f"pose(s) {bad.tolist()} are {residuals.max() * 1e3:.2f} mm from the common point "
                        f"(limit {MAX_RESIDUAL_MM:g} mm): they did not touch the same point, or the joints "
                        "belong to another robot or are in another unit")
    return ToolCalibration(t, P, residuals, spread_deg)
