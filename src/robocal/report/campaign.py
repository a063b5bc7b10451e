"""Self-contained HTML page of a planned calibration campaign (``robocal poses --html``).

From the campaign dict (:meth:`robocal.campaign.CampaignResult.to_dict`): the summary (predicted
accuracy, noise, measuring travel, the candidates each constraint removed), the predicted
accuracy against the number of poses (figure and table), the identifiability of the chosen set,
the TCP positions in measuring order and the pose table. Same page rules as the calibration
report: inline CSS and SVG, no JavaScript, a CSP that forbids loading anything, every string
escaped.
"""

from __future__ import annotations

import numpy as np

from robocal.core.errors import DataError
from robocal.report.format import joint_columns
from robocal.report.html import _figure, _grid, _identifiability, _num, _table, esc, page


def _summary(c: dict) -> str:
    robot = c.get("robot") or {}
    noise = c.get("noise") or {}
    cand = c.get("candidates") or {}
    settings = c.get("settings") or {}
    noise_text = (f"isotropic, {_num(noise.get('sigma_mm'))} mm per axis" if noise.get("model") == "isotropic"
                  else "the tracker's anisotropic model")
    facts = [("robot", f"{esc(robot.get('name'))} <span class='note'>{esc(robot.get('description'))}</span>"),
             ("measurement", esc(c.get("kind"))),
             ("criterion", esc(c.get("criterion"))),
             ("noise", noise_text),
             ("SMRs on the flange (mm)", esc(settings.get("smr_mm"))),
             ("tracker (mm, robot base frame)", esc(settings.get("tracker_mm") or "not given")),
             ("measuring travel", f"{_num(c.get('travel'), 2)} (in the search's order "
                                  f"{_num(c.get('travel_unordered'), 2)}; weights "
                                  f"{esc(np.round(c.get('travel_weights') or [], 3).tolist())})"),
             ("settings", ", ".join(f"{esc(k)}={esc(v)}" for k, v in settings.items()
                                    if k not in ("smr_mm", "smr_normals", "tracker_mm")))]
    out = [f"<div class='kpi'><div><span>poses</span><b>{esc(c.get('n_poses'))}</b></div>"
           f"<div><span>predicted accuracy (RMS over the region)</span>"
           f"<b class='good'>{_num(c.get('predicted_rms_mm'))} mm</b></div></div>",
           _table(["", ""], [[f"<b>{k}</b>", v] for k, v in facts], left=2)]
    rows = [[esc(r.get("constraint")), esc(r.get("count"))] for r in cand.get("removed") or []]
    out.append("<h3>Candidate poses</h3>" + _table(
        ["", "poses"], [["drawn or read", esc(cand.get("candidates"))], *rows,
                        ["left", esc(cand.get("left"))]]))
    out += [f"<div class='warn'>{esc(w)}</div>" for w in c.get("warnings") or []]
    return "".join(out)


def _curve(c: dict) -> str:
    from robocal.report import plots

    curve = c.get("curve") or []
    if not curve:
        return ""
    n = np.array([p["n"] for p in curve], float)
    planned = np.array([p["predicted_rms_mm"] for p in curve], float)
    random = np.array([p["random_median_mm"] for p in curve], float)
    fig = _figure(plots.accuracy_curve(n, planned, random, c.get("n_poses")),
                  "Predicted RMS error of the calibrated model's TCP position over the region of interest "
                  "against the number of poses: planned poses and the median of random choices among the "
                  "same candidates. The dashed line marks the planned campaign.",
                  "where the planned curve flattens: more poses beyond it buy little accuracy; the gap "
                  "to the random curve is what planning gains.")
    rows = [[esc(int(k)), _num(float(a)), _num(float(b)), f"{float(b) / float(a):.2f}"]
            for k, a, b in zip(n, planned, random, strict=True)]
    return _grid(fig, _table(["poses", "planned (mm)", "random, median (mm)", "random / planned"], rows))


def _poses(c: dict) -> str:
    from robocal.report import plots

    q = np.asarray(c.get("joints_deg") or [], float)  # deg; mm on a prismatic joint
    tcp = np.asarray(c.get("tcp_mm") or [], float)
    if q.ndim != 2 or tcp.shape != (len(q), 3):
        raise DataError("a campaign page needs joints_deg (N, n) and tcp_mm (N, 3)")
    track = np.asarray(c.get("e1_mm") or [], float)  # an arm on a track: its carriage, written apart
    external = int(track.shape == (len(q),) and len(q) > 0)
    if external:
        q = np.column_stack([track, q])
    visible = np.asarray(c.get("visible") or np.ones((len(q), 1)), int)
    fig = _figure(plots.points_3d(tcp, np.arange(1, len(q) + 1, dtype=float), "measuring order"),
                  "TCP (first SMR) positions of the planned poses, coloured by measuring order.",
                  "poses spread over the whole region the robot will work in; a region without poses is "
                  "a region the calibration does not vouch for.")
    header = (["#"] + [f"{esc(name)} ({esc(unit)})" for name, unit in joint_columns(c, q.shape[1], external)]
              + ["x (mm)", "y (mm)", "z (mm)"])
    multi = visible.shape[1] > 1
    if multi:
        header.append("SMRs seen")
    rows = []
    for k in range(len(q)):
        row = [str(k + 1)] + [_num(float(v), 4) for v in q[k]] + [_num(float(v), 2) for v in tcp[k]]
        if multi:
            row.append(esc(" ".join(str(s) for s in np.flatnonzero(visible[k]))))
        rows.append(row)
    return fig + _table(header, rows)


def render_campaign(campaign: dict, *, title: str | None = None) -> str:
    """The page of a campaign dict as one self-contained HTML string (the figures need matplotlib:
    :mod:`robocal.report.plots` says so when it is missing)."""
    if not isinstance(campaign, dict) or "joints_deg" not in campaign:
        raise DataError("a campaign page needs a planned campaign (robocal poses --json)")
    robot = (campaign.get("robot") or {}).get("name", "robot")
    title = title or f"Calibration campaign: {robot}"
    sections = [("summary", "Summary", _summary(campaign))]
    curve = _curve(campaign)
    if curve:
        sections.append(("curve", "Accuracy against the number of poses", curve))
    sections += [("identifiability", "Identifiability of the chosen poses", _identifiability(campaign)),
                 ("poses", "Poses in measuring order", _poses(campaign))]
    subtitle = f"{esc(campaign.get('n_poses'))} {esc(campaign.get('kind'))} poses"
    return page(title, subtitle, sections, campaign.get("robocal_version"))
