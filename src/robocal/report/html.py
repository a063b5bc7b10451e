"""Self-contained HTML calibration report from a result dict (docs/result-json.md).

One file, no network access when opened: styles inline, figures inline SVG (matplotlib), no
JavaScript, and a Content-Security-Policy that forbids loading anything. Every string that
comes from the user's files is escaped. Optional parts of the result (validation, rejected
observations, measured points, repeated poses, history) add sections when present.
"""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np

from robocal.errors import DataError
from robocal.io import write_atomic
from robocal.report.iso9283 import pose_accuracy_repeatability

MAX_3D_POINTS = 4000
MAX_CORRELATION_NAMES = 36  # a larger heat map's labels cannot be read
WORST = 10

_CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#222;
 margin:0;background:#f6f7f9}
main{max-width:1120px;margin:0 auto;padding:24px 32px 60px;background:#fff}
h1{font-size:24px;margin:0 0 4px}h2{font-size:18px;margin:32px 0 8px;border-bottom:2px solid #1b9e77;
 padding-bottom:3px}h3{font-size:15px;margin:18px 0 6px}
.sub{color:#666;margin:0 0 16px}nav{margin:8px 0 16px;font-size:13px}nav a{margin-right:12px;color:#1b6e5a}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{padding:3px 9px;border-bottom:1px solid #e3e3e3;text-align:right;white-space:nowrap}
th{background:#f0f2f4;font-weight:600}td.l,th.l{text-align:left}
tr.dropped td{background:#fff4e5}tr.chosen td{background:#e8f4ea;font-weight:600}
.kpi{display:flex;gap:14px;flex-wrap:wrap;margin:10px 0}
.kpi div{border:1px solid #dde;border-radius:6px;padding:8px 14px;min-width:150px}
.kpi b{display:block;font-size:22px}.kpi span{color:#666;font-size:12px}
.good{color:#1b9e77}.bad{color:#d95f02}.warn{background:#fff4e5;border-left:4px solid #d95f02;
 padding:6px 10px;margin:6px 0}
figure{margin:10px 0 18px}figure svg{width:100%;height:auto}figcaption{color:#555;font-size:12px}
.row{display:flex;flex-wrap:wrap;gap:12px}.row figure{flex:1 1 460px}
.note{color:#666;font-size:12px}td code{white-space:pre-wrap;word-break:break-all}
@media print{body{background:#fff}main{padding:0}h2{break-after:avoid}figure{break-inside:avoid}}
"""


def esc(value) -> str:
    """HTML-escaped text of any value (user strings, numbers, None)."""
    return html.escape("" if value is None else str(value), quote=True)


def _num(value, digits: int = 4) -> str:
    if value is None:
        return "&ndash;"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return esc(value)
    if not math.isfinite(value):
        return esc(value)
    if isinstance(value, int):
        return str(value)
    if value != 0 and (abs(value) >= 1e6 or abs(value) < 10 ** (-digits)):
        return f"{value:.{min(digits, 4)}g}" if abs(value) >= 1e6 else f"{value:.3e}"
    return f"{value:.{digits}f}"


def _table(header: list[str], rows: list[list[str]], left: int = 1, row_class=None) -> str:
    """Rows of pre-escaped cells; the first ``left`` columns are left-aligned."""
    def cls(k: int) -> str:
        return ' class="l"' if k < left else ""

    head = "".join(f"<th{cls(k)}>{h}</th>" for k, h in enumerate(header))
    body = []
    for i, r in enumerate(rows):
        rc = f' class="{row_class[i]}"' if row_class and row_class[i] else ""
        body.append(f"<tr{rc}>" + "".join(f"<td{cls(k)}>{c}</td>" for k, c in enumerate(r)) + "</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _figure(svg: str, caption: str) -> str:
    return f"<figure>{svg}<figcaption>{caption}</figcaption></figure>"


# ----------------------------------------------------------------- observation errors
def _array(obs: dict, key: str, cols: int | None = None) -> np.ndarray | None:
    value = obs.get(key)
    if value is None:
        return None
    arr = np.asarray(value, dtype=float)
    if cols is not None and (arr.ndim != 2 or arr.shape[1] != cols):
        raise DataError(f"result field observations.{key} must be a list of {cols}-vectors")
    return arr


def _or(value, default):
    return default if value is None else value


# what one observation's error is, by kind (the result's per-row error_before / error_after, mm)
ERROR_LABELS = {"point": "position error (mm)", "pose": "position error (mm)",
                "plane": "distance to fitted plane (mm)", "distance": "error of the pair's distance (mm)"}


class _ObsErrors:
    """Per-observation errors (mm) of one observation block, before and after."""

    def __init__(self, obs: dict) -> None:
        self.before_pts = _array(obs, "model_before", 3)
        self.after_pts = _array(obs, "model_after", 3)
        self.measured = _array(obs, "measured", 3)
        n = next((len(obs[k]) for k in ("error_after", "model_after", "error_before", "measured")
                  if obs.get(k) is not None), 0)  # rows (one length: robocal.schema checks it)
        self.joints = _array(obs, "joints_deg")
        self.pose_id = np.asarray(_or(obs.get("pose_id"), np.arange(n)))
        self.source_row = np.asarray(_or(obs.get("source_row"), np.arange(n)))
        self.smr = np.asarray(_or(obs.get("smr"), np.zeros(n, int)))
        weight = obs.get("weight")
        self.rejected = np.zeros(n, bool) if weight is None else np.asarray(weight, float) == 0
        self.label = ERROR_LABELS.get(obs.get("kind"), ERROR_LABELS["point"])
        self.vectors = None if self.measured is None or self.after_pts is None \
            else self.measured - self.after_pts
        self.before, self.after = _array(obs, "error_before"), _array(obs, "error_after")
        if self.after is None and self.vectors is not None and self.before_pts is not None:  # older results
            self.before = np.linalg.norm(self.measured - self.before_pts, axis=1)
            self.after = np.linalg.norm(self.vectors, axis=1)

    @property
    def ok(self) -> bool:
        """Whether there are per-row errors before and after to show."""
        return self.after is not None and self.after.size > 0 and self.before is not None


# ----------------------------------------------------------------- sections
def _stats_row(name: str, s: dict | None) -> list[str] | None:
    if not s:
        return None
    return [esc(name)] + [_num(s.get(k), 0 if k == "n" else 4) for k in ("n", "rms", "mean", "max", "p95")]


def _summary(result: dict) -> str:
    robot, data = result.get("robot") or {}, result.get("data") or {}
    obs = result.get("observations") or {}
    weights = obs.get("weight")
    rejected = result.get("rejected")
    n_rej = len(rejected) if rejected is not None else None
    if n_rej is None and weights is not None:
        n_rej = int(np.sum(np.asarray(weights, float) == 0))
    n_obs = data.get("n_observations")
    used = None if n_obs is None or n_rej is None else n_obs - n_rej
    settings = result.get("settings") or {}
    prov = result.get("provenance") or {}
    facts = [("robot", f"{esc(robot.get('name'))} <span class='note'>{esc(robot.get('description'))}</span>"),
             *_provenance(prov),
             ("joints", esc(robot.get("n_joints"))),
             ("data set", f"{esc(data.get('file'))} ({esc(data.get('kind'))})"),
             ("poses / observations", f"{esc(data.get('n_poses'))} / {esc(n_obs)}"),
             ("observations used / rejected", f"{esc(used)} / {esc(n_rej)}"),
             ("validation set", esc(data.get("validation_file")) if data.get("validation_file") else "none"),
             ("method", esc(result.get("method"))),
             ("settings", ", ".join(f"{esc(k)}={esc(v)}" for k, v in settings.items()) or "&ndash;")]
    if "converged" in result or "message" in result:
        state = "converged" if result.get("converged") else "<b class='bad'>not converged</b>"
        facts.append(("solver", f"{state} ({esc(result.get('status'))}: {esc(result.get('message'))})"))
    facts.append(("robocal", esc(result.get("robocal_version"))))
    out = [_table(["", ""], [[f"<b>{k}</b>", v] for k, v in facts], left=2)]
    b, a = result.get("before") or {}, result.get("after") or {}
    a_in = result.get("after_inliers")
    kpis = []
    for label, s0, s1 in (("calibration RMS" + (", inliers" if a_in else ""), b, a_in or a),
                          ("validation RMS", result.get("validation_before"), result.get("validation"))):
        if s1 and s1.get("rms") is not None:
            gain = ""
            if s0 and s0.get("rms"):
                gain = f" &middot; {100 * (1 - s1['rms'] / s0['rms']):.0f}% lower"
            start = f"{_num(s0.get('rms'))} &rarr; " if s0 else ""
            kpis.append(f"<div><span>{label}</span><b class='good'>{_num(s1['rms'])} mm</b>"
                        f"<span>{start}{_num(s1['rms'])} mm{gain}</span></div>")
    headline = a_in or a  # rejected observations are not the robot's accuracy
    if headline.get("max") is not None:
        kpis.append(f"<div><span>calibration max{', inliers' if a_in else ''}</span>"
                    f"<b>{_num(headline['max'])} mm</b><span>before {_num(b.get('max'))} mm</span></div>")
    rows = [r for r in (_stats_row("calibration set, before", b), _stats_row("calibration set, after", a),
                        _stats_row("calibration set, after, rejected left out", a_in),
                        _stats_row("validation set, before", result.get("validation_before")),
                        _stats_row("validation set, after", result.get("validation"))) if r]
    out.append(f"<div class='kpi'>{''.join(kpis)}</div>")
    out.append(_table(["", "n", "RMS (mm)", "mean (mm)", "max (mm)", "p95 (mm)"], rows))
    out.append(_per_file(result))
    warnings = result.get("warnings") or []
    out += [f"<div class='warn'>{esc(w)}</div>" for w in warnings]
    return "".join(out)


_KIND_ERROR = {"point": "position", "pose": "position", "plane": "distance to the plane",
               "distance": "distance error"}


def _per_file(result: dict) -> str:
    """Statistics per measurement file and per kind when a calibration used several files."""
    files = result.get("per_file") or []
    if len(files) < 2:
        return ""
    rows = []
    for f in files:
        before, after = f.get("before") or {}, f.get("after") or {}
        rows.append([esc(f.get("role")), esc(f.get("kind")), esc(_KIND_ERROR.get(f.get("kind"), "error")),
                     esc(f.get("file")), _num(before.get("rms")), _num(after.get("rms")),
                     _num(after.get("max")), esc(after.get("n"))])
    kinds = [[esc(k), _num(v.get("rms")), _num(v.get("max")), esc(v.get("n"))]
             for k, v in (result.get("per_kind") or {}).items()]
    return ("<h3>Per file</h3><p>Each file judged in its own kind of error (all in mm).</p>"
            + _table(["", "kind", "error", "file", "RMS before", "RMS after", "max after", "n"], rows, left=4)
            + "<h3>Per kind, after calibration</h3>" + _table(["", "RMS (mm)", "max (mm)", "n"], kinds))


def _provenance(prov: dict) -> list[tuple[str, str]]:
    """Where the numbers came from: when, which inputs, which split (pre-escaped rows)."""
    rows = []
    if prov.get("created"):
        rows.append(("created", esc(prov["created"])))
    if prov.get("command"):
        rows.append(("command", f"<code>{esc(prov['command'])}</code>"))
    if prov.get("robot_spec"):
        rows.append(("robot model from", esc(prov["robot_spec"])))
    for key, label in (("data_file", "calibration file"), ("validation_file", "validation file")):
        if prov.get(key):
            rows.append((label, esc(prov[key])))
    if prov.get("hold_out"):
        rows.append(("hold-out split", f"the last {esc(prov['hold_out'])} poses of the calibration file "
                                       "judge the calibration on the others"))
    return rows


def _subsample(n: int) -> np.ndarray:
    return np.arange(n) if n <= MAX_3D_POINTS else np.linspace(0, n - 1, MAX_3D_POINTS).astype(int)


def _errors_section(cal: _ObsErrors, val: _ObsErrors | None) -> str:
    from robocal.report import plots

    out = [_figure(plots.sorted_errors(cal.before, cal.after, cal.label),
                   f"Per-observation {esc(cal.label)} on the calibration set, before (nominal model) "
                   "and after calibration, each sorted from the largest.")]
    series = [("before", cal.before, plots.BEFORE), ("after", cal.after, plots.AFTER)]
    if val is not None and val.ok:
        series.append(("validation, after", val.after, plots.VALIDATION))
    out.append(_figure(plots.distribution(series, cal.label),
                       "Error distribution: histogram and cumulative share of observations "
                       "(dashed line: 95 %)."))
    if cal.joints is not None and cal.joints.ndim == 2 and len(cal.joints) == len(cal.after):
        out.append(_figure(plots.error_vs_joints(cal.joints, cal.before, cal.after, cal.label),
                           "Error against each joint angle: a trend left after calibration points "
                           "to an unmodelled effect of that joint (e.g. compliance, gear error). "
                           "Log scale when errors span more than a factor 20."))
    pts = cal.measured if cal.measured is not None else cal.after_pts
    if pts is not None:
        out.append(_points_figures(cal, pts))
    out.append(_worst_table(cal))
    return "".join(out)


def _points_figures(cal: _ObsErrors, pts: np.ndarray) -> str:
    """The 3-D view coloured by the error after, and the worst residual vectors."""
    from robocal.report import plots

    idx = _subsample(len(pts))
    note = "" if idx.size == len(pts) else f" ({idx.size} of {len(pts)} points shown)"
    what = "measured points" if cal.measured is not None else "modelled probe-tip points (no measured points)"
    rejected = ("; rejected observations (robust) are marked &times; and left out of the colour scale"
                if cal.rejected.any() else "")
    figs = [_figure(plots.points_3d(pts[idx], cal.after[idx], f"after: {cal.label}", cal.rejected[idx]),
                    f"3-D view of the {what} coloured by the residual after calibration{note}{rejected}.")]
    if cal.vectors is not None:
        worst = np.argsort(np.where(cal.rejected, -np.inf, -cal.after), kind="stable")[:WORST]
        figs.append(_figure(plots.worst_vectors(pts[idx], cal.vectors, worst),
                            f"Residual vectors (measured &minus; calibrated model) of the {worst.size} "
                            "worst observations that were not rejected, magnified."))
    return f"<div class='row'>{''.join(figs)}</div>"


def _worst_table(cal: _ObsErrors) -> str:
    worst = np.argsort(-cal.after, kind="stable")[:WORST]
    header = ["pose id", "source row", "smr", "before (mm)", "after (mm)"]
    rows = []
    for i in worst:
        row = [esc(cal.pose_id[i]) + (" <b class='bad'>rejected</b>" if cal.rejected[i] else ""),
               esc(cal.source_row[i]), esc(cal.smr[i]), _num(float(cal.before[i])),
               _num(float(cal.after[i]))]
        if cal.vectors is not None:
            row += [_num(float(v)) for v in cal.vectors[i]]
        rows.append(row)
    if cal.vectors is not None:
        header += ["dx (mm)", "dy (mm)", "dz (mm)"]
    return f"<h3>The {len(rows)} worst observations after calibration</h3>" + _table(header, rows, left=0)


def _unit_digits(unit) -> int:
    return 5 if unit in ("deg", "rad") else 4


def _parameters(result: dict) -> str:
    params = result.get("parameters") or []
    dropped = {d.get("name"): d for d in result.get("dropped") or []}
    rows, classes = [], []
    for p in params:
        digits = _unit_digits(p.get("unit"))
        status = p.get("status", "")
        conf = dropped.get(p.get("name"), {}).get("confounded_with")
        note = ("confounded with " + ", ".join(esc(c) for c in conf)) if conf else (
            esc(dropped[p.get("name")].get("reason")) if p.get("name") in dropped else "")
        rows.append([esc(p.get("name")), esc(status), esc(p.get("unit")), _num(p.get("nominal"), digits),
                     _num(p.get("estimate"), digits), _num(p.get("correction"), digits),
                     _num(p.get("sigma"), digits), note])
        classes.append("dropped" if status == "dropped" else "")
    if not rows:
        return "<p>No parameter table in this result.</p>"
    n_est = sum(p.get("status") == "estimated" for p in params)
    text = (f"<p>{n_est} parameters estimated, {len(dropped)} not identifiable from these data "
            "(kept at their start value; highlighted). Correction = estimate "
            "&minus; nominal; 1&sigma; from the covariance of the estimate.</p>")
    table = _table(["name", "status", "unit", "nominal", "estimate", "correction", "1&sigma;",
                    "note"], rows, left=3, row_class=classes).replace(
        "<td>confounded", "<td class='l'>confounded")
    return text + table + _nongeometric(result.get("nongeometric"), result.get("parameters"))


def _nongeometric(ng: dict | None, parameters: list) -> str:
    """The non-geometric terms' parameters, from the parameter table (its display units)."""
    if not ng or not ng.get("kept"):
        return ""
    table = {str(p.get("name")): p for p in parameters or []}
    rows = [[esc(name), esc(table[name].get("unit", "")), _num(table[name].get("estimate"), 5),
             _num(table[name].get("sigma"), 5)] for name in ng["kept"] if name in table]
    dropped = ng.get("dropped") or []
    return (f"<h3>Non-geometric terms: {esc(', '.join(ng.get('terms', [])))}</h3>"
            "<p>Joint errors the model adds to the commanded joints: compliance (per metre of "
            "unit-weight moment arm), gear harmonics, backlash (half lost motion, by approach "
            "direction), travel (error per degree of the joint's last move) and cyclic errors "
            "(cyc{joint}_{cycles per revolution}). "
            f"{len(dropped)} candidate(s) the data cannot separate from the geometry "
            "were left out.</p>" + _table(["name", "unit", "estimate", "1&sigma;"], rows, left=2))


def _model_selection(ms: dict | None) -> str:
    """The candidate error models with their cross-validated error, and the choice."""
    if not ms or not ms.get("candidates"):
        return ""
    cands = ms["candidates"]
    order = sorted(range(len(cands)), key=lambda i: _or(cands[i].get("cv_rms_mm"), np.inf))
    rows, classes = [], []
    for i in order:
        c = cands[i]
        mark = "chosen" if i == ms.get("chosen") else ("lowest CV error" if i == ms.get("best") else "")
        rows.append([esc(", ".join(c.get("terms") or []) or "geometric"), esc(mark), _num(c.get("n_params")),
                     _num(c.get("cv_rms_mm"), 4), _num(c.get("cv_se_mm"), 4),
                     _num(c.get("calibration_rms_mm"), 4)])
        classes.append("chosen" if i == ms.get("chosen") else "")
    text = (f"<p>{esc(ms.get('method'))}, {_num(ms.get('n_poses'))} poses. Chosen: "
            f"<b>{esc(', '.join(ms.get('chosen_terms') or []) or 'geometric')}</b> &mdash; "
            f"{esc(ms.get('reason'))}.</p>")
    freqs = ms.get("cyclic_frequencies") or []
    if freqs:
        text += ("<p>Cyclic errors found (joint: cycles per revolution): " + esc(", ".join(
            f"J{c.get('joint')}: {c.get('cycles_per_rev')}" for c in freqs)) + ".</p>")
    return text + _table(["model", "", "parameters", "CV RMS (mm)", "&plusmn; SE (mm)",
                          "calibration fit RMS (mm)"], rows, left=2, row_class=classes)


_IDENT_LABELS = {"n_params": "candidate parameters", "rank": "rank (identifiable)",
                 "condition_number": "condition number (scaled normal matrix)",
                 "condition_class": "ill-conditioning "
                                    "(&lt;100 weak, 100&ndash;1000 moderate, &gt;1000 strong)",
                 "O1": "O1 (geometric mean of singular values / &radic;poses)",
                 "O2": "O2 (&sigma;<sub>min</sub> / &sigma;<sub>max</sub>)",
                 "O3": "O3 (&sigma;<sub>min</sub>)",
                 "O4": "O4 (&sigma;<sub>min</sub>&sup2; / &sigma;<sub>max</sub>)"}


def _identifiability(result: dict) -> str:
    ident = result.get("identifiability") or {}
    keys = [k for k in _IDENT_LABELS if k in ident] + [k for k in ident if k not in _IDENT_LABELS]
    rows = [[_IDENT_LABELS.get(k, esc(k)), _num(ident[k], 4) if not isinstance(ident[k], float)
             else (f"{ident[k]:.4g}")] for k in keys if not isinstance(ident[k], list | dict)]
    out = _table(["", ""], rows, left=1) if rows else "<p>No identifiability analysis in this result.</p>"
    dropped = result.get("dropped") or []
    if dropped:
        out += "<h3>Parameters not identifiable from these data</h3>" + _table(
            ["parameter", "reason", "confounded with"],
            [[esc(d.get("name")), esc(d.get("reason")), esc(", ".join(d.get("confounded_with") or []))
              or "no effect on the measurements"] for d in dropped], left=3)
    return out


def _correlation(result: dict) -> str:
    from robocal.report import plots

    corr = result.get("correlation") or {}
    names, matrix = corr.get("names") or [], corr.get("matrix")
    if len(names) < 2 or matrix is None:
        return ""
    m = np.asarray(matrix, dtype=float)
    if m.shape != (len(names), len(names)):
        raise DataError("result field correlation.matrix must be square with one row per name")
    iu = np.triu_indices(len(names), 1)
    order = np.argsort(-np.abs(m[iu]), kind="stable")[:10]
    rows = [[esc(names[iu[0][k]]), esc(names[iu[1][k]]), f"{m[iu][k]:+.3f}"] for k in order]
    shown = np.arange(len(names))
    note = ""
    if len(names) > MAX_CORRELATION_NAMES:  # the parameters most correlated with another one
        strongest = np.abs(m - np.eye(len(names))).max(axis=1)
        shown = np.sort(np.argsort(-strongest, kind="stable")[:MAX_CORRELATION_NAMES])
        note = (f" The {shown.size} of {len(names)} parameters with the strongest correlation to another "
                f"one are shown (each |r| &ge; {strongest[shown].min():.2f}); the others are less "
                "correlated.")
    return (_figure(plots.correlation([str(names[i]) for i in shown], m[np.ix_(shown, shown)]),
                    "Correlation of the estimated parameters "
                    f"(1: fully correlated, &minus;1: anti-correlated).{note}")
            + "<h3>Strongest correlations</h3>" + _table(["parameter", "parameter", "correlation"], rows,
                                                          left=2))


def _rejected(result: dict) -> str:
    rejected = result.get("rejected")
    if not rejected:
        return "<p>No observation was rejected.</p>"
    rows = [[esc(r.get("source_row")), esc(r.get("pose_id")), _num(r.get("residual")),
             _num(r.get("weight"), 3)]
            for r in rejected]
    return (f"<p>{len(rejected)} observation(s) got zero weight in the robust estimation "
            "(IGG3 rejected segment); their residuals after calibration:</p>"
            + _table(["source row", "pose id", "residual (mm)", "weight"], rows, left=0))


def _iso(blocks: list[tuple[str, _ObsErrors]]) -> str:

    parts = []
    for name, ob in blocks:
        if ob is None or ob.measured is None or ob.after_pts is None or ob.joints is None \
                or ob.joints.ndim != 2:
            continue
        g = pose_accuracy_repeatability(ob.measured, ob.after_pts, ob.pose_id, ob.joints, ob.smr)
        if not len(g):
            continue
        rows = [[esc(g.pose_id[k]), str(g.n[k]), _num(float(g.ap[k])),
                 *(_num(float(v)) for v in g.ap_xyz[k]), _num(float(g.l_mean[k])), _num(float(g.s_l[k])),
                 _num(float(g.rp[k]))] for k in range(len(g))]
        parts.append(f"<h3>{esc(name)}: {len(g)} repeated pose(s)</h3>"
                     f"<p>max AP {_num(float(g.ap.max()))} mm, max RP {_num(float(g.rp.max()))} mm.</p>"
                     + _table(["pose id", "n", "AP (mm)", "APx", "APy", "APz", "l&#772; (mm)",
                               "S<sub>l</sub> (mm)", "RP (mm)"], rows, left=0))
    if not parts:
        return ""
    return ("<p>Repeated measurements of one commanded pose (same pose id and joints): AP is the distance "
            "from the barycentre of the measured positions to the commanded position (the calibrated "
            "model's prediction); RP = l&#772; + 3 S<sub>l</sub> with l the distances to the barycentre "
            "(ISO 9283 style; the standard asks for 30 cycles per pose).</p>" + "".join(parts))


def _history(result: dict) -> str:
    from robocal.report import plots

    hist = result.get("history") or []
    values = [h.get("rms") for h in hist]
    if len(hist) < 2 or not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
        return ""
    unit = (result.get("history_units") or {}).get("rms", "m")
    scale, label = (1e3, "RMS item error (mm)") if unit == "m" else (1.0, f"RMS item error ({esc(unit)})")
    it = np.asarray([h.get("iteration", k) for k, h in enumerate(hist)], dtype=int)
    return _figure(plots.history(it, np.asarray(values, float) * scale, label),
                   f"Solver history: the {label} of the best estimate per iteration "
                   f"({esc(result.get('method'))}).")


# ----------------------------------------------------------------- page
def render_report(result: dict, *, title: str | None = None) -> str:
    """The report of a calibration result dict as one self-contained HTML page (its figures need
    matplotlib: :mod:`robocal.report.plots` says so when it is missing)."""
    if not isinstance(result, dict):
        raise DataError("a report needs a calibration result (a JSON object)")
    robot = (result.get("robot") or {}).get("name", "robot")
    title = title or f"Calibration report: {robot}"
    obs = result.get("observations") or {}
    cal = _ObsErrors(obs)
    vobs = result.get("validation_observations")
    val = _ObsErrors(vobs) if vobs else None
    sections = [("summary", "Summary", _summary(result))]
    if cal.ok:
        sections.append(("errors", "Errors before and after", _errors_section(cal, val)))
    sections.append(("parameters", "Parameters", _parameters(result)))
    selection = _model_selection(result.get("model_selection"))
    if selection:
        sections.append(("model-selection", "Error model selection", selection))
    sections.append(("identifiability", "Identifiability and observability", _identifiability(result)))
    corr = _correlation(result)
    if corr:
        sections.append(("correlation", "Parameter correlation", corr))
    if result.get("rejected") or ("rejected" in result and result.get("method") == "robust"):
        sections.append(("rejected", "Rejected observations", _rejected(result)))
    iso = _iso([("calibration set", cal), ("validation set", val)])
    if iso:
        sections.append(("iso9283", "Pose accuracy and repeatability (ISO 9283)", iso))
    hist = _history(result)
    if hist:
        sections.append(("history", "Solver history", hist))
    data = result.get("data") or {}
    subtitle = f"{esc(data.get('file'))} &middot; method {esc(result.get('method'))}"
    return page(title, subtitle, sections, result.get("robocal_version"))


def page(title: str, subtitle: str, sections: list[tuple[str, str, str]], version) -> str:
    """One self-contained HTML page (inline CSS, a CSP that forbids loading anything) with a
    navigation bar over ``sections`` (id, heading, pre-escaped content); ``title`` is escaped
    here, ``subtitle`` must be escaped by the caller."""
    nav = "".join(f'<a href="#{sid}">{name}</a>' for sid, name, _ in sections)
    body = "".join(f'<section id="{sid}"><h2>{name}</h2>{content}</section>'
                   for sid, name, content in sections)
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
            "style-src 'unsafe-inline'; img-src data:\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)}</title><style>{_CSS}</style></head><body><main>"
            f"<h1>{esc(title)}</h1><p class='sub'>{subtitle} &middot; lengths in mm, angles in deg</p>"
            f"<nav>{nav}</nav>{body}<p class='note'>Generated by robocal {esc(version)}.</p>"
            "</main></body></html>\n")


def write_report(result: dict, path, *, title: str | None = None) -> Path:
    """Render the report and write it to ``path`` atomically; returns the path."""
    path = Path(path)
    write_atomic(path, render_report(result, title=title))
    return path
