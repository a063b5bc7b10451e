"""Errors a user can cause. The CLI prints their message (no traceback) and exits non-zero.

Catch `RobocalError` to handle every one of them; the subclasses say what kind of input was wrong.

Examples
--------
>>> import robocal as rc
>>> try:
...     rc.Robot.from_catalog("no_such_robot")
... except rc.RobocalError as exc:
...     print(type(exc).__name__)
ModelError
"""


class RobocalError(Exception):
    """Base class of every error robocal raises because of its input.

    Its message says what is wrong and what to do; the command line prints it alone and exits 2.

    See Also
    --------
    rc.DataError : Input data that cannot be used.
    rc.ModelError : A model that cannot be used.
    rc.UnitError : Values in the wrong unit.
    rc.IdentificationError : A calibration problem that cannot be solved.
    rc.PlausibilityError : Data and model that disagree beyond what real robots do.
    rc.UnreachableError : A target with no inverse-kinematics solution.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> try:
    ...     robot.fk(np.zeros((3, 5)))  # five joints for a six-joint robot
    ... except rc.RobocalError as exc:
    ...     isinstance(exc, rc.DataError)
    True
    """


class ModelError(RobocalError):
    """A robot model is malformed: wrong sizes, NaN parameters, unknown names, bad YAML.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class DataError(RobocalError):
    """A measurement file or array is malformed: columns, units, NaN, joint count.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class ListedError(DataError):
    """An error naming several items (targets, motions): the CLI prints its first line and then
    one item a line, as the message holds them."""


class UnitError(DataError):
    """Units are missing, unknown or implausible for the values.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class PlausibilityError(DataError):
    """Data and model disagree beyond what real robots do (a unit, the wrong robot, the wrong
    file); ``force`` overrides it.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class IdentificationError(RobocalError):
    """A calibration problem cannot be solved: too few observations, rank collapse.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class UnreachableError(RobocalError):
    """A target pose has no inverse-kinematics solution.

    See Also
    --------
    rc.RobocalError : The base of every refusal: catch it for any.
    """


class ResourceError(RobocalError):
    """A computation needs more memory than the machine offers (checked before it starts; a
    MemoryError during it ends the same way)."""
