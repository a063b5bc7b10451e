"""Reports: error statistics (and, later, HTML)."""

from robocal.report.metrics import position_stats

__all__ = ["position_stats"]
