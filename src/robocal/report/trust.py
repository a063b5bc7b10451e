"""The report's account of the limits of a calibration: the residual test against the instrument
(``consistency``) and the predicted accuracy over the workspace (``predicted_accuracy``) of a
result JSON (docs/result-json.md), as headline lines and a section."""

from __future__ import annotations

import numpy as np

from robocal.report.format import esc, joint_columns, num, p_value


def headline(result: dict) -> list[str]:
    """Pre-escaped headline lines: the residual test's verdict and the predicted accuracy."""
    lines = []
    c = result.get("consistency") or {}
    if c.get("verdict") == "inconsistent":
        lines.append(f"<b class='bad'>The model misses its data by more than the instrument and the error "
                     f"model explain</b> ({num(c.get('rms_mm'))} mm RMS against "
                     f"{num(c.get('expected_rms_mm'))} mm expected; chi-square p = "
                     f"{p_value(c.get('p_value'))})")
    elif c.get("verdict") == "step":
        lines.append("<b class='bad'>The residuals change along the measuring order</b> (see the warnings)")
    pa = result.get("predicted_accuracy") or {}
    ws, cal = pa.get("workspace") or {}, pa.get("calibration_region") or {}
    if ws.get("rms") is not None:
        cls = "bad" if pa.get("holds_only_near_poses") else "good"
        gauge = f" {esc(pa['gauge'])}" if pa.get("gauge") else ""
        lines.append(f"Predicted accuracy{gauge} over the workspace: <b class='{cls}'>{num(ws['rms'])} mm "
                     f"RMS</b> (p95 {num(ws.get('p95'))} mm); at the calibration poses "
                     f"{num(cal.get('rms'))} mm"
                     + (" &mdash; <b class='bad'>the calibration holds only near its poses</b>"
                        if pa.get("holds_only_near_poses") else ""))
    return lines


def section(result: dict) -> str | None:
    """The predicted-accuracy section (figure and joint coverage table), pre-escaped; None without
    a ``predicted_accuracy``."""
    from robocal.report import plots

    pa = result.get("predicted_accuracy") or {}
    curve = pa.get("by_distance") or {}
    if not curve.get("distance_deg"):
        return None
    joints = pa.get("coverage") or []
    names = joint_columns(result, len(joints))
    sliding = [name for name, unit in names if unit == "mm"]
    svg = plots.error_vs_distance(np.asarray(curve["distance_deg"], float),
                                  np.asarray(curve["rms_mm"], float), float(pa["validated_mm"]),
                                  float(pa["factor"]),
                                  unit="deg" + (f"; mm on {', '.join(sliding)}" if sliding else ""))
    units = {unit for _, unit in names}
    shown = f" ({units.pop()})" if len(units) == 1 else ""  # else each row says its unit
    rows = []
    for j in joints:
        name, unit = names[j["joint"] - 1] if 1 <= j["joint"] <= len(names) else (f"q{j['joint']}", "deg")
        (a, b), (lo, hi) = j.get(f"covered_{unit}") or [None, None], j.get(f"limits_{unit}") or [None, None]
        each = "" if shown else f" {esc(unit)}"
        rows.append(f"<tr><td>{esc(name)}</td><td>{num(a, 1)} .. {num(b, 1)}{each}</td><td>{num(lo, 1)} .. "
                    f"{num(hi, 1)}{each}</td><td>{num(100 * j['fraction'], 0)}%</td></tr>")
    ws = pa.get("workspace") or {}
    return ("<div class='grid'><div>"
            f"<figure>{svg}<figcaption><span class='look'><b>Look for:</b> the predicted error far from the "
            f"calibration poses against the validated {num(pa['validated_mm'])} mm "
            f"({esc(pa.get('validated_from'))}).</span> Predicted from the parameters' posterior "
            "covariance and the unmodelled error "
            f"({num(pa.get('unmodelled_mm'))} mm) at {esc(ws.get('samples'))} joint vectors uniform in "
            "the limits (seeded)"
            + (f", {esc(pa['gauge'])}" if pa.get("gauge") else "")
            + (f"; {esc(pa['scale'].get('text'))}" if pa.get("scale") else "")
            + ".</figcaption></figure></div><div>"
            f"<div class='scroll'><table><tr><th>joint</th><th>calibration poses{shown}</th>"
            f"<th>limits{shown}</th><th>covered</th></tr>{''.join(rows)}</table></div></div></div>")
