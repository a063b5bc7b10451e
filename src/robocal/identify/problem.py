"""A calibration problem: a robot, measurement sets, and their weighted residuals and Jacobians.

Each measurement set (a :class:`robocal.Measurements`, one kind) becomes an observation
(:mod:`robocal.identify.observations`); the problem stacks their residual rows. Residuals are
divided by the measurement uncertainty, so sets of different kinds (positions, plane deviations,
distances, rotations) combine in one least-squares norm: the data's ``sigma`` column, else the
``sigma`` given per kind, else the set's instrument's documented noise
(`robocal.data.instruments`), else :data:`KIND_SIGMA`. A single set without either is left unweighted
(residuals in SI units, what the solvers' thresholds and histories then show). The unknowns are a
:class:`ParameterSpace`: robot parameters (moved by :meth:`ParameterSpace.apply`) and the
observations' nuisance parameters (plane coefficients: plane ids name plates across all sets).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.data.instruments import noise_of
from robocal.data.kinds import OBSERVED
from robocal.identify.observations import observation_for
from robocal.identify.space import ParameterSpace, State, resolve_names

DEFAULT_SIGMA = 1.0  # residual scale of a lone set without sigma (unweighted: residuals in SI units)
# 1-sigma noise (m) of each kind when a set of several has no sigma column and none is given
KIND_SIGMA = {name: spec.sigma_m for name, spec in OBSERVED.items()}  # (robocal.data.kinds)


def _consecutive(sizes: Sequence[int]) -> list[np.ndarray]:
    """Consecutive index blocks of the given ``sizes`` (read-only)."""
    blocks = np.split(np.arange(sum(sizes)), np.cumsum(sizes)[:-1])
    for b in blocks:
        b.flags.writeable = False
    return blocks


def _check_sigma(sigma: dict | None) -> dict:
    sigma = dict(sigma or {})
    for kind, value in sigma.items():
        if kind not in KIND_SIGMA:
            raise IdentificationError(f"sigma for unknown kind {kind!r}; kinds are {', '.join(KIND_SIGMA)}")
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < 1:
            raise IdentificationError(f"sigma of {kind} must be a positive length in m (below 1 m), "
                                      f"got {value!r}")
    return sigma


class CalibrationProblem:
    """Weighted residuals and Jacobians of a robot against one or more measurement sets."""

    def __init__(self, robot, data, sigma: dict | None = None, **observation_options) -> None:
        self.datasets = list(data) if isinstance(data, list | tuple) else [data]
        if not self.datasets:
            raise IdentificationError("a calibration needs at least one measurement set")
        given = _check_sigma(sigma)
        self.observations = [observation_for(d, robot, **observation_options) for d in self.datasets]
        self._check_planes()
        lone = len(self.datasets) == 1 and not given
        self.set_sigma = [DEFAULT_SIGMA if lone else given.get(d.kind, noise_of(d))
                          for d in self.datasets]  # for sets without a sigma column
        self.weighted = not lone or any(d.sigma is not None for d in self.datasets)
        self.sigma = np.concatenate([obs.residual_scale(s) for obs, s in
                                     zip(self.observations, self.set_sigma, strict=True)])
        self._unit_sigma = bool(np.all(self.sigma == 1.0))  # dividing by it changes nothing: skipped
        self._nuisance = _consecutive([len(obs.nuisance_names) for obs in self.observations])
        self._rows = _consecutive([obs.n_items * obs.rows_per_item for obs in self.observations])
        self._items = _consecutive([obs.n_items for obs in self.observations])

    @property
    def noise_guess(self) -> float:
        """The residual scale of one row expected before any fit (residual unit): 1 for weighted
        residuals, else the set's instrument's or kind's noise (m); the priors' start value."""
        return 1.0 if self.weighted else noise_of(self.datasets[0])

    def _check_planes(self) -> None:
        """A plane id names one plate in every set of a calibration: the sets' ids must not repeat."""
        seen: dict[str, str] = {}
        for obs in self.observations:
            for name in obs.nuisance_names:
                if name in seen:
                    raise IdentificationError(
                        f"{name.split('.')[0]} is in two measurement sets ({seen[name]!r} and "
                        f"{obs.data.label!r}): number the plates uniquely across the files of one "
                        "calibration")
                seen[name] = obs.data.label

    def _with_nuisance(self, nuisance: np.ndarray):
        """Each observation with its part of the stacked ``nuisance (m,)``."""
        for obs, nu in zip(self.observations, self._nuisance, strict=True):
            yield obs, nuisance[nu]

    def item_error_vectors(self, state: State) -> list[np.ndarray]:
        """Per measurement set: each item's unweighted error ``(n_items, d)`` (m): measured minus
        modelled position (d = 3) for points and poses, the signed deviation (d = 1) for planes and
        distances."""
        return [obs.residuals(state.robot, nu).reshape(obs.n_items, obs.rows_per_item)[:, :3]
                for obs, nu in self._with_nuisance(state.nuisance)]

    def item_blocks(self) -> list[np.ndarray]:
        """Per measurement set: the indices of its items in :meth:`position_errors`."""
        return list(self._items)

    @property
    def observation(self):
        """The observation of a single-set problem (IdentificationError for several sets)."""
        if len(self.observations) != 1:
            raise IdentificationError("this step works on one measurement set at a time")
        return self.observations[0]

    @property
    def data(self):
        """The measurements of a single-set problem."""
        return self.observation.data

    @property
    def kind(self) -> str:
        """The observation kind ('point', 'pose', 'plane', 'flush', 'distance'; 'mixed' for several kinds)."""
        kinds = {obs.kind for obs in self.observations}
        return kinds.pop() if len(kinds) == 1 else "mixed"

    @property
    def nuisance_names(self) -> list[str]:
        return [name for obs in self.observations for name in obs.nuisance_names]

    @property
    def n_items(self) -> int:
        return sum(obs.n_items for obs in self.observations)

    @property
    def n_poses(self) -> int:
        return sum(d.n_poses for d in self.datasets)

    def row_blocks(self) -> list[tuple[np.ndarray, int]]:
        """Per measurement set: its residual row indices and its rows per item."""
        return [(rows, obs.rows_per_item) for obs, rows in zip(self.observations, self._rows, strict=True)]

    def item_rows(self) -> np.ndarray:
        """``(n_items,)`` residual rows per item (stacked over the observations)."""
        return np.concatenate([np.full(obs.n_items, obs.rows_per_item) for obs in self.observations])

    def item_sum_squares(self, r: np.ndarray) -> np.ndarray:
        """Per-item sum of squares ``(..., n_items)`` of weighted residuals ``(..., M)``."""
        parts = [(r[..., rows] ** 2).reshape(r.shape[:-1] + (obs.n_items, obs.rows_per_item)).sum(-1)
                 for obs, rows in zip(self.observations, self._rows, strict=True)]
        return np.concatenate(parts, axis=-1)

    def space(self, robot, params="auto") -> ParameterSpace:
        """The parameter space of ``params`` ('auto', 'all' or names; see
        :func:`robocal.identify.space.resolve_names`) plus every nuisance parameter. 'auto' and
        'all' leave out what no observation can see (the base frame for planes alone)."""
        blind = set.intersection(*(set(obs.not_observable(robot)) for obs in self.observations))
        orientation = any(OBSERVED[obs.kind].sees_orientation or OBSERVED[obs.kind].sees_tilt
                          for obs in self.observations)
        names = resolve_names(robot, params, sorted(blind), orientation)
        return ParameterSpace(tuple(names), tuple(self.nuisance_names))

    def start(self, robot) -> State:
        return State(robot, np.concatenate([obs.nuisance_start(robot) for obs in self.observations]))

    def instrument_frames(self, state: State) -> list[tuple[str, dict[str, np.ndarray]]]:
        """Per measurement set whose instrument carries frames of its own (a camera and its board,
        a capture frame and marker offsets): its label and those frames at ``state`` (4 x 4
        transforms or ``(3,)`` offsets, m; the observation's ``frames``)."""
        return [(obs.data.label, obs.frames(nuisance))
                for obs, nuisance in self._with_nuisance(state.nuisance) if hasattr(obs, "frames")]

    def export_nuisance(self, state: State) -> dict[str, np.ndarray]:
        """The state's nuisance as physical entities (planes as normal + offset), to judge other
        measurement sets with them (:meth:`carried_state`)."""
        out: dict[str, np.ndarray] = {}
        for obs, nuisance in self._with_nuisance(state.nuisance):
            out.update(obs.export_nuisance(nuisance))
        return out

    def carried_state(self, robot, entities: dict[str, np.ndarray]) -> State:
        """``robot`` with the nuisance of ``entities`` (another problem's :meth:`export_nuisance`)
        where this problem shares them, the rest fitted to ``robot``."""
        return State(robot, np.concatenate([obs.import_nuisance(robot, entities)
                                            for obs in self.observations]))

    def residuals(self, state: State) -> np.ndarray:
        """Weighted residuals ``(M,)``."""
        r = [obs.residuals(state.robot, nuisance) for obs, nuisance in self._with_nuisance(state.nuisance)]
        return np.concatenate(r) / self.sigma

    def jacobian(self, state: State, space: ParameterSpace) -> np.ndarray:
        """Weighted d(modelled)/d(unknowns) ``(M, space.size)``: robot columns, then every
        nuisance column (block-diagonal over the observations)."""
        k, m = len(space.robot), len(self.nuisance_names)
        if tuple(space.nuisance) != tuple(self.nuisance_names):
            raise IdentificationError("the parameter space must carry every nuisance parameter")
        if len(self.observations) == 1:  # its block is J: no second (M, k) array
            J = self.observations[0].jacobian(state.robot, space.robot, state.nuisance)
            if not self._unit_sigma:
                J /= self.sigma[:, None]
            return J
        J = np.zeros((self.sigma.size, k + m))
        for obs, rows, nu in zip(self.observations, self._rows, self._nuisance, strict=True):
            block = obs.jacobian(state.robot, space.robot, state.nuisance[nu])
            J[rows, :k] = block[:, :k]
            J[np.ix_(rows, k + nu)] = block[:, k:]
            del block  # one (M, k) array at a time besides J
        J /= self.sigma[:, None]
        return J

    def profiled_residuals_batch(self, robot, names: Sequence[str], X: np.ndarray):
        """Weighted residuals ``(P, M)`` and nuisance ``(P, m)`` for robot displacements ``X (P, k)``
        with every observation's nuisance fitted per displacement (the seed-004 plane fit)."""
        r, nu = zip(*(obs.profiled_residuals_batch(robot, names, X) for obs in self.observations),
                    strict=True)
        return np.concatenate(r, axis=-1) / self.sigma, np.concatenate(nu, axis=-1)

    def modelled_points(self, state: State) -> np.ndarray:
        """``(N, 3)`` modelled TCP (SMR, probe tip) positions of every data row (m)."""
        return np.concatenate([obs.modelled_points(state.robot, nuisance)
                               for obs, nuisance in self._with_nuisance(state.nuisance)])

    def position_errors(self, state: State) -> np.ndarray:
        """``(n_items,)`` unweighted position error of each measurement item (m)."""
        return np.concatenate([obs.position_errors(state.robot, nuisance)
                               for obs, nuisance in self._with_nuisance(state.nuisance)])
