"""A robot's timeline: its calibrations, checks and evaluations in a history, in recording order."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.core.version import __version__
from robocal.history.store import History
from robocal.report.timeline import moved_words


@dataclass
class Timeline:
    """The records of one robot id: ``entries`` (`robocal.history.store.Record.timeline_entry`
    of each, oldest first).

    Examples
    --------
    >>> from robocal.history.timeline import read_timeline
    >>> print(read_timeline("robots.sqlite", "IRB-17").summary())  # doctest: +SKIP
    #1    2026-12-06 03:12:36  calibration held-out 0.0359 mm  RMS 0.0309 mm
    """

    robot_id: str
    entries: list[dict]
    warnings: list[str] = field(default_factory=list)  # the records left out, unreadable, and why

    def to_dict(self) -> dict:
        """``{"robot_id": ..., "entries": [...], "warnings": [...]}`` (the timeline JSON;
        ``warnings``: the records left out, unreadable, and why)."""
        return {"robot_id": self.robot_id, "entries": self.entries, "warnings": self.warnings}

    def summary(self) -> str:
        """One line per record: id, date (UTC), kind, held-out and RMS (mm), a check's verdict, and
        ``joint zeros only (from #k)`` for an offsets-only recalibration of record k."""
        lines = []
        for e in self.entries:
            held, rms = ("-" if v is None else f"{v:.4f}" for v in (e["held_out_rms"], e["rms"]))
            line = f"#{e['id']:<4} {e['date']}  {e['kind']:<11} held-out {held} mm  RMS {rms} mm"
            if e["kind"] == "check":
                line += f"  {e['verdict']} (p = {e['p_value']:.3g})"
                moved = moved_words(e)
                line += f"  moved: {', '.join(moved)}" if moved else ""
            if e.get("offsets_only"):
                line += "  joint zeros only" + (f" (from #{e['parent']})" if e.get("parent") else "")
            lines.append(line)
        return "\n".join(lines)

    def write(self, json_path=None, report=None) -> list[str]:
        """Write the timeline JSON and/or the HTML page of the held-out and check RMS over time
        (all or none); the paths written."""
        texts = {}
        if json_path:
            texts[json_path] = json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n"
        if report:
            from robocal.report.timeline import render_history

            texts[report] = render_history(self.to_dict(), __version__)
        write_all(texts)
        return [str(path) for path in texts]


def read_timeline(location: str, robot_id: str) -> Timeline:
    """The `Timeline` of ``robot_id`` in the history at ``location``, opened read-only. A record
    that fails validation is left out with a warning naming it and the cause (a timeline is a
    report: the other records are still right; a command that uses a record, like check, refuses
    instead).

    Raises
    ------
    DataError
        The history holds no readable record of the robot id, is damaged (SQLite's integrity
        check, run when no record is found) or is not a robocal history.
    """
    skipped: list[str] = []
    with History(location, readonly=True) as history:
        records = history.entries(robot_id, skipped=skipped)
    if not records:
        raise DataError(f"the history has no record of robot id {robot_id!r}" if not skipped else
                        f"the history has no readable record of robot id {robot_id!r}: " + "; ".join(skipped))
    return Timeline(robot_id, [r.timeline_entry() for r in records], skipped)
