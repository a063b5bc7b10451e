"""One vocabulary for what an analysis or a calibration does with a parameter the data do not estimate.

``calibrate``, ``analyze`` and ``poses`` (the planner) say the same words of the same parameter:

- **not identifiable** (:data:`NOT_IDENTIFIABLE`): the rank test drops it, on these poses and on poses
  spread over the joint limits (:mod:`robocal.identify.structural`): its effect is exactly that of
  other parameters or of a frame (its confounders: d1 beside the base height, d3 beside d2 of two
  parallel axes, theta6 beside the tool), or it has no effect at all. It is held at nominal and its
  confounders absorb its error: no data separate it, so it costs nothing.
- **not determined by these data** (:data:`NOT_DETERMINED`): the data carry less information on it
  than its prior (posterior sigma above :data:`robocal.identify.priors.NOT_DETERMINED_RATIO` of the
  prior's), or the rank test drops it on these poses only: held near nominal by its prior. More
  poses, or poses that move it apart from its confounders, would determine it.
- **not used** (:data:`NOT_USED`): a payload or thermal term the calibration data cannot show (no
  ``payload_kg`` / ``temperature_c`` column, or one value in every row).

A joint-error term (:mod:`robocal.kinematics.joint_errors`) must be more clearly independent than a
geometric parameter to be estimated (a variance inflation below
:data:`robocal.identify.identifiability.NG_MAX_VIF` against the columns kept before it): one set aside
by that rule is not identifiable from these data although not exactly confounded, and its reason
says so (:data:`NOT_SEPARABLE`).

Every estimated parameter is :data:`ESTIMATED`. The functions take an
:class:`robocal.identify.identifiability.Identifiability` (``dropped``, ``undetermined``,
``confounded_with``, ``prior_ratio``).
"""

from __future__ import annotations

from robocal.identify.freedoms import freedom_lines
from robocal.identify.space import block_of

ESTIMATED = "estimated"
NOT_IDENTIFIABLE = "not identifiable"
NOT_DETERMINED = "not determined by these data"
NOT_USED = "not used"
NOT_SEPARABLE = "not separable from the geometry on these data (exactly or nearly confounded)"
# what each word means, said once (summaries and reports)
MEANING = {
    NOT_IDENTIFIABLE: "exactly confounded or without effect: held at nominal, the confounders absorb it",
    NOT_DETERMINED: "held near nominal by the prior: more or other poses would determine it",
    NOT_USED: "the data do not vary the condition it needs",
}


def status(name: str, ident, not_used: dict[str, str] | None = None) -> str:
    """The word for ``name``: :data:`NOT_USED` (a key of ``not_used``), :data:`NOT_IDENTIFIABLE`
    (in ``ident.dropped``), :data:`NOT_DETERMINED` (in ``ident.undetermined``), else
    :data:`ESTIMATED`."""
    if not_used and name in not_used:
        return NOT_USED
    if name in ident.dropped:
        return NOT_IDENTIFIABLE
    if name in ident.undetermined:
        return NOT_DETERMINED
    return ESTIMATED


def detail(name: str, ident, not_used: dict[str, str] | None = None, sep: str = ", ") -> str:
    """What is known of ``name`` beyond its word: the reason it was not used, its posterior / prior
    sigma ratio and its confounders (``sep`` between them), or 'no effect on these data'."""
    if not_used and name in not_used:
        return not_used[name]
    conf = sep.join(ident.confounded_with.get(name) or [])
    if name in ident.undetermined:
        ratio = ident.prior_ratio.get(name)
        parts = [f"posterior sigma {ratio:.0%} of its prior"] if ratio is not None else []
        return "; ".join(parts + ([f"confounded with {conf}"] if conf else []))
    if name in ident.dropped:
        what = f"{NOT_SEPARABLE}: confounded with {conf}" if block_of(name) == "joint_errors" \
            else f"confounded with {conf}"
        return what if conf else "no effect on these data"
    return ""


def reason(name: str, ident, not_used: dict[str, str] | None = None) -> str:
    """One sentence for a JSON ``dropped`` entry: the word, then :func:`detail` and what it means."""
    word = status(name, ident, not_used)
    if word == NOT_USED:
        return f"{NOT_USED}: {not_used[name]}"
    if word == NOT_IDENTIFIABLE:
        return f"{NOT_IDENTIFIABLE}: {detail(name, ident)}; held at nominal" + (
            ", its confounders absorb it" if ident.confounded_with.get(name) else "")
    return f"{NOT_DETERMINED}: {detail(name, ident)}; held near nominal by its prior"


def entries(names, ident, not_used: dict[str, str] | None = None) -> list[dict]:
    """The JSON ``dropped`` list of ``names``: name, ``status`` (the word), ``reason``,
    ``confounded_with`` and, for those not determined, ``prior_ratio``."""
    out = []
    for nm in names:
        word = status(nm, ident, not_used)
        row = {"name": nm, "status": word, "reason": reason(nm, ident, not_used),
               "confounded_with": list(ident.confounded_with.get(nm) or [])}
        if word == NOT_DETERMINED and nm in ident.prior_ratio:
            row["prior_ratio"] = float(ident.prior_ratio[nm])
        out.append(row)
    return out


def counts(ident) -> str:
    """'estimated: K; not determined by these data: U; not identifiable: D'."""
    return (f"{ESTIMATED}: {len(ident.kept)}; {NOT_DETERMINED} (held near nominal by their priors): "
            f"{len(ident.undetermined)}; {NOT_IDENTIFIABLE} (held at nominal): {len(ident.dropped)}")


def lines(ident, names=None, indent: str = "", not_used: dict[str, str] | None = None) -> list[str]:
    """Summary lines: one per word with parameters among ``names`` (default all not estimated),
    each listing them with :func:`detail` in short form (``name (~confounders)``)."""
    names = list(ident.dropped) + list(ident.undetermined) if names is None else list(names)
    out = []
    for word in (NOT_IDENTIFIABLE, NOT_DETERMINED, NOT_USED):
        these = [nm for nm in names if status(nm, ident, not_used) == word]
        if these:
            out.append(f"{indent}{word} ({MEANING[word]}): " + ", ".join(
                _short(nm, word, ident, not_used) for nm in these))
    return out + freedom_lines(getattr(ident, "freedoms", []), indent)


def _short(name: str, word: str, ident, not_used: dict[str, str] | None) -> str:
    if word == NOT_USED:
        return f"{name} ({not_used[name]})"
    conf = "/".join(ident.confounded_with.get(name) or [])
    if word == NOT_DETERMINED:
        ratio = ident.prior_ratio.get(name)
        what = [f"{ratio:.0%} of prior"] if ratio is not None else []
        return f"{name} ({'; '.join(what + ([f'~{conf}'] if conf else []))})" if what or conf else name
    return f"{name} (~{conf})" if conf else f"{name} (no effect)"
