"""A calibration problem: a robot, the parameters to identify, and observations.

Residuals are weighted by the measurement uncertainty (``sigma`` of the data, else 1 m, so
unweighted residuals are in metres). The unknowns are displacements of the named robot
parameters (see :meth:`Robot.displaced`) followed by the observation's nuisance parameters.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robocal.errors import IdentificationError
from robocal.identify.observations import observation_for


@dataclass(frozen=True)
class State:
    """A point of the search: the robot model and the nuisance parameters ``(m,)``."""

    robot: object
    nuisance: np.ndarray


def candidate_parameters(robot, observation, params) -> list[str]:
    """Resolve ``params``: 'auto' (the robot's default free set), 'all' (every parameter),
    or an explicit list of names. 'auto' and 'all' leave out what the observation can never
    see (``observation.not_observable``: e.g. the base frame for plane contacts and distances)."""
    if isinstance(params, str) and params in ("auto", "all"):
        names = (robot.default_free(orientation=(observation.kind == "pose")) if params == "auto"
                 else list(robot.parameter_names))
        blind = set(observation.not_observable(robot))
        return [n for n in names if n not in blind]
    if isinstance(params, str):
        params = [p for p in params.replace(",", " ").split() if p]
    names = list(params)
    robot.indices(names)  # validates
    if len(set(names)) != len(names):
        raise IdentificationError("a parameter is named twice in params")
    return names


class CalibrationProblem:
    """Weighted residuals and Jacobians of a robot against one set of measurements."""

    def __init__(self, robot, data, **observation_options) -> None:
        self.observation = observation_for(data, robot, **observation_options)
        self.sigma = self.observation.residual_scale(1.0)
        self.data = data

    @property
    def kind(self) -> str:
        return self.observation.kind

    @property
    def nuisance_names(self) -> list[str]:
        return list(self.observation.nuisance_names)

    @property
    def rows_per_item(self) -> int:
        return self.observation.rows_per_item

    def start(self, robot) -> State:
        return State(robot, self.observation.nuisance_start(robot))

    def residuals(self, state: State) -> np.ndarray:
        """Weighted residuals ``(M,)``."""
        return self.observation.residuals(state.robot, state.nuisance) / self.sigma

    def jacobian(self, state: State, names: Sequence[str]) -> np.ndarray:
        """Weighted d(modelled)/d(unknowns) ``(M, k + m)``: robot names, then nuisance."""
        return self.observation.jacobian(state.robot, names, state.nuisance) / self.sigma[:, None]

    def step(self, state: State, names: Sequence[str], dx: np.ndarray) -> State:
        """Apply a displacement ``dx (k + m,)`` of the robot names and the nuisance."""
        k = len(names)
        robot = state.robot.displaced(names, dx[:k]) if k else state.robot
        return State(robot, state.nuisance + dx[k:])

    def residuals_batch(self, state: State, names: Sequence[str], X: np.ndarray) -> np.ndarray:
        """Weighted residuals ``(P, M)`` for displacement vectors ``X (P, k)`` of ``names``."""
        r = self.observation.residuals_batch(state.robot, names, X, state.nuisance)
        return r / self.sigma

    def position_errors(self, state: State) -> np.ndarray:
        """``(N,)`` unweighted position error of each measurement item (m)."""
        return self.observation.position_errors(state.robot, state.nuisance)
