"""Damped least squares (Levenberg-Marquardt): the one iteration shared by calibration (one large
problem) and numeric inverse kinematics (a batch of small independent problems), and the words
every iterative method in robocal uses to say how it stopped.

The caller's problem holds ``size`` independent members (1 for a calibration, one per target
pose for IK) and their current points; :func:`minimize` drives them. Per member: linearise,
propose a step for the current damping, stop if the problem's convergence test holds, else try
the step; an accepted step (the cost decreased) divides the damping by ``DAMPING_FACTOR`` and
re-linearises, a rejected one multiplies it and tries again from the same linearisation. A
member whose damping exceeds ``DAMPING_MAX`` has stalled: at the minimum to rounding if the
linear model promised less than ``STALL_RTOL`` of the cost, else stalled for real.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol

import numpy as np

DAMPING_START = 1e-6  # relative to the problem's own scale (see DampedProblem.propose)
DAMPING_MIN = 1e-12
DAMPING_MAX = 1e8
DAMPING_FACTOR = 10.0
STALL_RTOL = 1e-6  # a stall promising less than this fraction of the cost is convergence


class Status(StrEnum):
    """How an iterative method stopped."""

    CONVERGED = "converged"  # its convergence test held
    THRESHOLD = "threshold"  # the error threshold the user set was reached
    MAX_ITERATIONS = "max_iterations"  # the iteration (generation, epoch) limit came first
    STALLED = "stalled"  # no damped step decreases the cost, though the linear model promises it
    INTERRUPTED = "interrupted"  # stopped by the user (Ctrl-C): the best point so far


SUCCESS = (Status.CONVERGED, Status.THRESHOLD)


class DampedProblem(Protocol):
    """What :func:`minimize` needs. ``members`` are index arrays into ``0..size-1``."""

    size: int

    def cost(self) -> np.ndarray:
        """``(size,)`` cost of every member at its current point."""

    def linearize(self, members: np.ndarray) -> None:
        """Linearise the members at their current points (kept until the next call)."""

    def propose(self, members: np.ndarray, damping: np.ndarray) -> np.ndarray:
        """Compute (and keep) the damped steps for ``damping`` ``(len(members),)``; return the
        decrease of the cost the linear model predicts for them."""

    def converged(self, members: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """``(len(members),)`` bool: the member's convergence test holds (before its step)."""

    def trial_cost(self, members: np.ndarray) -> np.ndarray:
        """Cost at the proposed points ``(len(members),)``."""

    def accept(self, members: np.ndarray) -> None:
        """Move the members to their proposed points."""


_CODES = np.array([Status.CONVERGED, Status.STALLED, Status.MAX_ITERATIONS], dtype=object)
_RUNNING, _CONVERGED, _STALLED, _MAX_ITERATIONS = -1, 0, 1, 2  # a member's state in minimize


@dataclass(frozen=True)
class DampedResult:
    """``status`` ``(size,)`` of :class:`Status` and ``nit`` ``(size,)`` accepted steps."""

    status: np.ndarray
    nit: np.ndarray


def minimize(problem: DampedProblem, max_iter: int,
             on_accept: Callable[[np.ndarray, np.ndarray], None] | None = None) -> DampedResult:
    """Run the iteration of the module docstring until every member has stopped; at most
    ``max_iter`` accepted steps per member. ``on_accept(members, nit)`` is called after each
    round of accepted steps (history, progress)."""
    size = problem.size
    damping = np.full(size, DAMPING_START)
    code = np.full(size, _RUNNING)  # index into _CODES once stopped (int codes: cheap to compare)
    nit = np.zeros(size, dtype=int)
    first = np.full(size, np.nan)  # predicted decrease at the first damping tried since linearising
    problem.linearize(np.arange(size))
    if max_iter < 1:
        code[:] = _MAX_ITERATIONS
    while (run := np.flatnonzero(code == _RUNNING)).size:
        cost = problem.cost()[run]
        predicted = problem.propose(run, damping[run])
        fresh = np.isnan(first[run])
        first[run[fresh]] = predicted[fresh]
        done = problem.converged(run, predicted)
        code[run[done]] = _CONVERGED
        run, cost = run[~done], cost[~done]
        if not run.size:
            break
        better = problem.trial_cost(run) < cost
        accepted, rejected = run[better], run[~better]
        problem.accept(accepted)
        nit[accepted] += 1
        damping[accepted] = np.maximum(damping[accepted] / DAMPING_FACTOR, DAMPING_MIN)
        first[accepted] = np.nan
        if on_accept is not None and accepted.size:
            on_accept(accepted, nit[accepted])
        damping[rejected] *= DAMPING_FACTOR
        gave_up = damping[rejected] > DAMPING_MAX
        stuck = rejected[gave_up]
        small = first[stuck] <= STALL_RTOL * cost[~better][gave_up]
        code[stuck] = np.where(small, _CONVERGED, _STALLED)
        code[accepted[nit[accepted] >= max_iter]] = _MAX_ITERATIONS
        relinearize = accepted[code[accepted] == _RUNNING]
        if relinearize.size:
            problem.linearize(relinearize)
    status = np.full(size, None, dtype=object)
    stopped = code != _RUNNING
    status[stopped] = _CODES[code[stopped]]
    return DampedResult(status=status, nit=nit)
