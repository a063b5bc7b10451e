"""Errors a user can cause. The CLI prints their message (no traceback) and exits non-zero."""


class RobocalError(Exception):
    """Base class of every error robocal raises because of its input."""


class ModelError(RobocalError):
    """A robot model is malformed: wrong sizes, NaN parameters, unknown names, bad YAML."""


class DataError(RobocalError):
    """A measurement file or array is malformed: columns, units, NaN, joint count."""


class ListedError(DataError):
    """An error naming several items (targets, motions): the CLI prints its first line and then
    one item a line, as the message holds them."""


class UnitError(DataError):
    """Units are missing, unknown or implausible for the values."""


class PlausibilityError(DataError):
    """Data and model disagree beyond what real robots do (a unit, the wrong robot, the wrong
    file); ``force`` overrides it."""


class IdentificationError(RobocalError):
    """A calibration problem cannot be solved: too few observations, rank collapse."""


class UnreachableError(RobocalError):
    """A target pose has no inverse-kinematics solution."""


class ResourceError(RobocalError):
    """A computation needs more memory than the machine offers (checked before it starts; a
    MemoryError during it ends the same way)."""
