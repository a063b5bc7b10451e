"""The report's section on the working conditions of a calibration with payload or thermal terms.

Rendered from the result's ``conditions`` section (docs/result-json.md; built by
:mod:`robocal.calibration.conditions`): the payloads and temperatures the calibration data covered
and T_ref, the thermal expansion coefficients (shared and per link group, with where each comes
from), the payload compliance per joint, the defaults the model assumes without a payload or a
temperature, and the terms not used. Every string from the result is escaped.
"""

from __future__ import annotations

from robocal.report.format import esc, table
from robocal.report.format import num as _num

SOURCES = {"own": "own (its deviation estimated)", "shared": "the shared k",
           "prior": "held at the prior mean"}  # where a link group's k comes from
TEXT_ENDS = "lrrl"  # the tables' alignment: a name, two numbers, a word


def _micro(value):
    """``value`` (1/K) in 1e-6/K; None stays None (a field the result lacks)."""
    return None if not isinstance(value, int | float) else value * 1e6


def _g(value) -> str:
    """A condition's value in 4 significant digits (escaped; '&ndash;' for a missing one)."""
    return f"{value:.4g}" if isinstance(value, int | float) and not isinstance(value, bool) else _num(value)


def _span(lo, hi, unit: str) -> str:
    return f"{_g(lo)}&ndash;{_g(hi)} {unit}" if lo != hi else f"{_g(lo)} {unit} only"


def _status(row: dict) -> str:
    """An estimate's status and why when it is not estimated (escaped)."""
    word, detail = esc(row.get("status")), esc(row.get("detail"))
    return f"{word} ({detail})" if detail else word


def section(result: dict) -> str:
    """The section's HTML (pre-escaped), or '' when the result has no ``conditions``."""
    c = result.get("conditions")
    if not isinstance(c, dict):
        return ""
    data = c.get("data") or {}
    rows = []
    payload, temperature = data.get("payload"), data.get("temperature")
    if payload:
        masses = payload.get("masses_kg")
        text = _span(payload.get("min_kg"), payload.get("max_kg"), "kg")
        if masses:
            text += " (" + ", ".join(_g(m) for m in masses) + " kg)"
        com = payload.get("centre_of_mass_mm")
        if com and com.get("min") == com.get("max"):
            text += "; centre of mass in the flange frame (" + ", ".join(_g(v) for v in com["min"]) + ") mm"
        elif com:
            text += "; centre of mass in the flange frame " + ", ".join(
                f"{axis} {_span(lo, hi, 'mm')}" for axis, lo, hi in zip("xyz", com.get("min") or [],
                                                                        com.get("max") or [], strict=False))
        rows.append(["payload", text])
    else:
        rows.append(["payload", "no payload_kg column"])
    rows.append(["temperature", _span(temperature.get("min_c"), temperature.get("max_c"), "&deg;C")
                 if temperature else "no temperature_c column"])
    unused = {row.get("term") for row in c.get("not_used") or []}
    if "thermal" in (c.get("terms") or []) and "thermal" not in unused:
        rows.append(["reference temperature T<sub>ref</sub>",
                     f"{_g(c.get('reference_temperature_c'))} &deg;C (the calibration data's mean)"])
    assumed = c.get("assumed") or {}
    said = []
    if "payload_kg" in assumed:
        said.append(f"no payload ({_g(assumed['payload_kg'])} kg) when none is given")
    if "temperature_c" in assumed:
        said.append(f"{_g(assumed['temperature_c'])} &deg;C (T<sub>ref</sub>) when no temperature "
                    "is given")
    if said:
        rows.append(["the model assumes", "; ".join(said)])
    out = ["<p>The payload and temperature terms hold for the conditions the calibration data covered: "
           "outside these ranges the model extrapolates.</p>", _rows(rows)]
    for row in c.get("not_used") or []:
        out.append(f"<p class='warn'><b>{esc(row.get('term'))} term not used:</b> "
                   f"{esc(row.get('reason'))}.</p>")
    k = c.get("thermal")
    if k and "thermal" not in unused:
        value = (f"{_num(_micro(k.get('k_per_K')), 3)} &plusmn; {_num(_micro(k.get('sigma_per_K')), 3)} "
                 "&times;10<sup>&minus;6</sup>/K") if k.get("sigma_per_K") is not None else _status(k)
        out.append("<h3>Thermal expansion</h3>" + _rows([["shared k (every link)", value]]))
    groups = c.get("thermal_groups")
    if groups and "thermal" not in unused:
        out.append(table(["link group", "k (10<sup>&minus;6</sup>/K)", "1&sigma;", "source"], [
            [esc(g.get("label") or g.get("group")), _num(_micro(g.get("k_per_K")), 3),
             _num(_micro(g.get("sigma_per_K")), 3), esc(SOURCES.get(g.get("source"), g.get("source")))]
            for g in groups], align=TEXT_ENDS))
    loads = c.get("payload")
    if loads and "payload" not in unused:
        unit = esc(loads[0].get("unit"))
        out.append("<h3>Payload compliance</h3><p>Joint turn per kg m of the payload's gravity moment "
                   "about the joint (joint 1 is vertical: none).</p>" + table(
                       ["joint", f"compliance ({unit})", "1&sigma;", "status"],
                       [[esc(r.get("joint")), _num(r.get("estimate"), 4), _num(r.get("sigma"), 4), _status(r)]
                        for r in loads], align=TEXT_ENDS))
    return "".join(out)


def _rows(rows: list[list[str]]) -> str:
    """A two-column key / value table (cells pre-escaped)."""
    body = "".join(f"<tr><th class='l'>{a}</th><td class='l wrap'>{b}</td></tr>" for a, b in rows)
    return f"<div class='scroll'><table><tbody>{body}</tbody></table></div>"
