"""Provenance markers on robocal's outputs.

A filtered robot program and a compensated targets file say, in the format's own comment syntax,
which calibrated model corrected them and which robocal version did it::

    robocal <version> model <fingerprint>

``fingerprint`` is the first `FINGERPRINT_HEX` hex digits of the SHA-256 of the calibrated
model's canonical parameters (every parameter name with its SI value to 12 significant digits:
the same model loaded from any of its files gives the same fingerprint). Reading a marked file
back in (filtering a filtered program, compensating compensated targets: the corrections applied
twice) is refused, naming the earlier run, unless the caller forces it.

Where the marker goes is one added line (the rest of the file byte for byte the same) in the
format's own comment syntax: each robot language says where in its
``programs/dialects/<language>/marker.py`` (registered in `robocal.programs.registry`); a CSV
(compensated targets) carries ``# ...`` as its first line (robocal's CSV readers skip leading ``#``
lines). A language whose comments are short cuts the fingerprint to fit (`shortened`, never below
`_SHORTEST_HEX` hex digits).

A format with no comment syntax carries no line of robocal's: its corrected copy is marked by its
name, ``<stem>_CAL<suffix>`` (`corrected_name`; the writer names it so whatever output name it is
given), and a file so named is refused as input like a marked one (`check_unmarked_name`). What the
name cannot cover: a user who renames the corrected copy and gives that back to robocal.

See Also
--------
rc.filter_program : Marks the programs it writes.
rc.compensate : Marks the targets it writes (``Compensation.write``).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from robocal.core.bom import bom_length
from robocal.core.errors import DataError
from robocal.core.version import __version__
from robocal.kinematics.model import Robot

FINGERPRINT_HEX = 12  # hex digits of the SHA-256 kept: 48 bits, a collision 1 in 2.8e14
_SHORTEST_HEX = 8  # a marker cut to fit a short comment keeps at least this many hex digits
_SIGNIFICANT = 12  # significant digits of each parameter in the canonical text
MARKER_RE = re.compile(rf"robocal (?P<version>\d[\w.+-]*) "
                       rf"model (?P<model>[0-9a-f]{{{_SHORTEST_HEX},{FINGERPRINT_HEX}}})\b")
_NOTE = {"filtered": "targets filtered, do not filter again",
         "compensated": "targets compensated, do not compensate again"}


@dataclass(frozen=True)
class Marker:
    """A marker found in a file: the robocal ``version`` and the calibrated ``model`` fingerprint.

    Attributes
    ----------
    version : str
        The robocal version that wrote the file.
    model : str
        The calibrated model's fingerprint: ``FINGERPRINT_HEX`` hex digits of the SHA-256 of its
        parameters (fewer where a language's comment is short: cut to fit).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.trust.output_marker import find_marker, marker_text, model_fingerprint
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> program = "MODULE weld\\n  ! " + marker_text(robot) + "\\nENDMODULE\\n"
    >>> marker = find_marker(program)
    >>> marker.model == model_fingerprint(robot), marker.version == rc.__version__
    (True, True)
    >>> marker.describe() == f"robocal {rc.__version__} with the calibrated model {marker.model}"
    True
    >>> find_marker("MODULE weld\\nENDMODULE\\n") is None  # an unmarked program
    True
    """

    version: str
    model: str

    def describe(self) -> str:
        return f"robocal {self.version} with the calibrated model {self.model}"


def model_fingerprint(robot: Robot) -> str:
    """The `FINGERPRINT_HEX` hex digits naming ``robot``'s parameters (see the module
    docstring).

    Parameters
    ----------
    robot : Robot
        The model.

    Returns
    -------
    str
        The fingerprint (hex digits).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.trust.output_marker import model_fingerprint
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> len(model_fingerprint(robot)), model_fingerprint(robot) == model_fingerprint(robot)
    (12, True)
    >>> longer = robot.with_values({"a2": robot.get("a2") + 1e-6})  # 1 um on one link
    >>> model_fingerprint(longer) == model_fingerprint(robot)
    False
    """
    canon = "\n".join(f"{name}={value:.{_SIGNIFICANT}g}"
                      for name, value in zip(robot.parameter_names, robot.values.tolist(), strict=True))
    return hashlib.sha256(canon.encode()).hexdigest()[:FINGERPRINT_HEX]


def marker_text(robot: Robot) -> str:
    """``robocal <version> model <fingerprint>`` of this robocal and ``robot``.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.trust.output_marker import marker_text, model_fingerprint
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> marker_text(robot) == f"robocal {rc.__version__} model {model_fingerprint(robot)}"
    True
    """
    return f"robocal {__version__} model {model_fingerprint(robot)}"


def find_marker(text: str) -> Marker | None:
    """The first marker in ``text``, else None.

    Parameters
    ----------
    text : str
        A file's text.

    Returns
    -------
    Marker or None
        The version and model fingerprint it names.

    Examples
    --------
    >>> from robocal.trust.output_marker import find_marker
    >>> find_marker("! robocal 0.1.0 model ebba57c5590e: targets filtered")
    Marker(version='0.1.0', model='ebba57c5590e')
    >>> find_marker("! written by hand") is None
    True
    """
    m = MARKER_RE.search(text)
    return None if m is None else Marker(m.group("version"), m.group("model"))


def check_unmarked(text: str, where: str, action: str, force: bool = False) -> Marker | None:
    """Refuse (DataError) a file that carries a marker: ``action`` ('filtered' or 'compensated') was
    already done to it by the run the marker names; ``force`` lets it through (the marker is
    returned, for a warning).

    Parameters
    ----------
    text : str
        The file's text.
    where : str
        Its name, for the message.
    action : {"filtered", "compensated"}
        What the caller is about to do.
    force : bool, default False
        Let a marked file through.

    Returns
    -------
    Marker or None
        The marker found (only with ``force``), None for an unmarked file.

    Raises
    ------
    DataError
        A marked file without ``force``.

    Examples
    --------
    >>> from robocal.trust.output_marker import check_unmarked
    >>> check_unmarked("x,y,z\\n", "targets.csv", "compensated") is None  # unmarked: go on
    True
    >>> marked = "# robocal 0.1.0 model ebba57c5590e: targets compensated\\nx,y,z\\n"
    >>> check_unmarked(marked, "targets.csv", "compensated")
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: targets.csv was already compensated by robocal 0.1.0 with the ...
    >>> check_unmarked(marked, "targets.csv", "compensated", force=True).model
    'ebba57c5590e'
    """
    found = find_marker(text)
    if found is not None and not force:
        verb = action[:-2] if action.endswith("ed") else action
        raise DataError(f"{where} was already {action} by {found.describe()}: {verb}ing its output again "
                        f"applies the corrections twice; start from the original file (or give --force "
                        "if this one really is uncorrected)")
    return found


CORRECTED_STEM = "_CAL"  # the end of the stem of a corrected copy marked by its name (VAR_CAL.DAT)


def corrected_name(name: str) -> str:
    """The name of a corrected copy of file ``name`` (a format that cannot carry a marker).

    Examples
    --------
    >>> corrected_name("VAR.DAT"), corrected_name("VAR")
    ('VAR_CAL.DAT', 'VAR_CAL')
    """
    stem, dot, suffix = name.rpartition(".")
    return f"{stem}{CORRECTED_STEM}{dot}{suffix}" if dot else f"{name}{CORRECTED_STEM}"


def is_corrected_name(name: str) -> bool:
    """Whether file ``name`` is named as a corrected copy (`corrected_name`).

    Examples
    --------
    >>> is_corrected_name("VAR_CAL.DAT"), is_corrected_name("var_cal.dat"), is_corrected_name("VAR.DAT")
    (True, True, False)
    """
    stem = name.rpartition(".")[0] or name
    return stem.upper().endswith(CORRECTED_STEM)


def check_unmarked_name(path, action: str, force: bool = False) -> bool:
    """Refuse (DataError) file ``path`` of a format that carries no marker when it is named as
    robocal's corrected copy (`corrected_name`); ``force`` lets it through (True is then
    returned, for a warning).

    Examples
    --------
    >>> check_unmarked_name("VAR.DAT", "filtered")
    False
    >>> check_unmarked_name("VAR_CAL.DAT", "filtered")
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: VAR_CAL.DAT is named as robocal's filtered copy (its format has ...
    """
    if not is_corrected_name(Path(path).name):
        return False
    if force:
        return True
    verb = action[:-2] if action.endswith("ed") else action
    raise DataError(f"{path} is named as robocal's {action} copy (its format has no comments: robocal "
                    f"marks it by the name's {CORRECTED_STEM}): {verb}ing it again applies the corrections "
                    "twice; start from the controller's original file (or give --force if this one really "
                    "is uncorrected)")


_LINE_END = re.compile(r"\r\n|\n|\r")


def newline(text: str) -> str:
    """The line end ``text`` uses: its first one (CRLF, LF or a lone CR: an old controller's or a
    Mac-era editor's file); LF when it has none."""
    m = _LINE_END.search(text)
    return m.group() if m else "\n"


def insert_after(text: str, anchor: re.Pattern, line: str) -> str:
    """``line`` inserted after the first match of ``anchor`` (whose group 1 is its line end), with
    the next line's indent; no match: as the first line (after a byte-order mark)."""
    m = anchor.search(text)
    nl = m.group(1) if m else newline(text)
    at = m.end() if m else bom_length(text)  # a byte-order mark stays first
    rest = text[at:]
    indent = re.match(r"[ \t]*", rest).group() if m and rest.strip() else ""
    return text[:at] + indent + line + nl + rest


def shortened(body: str, width: int) -> str:
    """``body`` with its fingerprint cut (to no fewer than _SHORTEST_HEX digits) to fit ``width``."""
    cut = max(_SHORTEST_HEX, FINGERPRINT_HEX - max(0, len(body) - width))
    return body[:len(body) - FINGERPRINT_HEX + cut]


class ProgramMarker(Protocol):
    """What marks a program: a language's comment syntax (the ``mark`` of its
    `robocal.programs.dialects.base.Dialect`).

    Examples
    --------
    >>> from robocal.programs.registry import dialect_named
    >>> body = "robocal 0.1.0 model ebba57c5590e"
    >>> dialect_named("urscript").mark("movej([0, 0, 0, 0, 0, 0])\\n", body, body + ": filtered")
    '# robocal 0.1.0 model ebba57c5590e: filtered\\nmovej([0, 0, 0, 0, 0, 0])\\n'
    """

    def mark(self, text: str, body: str, note: str) -> str:
        """``text`` with the marker ``body`` (and ``note``, the same with what was done) added."""


def mark_program(dialect: ProgramMarker, data: bytes, robot: Robot) -> bytes | None:
    """A filtered file's bytes (a program or a data file of its language) with the marker of
    ``robot`` (the calibrated model) added in ``dialect``'s comment syntax (see the module
    docstring); None for a file the dialect cannot mark (no comment syntax: a VAR.DAT), which is
    marked by its name instead (`corrected_path`).

    Parameters
    ----------
    dialect : ProgramMarker
        The program language (its comment syntax).
    data : bytes
        The program or data file.
    robot : Robot
        The calibrated model.

    Returns
    -------
    bytes or None
        The marked file; None where the format has no comment syntax (marked by its name).

    Raises
    ------
    DataError
        A format with no marker, or a program without the place its dialect marks (its ``marker.py``).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.programs.registry import dialect_named
    >>> from robocal.trust.output_marker import mark_program, marker_text
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> out = mark_program(dialect_named("rapid"), b"MODULE weld\\nENDMODULE\\n", robot)
    >>> out.decode().splitlines()[1] == f"! {marker_text(robot)}: targets filtered, do not filter again"
    True
    """
    body = marker_text(robot)
    text = data.decode("latin-1")
    marked = dialect.mark(text, body, f"{body}: {_NOTE['filtered']}")
    return None if marked == text else marked.encode("latin-1")


def corrected_path(path) -> Path:
    """Where a corrected file that cannot carry a marker is written: ``path`` when its name says
    it is corrected (`is_corrected_name`), else the same folder with `corrected_name`.

    Examples
    --------
    >>> str(corrected_path("out/VAR.DAT")), str(corrected_path("out/VAR_CAL.DAT"))
    ('out/VAR_CAL.DAT', 'out/VAR_CAL.DAT')
    """
    path = Path(path)
    return path if is_corrected_name(path.name) else path.with_name(corrected_name(path.name))


def mark_csv(text: str, robot: Robot) -> str:
    """A compensated targets CSV with the marker of ``robot`` as a ``#`` first line.

    Parameters
    ----------
    text : str
        The CSV text.
    robot : Robot
        The calibrated model.

    Returns
    -------
    str
        The marked text.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.trust.output_marker import find_marker, mark_csv, model_fingerprint
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> out = mark_csv("x,y,z\\n1.0,0.2,0.5\\n", robot)
    >>> out.splitlines()[1:], find_marker(out).model == model_fingerprint(robot)
    (['x,y,z', '1.0,0.2,0.5'], True)
    """
    return f"# {marker_text(robot)}: {_NOTE['compensated']}\n{text}"
