"""The report's account of the parameter priors: the scale of each prior group the fit used and
where it came from (the class default kept, estimated from the data, or given), what the data ask
for beyond it, and the estimated parameters their prior holds most (the result JSON's ``priors``
section, docs/result-json.md and docs/priors.md)."""

from __future__ import annotations

from robocal.report.format import esc, num, table

SOURCE_WORDS = {"fixed": "class default (the data do not ask for more)",
                "estimated": "widened: the data ask for it", "user": "given (--priors or the model file)"}


def section(result: dict) -> str | None:
    """The priors section (pre-escaped HTML), None for a result without group scales."""
    priors = result.get("priors") or {}
    groups = priors.get("groups") or {}
    if not groups:
        return None
    widened = any(g.get("source") == "estimated" for g in groups.values())
    gain = f" (here +{num(priors.get('evidence_gain_nats'), 1)} nats)" if widened else ""
    chosen = esc(priors.get("class_chosen_by"))
    text = (f"<p>Priors of the <b>{esc(priors.get('class'))}</b> class ({chosen}): "
            "each group's 1&sigma; scale starts from the class default and is widened only where the "
            f"evidence of the data rises by the threshold of docs/priors.md{gain}.</p>")
    rows = [[esc(name), f"{num(g.get('scale'), 3)} {esc(g.get('unit'))}", f"{num(g.get('default'), 3)} "
             f"{esc(g.get('unit'))}", esc(SOURCE_WORDS.get(g.get("source"), g.get("source")))]
            for name, g in groups.items()]
    out = text + table(["group", "scale (1&sigma;)", "class default", "source"], rows, align="lrrw")
    asked = priors.get("asked") or {}
    if asked:
        out += ("<p class='bad'>The data ask for wider priors than were used: "
                + ", ".join(f"{esc(g)} {num(v, 3)} {esc((groups.get(g) or {}).get('unit', ''))}".rstrip()
                            for g, v in asked.items())
                + f" (evidence +{num(priors.get('asked_gain_nats'), 1)} nats): see the warnings.</p>")
    for g in priors.get("at_bound") or []:
        out += f"<p class='bad'>The {esc(g)} scale reached the widening bound.</p>"
    leaning = priors.get("leaning") or {}
    if leaning:
        out += ("<p>Estimated parameters their prior holds (the prior's share of their information; the "
                "rest came from the data):</p>"
                + table(["parameter", "prior's share"],
                        [[esc(n), f"{100 * v:.0f} %"] for n, v in leaning.items()], align="lr"))
    return out
