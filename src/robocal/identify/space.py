"""What a calibration estimates: the unknowns, declared in one place.

A :class:`ParameterSpace` lists the free robot parameters (link geometry, base and tool frames,
extra SMR offsets, joint-error terms: all parameters of :class:`robocal.Robot`) and the
observations' nuisance parameters (plane coefficients ``plane0.a``...), in the order of the
unknown vector every solver works on. A :class:`State` is a point of that space: a robot and
the nuisance values. :meth:`ParameterSpace.apply` is the one way a step moves a state (robot
parameters through :meth:`Robot.displaced`: frame rotations compose, the rest adds).

A space may carry a prior (:mod:`robocal.identify.priors`): per unknown a mean (SI) and a 1-sigma
scale (inf: none), and the residual scale ``noise`` of one measurement row. Every solver then adds
the pseudo-observations :meth:`ParameterSpace.prior_residuals` to the data's residuals (MAP).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import compress

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.kinematics.joint_errors import is_parameter_name
from robocal.kinematics.model import Robot

BLOCKS = ("links", "base", "tool", "smr", "joint_errors", "nuisance")
_LINK = re.compile(r"^(alpha|a|beta|theta|d)\d+$")


def block_of(name: str) -> str:
    """The block a parameter name belongs to (one of :data:`BLOCKS`)."""
    if _LINK.match(name):
        return "links"
    if name.startswith(("base.", "tool.")):
        return name.split(".")[0]
    if re.match(r"^smr\d+\.", name):
        return "smr"
    if is_parameter_name(name):
        return "joint_errors"
    return "nuisance"


@dataclass(frozen=True, eq=False)
class State:
    """A point of the search: the robot model and the nuisance parameters ``(m,)``."""

    robot: Robot
    nuisance: np.ndarray

    def __post_init__(self) -> None:
        nuisance = np.array(self.nuisance, dtype=float).reshape(-1)
        nuisance.flags.writeable = False
        object.__setattr__(self, "nuisance", nuisance)


@dataclass(frozen=True)
class ParameterSpace:
    """The unknown vector: ``robot`` names (robot parameters) then ``nuisance`` names; optionally a
    prior: ``prior_sigma`` and ``prior_mean`` (one per unknown, SI; sigma inf where there is none,
    e.g. frames and nuisance) and ``noise``, the residual scale of one measurement row (residual
    unit) that weighs the prior against the data."""

    robot: tuple[str, ...]
    nuisance: tuple[str, ...] = ()
    prior_sigma: tuple[float, ...] = ()
    prior_mean: tuple[float, ...] = ()
    noise: float = 1.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "robot", tuple(self.robot))
        object.__setattr__(self, "nuisance", tuple(self.nuisance))
        object.__setattr__(self, "prior_sigma", tuple(float(v) for v in self.prior_sigma))
        object.__setattr__(self, "prior_mean", tuple(float(v) for v in self.prior_mean))
        if self.prior_sigma and not len(self.prior_sigma) == len(self.prior_mean) == self.size:
            raise IdentificationError("a prior needs one sigma and one mean per unknown")
        if self.prior_sigma and (min(self.prior_sigma) <= 0 or not self.noise > 0):
            raise IdentificationError("prior sigmas and the noise scale must be positive")
        names = self.names
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise IdentificationError(f"parameter(s) {twice} named twice in the estimated set")
        misplaced = [n for n in self.robot if block_of(n) == "nuisance"]
        if misplaced:
            raise IdentificationError(f"{misplaced} are not robot parameters")

    @property
    def names(self) -> list[str]:
        """Every unknown, in vector order."""
        return [*self.robot, *self.nuisance]

    @property
    def size(self) -> int:
        return len(self.robot) + len(self.nuisance)

    def blocks(self) -> dict[str, list[str]]:
        """The unknowns by block (:data:`BLOCKS`), each in vector order; empty blocks left out."""
        out: dict[str, list[str]] = {}
        for name in self.names:
            out.setdefault(block_of(name), []).append(name)
        return {b: out[b] for b in BLOCKS if b in out}

    def restricted(self, keep: Iterable[str]) -> ParameterSpace:
        """The same space (and prior) with only the names in ``keep`` (order kept)."""
        keep = set(keep)
        mask = [n in keep for n in self.names]  # no prior: compress keeps the empty tuples empty
        return ParameterSpace(tuple(n for n in self.robot if n in keep),
                              tuple(n for n in self.nuisance if n in keep),
                              tuple(compress(self.prior_sigma, mask)), tuple(compress(self.prior_mean, mask)),
                              self.noise)

    def with_prior(self, sigma, mean, noise: float) -> ParameterSpace:
        """This space with a prior (see the class)."""
        return ParameterSpace(self.robot, self.nuisance, tuple(sigma), tuple(mean), noise)

    @property
    def has_prior(self) -> bool:
        return bool(self.prior_sigma) and bool(np.isfinite(self.prior_sigma).any())

    @property
    def prior_weight(self) -> np.ndarray:
        """``(size,)`` weight of each unknown's prior row, ``noise / sigma`` (residual unit per SI
        unit; 0 without a prior)."""
        if not self.prior_sigma:
            return np.zeros(self.size)
        return self.noise / np.asarray(self.prior_sigma)

    def prior_residuals(self, state: State) -> np.ndarray:
        """``(size,)`` prior rows at ``state``: weight * (mean - value) (0 without a prior; robot
        parameters only: nuisance and frames carry none)."""
        w = self.prior_weight
        if not w.any():
            return w
        values = np.concatenate([state.robot.values[state.robot.indices(self.robot)], state.nuisance])
        return np.where(w > 0, w * (np.asarray(self.prior_mean) - values), 0.0)

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``x (..., size)`` -> (robot part ``(..., k)``, nuisance part ``(..., m)``)."""
        k = len(self.robot)
        return x[..., :k], x[..., k:]

    def apply(self, state: State, step: np.ndarray) -> State:
        """The state moved by ``step`` ``(size,)`` (SI)."""
        dx_robot, dx_nuisance = self.split(np.asarray(step, dtype=float))
        robot = state.robot.displaced(self.robot, dx_robot) if self.robot else state.robot
        return State(robot, state.nuisance + dx_nuisance)

    def robot_bounds(self, robot: Robot, bounds=None) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) displacement bounds ``(k,)`` of the robot names (SI): ``bounds`` given
        as two scalars or two arrays of k values, else :meth:`Robot.bounds`; they must contain 0
        (the start model)."""
        names, k = self.robot, len(self.robot)
        lo, hi = robot.bounds(names) if bounds is None else (np.asarray(b, float) for b in bounds)
        if np.ndim(lo) not in (0, 1) or np.size(lo) not in (1, k) or np.shape(lo) != np.shape(hi):
            raise IdentificationError(f"bounds must be two scalars or two arrays of {k} values (one per "
                                      f"free parameter: {', '.join(names)})")
        lo, hi = np.broadcast_to(lo, (k,)).astype(float), np.broadcast_to(hi, (k,)).astype(float)
        if not (np.isfinite(lo).all() and np.isfinite(hi).all() and (lo < hi).all()):
            raise IdentificationError("bounds must be finite with lower < upper for every parameter")
        outside = [n for n, a, b in zip(names, lo, hi, strict=True) if not a <= 0.0 <= b]
        if outside:
            raise IdentificationError(f"the bounds of {outside} exclude the nominal value: bounds are "
                                      "displacements from the start model (SI) and must contain 0")
        return lo, hi


def resolve_names(robot: Robot, params, blind: Sequence[str] = (), orientation: bool = False) -> list[str]:
    """The robot parameters a calibration frees: ``params`` 'auto' (the robot's default free
    set), 'all' (every parameter) or names (a list, or one string separated by spaces/commas).
    'auto' and 'all' leave out ``blind`` (what the data can never see)."""
    if isinstance(params, str) and params in ("auto", "all"):
        names = robot.default_free(orientation) if params == "auto" else list(robot.parameter_names)
        return [n for n in names if n not in set(blind)]
    if isinstance(params, str):
        params = [p for p in params.replace(",", " ").split() if p]
    names = list(params)
    robot.indices(names)  # validates (a name given twice: ParameterSpace refuses it)
    return names
