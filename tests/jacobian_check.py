"""The independent truth for the identification Jacobian: central differences of the residuals."""

import numpy as np

from robocal.identify.problem import CalibrationProblem
from robocal.identify.space import ParameterSpace


def central_difference(problem, state, space, column: int, h: float) -> np.ndarray:
    """``d residuals / d unknown[column]`` ``(M,)`` of ``problem`` at ``state`` by a central
    difference of step ``h`` (the unknown's unit), signed like ``problem.jacobian`` (of the
    model's prediction, the residual being measured minus modelled)."""
    e = np.zeros(space.size)
    e[column] = h
    return -(problem.residuals(space.apply(state, e)) - problem.residuals(space.apply(state, -e))) / (2 * h)


def assert_columns_match(problem, state, space, J: np.ndarray, n_geometric: int) -> None:
    """Every column of ``J`` against its central difference: steps 1e-7 for the first
    ``n_geometric`` unknowns (m, rad) and 1e-9 for the joint-error terms after them; rtol 1e-4,
    atol 1e-6 of the difference's largest value."""
    for c in range(space.size):
        h = 1e-9 if c >= n_geometric else 1e-7
        fd = central_difference(problem, state, space, c, h)
        np.testing.assert_allclose(J[:, c], fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def joint_error_jacobian(robot, data, names, values, geometric, reference_c: float | None = None):
    """``(problem, state, space, J)``: ``data`` seen by ``robot`` with the joint-error parameters
    ``names`` set to ``values`` (the thermal term's T_ref ``reference_c`` deg C where given), the
    space ``geometric`` then ``names`` and its Jacobian there."""
    truth = robot.with_joint_errors(names).with_values(dict(zip(names, values, strict=True)))
    if reference_c is not None:
        truth = truth.with_reference_temperature(reference_c)
    problem = CalibrationProblem(truth, data)
    space = ParameterSpace((*geometric, *names))
    state = problem.start(truth)
    return problem, state, space, problem.jacobian(state, space)
