"""Import raw tracker/controller exports (no header) into :class:`Measurements`.

Column roles and units come from specs ``[FILE:]cols=A-B:UNIT`` (0-based columns, ``A-B``
inclusive or ``a,b,c``; UNIT deg|rad for joints, mm|m for points). Two layouts:

- combined: every raw file holds joints and points on each row (``raw`` files, specs without
  FILE). Several files are concatenated in the given order (Meca500 data), each a measuring run
  of its own: the approach directions and joint moves (backlash, travel) of a file's first pose are
  0, not the move from another file's last pose;
- separate: one joints file plus one points file per SMR, row i of each file belonging to pose i
  (specs with FILE; the k-th points spec is SMR k-1). IRB 120 data: 1000 poses x 3 SMRs.

Values are split on commas, semicolons or whitespace; blank lines and ``#`` lines are skipped,
``skip_rows`` drops header lines. Failed readings (a points row all zeros, or NaN anywhere in the
row) are dropped and reported with file and line. Consecutive rows of one file with identical
joints are repeated readings of one pose: averaged (their spread reported: max and RMS deviation
from the mean), or kept with a shared ``pose_id`` (``average=False``). ``source_row`` is the line
(1-based) in the file that held the joints (for an averaged group, its first valid reading). Optional
``base`` specs name drift-monitor SMR files (fixed SMRs on the robot base re-measured at every
pose): their drift from the median position is reported, the data are not changed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError, UnitError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, read_text
from robocal.data.measurements import (
    MAX_JOINT_RAD,
    MAX_TRACKER_RANGE_M,
    Measurements,
    approach_from_order,
    travel_from_order,
)
from robocal.kinematics.conditions import Conditions

_SPLIT = re.compile(r"[,;\s]+")
# a digit, a comma, a digit, inside a value: a decimal comma when the line is split by ';' or
# whitespace (``12,5;3,25`` or ``12,5 3,25``), or when it has no decimal point at all
_DECIMAL_COMMA = re.compile(r"(?:^|[;\s])[-+]?\d+,\d+(?=$|[;\s])")
# A drift-monitor reading farther than this from its median is a stray (the tracker caught another
# target), reported by line and left out of the drift figures.
STRAY_MM = 1.0


@dataclass(frozen=True)
class ColumnSpec:
    """Which columns of which file (None: the raw files) hold a quantity, and its unit."""

    cols: tuple[int, ...]
    unit: str
    file: str | None = None

    @classmethod
    def parse(cls, text: str, role: str) -> ColumnSpec:
        """Parse ``[FILE:]cols=A-B:UNIT``; ``role`` is 'joints' or 'points' (decides valid units)."""
        units = ANGLE_UNITS if role == "joints" else LENGTH_UNITS
        parts = text.split(":")
        cols = unit = None
        rest = []
        for part in parts:
            if part.startswith("cols="):
                cols = _parse_cols(part[5:], text)
            elif part in units:
                unit = part
            elif part in ANGLE_UNITS or part in LENGTH_UNITS or part in ("cm", "um", "grad"):
                raise UnitError(f"--{role} {text!r}: unit {part!r} is not a {role} unit; use "
                                f"{' or '.join(units)}")
            else:
                rest.append(part)
        if unit is None:
            raise UnitError(f"--{role} {text!r}: state the unit ({' or '.join(units)}), e.g. "
                            f"{'cols=0-5:deg' if role == 'joints' else 'cols=6-8:mm'}")
        file = ":".join(rest) if rest else None
        if cols is None and role == "points" and file is not None:
            cols = (0, 1, 2)
        if cols is None:
            raise DataError(f"--{role} {text!r}: give the columns, e.g. "
                            f"{'cols=0-5' if role == 'joints' else 'cols=6-8'}")
        if role == "points" and len(cols) != 3:
            raise DataError(f"--{role} {text!r}: a point needs exactly 3 columns (x, y, z), got {len(cols)}")
        return cls(cols=cols, unit=unit, file=file)

    @property
    def scale(self) -> float:
        return {**ANGLE_UNITS, **LENGTH_UNITS}[self.unit]


def _parse_cols(text: str, spec: str) -> tuple[int, ...]:
    try:
        if "-" in text:
            a, b = (int(v) for v in text.split("-"))
            cols = tuple(range(a, b + 1))
        else:
            cols = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise DataError(f"{spec!r}: columns must be 'A-B' or 'a,b,c' (0-based integers)") from None
    if not cols or min(cols) < 0 or len(set(cols)) != len(cols):
        raise DataError(f"{spec!r}: columns must be distinct non-negative integers")
    return cols


def read_table(path, skip_rows: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Numeric table of a headerless text file: values ``(R, C)`` (``nan`` cells allowed) and their
    1-based line numbers ``(R,)``. Non-numeric cells and ragged rows raise DataError."""
    path = Path(path)
    text = read_text(path, "raw measurement file")
    rows, lines = [], []
    for ln, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if ln <= skip_rows or not s or s.startswith("#"):
            continue
        if _DECIMAL_COMMA.search(s) and ("." not in s or ";" in s):
            raise DataError(f"{path}, line {ln}: {s[:40]!r} has decimal commas: robocal reads numbers with a "
                            "decimal point (commas separate values); convert the file to '.' decimals")
        cells = [c for c in _SPLIT.split(s) if c]
        values = []
        for col, cell in enumerate(cells):
            try:
                values.append(float(cell))
            except ValueError:
                raise DataError(f"{path}, line {ln}, column {col}: {cell[:40]!r} is not a number; if the "
                                "file has a header, skip it with --skip-rows") from None
            if np.isinf(values[-1]):
                raise DataError(f"{path}, line {ln}, column {col}: {cell[:40]!r} is infinite; fix or "
                                "remove that reading (a failed reading may be NaN or all zeros)")
        rows.append(values)
        lines.append(ln)
        if len(rows[-1]) != len(rows[0]):
            raise DataError(f"{path}, line {ln}: {len(rows[-1])} values but the first data line has "
                            f"{len(rows[0])}; every row needs the same columns")
    if not rows:
        raise DataError(f"{path}: no data rows")
    return np.array(rows, dtype=float), np.array(lines, dtype=np.int64)


def _columns(table: np.ndarray, lines: np.ndarray, spec: ColumnSpec, path, role: str) -> np.ndarray:
    """The spec's columns in SI; a value no robot or tracker can produce is a unit error naming
    its file, line, column and value."""
    if max(spec.cols) >= table.shape[1]:
        raise DataError(f"{path}: {role} columns {list(spec.cols)} but the file has only "
                        f"{table.shape[1]} columns (0..{table.shape[1] - 1})")
    values = table[:, list(spec.cols)] * spec.scale
    limit, what = ((MAX_JOINT_RAD, "joint angle beyond two turns") if spec.unit in ANGLE_UNITS
                   else (MAX_TRACKER_RANGE_M, "point beyond any tracker's range"))
    with np.errstate(invalid="ignore"):
        absurd = np.abs(values) > limit
    if absurd.any():
        r, c = np.argwhere(absurd)[0]
        raise UnitError(f"{path}, line {lines[r]}, column {spec.cols[c]}: {table[r, spec.cols[c]]:.6g} "
                        f"{spec.unit} is a {what}: the unit ({spec.unit}) is probably wrong, or the "
                        "reading is corrupt")
    return values


@dataclass
class ImportResult:
    """``data``: the measurements; ``dropped``: (file, line, reason) of failed readings;
    ``spread_max``/``spread_rms`` (P,) m: per averaged pose, max and RMS deviation of its readings
    from their mean (0 for single readings); ``readings`` (P,) readings per pose; ``drift``: per
    base SMR file {file, max_mm, rms_mm, line_of_max}; ``files``: (file, poses) in order."""

    data: Measurements
    dropped: list = field(default_factory=list)
    spread_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    spread_rms: np.ndarray = field(default_factory=lambda: np.zeros(0))
    readings: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    drift: list = field(default_factory=list)
    files: list = field(default_factory=list)

    @property
    def warnings(self) -> list[str]:
        """What the user must know even with ``--quiet``: dropped readings, stray base readings."""
        out = []
        if self.dropped:
            shown = "; ".join(f"{f}, line {ln}: {why}" for f, ln, why in self.dropped[:20])
            more = f"; ... and {len(self.dropped) - 20} more" if len(self.dropped) > 20 else ""
            out.append(f"dropped {len(self.dropped)} failed reading(s): {shown}{more}")
        for dr in self.drift:
            if dr["stray_lines"]:
                out.append(f"{dr['file']}: {len(dr['stray_lines'])} base reading(s) more than {STRAY_MM:g} "
                           "mm from their median left out of the drift figures (lines "
                           f"{dr['stray_lines'][:10]})")
        return out

    def summary(self) -> str:
        """Human-readable summary: counts, dropped rows, repeat spread, drift."""
        d = self.data
        lines = [f"imported {len(d)} observations: {d.n_poses} poses x {d.n_smr} SMR(s), "
                 f"{d.n_joints} joints, from {len(self.files)} file(s)"]
        for f, poses in self.files:
            lines.append(f"  {f}: {poses} poses")
        if self.dropped:
            lines.append(f"dropped {len(self.dropped)} failed reading(s):")
            lines += [f"  {f}, line {ln}: {why}" for f, ln, why in self.dropped[:20]]
            if len(self.dropped) > 20:
                lines.append(f"  ... and {len(self.dropped) - 20} more")
        else:
            lines.append("dropped 0 failed readings")
        multi = self.readings > 1
        if multi.any():
            r = self.readings[multi]
            rms = np.sqrt(np.mean(self.spread_rms[multi] ** 2)) * 1e3
            lines.append(f"repeated readings: {int(multi.sum())} poses with {int(r.min())}-{int(r.max())} "
                         f"readings; spread max {self.spread_max.max() * 1e3:.4f} mm, RMS {rms:.4f} mm")
        for dr in self.drift:
            lines.append(f"base SMR drift {dr['file']}: max {dr['max_mm']:.4f} mm "
                         f"(line {dr['line_of_max']}), RMS {dr['rms_mm']:.4f} mm; ignored "
                         f"{dr['dropped']} failed reading(s) and {len(dr['stray_lines'])} stray reading(s) "
                         f"> {STRAY_MM:g} mm off (lines {dr['stray_lines'][:10]})")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The import's figures: observations, poses, SMRs, joints, poses per file, dropped readings
        ``[file, line, reason]``, the base SMR drift and the warnings."""
        d = self.data
        return {"observations": len(d), "poses": d.n_poses, "smr": d.n_smr, "joints": d.n_joints,
                "files": [[str(f), int(n)] for f, n in self.files],
                "dropped": [[str(f), int(ln), why] for f, ln, why in self.dropped],
                "drift": self.drift, "warnings": self.warnings}

    def write(self, output) -> list[str]:
        """Write the measurements as the canonical measurement CSV (`Measurements.save`); the
        paths written."""
        self.data.save(output)
        return [str(output)]


def _failed(points: np.ndarray, joints: np.ndarray) -> tuple[np.ndarray, list[str]]:
    zero = (points == 0).all(axis=1)
    nan = ~np.isfinite(points).all(axis=1) | ~np.isfinite(joints).all(axis=1)
    reasons = np.where(nan, "NaN in the row", "point is all zeros (failed reading)")
    return zero | nan, reasons


def _group_repeats(joints: np.ndarray) -> np.ndarray:
    """Group index (R,) of consecutive rows with identical joints."""
    new = np.ones(len(joints), bool)
    new[1:] = (joints[1:] != joints[:-1]).any(axis=1)
    return np.cumsum(new) - 1


def _parse_specs(raw, joints, points) -> tuple[list[str], ColumnSpec, list[ColumnSpec]]:
    """Validated raw file names, joints spec and points specs (one layout or the other)."""
    jspec = joints if isinstance(joints, ColumnSpec) else ColumnSpec.parse(joints, "joints")
    pspecs = [points] if isinstance(points, str | ColumnSpec) else list(points)
    pspecs = [p if isinstance(p, ColumnSpec) else ColumnSpec.parse(p, "points") for p in pspecs]
    if not pspecs:
        raise DataError("give at least one --points spec")
    raw = [str(r) for r in raw]
    separate = jspec.file is not None
    if separate and raw:
        raise DataError("give either raw files with joints and points columns, or --joints FILE:... with "
                        "--points FILE:... specs, not both")
    if not separate and not raw:
        raise DataError("no input: give raw files, or --joints FILE:cols=..:deg and --points FILE:..")
    if not separate and (any(p.file for p in pspecs) or len(pspecs) != 1):
        raise DataError("with raw files give one --points spec without a file (cols=..:unit)")
    if separate and any(p.file is None for p in pspecs):
        raise DataError("with --joints FILE:... every --points spec needs its FILE too")
    return raw, jspec, pspecs


def _read_blocks(raw: list[str], jspec: ColumnSpec, pspecs: list[ColumnSpec], skip_rows: int) -> list:
    """One block per points source: (joints (R, n), points (R, 3), smr, joint-file lines (R,),
    point-file lines (R,), points file, joints file)."""
    blocks = []
    if jspec.file is not None:
        jt, jl = read_table(jspec.file, skip_rows)
        q = _columns(jt, jl, jspec, jspec.file, "joints")
        for s, ps in enumerate(pspecs):
            pt, pl = read_table(ps.file, skip_rows)
            if len(pt) != len(jt):
                raise DataError(f"{ps.file} has {len(pt)} rows but {jspec.file} has {len(jt)}: a points "
                                "file needs one row per joints row")
            blocks.append((q, _columns(pt, pl, ps, ps.file, "points"), s, jl, pl, ps.file, jspec.file))
    else:
        for f in raw:
            t, lines = read_table(f, skip_rows)
            q, p = _columns(t, lines, jspec, f, "joints"), _columns(t, lines, pspecs[0], f, "points")
            blocks.append((q, p, 0, lines, lines, f, f))
    return blocks


def _group_stats(group: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """Per group of repeated readings: readings, mean point, max and RMS deviation from the mean."""
    n_groups = int(group.max()) + 1
    count = np.bincount(group, minlength=n_groups)
    mean = np.zeros((n_groups, 3))
    np.add.at(mean, group, points)
    mean /= count[:, None]
    dev = np.linalg.norm(points - mean[group], axis=1)
    gmax = np.zeros(n_groups)
    np.maximum.at(gmax, group, dev)
    gss = np.zeros(n_groups)
    np.add.at(gss, group, dev**2)
    return count, mean, gmax, np.sqrt(gss / count)


def import_tracker(raw=(), *, joints: str | ColumnSpec, points, base=(), average: bool = True,
                   skip_rows: int = 0) -> ImportResult:
    """Import raw files (see module docstring). ``points``: one spec or a list (one per SMR)."""
    raw, jspec, pspecs = _parse_specs(raw, joints, points)
    separate = jspec.file is not None
    dropped, files = [], []
    out = {k: [] for k in ("q", "p", "smr", "pose", "row", "approach", "travel", "spread_max", "spread_rms",
                           "readings")}
    next_pose = 0
    for b, (q, p, s, lines, plines, pfile, jfile) in enumerate(_read_blocks(raw, jspec, pspecs, skip_rows)):
        bad, why = _failed(p, q)
        dropped += [(pfile, int(plines[i]), str(why[i])) for i in np.flatnonzero(bad)]
        qk, pk, lk = q[~bad], p[~bad], lines[~bad]
        # separate files: row i of every file is pose i (no repeat detection); else repeats group
        group = np.arange(len(qk)) if separate else _group_repeats(qk)
        n_groups = int(group.max()) + 1 if len(group) else 0
        if not separate or b == 0:
            files.append((jfile, n_groups))
        if n_groups == 0:
            continue
        count, mean, gmax, grms = _group_stats(group, pk)
        first = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
        out["spread_max"].append(gmax)
        out["spread_rms"].append(grms)
        out["readings"].append(count)
        if separate:
            ids = lk  # the joints line number identifies the pose across SMR files
        else:
            ids = next_pose + (group if not average else np.arange(n_groups))
            next_pose += n_groups
        take = first if average else slice(None)
        out["q"].append(qk[take])
        out["p"].append(mean if average else pk)
        out["smr"].append(np.full(len(qk[take]), s))
        out["pose"].append(ids)
        out["row"].append(lk[take])
        # each raw file is a measuring run of its own: its first pose follows no row of another file
        out["approach"].append(approach_from_order(qk[take], ids))
        out["travel"].append(travel_from_order(qk[take], ids))
    if not out["q"]:
        raise DataError("no valid readings left after dropping failed rows")
    q, p, smr, pose_id, rows = (np.concatenate(out[k]) for k in ("q", "p", "smr", "pose", "row"))
    order = np.arange(len(q))
    approach = travel = None  # separate: one joints file, the row order's
    if separate:  # order by pose, then SMR; renumber poses 0..P-1
        order = np.lexsort((smr, pose_id))
        pose_id = np.unique(pose_id, return_inverse=True)[1]
    else:
        approach, travel = np.concatenate(out["approach"]), np.concatenate(out["travel"])
    names = [f for f, _ in files] + ([p.file for p in pspecs] if separate else [])
    files_text = ", ".join(Path(f).name for f in names)
    data = Measurements.from_arrays("point", q[order], points=p[order], smr=smr[order],
                                    pose_id=pose_id[order], source_row=rows[order],
                                    conditions=Conditions(approach, travel),
                                    source=f"imported by robocal from {files_text}")
    drift = [_drift(ColumnSpec.parse(b, "points") if isinstance(b, str) else b, skip_rows) for b in base]
    return ImportResult(data=data, dropped=dropped, spread_max=np.concatenate(out["spread_max"]),
                        spread_rms=np.concatenate(out["spread_rms"]),
                        readings=np.concatenate(out["readings"]), drift=drift, files=files)


def _drift(spec: ColumnSpec, skip_rows: int) -> dict:
    if spec.file is None:
        raise DataError("a --base spec needs its FILE, e.g. measured_base_1.txt:cols=0-2:mm")
    t, lines = read_table(spec.file, skip_rows)
    p = _columns(t, lines, spec, spec.file, "base points")
    bad, _ = _failed(p, np.zeros((len(p), 1)))
    p, lines = p[~bad], lines[~bad]
    if len(p) == 0:
        raise DataError(f"{spec.file}: every base reading failed")
    dev = np.linalg.norm(p - np.median(p, axis=0), axis=1)
    stray = dev > STRAY_MM * 1e-3
    if stray.all():
        raise DataError(f"{spec.file}: every base reading is more than {STRAY_MM:g} mm from their median "
                        "position (the drift monitor moved, or the file holds another target): check the "
                        "file")
    stray_lines = lines[stray].tolist()
    dev, lines = dev[~stray], lines[~stray]
    return {"file": spec.file, "max_mm": float(dev.max() * 1e3),
            "rms_mm": float(np.sqrt(np.mean(dev**2)) * 1e3),
            "line_of_max": int(lines[np.argmax(dev)]), "dropped": int(bad.sum()), "stray_lines": stray_lines}
