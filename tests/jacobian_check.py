"""The independent truth for the identification Jacobian: central differences of the residuals."""

import numpy as np


def central_difference(problem, state, space, column: int, h: float) -> np.ndarray:
    """``d residuals / d unknown[column]`` ``(M,)`` of ``problem`` at ``state`` by a central
    difference of step ``h`` (the unknown's unit), signed like ``problem.jacobian`` (of the
    model's prediction, the residual being measured minus modelled)."""
    e = np.zeros(space.size)
    e[column] = h
    return -(problem.residuals(space.apply(state, e)) - problem.residuals(space.apply(state, -e))) / (2 * h)
