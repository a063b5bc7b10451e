"""The report's account of the limits of a calibration: the residual test against the instrument
(``consistency``) and the predicted accuracy over the workspace (``predicted_accuracy``) of a
result JSON (docs/result-json.md), as headline lines and a section."""

from __future__ import annotations

import numpy as np

from robocal.report.format import esc, num, p_value


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
        lines.append(f"Predicted accuracy over the workspace: <b class='{cls}'>{num(ws['rms'])} mm RMS</b> "
                     f"(p95 {num(ws.get('p95'))} mm); at the calibration poses {num(cal.get('rms'))} mm"
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
    svg = plots.error_vs_distance(np.asarray(curve["distance_deg"], float),
                                  np.asarray(curve["rms_mm"], float), float(pa["validated_mm"]),
                                  float(pa["factor"]))
    rows = "".join(f"<tr><td>q{esc(j['joint'])}</td><td>{num(j['covered_deg'][0], 1)} .. "
                   f"{num(j['covered_deg'][1], 1)}</td><td>{num(j['limits_deg'][0], 1)} .. "
                   f"{num(j['limits_deg'][1], 1)}</td><td>{num(100 * j['fraction'], 0)}%</td></tr>"
                   for j in pa.get("coverage") or [])
    ws = pa.get("workspace") or {}
    return (f"<figure>{svg}<figcaption><b>Look for:</b> the predicted error far from the calibration poses "
            f"against the validated {num(pa['validated_mm'])} mm ({esc(pa.get('validated_from'))}). "
            f"Predicted from the parameters' posterior covariance and the unmodelled error "
            f"({num(pa.get('unmodelled_mm'))} mm) at {esc(ws.get('samples'))} joint vectors uniform in "
            "the limits (seeded).</figcaption></figure>"
            "<table><tr><th>joint</th><th>calibration poses (deg)</th><th>limits (deg)</th><th>covered</th>"
            f"</tr>{rows}</table>")
