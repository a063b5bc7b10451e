"""The report's verdict box: in one place at the top, whether the calibration can be used and what
to do next. It reads the result JSON (docs/result-json.md) and judges:

- the held-out accuracy against the noise floor (:mod:`robocal.report.floor`: the RMS a perfect
  model would show on the held-out data, ``validation.noise_floor_mm``);
- the predicted accuracy over the workspace (``predicted_accuracy``);
- the warnings, counting the parameters held at nominal (``dropped``), by the words of
  :mod:`robocal.identify.vocabulary` (not identifiable; not determined by these data; not used);
- the next step, one sentence chosen by the first rule that applies (see `next_step`).
"""

from __future__ import annotations

from robocal.report.floor import of_result as noise_floor_mm
from robocal.report.floor import own_error_mm
from robocal.report.format import esc, num

FLOOR_FACTOR = 1.5  # held-out RMS within this factor of the noise floor: the model explains the data
# the held-out judgement's verdicts as the result JSON writes them (``held_out.verdict``, docs/result-json.md;
# robocal.trust.held_out, which the report does not import: it renders the JSON alone)
HELD_OUT_FRAME_SHIFT, HELD_OUT_BEYOND = "frame shift", "beyond the prediction"


def held_parameters(result: dict) -> list[str]:
    """The parameters held at nominal because the data do not determine them."""
    return [str(d.get("name")) for d in result.get("dropped") or []]


# how the box says each word of robocal.identify.vocabulary (an older result's entry without a
# status: the word its reason starts with, else held at nominal)
HELD_WORDS = {"not identifiable": "not identifiable (held at nominal, the confounders absorb it)",
              "not determined by these data": "not determined by these data (held near nominal by "
                                              "their priors: more or other poses would determine them)",
              "not used": "not used (the data do not vary their condition)"}
HELD_DEFAULT = "held at nominal"


def held_by_word(result: dict) -> dict[str, list[str]]:
    """The held parameters (`held_parameters`) grouped by how the box says why."""
    out: dict[str, list[str]] = {}
    for d in result.get("dropped") or []:
        reason = str(d.get("reason") or "")
        word = d.get("status") or next((w for w in HELD_WORDS if reason.startswith(w)), None)
        out.setdefault(HELD_WORDS.get(word, HELD_DEFAULT), []).append(str(d.get("name")))
    return out


def next_step(result: dict) -> tuple[str, str]:
    """``(level, sentence)``: level 'good', 'care' or 'bad', and what the user should do next."""
    consistency = result.get("consistency") or {}
    predicted = result.get("predicted_accuracy") or {}
    held_out = (result.get("validation") or {}).get("rms")
    judged = result.get("held_out") or {}
    if judged.get("verdict") == HELD_OUT_FRAME_SHIFT:  # the model is judged without the tracker's shift
        held_out = judged.get("model_error_mm", held_out)
    floor = noise_floor_mm(result)
    if "converged" in result and not result.get("converged"):
        return "bad", ("The solver did not converge: do not use this model; read the warnings and calibrate "
                       "again.")
    if consistency.get("verdict") == "inconsistent":
        return "bad", ("The model misses its own data by more than the instrument explains: find the cause "
                       "named in the warnings (units, a moved reflector or tracker, the wrong robot) before "
                       "using it.")
    if consistency.get("verdict") == "step":
        return "bad", ("The residuals change part-way through the measuring order (a reflector or the "
                       "tracker moved): measure again, or calibrate on the rows before the change.")
    if judged.get("verdict") == HELD_OUT_BEYOND:
        return "bad", ("NOT VALIDATED: the model misses the held-out poses by more than its prediction, "
                       "even with the tracker frame refitted on them: find the cause named in the warnings "
                       "(another SMR nest or tool, another robot, a changed arm) before using it.")
    if held_out is None:
        return "care", ("No poses were held out: measure 20 or more poses the calibration did not see and "
                        "judge the model on them (robocal calibrate --validate, or robocal evaluate).")
    if predicted.get("holds_only_near_poses"):
        return "care", ("The calibration holds only near its poses: measure poses across the joint ranges "
                        "the table under Predicted accuracy shows as not covered, and calibrate again.")
    if floor is not None and held_out > FLOOR_FACTOR * floor:
        return "care", (f"The held-out error is more than {FLOOR_FACTOR:g} times the noise floor: errors the "
                        "model lacks remain; try --nongeometric auto (joint errors) or more poses.")
    return "good", ("Ready to use: correct your programs with robocal filter (or targets with robocal "
                    "compensate), and check the robot with a short campaign from time to time.")


def verdict_box(result: dict) -> str:
    """The verdict box as pre-escaped HTML."""
    level, step = next_step(result)
    title = {"good": "Verdict: ready to use", "care": "Verdict: use with care",
             "bad": "Verdict: do not use yet"}[level]
    lines = []
    val = result.get("validation") or {}
    floor = noise_floor_mm(result)
    if val.get("rms") is not None:
        own = ""
        if floor is not None:
            own = (f" against a noise floor of {num(floor)} mm (the instrument alone); the model's own "
                   f"error is about {num(own_error_mm(val['rms'], floor))} mm")
        lines.append(f"Held out: <b>{num(val['rms'])} mm RMS</b> on {esc(val.get('n'))} observations the "
                     f"calibration did not see{own}.")
    else:
        lines.append("Held out: <b class='bad'>none</b> &mdash; the calibration set's own error is "
                     "optimistic.")
    ws = (result.get("predicted_accuracy") or {}).get("workspace") or {}
    if ws.get("rms") is not None:
        lines.append(f"Predicted over the whole workspace: <b>{num(ws['rms'])} mm RMS</b> "
                     f"(p95 {num(ws.get('p95'))} mm).")
    warnings, held = result.get("warnings") or [], held_by_word(result)
    parts = []
    if warnings:
        parts.append(f"{len(warnings)} warning(s) below")
    for word, names in held.items():
        shown = ", ".join(esc(n) for n in names[:8]) + (" ..." if len(names) > 8 else "")
        parts.append(f"{len(names)} parameter(s) {esc(word)}: {shown}")
    # orange only for a warning: parameters held at nominal are read, not alarmed about
    lead = "<b class='bad'>Read first:</b> " if warnings else "<b>Read first:</b> "
    lines.append((lead + "; ".join(parts) + ".") if parts
                 else "No warnings, and every parameter was determined by the data.")
    lines.append(f"<b>Next:</b> {esc(step)}")
    body = "".join(f"<p>{line}</p>" for line in lines)
    return f"<div class='verdict {level}'><h3>{title}</h3>{body}</div>"
