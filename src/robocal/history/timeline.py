"""A robot's timeline: its calibrations, checks and evaluations in a history, in recording order."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.core.version import __version__
from robocal.history.store import History


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
    warnings: list[str] = field(default_factory=list)  # a timeline only reports: none

    def to_dict(self) -> dict:
        """``{"robot_id": ..., "entries": [...]}`` (the timeline JSON)."""
        return {"robot_id": self.robot_id, "entries": self.entries}

    def summary(self) -> str:
        """One line per record: id, date (UTC), kind, held-out and RMS (mm), a check's verdict, and
        ``joint zeros only (from #k)`` for an offsets-only recalibration of record k."""
        lines = []
        for e in self.entries:
            held, rms = ("-" if v is None else f"{v:.4f}" for v in (e["held_out_rms"], e["rms"]))
            line = f"#{e['id']:<4} {e['date']}  {e['kind']:<11} held-out {held} mm  RMS {rms} mm"
            if e["kind"] == "check":
                line += f"  {e['verdict']} (p = {e['p_value']:.3g})"
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
    """The `Timeline` of ``robot_id`` in the history at ``location`` (DataError when it holds no
    record of it)."""
    with History(location) as history:
        records = history.entries(robot_id)
    if not records:
        raise DataError(f"the history has no record of robot id {robot_id!r}")
    return Timeline(robot_id, [r.timeline_entry() for r in records])
