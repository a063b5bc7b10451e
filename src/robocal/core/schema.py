"""Field-by-field validation of plain data read from users' files (JSON, YAML) before use, and the
schema of the calibration result JSON (docs/result-json.md).

A schema is built from small specs (:class:`Num`, :class:`Int`, :class:`Str`, :class:`Bool`,
:class:`Arr`, :class:`Seq`, :class:`Obj`, :class:`Map`, :class:`Any`); :func:`validate` walks the
data once and raises one DataError naming the field (``observations.joints_deg[3]: expected 6
numbers, got 5``) for a wrong type, a non-finite or absurd number, a ragged array or a size beyond
the bounds. Keys a schema does not know are kept unchecked (newer files stay readable).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from robocal.core.errors import DataError

MAX_ABS = 1e15  # no number in a robocal file is larger (mm, deg, counts)
MAX_INT = 2**53  # integers beyond are not exact as JSON numbers
MAX_STR = 100_000  # characters in one text field
MAX_ITEMS = 10_000_000  # elements in one list


def _fail(where: str, reason: str):
    raise DataError(f"{where or 'the document'}: {reason}")


def _short(value) -> str:
    text = repr(value) if not isinstance(value, list | dict) else type(value).__name__
    return text if len(text) <= 40 else text[:37] + "..."


class Spec:
    """A field's rule; ``null`` allows None."""

    null = False

    def check(self, value, where: str) -> None:
        raise NotImplementedError

    def __call__(self, value, where: str) -> None:
        if value is None:
            if not self.null:
                _fail(where, "is null (missing value)")
            return
        self.check(value, where)


def _number(value, where: str, max_abs: float) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        _fail(where, f"expected a number, got {_short(value)}")
    if isinstance(value, float) and not math.isfinite(value):
        _fail(where, f"{value!r} is not finite")
    if not -max_abs <= value <= max_abs:
        _fail(where, f"{_short(value)} is beyond {max_abs:g} (an absurd value)")


class Num(Spec):
    def __init__(self, null: bool = False, max_abs: float = MAX_ABS) -> None:
        self.null, self.max_abs = null, max_abs

    def check(self, value, where):
        _number(value, where, self.max_abs)


class Int(Spec):
    def __init__(self, null: bool = False, lo: int = -MAX_INT, hi: int = MAX_INT) -> None:
        self.null, self.lo, self.hi = null, lo, hi

    def check(self, value, where):
        if isinstance(value, bool) or not isinstance(value, int):
            _fail(where, f"expected an integer, got {_short(value)}")
        if not self.lo <= value <= self.hi:
            _fail(where, f"{_short(value)} is outside [{self.lo}, {self.hi}]")


class Str(Spec):
    def __init__(self, null: bool = False, max_len: int = MAX_STR) -> None:
        self.null, self.max_len = null, max_len

    def check(self, value, where):
        if not isinstance(value, str):
            _fail(where, f"expected a text, got {_short(value)}")
        if len(value) > self.max_len:
            _fail(where, f"a text of {len(value)} characters (more than {self.max_len})")


class Bool(Spec):
    def __init__(self, null: bool = False) -> None:
        self.null = null

    def check(self, value, where):
        if not isinstance(value, bool):
            _fail(where, f"expected true or false, got {_short(value)}")


class Any(Spec):
    """Anything (a field only shown as text)."""

    null = True

    def check(self, value, where):
        pass


class Arr(Spec):
    """A numeric array as nested lists: ``ndim`` 1 (a list of numbers) or 2 (a list of rows of
    equal length, ``cols`` when given); ``integer`` for integer entries."""

    def __init__(self, ndim: int = 1, cols: int | None = None, integer: bool = False, null: bool = False,
                 max_abs: float = MAX_ABS) -> None:
        self.ndim, self.cols, self.integer, self.null, self.max_abs = ndim, cols, integer, null, max_abs

    def check(self, value, where):
        if not isinstance(value, list):
            _fail(where, f"expected a list, got {_short(value)}")
        if len(value) > MAX_ITEMS:
            _fail(where, f"{len(value)} entries (more than {MAX_ITEMS})")
        rows = [value] if self.ndim == 1 else value
        width = self.cols
        for i, row in enumerate(rows):
            at = where if self.ndim == 1 else f"{where}[{i}]"
            if self.ndim == 2:
                if not isinstance(row, list):
                    _fail(at, f"expected a list of numbers, got {_short(row)}")
                width = len(row) if width is None else width
                if len(row) != width:
                    _fail(at, f"expected {width} numbers, got {len(row)} (a ragged array)")
            for j, v in enumerate(row):
                if self.integer:
                    if isinstance(v, bool) or not isinstance(v, int) or not -MAX_INT <= v <= MAX_INT:
                        _fail(f"{at}[{j}]", f"expected an integer, got {_short(v)}")
                else:
                    _number(v, f"{at}[{j}]", self.max_abs)


class Seq(Spec):
    """A list whose items follow ``item``."""

    def __init__(self, item: Spec, null: bool = False, max_len: int = MAX_ITEMS) -> None:
        self.item, self.null, self.max_len = item, null, max_len

    def check(self, value, where):
        if not isinstance(value, list):
            _fail(where, f"expected a list, got {_short(value)}")
        if len(value) > self.max_len:
            _fail(where, f"{len(value)} entries (more than {self.max_len})")
        for i, v in enumerate(value):
            self.item(v, f"{where}[{i}]")


class Obj(Spec):
    """A mapping with known ``fields`` (each optional unless in ``required``); ``post(value,
    where)`` checks relations between fields."""

    def __init__(self, fields: dict[str, Spec], required: tuple[str, ...] = (), null: bool = False,
                 post: Callable | None = None) -> None:
        self.fields, self.required, self.null, self.post = fields, required, null, post

    def check(self, value, where):
        if not isinstance(value, dict):
            _fail(where, f"expected a mapping, got {_short(value)}")
        for key in self.required:
            if key not in value:
                _fail(where, f"missing field {key!r}")
        for key, spec in self.fields.items():
            if key in value:
                spec(value[key], f"{where}.{key}" if where else key)
        if self.post is not None:
            self.post(value, where)


class Map(Spec):
    """A mapping of texts to values following ``value``."""

    def __init__(self, value: Spec, null: bool = False) -> None:
        self.value, self.null = value, null

    def check(self, value, where):
        if not isinstance(value, dict):
            _fail(where, f"expected a mapping, got {_short(value)}")
        for key, v in value.items():
            self.value(v, f"{where}[{key!r}]")


def validate(value, spec: Spec, where: str = ""):
    """``value`` unchanged when it follows ``spec``; else DataError naming the field."""
    spec(value, where)
    return value


# ----------------------------------------------------------------- the result JSON
def _same_length(*keys: str) -> Callable:
    def post(value: dict, where: str) -> None:
        sizes = {k: len(value[k]) for k in keys if isinstance(value.get(k), list)}
        if len(set(sizes.values())) > 1:
            _fail(where, "arrays of different lengths: " + ", ".join(f"{k} {n}" for k, n in sizes.items()))
    return post


def _square(value: dict, where: str) -> None:
    names, matrix = value.get("names"), value.get("matrix")
    if isinstance(names, list) and isinstance(matrix, list) and matrix \
            and (len(matrix) != len(names) or len(matrix[0]) != len(names)):
            _fail(f"{where}.matrix", f"expected {len(names)} x {len(names)} values (one per name)")


_STATS = Obj({"n": Int(lo=0), "rms": Num(null=True), "mean": Num(null=True), "max": Num(null=True),
              "p95": Num(null=True)}, null=True)
_OBSERVATIONS = Obj({
    "kind": Str(null=True, max_len=40),
    "error_before": Arr(null=True), "error_after": Arr(null=True),
    "pose_id": Arr(integer=True, null=True), "source_row": Arr(integer=True, null=True),
    "smr": Arr(integer=True, null=True), "plane": Arr(integer=True, null=True),
    "joints_deg": Arr(2, null=True), "measured": Arr(2, 3, null=True),
    "model_before": Arr(2, 3, null=True), "model_after": Arr(2, 3, null=True),
    "weight": Arr(null=True)},
    null=True, post=_same_length("error_before", "error_after", "pose_id", "source_row", "smr", "plane",
                                 "joints_deg", "measured", "model_before", "model_after", "weight"))
_TEXTS = Seq(Str(), null=True)
_CANDIDATE = Obj({"terms": _TEXTS, "cv_rms_mm": Num(null=True), "cv_se_mm": Num(null=True),
                  "cv_robust_rms_mm": Num(null=True), "cv_paired_se_mm": Num(null=True),
                  "fold_rms_mm": Arr(null=True), "calibration_rms_mm": Num(null=True),
                  "n_params": Int(null=True, lo=0), "parameters": _TEXTS})

_ESTIMATE = {"status": Str(null=True, max_len=100), "detail": Str(null=True)}
_CONDITIONS = Obj({  # robocal.calibration.conditions
    "terms": _TEXTS, "reference_temperature_c": Num(null=True),
    "data": Obj({"payload": Obj({"min_kg": Num(), "max_kg": Num(), "masses_kg": Arr(null=True),
                                 "centre_of_mass_mm": Obj({"min": Arr(), "max": Arr()}, null=True)},
                                null=True),
                 "temperature": Obj({"min_c": Num(), "max_c": Num()}, null=True)}, null=True),
    "thermal": Obj({"k_per_K": Num(), "sigma_per_K": Num(null=True), **_ESTIMATE}, null=True),
    "thermal_groups": Seq(Obj({"group": Str(max_len=100), "label": Str(null=True, max_len=100),
                               "k_per_K": Num(), "sigma_per_K": Num(), "source": Str(max_len=100)}),
                          null=True),
    "payload": Seq(Obj({"name": Str(max_len=100), "joint": Int(lo=1, hi=64), "estimate": Num(),
                        "unit": Str(null=True, max_len=40), "sigma": Num(null=True), **_ESTIMATE}),
                   null=True),
    "payload_com_correction_mm": Obj({"joints": Arr(), "xyz": Arr()}, null=True),
    "assumed": Map(Num(), null=True),
    "not_used": Seq(Obj({"term": Str(max_len=100), "reason": Str(null=True)}), null=True)}, null=True)

def _pairs(value: dict, where: str) -> None:
    """The ranges of a coverage entry are (lower, upper) pairs."""
    for key in ("limits_deg", "covered_deg", "limits_mm", "covered_mm"):
        if value.get(key) is not None and len(value[key]) != 2:
            _fail(f"{where}.{key}", f"expected [lower, upper], got {len(value[key])} numbers")


_PREDICTED_ACCURACY = Obj({  # robocal.trust.coverage: what the report reads of it
    "workspace": Obj({"n": Int(null=True, lo=0), "rms": Num(null=True), "p95": Num(null=True),
                      "max": Num(null=True), "samples": Int(null=True, lo=0)}, null=True),
    "calibration_region": Obj({"n": Int(null=True, lo=0), "rms": Num(null=True), "p95": Num(null=True),
                               "max": Num(null=True)}, null=True),
    "validated_mm": Num(), "validated_from": Str(null=True), "unmodelled_mm": Num(null=True),
    "ratio": Num(null=True, max_abs=math.inf), "factor": Num(), "holds_only_near_poses": Bool(null=True),
    "coverage": Seq(Obj({"joint": Int(lo=1, hi=64), "fraction": Num(),
                         "limits_deg": Arr(null=True), "covered_deg": Arr(null=True),
                         "limits_mm": Arr(null=True), "covered_mm": Arr(null=True)},
                        required=("joint", "fraction"), post=_pairs), null=True),
    "by_distance": Obj({"distance_deg": Arr(null=True), "rms_mm": Arr(null=True)}, null=True),
}, required=("validated_mm", "factor"), null=True)

RESULT_SCHEMA = Obj({
    "format": Str(), "robocal_version": Str(null=True, max_len=100),
    "robot": Obj({"name": Str(null=True, max_len=1000), "description": Str(null=True),
                  "n_joints": Int(null=True, lo=1, hi=64),
                  "joints": Seq(Str(max_len=40), null=True)}, null=True),
    "provenance": Obj({"created": Str(null=True), "command": Str(null=True), "robot_spec": Str(null=True),
                       "data_file": Str(null=True), "validation_file": Str(null=True), "hold_out": Any()},
                      null=True),
    "data": Obj({"file": Str(null=True), "kind": Str(null=True), "n_poses": Int(null=True, lo=0),
                 "n_observations": Int(null=True, lo=0), "validation_file": Str(null=True),
                 "files": Seq(Obj({"file": Str(null=True), "kind": Str(null=True),
                                   "n_poses": Int(null=True, lo=0), "n_observations": Int(null=True, lo=0),
                                   "sigma_mm": Num(null=True)}), null=True)}, null=True),
    "method": Str(null=True, max_len=100), "settings": Map(Any(), null=True),
    "converged": Bool(null=True), "status": Str(null=True, max_len=100), "message": Str(null=True),
    "before": _STATS, "after": _STATS, "after_inliers": _STATS, "validation_before": _STATS,
    "validation": Obj({**_STATS.fields, "noise_floor_mm": Num(null=True)}, null=True),  # robocal.report.floor
    "parameters": Seq(Obj({"name": Str(max_len=200), "unit": Str(null=True, max_len=40),
                           "nominal": Num(null=True), "estimate": Num(null=True),
                           "correction": Num(null=True),
                           "sigma": Num(null=True), "status": Str(null=True, max_len=40),
                           "identification": Str(null=True, max_len=100)},
                          required=("name",)), null=True),
    "dropped": Seq(Obj({"name": Str(max_len=200), "reason": Str(null=True),
                        "status": Str(null=True, max_len=100), "prior_ratio": Num(null=True),
                        "confounded_with": _TEXTS}, required=("name",)), null=True),
    "conditions": _CONDITIONS,
    "predicted_accuracy": _PREDICTED_ACCURACY,
    "validation_shifts": Obj({  # robocal.trust.file_shifts
        "test": Str(null=True, max_len=100), "statistic": Num(null=True, max_abs=math.inf),
        "dof": Arr(integer=True, null=True), "p_value": Num(null=True), "alpha": Num(null=True),
        "rms_mm": Num(null=True), "shift_rms_mm": Num(null=True), "within_rms_mm": Num(null=True),
        "significant": Bool(null=True),
        "files": Seq(Obj({"file": Str(null=True), "poses": Int(lo=0), "shift_mm": Arr(null=True)}),
                     null=True)},
        null=True),
    "identifiability": Obj({"n_params": Int(null=True, lo=0), "rank": Int(null=True, lo=0),
                            "condition_number": Num(null=True, max_abs=math.inf),
                            "condition_class": Str(null=True, max_len=40), "O1": Num(null=True),
                            "O2": Num(null=True), "O3": Num(null=True), "O4": Num(null=True),
                            "structural_freedoms": Seq(Obj({  # robocal.identify.freedoms (a SCARA)
                                "freedom": Str(max_len=40), "words": Str(), "held": _TEXTS,
                                "carried_by": _TEXTS}), null=True)}, null=True),
    "correlation": Obj({"names": Seq(Str(max_len=200)), "matrix": Arr(2, null=True, max_abs=1.0 + 1e-6)},
                       null=True, post=_square),
    "rejected": Seq(Obj({"source_row": Int(null=True), "pose_id": Int(null=True), "residual": Num(null=True),
                         "weight": Num(null=True), "file": Str(null=True)}), null=True),
    "observations": _OBSERVATIONS, "validation_observations": _OBSERVATIONS,
    "per_file": Seq(Obj({"role": Str(null=True), "file": Str(null=True), "kind": Str(null=True),
                         "before": _STATS, "after": _STATS}), null=True),
    "per_kind": Map(_STATS, null=True),
    "history_units": Obj({"cost": Str(null=True, max_len=100), "rms": Str(null=True, max_len=100)},
                         null=True),
    "history": Seq(Obj({"iteration": Int(lo=0), "cost": Num(null=True, max_abs=math.inf),
                        "rms": Num(null=True, max_abs=math.inf)}), null=True),
    "warnings": _TEXTS,
    "nongeometric": Obj({"terms": _TEXTS, "kept": _TEXTS, "dropped": _TEXTS,
                         "parameters": Seq(Obj({"name": Str(), "estimate": Num(null=True),
                                                "sigma": Num(null=True)}), null=True)}, null=True),
    "model_selection": Obj({"method": Str(null=True), "folds": Int(null=True), "seed": Any(),
                            "n_poses": Int(null=True), "candidates": Seq(_CANDIDATE, null=True),
                            "chosen": Int(null=True), "best": Int(null=True), "reason": Str(null=True),
                            "tolerance": Num(null=True),
                            "chosen_terms": _TEXTS,
                            "cyclic_frequencies": Seq(Obj({"joint": Int(null=True),
                                                           "cycles_per_rev": Num(null=True)}), null=True),
                            "terms_without_data": _TEXTS, "time_s": Map(Num(null=True), null=True)},
                           null=True),
}, required=("format",))
