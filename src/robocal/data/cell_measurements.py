"""Measurements of a work cell: rows on several bodies (arms, positioners) in one tracker frame.

A cell's measurement CSV is the canonical measurement CSV (`robocal.data.measurements`) with two
more things:

- a ``body`` column naming the body that carries each row's SMR: an arm's name, a positioner's name
  or its mechanical unit (``STN1``); ``flange`` is the anchor arm and ``plate`` the only positioner
  (aliases). Without a ``body`` column every row is on the anchor (today's files unchanged);
- the positioners' joint columns, named as each `Positioner` declares them (``e1_deg``, ``e2_deg``:
  its ``columns`` with a unit, ``_deg``/``_rad`` or ``_mm``/``_m`` for a prismatic axis).

The arm columns (``q1_deg..``, a track's ``e1_mm``) hold the joints of the row's ARM (with two arms,
each row's q columns are the joints of the arm its body names); a positioner's columns on an arm
row are the table's position then (free to leave empty: the arm's rows do not depend on it). A
positioner row needs its positioner's values and ignores the arm columns.

Because each SMR sits on one body, the rows split per body into ordinary `Measurements` of that
body's chain (`CellMeasurements.bodies`): an arm's rows with the arm's joints, a positioner's rows
with its axes as joints (``q1..qn`` of its chain, SI), everything else (x/y/z, smr, sigma, pose_id,
quaternions) as the canonical reader reads it, with the line numbers of the cell file.

Refused with one line naming the file and the line, nothing returned: a body that is not in the
cell, a positioner row without its positioner's columns or values, a positioner value outside its
axis' limits.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from robocal.core.errors import DataError, ModelError
from robocal.core.escape import line_text
from robocal.core.io import read_text, write_atomic
from robocal.data.csv_table import text_lines
from robocal.data.measurements import Measurements, joint_range_rad, parse_csv

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

BODY_COLUMN = "body"
# columns of the arm's joints and of its working conditions: a positioner row does not use them
_ARM_ONLY = re.compile(r"([qe]\d+_[a-z]+|approach\d+|travel\d+_[a-z]+|payload_.*|temperature_c)")


def _joint_names(cell, name: str) -> tuple[str, ...]:
    """The joint column names (no unit) of body ``name`` in a cell file (`Cell.joints`): an arm's
    ``q1``.. (a track's ``e1``), a positioner's columns (``e1``, ``e2``)."""
    return tuple(j.name for j in cell.joints(name))


def _resolved(cell, label: str, where: str) -> str:
    """The body a ``body`` cell names (`robocal.kinematics.workcell.Cell.resolve`: a body's name or
    unit, ``flange``, ``plate``); DataError naming ``where`` and the cell's bodies otherwise."""
    try:
        return cell.resolve(label)
    except ModelError:
        raise DataError(f"{where}: body {label!r} is not in the cell (its bodies: {', '.join(cell.bodies)}; "
                        "flange: the first arm, plate: the only positioner)") from None


def _row_cells(line: str, name: str, ln: int) -> list[str]:
    try:
        return next(csv.reader([line]), [])
    except csv.Error as exc:
        raise DataError(f"{name}, line {ln}: not a valid CSV row ({exc})") from None


def _csv_line(cells: list[str]) -> str:
    out = io.StringIO()
    csv.writer(out, lineterminator="").writerow(cells)
    return out.getvalue()


def _skipped(line: str) -> bool:
    return line.lstrip().startswith("#") or not line.replace(",", "").strip()


class _Table:
    """The cell CSV as text: the lines above the header, the header, each data line's cells and
    line number, and the body of each data row (the ``body`` column resolved)."""

    def __init__(self, text: str, cell, name: str) -> None:
        lines = list(text_lines(text))
        start = next((k for k, line in enumerate(lines) if not _skipped(line)), None)
        if start is None:
            raise DataError(f"{name}: the file is empty; a measurement CSV needs a header line and data rows")
        self.name, self.top, self.n_lines = name, lines[:start], len(lines)
        self.header = [h.strip().lower() for h in _row_cells(lines[start], name, start + 1)]
        self.header_line = start + 1
        self.rows: list[tuple[int, list[str]]] = [
            (k + 1, _row_cells(line, name, k + 1)) for k, line in enumerate(lines[start + 1:], start + 1)
            if not _skipped(line)]
        for ln, cells in self.rows:
            if len(cells) != len(self.header):
                raise DataError(f"{name}, line {ln}: {len(cells)} values but the header has "
                                f"{len(self.header)} columns; fix or remove that row")
        self.body = self._bodies(cell)

    def _bodies(self, cell) -> list[str]:
        if BODY_COLUMN not in self.header:
            theirs = [h for n, p in cell.positioners.items() if n != cell.anchor
                      for h in self.columns_of(tuple(p.columns)).values()
                      if any(cells[self.header.index(h)].strip() for _, cells in self.rows)]
            if theirs:  # every row would be taken as the anchor's, a plate row's empty joints refused
                raise DataError(f"{self.name}, line {self.header_line}: no '{BODY_COLUMN}' column, but the "
                                f"positioners' columns ({', '.join(theirs)}) are there: say on each row "
                                f"which body carries the SMR ({', '.join(cell.bodies)}; or flange / plate)")
            return [cell.anchor] * len(self.rows)
        k, seen, out = self.header.index(BODY_COLUMN), {}, []
        for ln, cells in self.rows:
            text = cells[k].strip()
            if text not in seen:
                seen[text] = _resolved(cell, text, f"{self.name}, line {ln}")
            out.append(seen[text])
        return out

    def columns_of(self, unit_names: tuple[str, ...]) -> dict[str, str]:
        """Joint base name (``e1``) -> its header column (``e1_deg``) for the names in the header."""
        out = {}
        for h in self.header:
            base = h.rsplit("_", 1)[0]
            if base in unit_names and "_" in h:
                if base in out:
                    raise DataError(f"{self.name}, line {self.header_line}: two columns for axis {base} "
                                    f"({out[base]}, {h}): keep one")
                out[base] = h
        return out


def _positioner_columns(table: _Table, cell) -> dict[str, dict[str, str]]:
    """Per positioner: its joint base names -> header columns present."""
    return {n: table.columns_of(tuple(p.columns)) for n, p in cell.positioners.items()}


def _body_text(table: _Table, body: str, keep: list[int], names: list[str]) -> str:
    """The canonical CSV text of ``body``'s rows (header ``names`` of the columns ``keep``), every
    other row a blank line so that line numbers stay the cell file's."""
    lines = [*table.top, _csv_line(names)]
    by_line = {ln: cells for (ln, cells), b in zip(table.rows, table.body, strict=True) if b == body}
    for ln in range(table.header_line + 1, table.n_lines + 1):
        cells = by_line.get(ln)
        lines.append("" if cells is None else _csv_line([cells[k] for k in keep]))
    return "\n".join(lines) + "\n"


def _body_columns(table: _Table, cell, body: str, positioner_cols: dict) -> tuple[list[int], list[str]]:
    """The columns (indices, canonical names) of ``body``'s rows: an arm's without the body and
    positioner columns; a positioner's without the arm-only ones, its axes renamed to its chain's
    joint names; columns empty on every row of the body left out."""
    rows = [cells for (_, cells), b in zip(table.rows, table.body, strict=True) if b == body]
    filled = [any(cells[k].strip() for cells in rows) for k in range(len(table.header))]
    others = {h for cols in positioner_cols.values() for h in cols.values()}
    keep, names = [], []
    if body in cell.positioners:
        own = {h: base for base, h in positioner_cols[body].items()}
        chain_names = [j.name for j in cell.positioners[body].chain.joints]
        base_index = {base: i for i, base in enumerate(cell.positioners[body].columns)}
        for k, h in enumerate(table.header):
            if h in own:
                keep.append(k)
                names.append(f"{chain_names[base_index[own[h]]]}_{h.rsplit('_', 1)[1]}")
            elif filled[k] and h != BODY_COLUMN and h not in others and not _ARM_ONLY.fullmatch(h):
                keep.append(k)
                names.append(h)
        return keep, names
    for k, h in enumerate(table.header):
        if filled[k] and h != BODY_COLUMN and h not in others:
            keep.append(k)
            names.append(h)
    return keep, names


def _file_columns(message: str, header: list[str], names: list[str]) -> str:
    """``message`` with each column renamed for reading (``q1_rad``) named as the file has it
    (``e1_rad``)."""
    renamed = {n: h for h, n in zip(header, names, strict=True) if n != h}
    if not renamed:
        return message
    return re.sub(r"\b(" + "|".join(map(re.escape, renamed)) + r")\b", lambda m: renamed[m[1]], message)


def _check_positioner_rows(table: _Table, cell, body: str, cols: dict[str, str]) -> None:
    """A positioner's rows need every one of its columns, each filled."""
    p = cell.positioners[body]
    lines = [ln for (ln, _), b in zip(table.rows, table.body, strict=True) if b == body]
    missing = [c for c in p.columns if c not in cols]
    if missing:
        want = ", ".join(f"{c}_deg" for c in p.columns)
        raise DataError(f"{table.name}, line {lines[0]}: a row on the positioner {body}'s plate but the file "
                        f"has no column for its axis {missing[0]}: give the positioner's joints ({want})")
    index = [table.header.index(cols[c]) for c in p.columns]
    for (ln, cells), b in zip(table.rows, table.body, strict=True):
        if b == body and (empty := [table.header[k] for k in index if not cells[k].strip()]):
            raise DataError(f"{table.name}, line {ln}: a row on the positioner {body}'s plate without its "
                            f"value {empty[0]}: every plate row needs the positioner's joints")


def _check_limits(data: Measurements, chain, body: str, columns: tuple[str, ...], name: str) -> None:
    """Positioner values within its axes' limits (one line naming the row and the axis)."""
    lo, hi = chain.limits[:, 0], chain.limits[:, 1]
    bad = chain.outside_limits(data.joints)
    if bad.any():
        r, j = np.argwhere(bad)[0]
        spec = chain.joints[j]
        shown = spec.shown(np.array([data.joints[r, j], lo[j], hi[j]]))
        raise DataError(f"{name}, line {int(data.source_row[r])}: the positioner {body}'s axis "
                        f"{columns[j]} = {shown[0]:.6g} {spec.unit} is outside its limits ({shown[1]:.6g} .. "
                        f"{shown[2]:.6g} {spec.unit}): a wrong column or unit, or the cell file's limits")


@dataclass(frozen=True, eq=False)
class CellMeasurements:
    """A cell's measurements split per body (module docstring).

    Attributes
    ----------
    bodies : dict of str to Measurements
        Body name -> its rows as ordinary measurements of its chain (joints = that body's joints,
        SI), in the cell's order (arms, then positioners); bodies without rows are absent.
    columns : dict of str to tuple of str
        Body name -> its joints' column names in the cell file, without unit (``q1``.., ``e1``).
    file : str
        The file it was read from ("" when built from arrays).
    source : str
        The provenance text (the file's first ``#`` comment).

    See Also
    --------
    rc.Measurements : One body's measurements.
    rc.Cell : The cell they measure.
    rc.simulate_cell : Simulated measurements of a cell.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> mount = np.eye(4)
    >>> mount[0, 3] = 1.5  # the table 1.5 m in front of the arm
    >>> nests = [[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]]  # m, on the plate
    >>> table = rc.Positioner.from_catalog("abb_irbp_a250", "STN1", mount, nests=nests)
    >>> cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")}, {"STN1": table})
    >>> sim = rc.simulate_cell(cell, 30, 20, seed=1)
    >>> data = sim.data  # a CellMeasurements
    >>> back = rc.CellMeasurements.parse(data.to_csv(), cell)  # the cell's CSV, read back
    >>> sorted(back.bodies), bool(np.allclose(back.bodies["STN1"].points, data.bodies["STN1"].points))
    (['STN1', 'arm'], True)
    """

    bodies: Mapping[str, Measurements]
    columns: Mapping[str, tuple[str, ...]]
    file: str = ""
    source: str = ""

    def __post_init__(self) -> None:
        if not self.bodies:
            raise DataError("a cell's measurements need rows on at least one body")
        for name, data in self.bodies.items():
            if not isinstance(data, Measurements):
                raise DataError(f"body {name}: expected Measurements, got {type(data).__name__}")
            if name not in self.columns or len(self.columns[name]) != data.n_joints:
                raise DataError(f"body {name}: give its {data.n_joints} joint column names")

    def __len__(self) -> int:
        return sum(len(d) for d in self.bodies.values())

    def __getitem__(self, body: str) -> Measurements:
        if body not in self.bodies:
            raise DataError(f"no rows on body {body!r} (bodies with rows: {', '.join(self.bodies)})")
        return self.bodies[body]

    @property
    def label(self) -> str:
        """How messages name the set: its file, else its provenance text."""
        return self.file or self.source

    @classmethod
    def from_bodies(cls, cell: Cell, bodies: Mapping[str, Measurements],
                    source: str = "") -> CellMeasurements:
        """Measurements of ``cell`` from per-body measurements (joints of each body's chain, SI);
        each body checked against its chain, a positioner's values against its limits.

        Parameters
        ----------
        cell : Cell
            The cell.
        bodies : mapping of str to Measurements
            Each body's measurements.
        source : str, optional
            Where they come from, for messages.

        Returns
        -------
        CellMeasurements
            The cell's measurements.
        """
        out = {}
        for name, data in bodies.items():
            body = _resolved(cell, str(name), "the data")
            chain = cell.body(body)
            data.check_against(chain)
            if body in cell.positioners:
                _check_limits(data, chain, body, _joint_names(cell, body), data.label or "the data")
            out[body] = data
        order = [b for b in [*cell.arms, *cell.positioners] if b in out]
        return cls({b: out[b] for b in order}, {b: _joint_names(cell, b) for b in order}, source=source)

    @classmethod
    def parse(cls, text: str, cell: Cell, name: str = "<text>") -> CellMeasurements:
        """Parse a cell's measurement CSV text (module docstring); ``name`` names it in messages.

        Parameters
        ----------
        text : str
            The CSV text.
        cell : Cell
            The cell it measures.
        name : str, optional
            Its name in messages.

        Returns
        -------
        CellMeasurements
            The rows.

        Raises
        ------
        DataError
            A malformed file.
        """
        table = _Table(text, cell, name)
        if not table.rows:
            raise DataError(f"{name}: the file has a header but no data rows")
        positioner_cols = _positioner_columns(table, cell)
        present = [b for b in [*cell.arms, *cell.positioners] if b in set(table.body)]
        for body in present:
            if body in cell.positioners:
                _check_positioner_rows(table, cell, body, positioner_cols[body])
        bodies = {}
        for body in present:
            chain = cell.body(body)
            keep, names = _body_columns(table, cell, body, positioner_cols)
            try:
                data = parse_csv(_body_text(table, body, keep, names), name, joint_range_rad(chain))
                data.check_against(chain, path=name)
            except DataError as exc:  # a positioner's axes are read as its chain's joints: name the file's
                raise DataError(_file_columns(str(exc), [table.header[k] for k in keep], names)) from None
            data = replace(data, external=chain.external_axes, file=name)
            if body in cell.positioners:
                _check_limits(data, chain, body, _joint_names(cell, body), name)
            bodies[body] = data
        first = next(iter(bodies.values()))
        return cls(bodies, {b: _joint_names(cell, b) for b in bodies}, file=name, source=first.source)

    @classmethod
    def load(cls, path: str | Path, cell: Cell) -> CellMeasurements:
        """Read a cell's measurement CSV (module docstring) for ``cell``.

        Parameters
        ----------
        path : str or path-like
            The CSV file.
        cell : Cell
            The work cell whose bodies the ``body`` column names.

        Returns
        -------
        CellMeasurements

        Raises
        ------
        DataError
            A body not in the cell, a positioner row without its columns or values, a positioner
            value outside its limits, or anything the canonical reader refuses (naming the line).
        """
        path = Path(path)
        return cls.parse(read_text(path, "measurement file"), cell, str(path))

    def _rows(self) -> Iterator[tuple[int, str, dict[str, str]]]:
        """(source row, body, {column: text}) of every row, the joints under the cell's names."""
        for body, data in self.bodies.items():
            reader = csv.reader(line for line in data.to_csv().splitlines() if not line.startswith("#"))
            header = next(reader)
            rename = {data.joint_column(k, unit): f"{self.columns[body][k]}{unit}"
                      for k in range(data.n_joints) for unit in ("_rad", "_m")}
            for row, values in zip(data.source_row, reader, strict=True):
                yield int(row), body, {rename.get(h, h): v for h, v in zip(header, values, strict=True)}

    def to_csv(self) -> str:
        """The cell's CSV text (SI columns, a ``body`` column; rows in their source order): `parse`
        gives the same values back.

        Returns
        -------
        str
            The CSV text.
        """
        rows = sorted(self._rows(), key=lambda r: r[0])
        header = [BODY_COLUMN] + list(dict.fromkeys(h for _, _, cells in rows for h in cells))
        out = io.StringIO()
        if self.source:
            out.write(f"# {line_text(self.source)}\n")
        instrument = next((d.instrument for d in self.bodies.values() if d.instrument), "")
        if instrument:
            out.write(f"# instrument: {line_text(instrument)}\n")
        out.write(",".join(header) + "\n")
        for _, body, cells in rows:
            out.write(_csv_line([body] + [cells.get(h, "") for h in header[1:]]) + "\n")
        return out.getvalue()

    def save(self, path) -> None:
        """Write `to_csv` atomically.

        Parameters
        ----------
        path : str or pathlib.Path
            The CSV file to write.
        """
        write_atomic(path, self.to_csv())

    def split_poses(self, fraction: float = 0.5, seed: int = 0) -> tuple[CellMeasurements, CellMeasurements]:
        """Each body's poses split at random into (first, rest) (`Measurements.split_poses`).

        Parameters
        ----------
        fraction : float, default 0.5
            Share of each body's poses in the first part.
        seed : int, default 0
            Seed of the random choice.

        Returns
        -------
        tuple of CellMeasurements
            ``(first, rest)``.
        """
        parts = {b: d.split_poses(fraction, seed) for b, d in self.bodies.items()}
        return tuple(replace(self, bodies={b: p[k] for b, p in parts.items()}) for k in (0, 1))
