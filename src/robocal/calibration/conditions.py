"""The working conditions of a calibration with payload or thermal terms, for its summary, JSON and report.

A model with the ``payload`` (:mod:`robocal.kinematics.load`) or ``thermal`` / ``thermal_groups``
(:mod:`robocal.kinematics.thermal`) terms is only as good as the conditions its data covered. The
result's ``conditions`` section says:

- ``data``: the payloads (kg, and the centre of mass in the flange frame, mm) and the arm
  temperatures (deg C) the calibration data recorded (null for a column the data do not have);
- ``reference_temperature_c``: T_ref, the calibration data's mean temperature, saved in the model;
- ``thermal``: the shared expansion coefficient k (1/K) with its 1-sigma and status; ``thermal_groups``:
  per link group its k and where it comes from (``own``: its deviation estimated; ``shared``: the
  shared k; ``prior``: held at the prior mean), with a 1-sigma (the posterior's, the prior's for
  ``prior``);
- ``payload``: each joint's payload compliance (urad of joint turn per kg m of payload moment) with
  its 1-sigma and status;
- ``assumed``: what the delivered model assumes when it is used without a payload (none, 0 kg) or a
  temperature (T_ref);
- ``not_used``: the terms named that the data cannot show (no column, or one value in every row).

Statuses are the words of :mod:`robocal.identify.vocabulary`.
"""

from __future__ import annotations

import numpy as np

from robocal.identify import vocabulary
from robocal.identify.priors import prior_sigma
from robocal.identify.space import block_of
from robocal.kinematics import load, thermal
from robocal.kinematics.conditions import range_of
from robocal.kinematics.joint_errors import CONDITION_TERMS, condition_terms, term_of

PAYLOAD_UNIT = "urad/(kg m)"  # the payload compliance's display unit: joint turn per kg m of payload moment
PAYLOAD_SCALE = 1e6  # rad -> urad
MAX_LISTED_PAYLOADS = 10  # distinct payload masses listed; more are a range only


def _is_condition(name: str) -> bool:
    return block_of(name) == "joint_errors" and (thermal.is_name(name) or term_of(name) in CONDITION_TERMS)


def _column(datasets, attr: str) -> np.ndarray | None:
    """The calibration data's rows of ``attr`` (``payload`` or ``temperature``), None when no set has it."""
    parts = [getattr(d, attr) for d in datasets if getattr(d, attr) is not None]
    return np.concatenate([np.asarray(p, float) for p in parts]) if parts else None


def not_used(datasets, names) -> dict[str, str]:
    """Of the declared parameters ``names``: each payload or thermal one the calibration data
    ``datasets`` cannot show, with why (no ``payload_kg`` column or no payload in any row; no
    ``temperature_c`` column or one temperature in every row)."""
    payload, temperature = _column(datasets, "payload"), _column(datasets, "temperature")
    why_payload = ("the calibration data have no payload_kg column" if payload is None else
                   "the payload_kg column is 0 kg in every row" if not np.any(payload[:, 0]) else None)
    why_thermal = ("the calibration data have no temperature_c column" if temperature is None else
                   f"the temperature_c column has one value ({temperature[0]:g} deg C)"
                   if np.ptp(temperature) == 0 else None)
    out = {}
    for nm in names:
        why = None if not _is_condition(nm) else why_thermal if thermal.is_name(nm) else why_payload
        if why:
            out[nm] = why
    return out


def section(result) -> dict | None:
    """The ``conditions`` section (module docstring) of a `robocal.calibration.result.CalibrationResult`,
    or None when its candidate parameters have no payload or thermal term."""
    ident = result.identifiability
    declared = [nm for nm in ident.names if _is_condition(nm)]
    if not declared:
        return None
    datasets = result.problem.datasets
    unused = not_used(datasets, declared)
    sigma = dict(zip(result.unknowns, result.sigma, strict=True))
    values = dict(zip(result.robot.parameter_names, result.robot.values, strict=True))
    start = result.initial.robot
    t_ref = float(start.joint_errors.reference_temperature_c)
    out = {"terms": sorted({"thermal" if thermal.is_name(nm) else "payload" for nm in declared},
                           key=CONDITION_TERMS.index),
           "data": _coverage(datasets), "reference_temperature_c": t_ref}
    if thermal.NAME in declared:
        out["thermal"] = {"k_per_K": float(values.get(thermal.NAME, 0.0)),
                          "sigma_per_K": None if thermal.NAME not in sigma else float(sigma[thermal.NAME]),
                          "status": vocabulary.status(thermal.NAME, ident, unused),
                          "detail": vocabulary.detail(thermal.NAME, ident, unused)}
    if any(nm in thermal.GROUP_NAMES for nm in declared):
        out["thermal_groups"] = _groups(result, values, sigma, start, declared)
    payload = [nm for nm in declared if term_of(nm) == "payload" and not load.is_lever(nm)]  # compliances
    if payload:
        out["payload"] = [{"name": nm, "joint": load.joint_of(nm, start.n_joints) + 1,
                           "estimate": float(values.get(nm, 0.0) * PAYLOAD_SCALE), "unit": PAYLOAD_UNIT,
                           "sigma": None if nm not in sigma else float(sigma[nm] * PAYLOAD_SCALE),
                           "status": vocabulary.status(nm, ident, unused),
                           "detail": vocabulary.detail(nm, ident, unused)} for nm in payload]
    levers = sorted({load.joint_of(nm, start.n_joints) + 1 for nm in declared if load.is_lever(nm)})
    if levers and not any(term_of(nm) == "payload" for nm in unused):  # the load's centre of mass
        delta = load.lever_correction({nm: values.get(nm, 0.0) for nm in declared}, levers)
        if delta is not None:
            out["payload_com_correction_mm"] = {"joints": levers,
                                                "xyz": (np.nan_to_num(delta) * 1e3).tolist()}
    used = condition_terms(result.robot)
    out["assumed"] = {**({"payload_kg": 0.0} if "payload" in used else {}),
                      **({"temperature_c": t_ref} if "thermal" in used else {})}
    out["not_used"] = [{"term": term, "reason": why} for term, why in
                       dict.fromkeys(("thermal" if thermal.is_name(nm) else "payload", why)
                                     for nm, why in unused.items())]
    return out


def _coverage(datasets) -> dict:
    """The payloads and temperatures the calibration rows recorded (the range the model keeps,
    :func:`robocal.kinematics.conditions.range_of`, with the distinct masses and centres of mass)."""
    covered = range_of([d.conditions for d in datasets])
    out: dict = {"payload": None, "temperature": None}
    if covered.payload_kg is not None:
        payload = _column(datasets, "payload")
        masses = np.unique(payload[:, 0])
        loaded = payload[payload[:, 0] > 0, 1:] * 1e3
        out["payload"] = {"min_kg": covered.payload_kg[0], "max_kg": covered.payload_kg[1],
                          "masses_kg": masses.tolist() if masses.size <= MAX_LISTED_PAYLOADS else None,
                          "centre_of_mass_mm": None if not len(loaded) else
                          {"min": loaded.min(axis=0).tolist(), "max": loaded.max(axis=0).tolist()}}
    if covered.temperature_c is not None:
        out["temperature"] = {"min_c": covered.temperature_c[0], "max_c": covered.temperature_c[1]}
    return out


def _groups(result, values: dict, sigma: dict, start, declared: list[str]) -> list[dict]:
    """Per link group: k (1/K), source (``own`` / ``shared`` / ``prior``), its 1-sigma and label."""
    names = result.unknowns
    cov = result.covariance
    rows = thermal.group_sources(values, set(names), start.prismatic)
    for row in rows:
        dev = f"{thermal.NAME}_{row['group']}"
        if row["source"] == "own":
            idx = [names.index(nm) for nm in (thermal.NAME, dev) if nm in names]
            s = float(np.sqrt(max(cov[np.ix_(idx, idx)].sum(), 0.0)))
        elif row["source"] == "shared":
            s = float(sigma[thermal.NAME])
        else:  # held at the prior mean: the prior's spread of the shared k and the group's deviation
            held = [nm for nm in (thermal.NAME, dev) if nm in declared]
            s = float(np.sqrt(np.sum(prior_sigma(start, held) ** 2)))
        row.update(label=thermal.GROUP_LABELS[row["group"]], sigma_per_K=s)
    return rows


def summary_lines(conditions: dict) -> list[str]:
    """The summary's lines of a ``conditions`` section: coverage and T_ref, the expansion
    coefficients, the payload compliances, the defaults assumed, the terms not used."""
    data, lines = conditions["data"], []
    cover = []
    if data["payload"] is not None:
        p = data["payload"]
        cover.append(f"payload {p['min_kg']:g}-{p['max_kg']:g} kg" + (
            f" ({', '.join(f'{m:g}' for m in p['masses_kg'])})" if p["masses_kg"] else ""))
    if data["temperature"] is not None:
        t = data["temperature"]
        cover.append(f"temperature {t['min_c']:g}-{t['max_c']:g} deg C")
    unused = {row["term"] for row in conditions["not_used"]}
    lines.append("working conditions of the calibration data: " + ("; ".join(cover) or "none recorded")
                 + (f"; T_ref {conditions['reference_temperature_c']:.4g} deg C"
                    if "thermal" in set(conditions["terms"]) - unused else ""))
    if (k := conditions.get("thermal")) is not None and "thermal" not in unused:
        lines.append("thermal expansion k (shared): " + _value(k["k_per_K"] * 1e6, k["sigma_per_K"], 1e6,
                                                               "1e-6/K", k))
    if conditions.get("thermal_groups") and "thermal" not in unused:
        what = {"own": "own", "shared": "the shared k", "prior": "held at the prior"}
        lines.append("thermal expansion per link group (1e-6/K): " + ", ".join(
            f"{r['label']} {r['k_per_K'] * 1e6:.3g} ± {r['sigma_per_K'] * 1e6:.2g} ({what[r['source']]})"
            for r in conditions["thermal_groups"]))
    if conditions.get("payload") and "payload" not in unused:
        lines.append(f"payload compliance ({PAYLOAD_UNIT}): " + ", ".join(
            f"J{r['joint']} " + _value(r["estimate"], r["sigma"], 1.0, "", r) for r in conditions["payload"]))
    if (com := conditions.get("payload_com_correction_mm")) is not None:
        lines.append("the load's centre of mass, as the payload term sees it (joints "
                     f"{', '.join(map(str, com['joints']))}): " + ", ".join(
                         f"{a} {v:+.0f}" for a, v in zip("xyz", com["xyz"], strict=True))
                     + " mm from the one recorded (flange frame)")
    assumed = conditions["assumed"]
    if assumed:
        said = (["no payload (0 kg) when none is given"] if "payload_kg" in assumed else []) + (
            [f"T_ref {assumed['temperature_c']:.4g} deg C when no temperature is given"]
            if "temperature_c" in assumed else [])
        lines.append("the model assumes " + " and ".join(said))
    for row in conditions["not_used"]:
        lines.append(f"{row['term']} term not used: {row['reason']}")
    return lines


def _value(value: float, sigma: float | None, f: float, unit: str, row: dict) -> str:
    """'v ± s unit' of an estimated parameter, else its status and detail."""
    if row["status"] != vocabulary.ESTIMATED:
        return f"{row['status']} ({row['detail']})" if row["detail"] else row["status"]
    return f"{value:.4g} ± {sigma * f:.2g}" + (f" {unit}" if unit else "")
