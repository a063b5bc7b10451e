"""The result of filtering a program: the filtered bytes, the per-target table, the per-motion
accounting (:mod:`robocal.programs.motions`) and the warnings; how they are summarised and written.

``FilterResult.table_json()`` holds ``summary`` (targets, corrections and ``motions``:
``{"total", "corrected", "named"}``), ``warnings``, ``targets`` (one row per target) and
``motions`` (one record per motion instruction to a Cartesian pose). Writing goes through
:func:`robocal.core.io.write_all`: the programs and the table together, or nothing.
"""

from __future__ import annotations

import csv
import io
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import check_outputs, write_all
from robocal.kinematics.model import Robot
from robocal.programs.motions import MotionRecord, summary, summary_line
from robocal.programs.registry import dialect_with_name
from robocal.programs.runtime import ROUTED
from robocal.trust.output_marker import ProgramMarker, corrected_path, mark_program

LISTED = 20  # problems (warnings) listed in one message
JSON_ROWS = 5_000  # table rows encoded by one call of json's encoder


@dataclass
class FilterResult:
    """``outputs``: input path -> filtered bytes; ``rows``: the per-target table; ``warnings``.

    Returned by `robocal.filter_program`; nothing is written until `write`.

    Attributes
    ----------
    dialect : str
        The program language (``'ABB RAPID'``, ``'KUKA KRL'``, ``'FANUC TP'``, ``'URScript'``,
        ``'Yaskawa INFORM'``, ``'Staubli VAL3'``).
    outputs : dict of pathlib.Path to bytes
        Each input file's filtered text, byte for byte the input except the corrected numbers.
    rows : list of dict
        One row per Cartesian target (the filter target table): file, line, name, frame, tool,
        ``correction_mm``, ``correction_deg``, configuration before and after, joint-limit margin
        (deg), singularity distances.
    warnings : list of str
        What the user should check (unreached targets kept, changed configurations...).
    uncorrected : list of str
        Motions to a Cartesian pose left as they are (also among the warnings).
    motions : list of MotionRecord
        One record per motion instruction to a Cartesian pose: corrected, or named with why.
    calibrated : Robot or None
        The model that corrected the targets; `write` puts its marker on the files.
    joints : numpy.ndarray, shape (T, n), optional
        Each target's joints on the calibrated model, radians, in the order of `rows`; NaN where
        a target was not corrected.
    loads : list of str
        For a model with a payload term, which motions ran with which load (one line per load:
        kg, centre of mass in tool0 mm, where the program sets it, the motions' lines).
    language : Dialect, optional
        The language's dialect, which marks the written files (default: the registered one
        named `dialect`).
    data_files : frozenset of pathlib.Path
        Outputs that are data, not programs: written without a marker.
    derived : frozenset of pathlib.Path
        Outputs made from the references, written beside the first output.

    See Also
    --------
    rc.filter_program : The filter that returns it.

    Examples
    --------
    >>> from pathlib import Path
    >>> import robocal as rc
    >>> target = ("[[1139.82,200.98,722.77],[0.1300295,-0.08641011,0.98767211,0.01137611],[0,0,-1,0],"
    ...           "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]")  # mm, quaternion, configuration
    >>> lines = ["MODULE Cell", f"  CONST robtarget pPick:={target};", "  PROC main()",
    ...          "    MoveJ pPick, v1000, fine, tool0;", "  ENDPROC", "ENDMODULE", ""]
    >>> _ = Path("cell.mod").write_text("\\n".join(lines))
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> real = nominal.with_values({"a2": nominal.get("a2") + 0.0005})  # a link 0.5 mm longer
    >>> result = rc.filter_program("cell.mod", real, nominal)
    >>> row = result.rows[0]
    >>> row["name"], round(row["correction_mm"], 3), row["configuration"]
    ('pPick', 0.5, 'kept')
    >>> result.summary_dict()["filtered"], result.warnings
    (1, [])
    """

    dialect: str
    outputs: dict[Path, bytes]
    rows: list[dict]
    warnings: list[str] = field(default_factory=list)
    uncorrected: list[str] = field(default_factory=list)  # motions left as they are (also warnings)
    motions: list[MotionRecord] = field(default_factory=list)  # every motion to a Cartesian pose
    calibrated: Robot | None = None  # the model that corrected the targets: its marker goes on the files
    joints: np.ndarray | None = None  # (targets, n) rad on the calibrated model, NaN where not corrected
    data_files: frozenset[Path] = frozenset()  # outputs that are data, not programs (marked in their syntax)
    # outputs made from the reference files (FANUC PR_CAL.LS, INFORM VAR_CAL.DAT): no input of their
    # own; `write` puts them beside the programs unless a path is given
    derived: frozenset[Path] = frozenset()
    loads: list[str] = field(default_factory=list)  # which motions ran with which load (payload term)
    language: ProgramMarker | None = field(default=None, repr=False, compare=False)  # marks the files

    def table_csv(self) -> str:
        """The per-target table as CSV text (one row per target, `rows`' columns).

        Returns
        -------
        str
            The CSV text.
        """
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        cols = list(self.rows[0]) if self.rows else ["file", "line", "name"]
        writer.writerow(cols)
        for r in self.rows:
            writer.writerow([f"{r[c]:.6g}" if isinstance(r[c], float) else r[c] for c in cols])
        return out.getvalue()

    def to_dict(self) -> dict:
        """The result as plain data: the dialect, the filtered files, the summary
        (`summary_dict`), the loads, the warnings, the per-target table and the motions (what
        `table_json` writes).

        Returns
        -------
        dict
            The result (JSON-ready).
        """
        return {"dialect": self.dialect, "files": [str(p) for p in self.outputs],
                "summary": self.summary_dict(), "loads": self.loads, "warnings": self.warnings,
                "targets": self.rows, "motions": [m.as_dict() for m in self.motions]}

    def table_json(self) -> str:
        """The per-target table, the summary, the motions and the warnings as JSON text: one key
        per line, one target or motion per line (each encoded by json's C encoder: an indented dump
        runs the pure-Python encoder, seconds for a 100,000-target program).

        Returns
        -------
        str
            The JSON text.
        """
        content = self.to_dict()
        lists = {key: content.pop(key) for key in ("targets", "motions")}
        parts = ["{\n", ",\n".join(f" {json.dumps(k)}: {json.dumps(v)}" for k, v in content.items())]
        for k, rows in lists.items():
            parts.append(f",\n {json.dumps(k)}: [")
            for s in range(0, len(rows), JSON_ROWS):  # a few MB of text at a time, joined once
                parts.append(("," if s else "") + _one_per_line(rows[s:s + JSON_ROWS]))
            parts.append("\n ]")
        parts.append("\n}\n")
        return "".join(parts)

    def summary_dict(self) -> dict:
        """Counts and extremes: targets filtered, motions corrected and named, configurations
        changed, corrections (mm, deg), the smallest joint-limit margin and the nearest singularity.

        Returns
        -------
        dict
            The counts and extremes (mm, deg) (JSON-ready).
        """
        rows = [r for r in self.rows if r["filtered"]]
        pos = np.array([r["correction_mm"] for r in rows]) if rows else np.zeros(0)
        rot = np.array([r["correction_deg"] for r in rows]) if rows else np.zeros(0)
        margin = [r["limit_margin_deg"] for r in rows]
        sig = [r["sigma_rel"] for r in rows if "sigma_rel" in r]  # none on a SCARA (no wrist singularity)
        out = {"targets": len(self.rows), "filtered": len(rows),
               "configuration_changed": sum(r["configuration"] == "changed" for r in rows),
               "correction_mm": {"median": float(np.median(pos)) if pos.size else 0.0,
                                 "max": float(pos.max(initial=0.0))},
               "correction_deg": {"median": float(np.median(rot)) if rot.size else 0.0,
                                  "max": float(rot.max(initial=0.0))},
               "motions": summary(self.motions),
               "uncorrected_motions": len(self.uncorrected), "warnings": len(self.warnings)}
        if rows:
            i = int(np.argmin(margin))
            out["smallest_limit_margin"] = {"name": rows[i]["name"], "deg": margin[i],
                                            "joint": rows[i]["limit_joint"], "unit": rows[i]["limit_unit"]}
        if sig:
            j = int(np.argmin(sig))
            out["nearest_singularity"] = {"name": rows[j]["name"], "kind": rows[j]["nearest_singularity"],
                                          "sigma_rel": sig[j]}
        return out

    def summary(self) -> str:
        """A short human summary of `summary_dict` and the warnings.

        Returns
        -------
        str
            The summary text.
        """
        s = self.summary_dict()
        lines = [f"{self.dialect}: {s['filtered']} of {s['targets']} Cartesian target(s) filtered in "
                 f"{', '.join(p.name for p in self.outputs)}"]
        lines.append(f"  {summary_line(s['motions'])}")
        routed = sum(m.reason.startswith(ROUTED) for m in self.motions)
        if routed:
            lines.append(f"  {routed} of them corrected at run time by the routine added to the program "
                         "(--runtime-correction)")
        if len(self.uncorrected) > s["motions"]["named"]:
            lines.append(f"  {len(self.uncorrected)} place(s) where a Cartesian pose is not corrected, calls "
                         "of routines not in these files included (each named in a warning below)")
        if s["filtered"]:
            lines += [f"  correction  median {s['correction_mm']['median']:.3f} mm, max "
                      f"{s['correction_mm']['max']:.3f} mm; orientation median "
                      f"{s['correction_deg']['median']:.4f} deg, max {s['correction_deg']['max']:.4f} deg",
                      f"  configuration changed on {s['configuration_changed']} target(s)",
                      f"  smallest joint-limit margin {s['smallest_limit_margin']['deg']:.2f} "
                      f"{s['smallest_limit_margin']['unit']} "
                      f"({s['smallest_limit_margin']['name']}, joint {s['smallest_limit_margin']['joint']})"]
            if "nearest_singularity" in s:
                lines.append(f"  nearest singularity: {s['nearest_singularity']['name']} "
                             f"({s['nearest_singularity']['kind']}, sigma_rel "
                             f"{s['nearest_singularity']['sigma_rel']:.4f})")
        lines += [f"  load: {line}" for line in self.loads]
        shown = collapse(self.warnings)
        for w in shown[:LISTED]:
            lines.append(f"  warning: {w}")
        if len(shown) > LISTED:
            lines.append(f"  ... {len(shown) - LISTED} more warning(s) in the table")
        return "\n".join(lines)

    def write(self, outputs: dict[Path, Path] | Path | str, table: str | Path | None = None) -> list[Path]:
        """Write the filtered files (input path -> output path, or one output path for a single
        input; a file made from the references (`derived`) goes beside the first output under its
        own name unless the mapping gives it a path) and the table (``table`` ending .csv or .json:
        that one; otherwise both ``table.csv`` and ``table.json``), all together or none. Refuses to
        overwrite an input. Every file carries the calibrated model's marker in its own comment
        syntax, a data file too (`robocal.trust.output_marker.mark_program`); one without comments
        (a VAR.DAT) is marked by its name: written as ``<stem>_CAL<suffix>`` beside the output
        path given, unless that name already says so (`robocal.trust.output_marker.corrected_path`).
        Returns the paths written.

        Parameters
        ----------
        outputs : dict of path to path, or str or path-like
            Input path -> output path, or one output path when there is one input.
        table : str or path-like, optional
            The target table: a ``.csv`` or ``.json`` file, or a stem for both.

        Returns
        -------
        list of pathlib.Path
            The files written.

        Raises
        ------
        DataError
            One output path for several inputs, or an output that would overwrite an input.
        """
        inputs = [p for p in self.outputs if p not in self.derived]
        if not isinstance(outputs, dict):
            if len(inputs) != 1:
                raise DataError("several program files: give one output path per input")
            outputs = {inputs[0]: Path(outputs)}
        folder = Path(next(iter(outputs.values()))).parent if outputs else Path(".")
        outputs = {**{p: folder / Path(p).name for p in self.derived}, **outputs}
        files: dict[Path, bytes] = {}
        for src, dst in outputs.items():  # marked with the calibrated model that corrected them
            data = self.outputs[Path(src)]  # programs and data files alike (a register file too)
            if self.calibrated is None:
                files[Path(dst)] = data
                continue
            marked = mark_program(self.language or dialect_with_name(self.dialect), data, self.calibrated)
            if marked is None:  # no comment syntax (a VAR.DAT): marked by its name
                files[corrected_path(dst)] = data
            else:
                files[Path(dst)] = marked
        for t in table_paths(table) if table is not None else []:
            files[t] = (self.table_csv() if t.suffix.lower() == ".csv" else self.table_json()).encode()
        check_outputs(files, self.outputs)
        write_all(files)
        return list(files)


_ITEMS = ",\x00"  # json's separator between items, marked: a raw NUL is never inside encoded JSON


def _one_per_line(rows: list[dict]) -> str:
    """``rows`` (flat dicts of scalars) as JSON, each on its own line after a newline and two
    spaces, comma-separated: what ``json.dumps`` of each row gives, encoded by one call of json's
    C encoder (the separator between rows is told from the one between a row's items by the
    braces around it)."""
    if not rows:
        return ""
    text = json.dumps(rows, separators=(_ITEMS, ": "))
    return "\n  " + text[1:-1].replace("}" + _ITEMS + "{", "},\n  {").replace(_ITEMS, ", ")


_WHERE = re.compile(r"^(\S+:\d+(?: \([^)]*\))?): (.*)$", re.DOTALL)
SHOWN_PLACES = 4  # places named in one collapsed line


def collapse(lines: list[str]) -> list[str]:
    """Messages ``file:line (name): why`` with the same ``why`` collapsed into one line naming the
    first places and how many there are; other messages as they are, in order of first
    appearance."""
    groups: dict[str, list[str]] = {}
    for line in lines:
        m = _WHERE.match(line)
        where, why = (m.group(1), m.group(2)) if m else ("", line)
        groups.setdefault(why, []).append(where)
    out = []
    for why, places in groups.items():
        places = [p for p in places if p]
        if len(places) <= 1:
            out.append(f"{places[0]}: {why}" if places else why)
        else:
            more = f" and {len(places) - SHOWN_PLACES} more" if len(places) > SHOWN_PLACES else ""
            out.append(f"{why} ({len(places)} places: {', '.join(places[:SHOWN_PLACES])}{more})")
    return out


def table_paths(table: str | Path) -> list[Path]:
    """The table file(s) :meth:`FilterResult.write` writes for ``table``: that file when it ends
    .csv or .json, else ``table.csv`` and ``table.json``."""
    t = Path(table)
    if t.suffix.lower() in (".csv", ".json"):
        return [t]
    return [t.with_name(t.name + ".csv"), t.with_name(t.name + ".json")]


