"""Self-contained HTML calibration report from a result dict (docs/result-json.md).

One file, no network access when opened: styles inline, figures inline SVG (matplotlib), no
JavaScript, and a Content-Security-Policy that forbids loading anything. Every string that
comes from the user's files is escaped. Optional parts of the result (validation, rejected
observations, measured points, repeated poses, history) add sections when present.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import write_atomic
from robocal.report.format import esc, joint_columns, p_value
from robocal.report.format import num as _num
from robocal.report.format import table as _table
from robocal.report.iso9283 import pose_accuracy_repeatability
from robocal.report.verdict import held_parameters, verdict_box

MAX_3D_POINTS = 4000
MAX_CORRELATION_NAMES = 24  # a larger heat map's labels cannot be read at the page's width
WORST = 10

_CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;color:#222;
 margin:0;background:#f6f7f9}
main{max-width:1400px;margin:0 auto;padding:20px 28px 48px;background:#fff}
h1{font-size:24px;margin:0 0 4px}h2{font-size:18px;margin:28px 0 8px;border-bottom:2px solid #1b9e77;
 padding-bottom:3px}h3{font-size:15px;margin:14px 0 6px}
.sub{color:#666;margin:0 0 12px}nav{margin:8px 0 12px;font-size:13px}nav a{margin-right:12px;color:#1b6e5a}
table{border-collapse:collapse;margin:6px 0 12px;font-size:13px}
th,td{padding:3px 6px;border-bottom:1px solid #e3e3e3;text-align:right;white-space:nowrap}
th{background:#f0f2f4;font-weight:600}td.l,th.l{text-align:left}td.wrap{white-space:normal;min-width:8em}
td.l:first-child{white-space:normal}
tr.dropped td{background:#fff4e5}tr.chosen td{background:#e8f4ea;font-weight:600}
.lead{font-size:16px;margin:4px 0 10px}.lead b{font-size:17px}
.kpi{display:flex;gap:12px;flex-wrap:wrap;margin:10px 0}
.kpi div{border:1px solid #dde;border-radius:6px;padding:8px 14px;min-width:150px}
.kpi b{display:block;font-size:22px}.kpi span{color:#666;font-size:12px}
.kpi div.main{border:2px solid #1b9e77}
.verdict{border:2px solid #1b9e77;border-radius:8px;padding:4px 16px;margin:8px 0 14px}
.verdict h3{margin:8px 0 4px}.verdict p{margin:4px 0}.verdict.care{border-color:#e6a700}
.verdict.bad{border-color:#d95f02;background:#fff4e5}
.good{color:#1b9e77}.bad{color:#d95f02}.warn{background:#fff4e5;border-left:4px solid #d95f02;
 padding:6px 10px;margin:6px 0}
figure{margin:4px 0 10px;max-width:780px}.grid figure{max-width:none}figure svg{width:100%;height:auto}
figcaption{color:#555;font-size:12px}figcaption b{color:#222}
.grid{display:grid;grid-template-columns:repeat(auto-fit,minmax(min(560px,100%),1fr));gap:8px 28px;
 align-items:start}
.grid>*{min-width:0}.scroll{max-width:100%;overflow-x:auto}section.narrow>figure{max-width:680px}
.note{color:#666;font-size:12px}td code{white-space:pre-wrap;word-break:break-all}.printonly{display:none}
@media (max-width:600px){main{padding:12px 10px 32px}.kpi div{min-width:0;flex:1 1 40%}
 table{font-size:12px}th,td{padding:2px 4px}
 figure{overflow-x:auto}figure svg{min-width:520px}}
@page{size:A4;margin:10mm 10mm 11mm}
@media print{body{background:#fff;font-size:8.5pt;line-height:1.3}main{padding:0;max-width:none}
 h1{font-size:14pt}h2{font-size:11.5pt;margin:10px 0 4px}h3{font-size:9.5pt;margin:6px 0 3px}
 h1,h2,h3{break-after:avoid;page-break-after:avoid}h2+*,h3+*{break-before:avoid;page-break-before:avoid}
 nav,.kpi,.noprint,figcaption .look{display:none}.printonly{display:block}
 .sub{margin:0 0 6px}.lead{font-size:9pt;margin:1px 0 3px}.lead b{font-size:9pt}
 .verdict{padding:0 10px;margin:4px 0 6px;break-inside:avoid}.verdict h3{margin:4px 0 2px}
 .verdict p{margin:1px 0}.warn{padding:2px 6px;margin:2px 0;break-inside:avoid}
 .grid{grid-template-columns:1fr 1fr;gap:2px 14px}.grid .grid{grid-template-columns:1fr}
 .grid>:only-child{grid-column:1/-1}
 figure{margin:2px 0 4px;max-width:none;break-inside:avoid}figcaption,.note{font-size:7.5pt}
 section.narrow>figure{max-width:none}
 table{font-size:7.5pt;margin:3px 0 6px}th,td{padding:1px 3px;white-space:normal}td.wrap{min-width:0}
 .keep{break-inside:avoid}
 thead{display:table-header-group}tr{break-inside:avoid}.scroll{overflow:visible}}
"""


SCREEN_FIGURE = "<figure class='noprint'"  # how a figure left out of a print starts


def _figure(svg: str, caption: str, look: str | None = None, *, screen_only: bool = False) -> str:
    """A figure with its caption, led by one line saying what to look for (pre-escaped text);
    ``screen_only``: left out of the printed page (a 3-D view, a map one reads by hovering)."""
    lead = f"<span class='look'><b>Look for:</b> {look} </span>" if look else ""
    start = SCREEN_FIGURE if screen_only else "<figure"
    return f"{start}>{svg}<figcaption>{lead}{caption}</figcaption></figure>"


def _grid(*parts: str) -> str:
    """Blocks side by side where the page is wide enough (one column on a narrow screen)."""
    cell = {True: "<div class='noprint'>", False: "<div>"}  # a screen-only figure leaves no hole on paper
    cells = "".join(f"{cell[p.startswith(SCREEN_FIGURE)]}{p}</div>" for p in parts if p)
    return f"<div class='grid'>{cells}</div>"


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
                "plane": "distance to fitted plane (mm)",
                "flush": "flush contact error: height and rim lifts (mm)",
                "distance": "error of the pair's distance (mm)"}


class _ObsErrors:
    """Per-observation errors (mm) of one observation block, before and after."""

    def __init__(self, obs: dict, result: dict) -> None:
        self.before_pts = _array(obs, "model_before", 3)
        self.after_pts = _array(obs, "model_after", 3)
        self.measured = _array(obs, "measured", 3)
        n = next((len(obs[k]) for k in ("error_after", "model_after", "error_before", "measured")
                  if obs.get(k) is not None), 0)  # rows (one length: robocal.core.schema checks it)
        self.joints = _array(obs, "joints_deg")  # deg; mm on a prismatic joint
        self.joint_names = None if self.joints is None or self.joints.ndim != 2 else \
            joint_columns(result, self.joints.shape[1])  # (name, unit) of each
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


def error_model(result: dict) -> tuple[str, str]:
    """The error model in words and how it was chosen (both pre-escaped)."""
    ng, ms = result.get("nongeometric") or {}, result.get("model_selection") or {}
    terms = ng.get("terms") or ms.get("chosen_terms") or []
    name = ("MDH + beta with joint errors: " + esc(", ".join(terms))) if terms else "geometric (MDH + beta)"
    if ms.get("candidates"):
        how = f"chosen by cross-validation among {len(ms['candidates'])} models (auto)"
    elif terms:
        how = "as named in the settings"
    else:
        how = "joint errors not modelled"
    return name, how


def _headline(result: dict) -> tuple[str, dict, dict, bool]:
    """``(what, after, before, held_out)``: the accuracy to quote, held out when there is a
    validation set, else the calibration set's without rejected observations."""
    val = result.get("validation") or {}
    if val.get("rms") is not None:
        return f"held out ({_num(val.get('n'))} validation observations)", val, \
            result.get("validation_before") or {}, True
    after = result.get("after_inliers") or result.get("after") or {}
    return "on the calibration set", after, result.get("before") or {}, False


def _lead(result: dict) -> str:
    """The summary's first lines: error model, headline accuracy, warnings."""
    name, how = error_model(result)
    what, after, before, held_out = _headline(result)
    warnings = result.get("warnings") or []
    lines = [f"Error model: <b>{name}</b> <span class='note'>({how})</span>"]
    if after.get("rms") is not None:
        start = f" (before calibration {_num(before.get('rms'))} mm)" if before.get("rms") is not None else ""
        caveat = "" if held_out else (" <span class='bad'>&mdash; no validation set: this is the fit's own "
                                      "error, optimistic; judge on poses the fit did not see</span>")
        lines.append(f"Accuracy {what}: <b class='good'>{_num(after['rms'])} mm RMS</b>{start}, "
                     f"max {_num(after.get('max'))} mm, p95 {_num(after.get('p95'))} mm{caveat}")
    from robocal.report.trust import headline

    lines += headline(result)
    if "converged" in result and not result.get("converged"):
        lines.append("<b class='bad'>The solver did not converge</b>: "
                     f"{esc(result.get('status'))}, {esc(result.get('message'))}")
    held = held_parameters(result)
    kept = f"{len(held)} parameter(s) held at nominal (see Parameters)" if held else ""
    if warnings:  # the count coloured by what it says: orange only when there is one to read
        lines.append(f"<b class='bad'>{len(warnings)} warning(s)</b>" + (f" and {kept}" if kept else "")
                     + ", read them before the numbers:")
    else:
        lines.append(f"<b class='good'>0 warnings</b>; {kept}: read them before the numbers." if kept
                     else "No warnings.")
    out = "".join(f"<p class='lead'>{line}</p>" for line in lines)
    out += "".join(f"<div class='warn'>{esc(w)}</div>" for w in warnings)
    return out


def _kpis(result: dict) -> str:
    b, a = result.get("before") or {}, result.get("after") or {}
    a_in = result.get("after_inliers")
    cards = []
    for label, s0, s1, main in (("validation RMS (held out)", result.get("validation_before"),
                                 result.get("validation"), True),
                                ("calibration RMS" + (", inliers" if a_in else ""), b, a_in or a, False)):
        if s1 and s1.get("rms") is not None:
            gain = ""
            if s0 and s0.get("rms"):
                gain = f" &middot; {100 * (1 - s1['rms'] / s0['rms']):.0f}% lower"
            start = f"before {_num(s0.get('rms'))} mm{gain}" if s0 else ""
            cls = " class='main'" if main else ""
            cards.append(f"<div{cls}><span>{label}</span><b class='good'>{_num(s1['rms'])} mm</b>"
                         f"<span>{start}</span></div>")
    headline = a_in or a  # rejected observations are not the robot's accuracy
    if headline.get("max") is not None:
        cards.append(f"<div><span>calibration max{', inliers' if a_in else ''}</span>"
                     f"<b>{_num(headline['max'])} mm</b><span>before {_num(b.get('max'))} mm</span></div>")
    return f"<div class='kpi'>{''.join(cards)}</div>"


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
             ("joints", esc(robot.get("n_joints"))),
             ("data set", f"{esc(data.get('file'))} ({esc(data.get('kind'))})"),
             ("poses / observations", f"{esc(data.get('n_poses'))} / {esc(n_obs)}"),
             ("observations used / rejected", f"{esc(used)} / {esc(n_rej)}"),
             ("validation set", esc(data.get("validation_file")) if data.get("validation_file") else "none"),
             ("method", esc(result.get("method"))),
             *_instruments(prov, result.get("variance_components") or []),
             *_provenance(prov),
             ("settings", ", ".join(f"{esc(k)}={esc(v)}" for k, v in settings.items()) or "&ndash;")]
    if "converged" in result or "message" in result:
        state = "converged" if result.get("converged") else "<b class='bad'>not converged</b>"
        facts.append(("solver", f"{state} ({esc(result.get('status'))}: {esc(result.get('message'))})"))
    facts.append(("robocal", esc(result.get("robocal_version"))))
    b, a = result.get("before") or {}, result.get("after") or {}
    rows = [r for r in (_stats_row("calibration set, before", b), _stats_row("calibration set, after", a),
                        _stats_row("calibration set, after, rejected left out", result.get("after_inliers")),
                        _stats_row("validation set, before", result.get("validation_before")),
                        _stats_row("validation set, after", result.get("validation"))) if r]
    stats = ("<h3>Before and after calibration</h3>"
             + _table(["", "n", "RMS (mm)", "mean (mm)", "max (mm)", "p95 (mm)"], rows))
    provenance = "<h3>Where these numbers come from</h3>" + _table(
        ["", ""], [[f"<b>{k}</b>", v] for k, v in facts], align="lw")
    return (verdict_box(result) + _lead(result) + _grid(_kpis(result) + stats, provenance)
            + _per_file(result))


_KIND_ERROR = {"point": "position", "pose": "position", "plane": "distance to the plane",
               "flush": "flush contact error", "distance": "distance error", "marker": "marker position",
               "eye_to_hand": "board position", "eye_in_hand": "board position"}


def _instruments(prov: dict, components: list[dict]) -> list[tuple[str, str]]:
    """The instruments of the calibration files and the 6-D noise estimated from them (pre-escaped
    rows; none when no file declares an instrument)."""
    rows = []
    named = [i for i in prov.get("instruments") or [] if i]
    if named:
        rows.append(("instrument", esc(", ".join(dict.fromkeys(named)))))
    for c in components:
        rows.append(("6-D noise (variance components)",
                     f"{_num(c.get('sigma_position_mm'))} mm, {_num(c.get('sigma_rotation_deg'))} deg "
                     "per axis "
                     f"<span class='note'>{esc(c.get('data'))}; {esc(c.get('rounds'))} fits"
                     f"{'' if c.get('settled') else ', not settled'}</span>"))
    return rows


def _per_file(result: dict) -> str:
    """Statistics per measurement file and per kind when a calibration used several files."""
    files = result.get("per_file") or []
    roles = [f.get("role") for f in files]
    if max(roles.count("calibration"), roles.count("validation"), 0) < 2:  # the statistics table says it
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
            + _table(["", "kind", "error", "file", "RMS before", "RMS after", "max after", "n"], rows,
                     align="lllwrrrr") + _validation_shifts(result.get("validation_shifts") or {})
            + "<h3>Per kind, after calibration</h3>" + _table(["", "RMS (mm)", "max (mm)", "n"], kinds))


def _validation_shifts(shifts: dict) -> str:
    """The held-out error split into a shift per validation file and the error within the files."""
    if shifts.get("rms_mm") is None:
        return ""
    p = shifts.get("p_value")
    verdict = ("<b class='bad'>the files are shifted from each other</b>: the tracker or the base set up "
               "again between sessions, the arm at another temperature, or an error of the model constant "
               "over a file's poses" if shifts.get("significant") else "no shift per file beyond the scatter")
    rows = [[esc(f.get("file")), esc(f.get("poses")), *(_num(v) for v in f.get("shift_mm") or [])]
            for f in shifts.get("files") or []]
    return (f"<p>Of the held-out {_num(shifts['rms_mm'])} mm RMS (per pose), a shift common to each "
            f"validation file carries {_num(shifts.get('shift_rms_mm'))} mm and the error within the files "
            f"is {_num(shifts.get('within_rms_mm'))} mm (F test p = {p_value(p)}): {verdict}.</p>"
            + _table(["validation file", "poses", "shift x (mm)", "shift y (mm)", "shift z (mm)"], rows,
                     align="wrrrr"))


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

    sorted_fig = _figure(
        plots.sorted_errors(cal.before, cal.after, cal.label),
        f"Per-observation {esc(cal.label)} on the calibration set, before (nominal model) and after "
        "calibration, each sorted from the largest.",
        "a low, flat &lsquo;after&rsquo; curve; a few tall bars at the left are single bad "
        "observations (outliers, a knocked reflector).")
    series = [("calibration, before", cal.before, plots.BEFORE),
              ("calibration, after", cal.after, plots.AFTER)]
    if val is not None and val.ok:
        series.append(("validation, after", val.after, plots.VALIDATION))
    shares = len({len(v) for _, v, _ in series}) > 1
    dist_fig = _figure(
        plots.distribution(series, cal.label, shares=shares),
        "Histogram "
        + ("as the share of each set per bin (the sets differ in size)" if shares else "(counts)")
        + " and cumulative share of observations below an error (dashed line: 95 %).",
        "the validation curve close to the calibration one: far to its right, the model does not carry "
        "over to poses it was not fitted on; a long right tail means outliers." if val is not None and val.ok
        else "a narrow &lsquo;after&rsquo; distribution; a long right tail means outliers.")
    figs = [sorted_fig, dist_fig]
    if cal.joints is not None and cal.joints.ndim == 2 and len(cal.joints) == len(cal.after):
        figs.append(_figure(
            plots.error_vs_joints(cal.joints, cal.after, cal.label, rejected=cal.rejected,
                                  joints=cal.joint_names),
            "Error after calibration against each joint angle (linear scale); the line is the mean of "
            f"{plots.JOINT_BINS} groups of equally many observations, in the order of the joint's angle.",
            "a trend, wave or step of the line: an effect of that joint the model lacks (compliance, "
            "gear or cyclic errors, backlash); a flat line at the noise level is what a good model leaves."))
    pts = cal.measured if cal.measured is not None else cal.after_pts
    if pts is not None:
        figs += _points_figures(cal, pts)
    figs.append(_worst_table(cal))
    return _grid(*figs)


def _points_figures(cal: _ObsErrors, pts: np.ndarray) -> list[str]:
    """The 3-D view coloured by the error after, and the worst residual vectors."""
    from robocal.report import plots

    figs = []
    idx = _subsample(len(pts))
    note = "" if idx.size == len(pts) else f" ({idx.size} of {len(pts)} points shown)"
    what = "measured points" if cal.measured is not None else "modelled probe-tip points (no measured points)"
    rejected = ("; rejected observations (robust) are marked &times; and left out of the colour scale"
                if cal.rejected.any() else "")
    figs.append(_figure(plots.points_3d(pts[idx], cal.after[idx], f"after: {cal.label}", cal.rejected[idx]),
                        f"3-D view of the {what} coloured by the residual after calibration{note}{rejected}.",
                        "regions of large residuals (yellow): where the model is weakest, often at the "
                        "edge of the measured workspace.", screen_only=True))
    if cal.vectors is not None:
        worst = np.argsort(np.where(cal.rejected, -np.inf, -cal.after), kind="stable")[:WORST]
        figs.append(_figure(plots.worst_vectors(pts[idx], cal.vectors, worst),
                            f"Residual vectors (measured &minus; calibrated model) of the {worst.size} "
                            "worst observations that were not rejected, magnified (the title says by how "
                            "much).",
                            "arrows pointing the same way: a systematic error is left; random directions "
                            "are noise.", screen_only=True))
    return figs


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


# A parameter's status in the result -> (row class, how the table shows it). A status not listed
# here is shown as it is, without highlighting; a new status needs one entry.
PARAMETER_STATUS = {"estimated": ("", "estimated"), "fixed": ("", "fixed"),
                    "dropped": ("dropped", "not identifiable"),
                    "not determined": ("dropped", "not determined by these data"),
                    "not identifiable": ("dropped", "not identifiable"),
                    "not determined by these data": ("dropped", "not determined by these data"),
                    "not used": ("dropped", "not used")}


def _status(p: dict):
    """A parameter row's status: its ``identification`` word when the result has it, else ``status``."""
    return p.get("identification") or p.get("status")


def _note(p: dict, dropped: dict) -> str:
    """Why a parameter is not estimated: its confounders or the reason given (pre-escaped)."""
    d = dropped.get(p.get("name"))
    if not d:
        return ""
    conf = d.get("confounded_with")
    return "confounded with " + ", ".join(esc(c) for c in conf) if conf else esc(d.get("reason"))


# column -> (header, alignment, cell of a parameter dict given the dropped table; pre-escaped)
PARAMETER_COLUMNS = {
    "name": ("name", "l", lambda p, d: esc(p.get("name"))),
    "status": ("status", "l", lambda p, d: esc(PARAMETER_STATUS.get(_status(p), ("", _status(p)))[1])),
    "unit": ("unit", "l", lambda p, d: esc(p.get("unit"))),
    "nominal": ("nominal", "r", lambda p, d: _num(p.get("nominal"), _unit_digits(p.get("unit")))),
    "estimate": ("estimate", "r", lambda p, d: _num(p.get("estimate"), _unit_digits(p.get("unit")))),
    "correction": ("correction", "r", lambda p, d: _num(p.get("correction"), _unit_digits(p.get("unit")))),
    "sigma": ("1&sigma;", "r", lambda p, d: _num(p.get("sigma"), _unit_digits(p.get("unit")))),
    "note": ("note", "w", _note),
}
GEOMETRY_COLUMNS = ("name", "status", "unit", "nominal", "estimate", "correction", "sigma", "note")
JOINT_ERROR_COLUMNS = ("name", "status", "unit", "estimate", "sigma", "note")


def _parameter_table(params: list[dict], dropped: dict, columns: tuple[str, ...]) -> str:
    """One row per parameter dict, the ``columns`` of :data:`PARAMETER_COLUMNS`, rows of the
    statuses :data:`PARAMETER_STATUS` highlights marked."""
    spec = [PARAMETER_COLUMNS[c] for c in columns]
    rows = [[cell(p, dropped) for _, _, cell in spec] for p in params]
    classes = [PARAMETER_STATUS.get(_status(p), ("", ""))[0] for p in params]
    return _table([h for h, _, _ in spec], rows, row_class=classes, align="".join(a for _, a, _ in spec))


def _joint_error_names(result: dict) -> set[str]:
    ng = result.get("nongeometric") or {}
    return {str(n) for n in (ng.get("kept") or []) + (ng.get("dropped") or [])}


def _parameters(result: dict) -> str:
    params = result.get("parameters") or []
    if not params:
        return "<p>No parameter table in this result.</p>"
    dropped = {d.get("name"): d for d in result.get("dropped") or []}
    joint = _joint_error_names(result)
    geometry = [p for p in params if p.get("name") not in joint]
    n_est = sum(p.get("status") == "estimated" for p in geometry)
    n_not = sum(p.get("name") in dropped for p in geometry)
    text = (f"<p>Geometry, frames and reflectors: {n_est} parameters estimated, {n_not} not identifiable "
            "or not determined by these data (kept at their start value, highlighted: never read their "
            "value as measured). Correction = estimate &minus; nominal; 1&sigma; from the posterior "
            "covariance of the estimate (with the parameter priors: see the priors page of the "
            "documentation): a correction of the order of its 1&sigma; is noise.</p>")
    return _grid(text + _parameter_table(geometry, dropped, GEOMETRY_COLUMNS),
                 _nongeometric(result.get("nongeometric"), [p for p in params if p.get("name") in joint],
                               dropped))


def _nongeometric(ng: dict | None, params: list[dict], dropped: dict) -> str:
    """The joint-error terms' parameters (their display units), shown here and only here."""
    if not ng or not params:
        return ""
    n_unused = sum(_status(p) == "not used" for p in params)
    n_out = sum(p.get("name") in dropped for p in params) - n_unused
    return (f"<h3>Joint errors: {esc(', '.join(ng.get('terms', [])))}</h3>"
            "<p>Errors the model adds to the commanded joints: compliance (per metre of unit-weight "
            "moment arm), gear harmonics, backlash (half lost motion, by approach direction), travel "
            "(error per degree of the joint's last move) and cyclic errors "
            "(named cyc, the joint, then the cycles per revolution: <code>cyc3_2</code> is joint 3, twice "
            "per turn). "
            f"{n_out} term(s) the data cannot separate from the geometry were left out (highlighted)"
            + (f"; {n_unused} not used: the data do not vary their condition" if n_unused else "") + ".</p>"
            + _parameter_table(params, dropped, JOINT_ERROR_COLUMNS))


def _model_selection(ms: dict | None) -> str:
    """The candidate error models with their cross-validated error, and the choice."""
    if not ms or not ms.get("candidates"):
        return ""
    cands = ms["candidates"]
    order = sorted(range(len(cands)), key=lambda i: _or(cands[i].get("cv_rms_mm"), np.inf))
    rows, classes = [], []
    for i in order:
        c = cands[i]
        best = "lowest winsorized CV error" if i == ms.get("best") else ""
        mark = "chosen" if i == ms.get("chosen") else best
        rows.append([esc(", ".join(c.get("terms") or []) or "geometric"), esc(mark), _num(c.get("n_params")),
                     _num(c.get("cv_rms_mm"), 4), _num(c.get("cv_se_mm"), 4),
                     _num(c.get("cv_robust_rms_mm"), 4), _num(c.get("cv_paired_se_mm"), 4),
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
                          "winsorized CV RMS (mm)", "paired SE (mm)", "fit RMS (mm)"], rows, left=2,
                         row_class=classes)


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
    freedoms = ident.get("structural_freedoms") or []  # a SCARA's (robocal.identify.freedoms)
    if freedoms:
        out += ("<h3>Structural freedoms of a SCARA</h3><p>The robot's structure, not the poses: no "
                "campaign separates these; each is estimated once and the rest held at nominal.</p>"
                + _table(["freedom", "held at nominal", "carried by"],
                         [[esc(f.get("words")), esc(", ".join(f.get("held") or [])),
                           esc(", ".join(f.get("carried_by") or [])) or "&ndash;"] for f in freedoms],
                         align="www"))
    if not dropped:
        return out
    return _grid(out, "<h3>Parameters not estimated</h3>"
                 "<p><b>not identifiable</b>: exactly confounded with the parameters or frame named (or "
                 "without effect; a joint-error term also when nearly so): held at nominal, they absorb "
                 "it. <b>not determined by these data</b>: "
                 "held near nominal by its prior (posterior &sigma; over half the prior's): more or other "
                 "poses would determine it. <b>not used</b>: the data do not vary the condition it needs.</p>"
                 "<p class='printonly note'>Each one's confounders: the note column of the Parameters "
                 "table.</p><div class='noprint'>"
                 + _table(["parameter", "status", "reason", "confounded with"],
                          [[esc(d.get("name")), esc(d.get("status") or "held at nominal"),
                            esc(d.get("reason")), esc(", ".join(d.get("confounded_with") or [])) or "&ndash;"]
                           for d in dropped],
                          align="llww") + "</div>")


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
    return _grid(_figure(plots.correlation([str(names[i]) for i in shown], m[np.ix_(shown, shown)]),
                         "Correlation of the estimated parameters "
                         f"(1: fully correlated, &minus;1: anti-correlated).{note}",
                         "dark red or blue cells off the diagonal: the data barely separate those two "
                         "parameters, so each one's value is uncertain even where their joint effect is "
                         "well determined.", screen_only=True),
                 "<h3>Strongest correlations</h3>" + _table(["parameter", "parameter", "correlation"], rows,
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


START_MISMATCH = 0.01  # relative difference of the history's first RMS and "before" worth explaining


def _history(result: dict) -> str:
    from robocal.report import plots

    hist = result.get("history") or []
    values = [h.get("rms") for h in hist]
    if len(hist) < 2 or not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
        return ""
    unit = (result.get("history_units") or {}).get("rms", "m")
    scale, label = (1e3, "RMS item error (mm)") if unit == "m" else (1.0, f"RMS item error ({esc(unit)})")
    it = np.asarray([h.get("iteration", k) for k, h in enumerate(hist)], dtype=int)
    rms = np.asarray(values, float) * scale
    before = (result.get("before") or {}).get("rms")
    comparable = unit == "m" and (result.get("data") or {}).get("kind") == "point" and before is not None
    start = ""
    if comparable and abs(rms[0] - before) > START_MISMATCH * before:
        warm = "model_selection" in result and result.get("method") == "lsq"
        start = (f" It starts at {_num(float(rms[0]))} mm, not at the error before calibration "
                 f"({_num(before)} mm, dashed line): "
                 + ("with the auto error model the chosen model's fit starts from the largest candidate "
                    "model's estimate, which the selection already fitted." if warm else
                    "the solver started from an estimate, not from the nominal model."))
    else:
        before = None
    return _figure(plots.history(it, rms, label, before=before),
                   f"Solver history: the {label} of the best estimate per iteration "
                   f"({esc(result.get('method'))}).{start}",
                   "a fall that levels off; a curve still falling at the last iteration means the solve "
                   "stopped early.")


# ----------------------------------------------------------------- page
def render_report(result: dict, *, title: str | None = None) -> str:
    """The report of a calibration result as one self-contained HTML page.

    No script, no network: the figures are inline SVG (they need matplotlib, the ``report``
    extra), and every string from the user's files is escaped.

    Parameters
    ----------
    result : dict
        A calibration result as `CalibrationResult.to_dict` gives it (or as read from the
        ``--json`` file of ``robocal calibrate``).
    title : str, optional
        The page's title (default: "Calibration report: " and the robot's name).

    Returns
    -------
    str
        The HTML page.

    Raises
    ------
    DataError
        ``result`` is not a calibration result (or a field of it is malformed, named).

    See Also
    --------
    robocal.report.html.write_report : Write it to a file.
    rc.CalibrationResult : What the report shows.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> result = rc.calibrate(robot, rc.simulate_tracker(robot, 40, seed=2).data)
    >>> from robocal.report.html import render_report
    >>> page = render_report(result.to_dict())
    >>> page.startswith("<!DOCTYPE html>"), "<script" in page
    (True, False)
    """
    if not isinstance(result, dict):
        raise DataError("a report needs a calibration result (a JSON object)")
    robot = (result.get("robot") or {}).get("name", "robot")
    title = title or f"Calibration report: {robot}"
    obs = result.get("observations") or {}
    cal = _ObsErrors(obs, result)
    vobs = result.get("validation_observations")
    val = _ObsErrors(vobs, result) if vobs else None
    sections = [("summary", "Summary", _summary(result))]
    if cal.ok:
        sections.append(("errors", "Errors before and after", _errors_section(cal, val)))
    from robocal.report.trust import section

    accuracy = section(result)
    if accuracy:
        sections.append(("predicted-accuracy", "Predicted accuracy over the workspace", accuracy))
    sections.append(("parameters", "Parameters", _parameters(result)))
    from robocal.report.priors import section as priors_section

    if priors := priors_section(result):
        sections.append(("priors", "Parameter priors", priors))
    from robocal.report.conditions import section as conditions_section

    working = conditions_section(result)
    if working:
        sections.append(("conditions", "Payload and temperature", working))
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
    sections[0] = (*sections[0][:2], sections[0][2] + _print_note(sections))
    data = result.get("data") or {}
    named = (result.get("provenance") or {}).get("data_file") or data.get("file")  # its source: the table
    subtitle = (f"{esc(named)} &middot; error model {error_model(result)[0]} &middot; "
                f"method {esc(result.get('method'))}")
    narrow = {"identifiability", "rejected", "iso9283", "history", "priors"}  # their tables fit half
    return page(title, subtitle, sections, result.get("robocal_version"), frozenset(narrow),
                screen_only=SCREEN_ONLY)


# sections left out of the printed page (an A4 print is the summary to file and forward: the
# solver's history and the 3-D views are read on screen; `_print_note` says so on paper)
SCREEN_ONLY = frozenset({"history"})


def _print_note(sections: list[tuple[str, str, str]]) -> str:
    """A line shown only on paper: what the print leaves out and where it is."""
    left = [name.lower() for sid, name, _ in sections if sid in SCREEN_ONLY] + [
        "the 3-D views", "the correlation map"]
    return (f"<p class='printonly note'>Printed without {', '.join(left[:-1])} and {left[-1]}: "
            "open the HTML report for them.</p>")


def page(title: str, subtitle: str, sections: list[tuple[str, str, str]], version,
         narrow: frozenset[str] = frozenset(), screen_only: frozenset[str] = frozenset()) -> str:
    """One self-contained HTML page (inline CSS, a CSP that forbids loading anything) with a
    navigation bar over ``sections`` (id, heading, pre-escaped content); two consecutive sections
    whose ids are in ``narrow`` sit side by side on a wide screen (and on paper); the sections in
    ``screen_only`` are left out of a print. ``title`` is escaped here, ``subtitle`` must be
    escaped by the caller."""
    nav = "".join(f'<a href="#{sid}">{name}</a>' for sid, name, _ in sections)

    def classes(sid: str) -> str:
        names = [c for c, on in (("narrow", sid in narrow), ("noprint", sid in screen_only)) if on]
        return f' class="{" ".join(names)}"' if names else ""

    html_sections = [f'<section id="{sid}"{classes(sid)}><h2>{name}</h2>{content}</section>'
                     for sid, name, content in sections]
    body, k = [], 0
    while k < len(sections):
        if k + 1 < len(sections) and sections[k][0] in narrow and sections[k + 1][0] in narrow:
            body.append(f"<div class='grid'>{html_sections[k]}{html_sections[k + 1]}</div>")
            k += 2
        else:
            body.append(html_sections[k])
            k += 1
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
            "style-src 'unsafe-inline'; img-src data:\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)}</title><style>{_CSS}</style></head><body><main>"
            f"<h1>{esc(title)}</h1><p class='sub'>{subtitle} &middot; lengths in mm, angles in deg</p>"
            f"<nav>{nav}</nav>{''.join(body)}<p class='note'>Generated by robocal {esc(version)}.</p>"
            "</main></body></html>\n")


def write_report(result: dict, path, *, title: str | None = None) -> Path:
    """Render the report (see `render_report`) and write it to ``path`` atomically.

    Parameters
    ----------
    result : dict
        A calibration result (`CalibrationResult.to_dict`).
    path : str or pathlib.Path
        The HTML file to write; its folder must exist.
    title : str, optional
        The page's title.

    Returns
    -------
    pathlib.Path
        ``path``.

    See Also
    --------
    robocal.report.html.render_report : The HTML text, not written.
    rc.CalibrationResult : What the report shows.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.report.html import write_report
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> result = rc.calibrate(robot, rc.simulate_tracker(robot, 40, seed=2).data)
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> write_report(result.to_dict(), folder / "report.html").name
    'report.html'
    """
    path = Path(path)
    write_atomic(path, render_report(result, title=title))
    return path
