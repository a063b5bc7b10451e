"""The posterior analysis calibration and the campaign planner share: measurement noise models,
noise-whitened identification Jacobians, and what a set of measurements determines with the priors.

:func:`judge` says of a pose set what the calibration will say of each parameter, in the words of
:mod:`robocal.identify.vocabulary`: estimated, not determined by these data (posterior sigma above
:data:`robocal.identify.priors.NOT_DETERMINED_RATIO` of the prior's: held near nominal by its
prior) or not identifiable (``dropped`` by the rank test: exactly confounded or without effect).
The noise models (:class:`Noise`):

- isotropic: ``sigma`` (m) on each coordinate;
- tracker: the virtual tracker's model (:mod:`robocal.data.simulate`): radial
  ``10 um + 0.5 um/m * r`` and transverse ``2.5 urad * r`` at distance ``r`` from the tracker;
- pose orientations: ``rotation_sigma`` (rad) per axis; plane contacts and distances: ``sigma``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.data.measurements import Measurements
from robocal.data.simulate import (
    NOISE_MODELS,
    TRACKER_ANGULAR_URAD,
    TRACKER_RADIAL_MM,
    TRACKER_RADIAL_UM_PER_M,
)
from robocal.identify.identifiability import DEFAULT_RTOL, Identifiability, analyze, hold
from robocal.identify.priors import prior_sigma, undetermined
from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace, State


@dataclass(frozen=True)
class Noise:
    """The measurement noise: ``sigma_m`` (isotropic, per coordinate; plane and distance data),
    ``model`` ('isotropic' or 'tracker', which needs ``tracker_position``), and the orientation
    noise ``rotation_sigma_rad`` of 6-DOF poses."""

    sigma_m: float = 2e-5
    model: str = "isotropic"
    tracker_position: np.ndarray | None = None
    rotation_sigma_rad: float = np.deg2rad(0.001)

    def __post_init__(self) -> None:
        if self.model not in NOISE_MODELS:
            raise DataError(f"unknown noise model {self.model!r}: use 'isotropic' or 'tracker'")
        if self.model == "tracker" and self.tracker_position is None:
            raise DataError("the tracker noise model needs the tracker's position")
        if not (self.sigma_m > 0 and self.rotation_sigma_rad > 0):
            raise DataError("noise levels must be > 0 (a noise-free measurement has no optimal design)")

    def whitener(self, points: np.ndarray) -> np.ndarray:
        """``(N, 3, 3)`` matrices W with ``W^T W = Sigma^-1`` for points ``(N, 3)`` (m)."""
        N = len(points)
        if self.model == "isotropic":
            return np.broadcast_to(np.eye(3) / self.sigma_m, (N, 3, 3))
        d = points - self.tracker_position
        r = np.linalg.norm(d, axis=1)
        u = d / np.maximum(r, 1e-12)[:, None]
        radial = TRACKER_RADIAL_MM * 1e-3 + TRACKER_RADIAL_UM_PER_M * 1e-6 * r
        transverse = np.maximum(TRACKER_ANGULAR_URAD * 1e-6 * r, 1e-12)
        uu = u[:, :, None] * u[:, None, :]
        return uu / radial[:, None, None] + (np.eye(3) - uu) / transverse[:, None, None]


def judge(J: np.ndarray, J_white: np.ndarray, names: list[str], sigma: np.ndarray, n_poses: int,
          rtol: float = DEFAULT_RTOL) -> Identifiability:
    """What a pose set determines, with the priors, as the calibration judges it
    (:mod:`robocal.identify.vocabulary`): the rank test on ``J (M, k)`` (unit weights, as
    :func:`robocal.identify.identifiability.analyze`) gives ``dropped`` (not identifiable: exactly
    confounded or without effect, whatever their prior); then, on the noise-whitened rows
    ``J_white (M, k)`` and the priors ``sigma (k,)`` (SI, inf: none), the kept parameters the data
    do not determine beyond their prior (:func:`robocal.identify.priors.undetermined`) are
    ``undetermined`` (not determined by these data, with their posterior / prior sigma ratio)."""
    sigma = np.asarray(sigma, dtype=float)
    ident = analyze(J, names, n_poses, rtol)
    kept = [names.index(nm) for nm in ident.kept]
    held, ratio = undetermined(J_white[:, kept], sigma[kept], 1.0)
    return hold(ident, J, [ident.kept[j] for j in held],
                {ident.kept[j]: float(q) for j, q in enumerate(ratio) if np.isfinite(q)})


def whitened_jacobian(robot, problem: CalibrationProblem, state: State, J: np.ndarray,
                       noise: Noise) -> np.ndarray:
    """The rows ``J (M, k + m)`` of the observation Jacobian at ``state`` divided by their noise
    (whitened)."""
    obs = problem.observation
    r = obs.rows_per_item
    if not obs.data.spec.sees_position:
        return J / noise.sigma_m
    blocks = J.reshape(obs.n_items, r, -1)
    W = noise.whitener(obs.modelled_points(robot, state.nuisance))
    out = np.empty_like(blocks)
    out[:, :3] = np.einsum("nij,njk->nik", W, blocks[:, :3])
    if r == 6:
        out[:, 3:] = blocks[:, 3:] / (noise.rotation_sigma_rad * obs.scale[3])
    return out.reshape(J.shape)


def _at_start(robot, data: Measurements, params) -> tuple[CalibrationProblem, ParameterSpace, State,
                                                           np.ndarray]:
    """The problem of ``data``, the space of the unknowns ``params``, the model's start state and
    the Jacobian ``(M, k + m)`` there."""
    problem = CalibrationProblem(robot, data)
    space = problem.space(robot, params)
    state = problem.start(robot)
    return problem, space, state, problem.jacobian(state, space)


def whitened_rows(robot, data: Measurements, noise: Noise, names: list[str]) -> tuple[object, np.ndarray]:
    """The observation of ``data`` and its identification-Jacobian rows ``(M, k)`` over the robot
    parameters ``names`` at the model's start, whitened by ``noise``."""
    problem, space, state, J = _at_start(robot, data, names)
    columns = [space.names.index(nm) for nm in names]
    return problem.observation, whitened_jacobian(robot, problem, state, J, noise)[:, columns]


def posterior_analysis(robot, data: Measurements, noise: Noise, params="auto",
                       rtol: float = DEFAULT_RTOL) -> Identifiability:
    """:func:`judge` of the measurements ``data`` (their rows at the model's predictions) for the
    unknowns ``params``, the data whitened by ``noise``."""
    problem, space, state, J = _at_start(robot, data, params)
    sigma = np.r_[prior_sigma(robot, space.robot), np.full(len(space.nuisance), np.inf)]
    return judge(J, whitened_jacobian(robot, problem, state, J, noise), space.names, sigma,
                 data.n_poses, rtol)
