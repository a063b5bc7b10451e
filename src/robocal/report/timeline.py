"""A robot's history as a self-contained HTML page (``robocal history --report``): the held-out
RMS of its calibrations and evaluations and the RMS of its checks over time, and the timeline table.
Same page rules as the calibration report (inline CSS and SVG, no JavaScript, every string escaped)."""

from __future__ import annotations

import datetime

from robocal.report.html import _figure, _num, _table, esc, page
from robocal.report.plots import AFTER, BEFORE, VALIDATION, _legend_above, _styled
from robocal.report.plots import _figure as _mpl_figure


@_styled
def rms_over_time(dates: list[datetime.datetime], held_out: list, checks: list, changed: list[bool],
                  fitted: list | None = None):
    """Held-out RMS (mm; None where a record has none) and check RMS (mm) against the date;
    checks that found a change are drawn as filled red markers; ``fitted``: the RMS on their own
    data of the calibrations without held-out data (an offsets-only recalibration on a check
    campaign), open markers. A margin on both sides keeps the first and last records inside."""
    fig = _mpl_figure(6.4, 2.8, top=0.4)
    ax = fig.add_subplot()
    fitted = fitted or [None] * len(dates)
    for values, label, color, marker in ((held_out, "held-out RMS", VALIDATION, "o"),
                                         (checks, "check RMS", AFTER, "s"),
                                         (fitted, "fit RMS (no held-out data)", VALIDATION, "D")):
        keep = [i for i, v in enumerate(values) if v is not None]
        if keep:
            ax.plot([dates[i] for i in keep], [values[i] for i in keep], marker, color=color, ms=5,
                    ls="none" if marker == "D" else "-", lw=1, label=label,
                    mfc="none" if marker == "D" else color)
    bad = [i for i, c in enumerate(changed) if c and checks[i] is not None]
    if bad:
        ax.plot([dates[i] for i in bad], [checks[i] for i in bad], "s", color=BEFORE, ms=8,
                label="check: changed")
    ax.set_ylabel("RMS (mm)")
    ax.margins(x=0.08, y=0.15)
    ax.set_ylim(bottom=0)
    fig.autofmt_xdate()
    _legend_above(ax)
    return fig


def moved_words(entry: dict) -> list[str]:
    """What a check entry of a timeline says moved: the SMR or the tracker frame (a check's
    ``frame_change``: not the robot) and the parameters (name, shift ± sigma, unit); empty for
    other entries."""
    f = entry.get("frame_change") or {}
    out = []
    if "smr" in (f.get("moved") or []):
        which = f" {f['smr']}" if f.get("smr") else ""
        out.append(f"SMR{which} {f['smr_shift_norm_mm']:.4f} mm (not the robot)")
    if "tracker" in (f.get("moved") or []):
        out.append(f"tracker frame {f['points_moved_rms_mm']:.4f} mm (not the robot)")
    return out + [f"{c['name']} {c['shift']:+.4f} ± {c['sigma']:.4f} {c['unit']}"
                  for c in entry.get("changed_parameters") or []]


def render_history(timeline: dict, version: str) -> str:
    """The HTML page of ``timeline`` (``robocal history --json``'s content)."""
    entries = timeline["entries"]
    dates = [datetime.datetime.fromisoformat(e["date"]) for e in entries]
    svg = rms_over_time(dates, [e["held_out_rms"] for e in entries],
                        [e["rms"] if e["kind"] == "check" else None for e in entries],
                        [e["verdict"] == "changed" for e in entries],
                        [e["rms"] if e["kind"] == "calibration" and e["held_out_rms"] is None else None
                         for e in entries])
    rows = []
    for e in entries:
        moved = esc(", ".join(moved_words(e)))
        rows.append([esc(e["id"]), esc(e["date"]), esc(e["kind"] + (" (offsets only)" if e.get("offsets_only")
                                                                     else "")),
                     _num(e["held_out_rms"]), _num(e["rms"]), esc(e["verdict"] or ""),
                     "" if e["p_value"] is None else f"{e['p_value']:.3g}", moved,
                     esc(", ".join(d["sha256"][:12] for d in e["data"]))])
    table = _table(["#", "date (UTC)", "kind", "held-out RMS", "RMS", "verdict", "p", "moved",
                    "data SHA-256"], rows, align="lllrrllww")
    figure = _figure(svg, "Held-out RMS of each calibration with validation data (and of each evaluation), "
                          "fit RMS of a calibration without (an offsets-only one: open marker), "
                          "RMS of each check after the tracker frame was refitted.",
                     "a check RMS well above the held-out RMS, and checks marked changed.")
    robot = esc(timeline["robot_id"])
    left_out = len(timeline.get("warnings") or [])  # unreadable records the timeline left out
    subtitle = f"robot id {robot} &middot; {len(entries)} records" + \
        (f" &middot; {left_out} unreadable left out (robocal history prints which and why)" if left_out
         else "")
    return page(f"History of {timeline['robot_id']}", subtitle,
                [("accuracy", "Accuracy over time", figure), ("timeline", "Timeline", table)], version,
                narrow=frozenset({"accuracy"}))

