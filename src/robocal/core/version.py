"""The package version (the one place it is written; pyproject.toml reads it).

``rc.__version__`` is the installed robocal version, a PEP 440 string (``major.minor.patch``);
the result and campaign JSON files record it (``robocal_version``), and
``robocal --version`` prints it.

See Also
--------
robocal.history.Record : Records the version of each calibration and check.
rc.CalibrationResult : Its JSON names the version that made it.

Examples
--------
>>> import robocal as rc
>>> from robocal.core.version import __version__
>>> rc.__version__ == __version__
True
>>> major, minor, patch = (int(part) for part in rc.__version__.split(".")[:3])
>>> (major, minor) >= (0, 1)
True
"""

__version__ = "0.7.0"
