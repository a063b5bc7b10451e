"""Provenance markers on robocal's outputs.

A filtered robot program and a compensated targets file say, in the format's own comment syntax,
which calibrated model corrected them and which robocal version did it::

    robocal <version> model <fingerprint>

``fingerprint`` is the first `FINGERPRINT_HEX` hex digits of the SHA-256 of the calibrated
model's canonical parameters (every parameter name with its SI value to 12 significant digits:
the same model loaded from any of its files gives the same fingerprint). Reading a marked file
back in (filtering a filtered program, compensating compensated targets: the corrections applied
twice) is refused, naming the earlier run, unless the caller forces it.

Where the marker goes (one added line; the rest of the file is byte for byte the same):

* ABB RAPID: ``! ...`` on the line after the first ``MODULE`` line (the file's first line
  without one);
* KUKA KRL: ``; ...`` on the line after the first ``DEF`` / ``DEFDAT`` / ``DEFFCT`` line;
* FANUC TP (.ls): a remark ``!...`` as the last line of ``/MN``, numbered after the last line,
  with ``LINE_COUNT`` raised by one; a remark line holds `TP_REMARK_WIDTH` characters, so
  the fingerprint is cut to fit (10 hex digits with a five-character version);
* URScript: ``# ...`` as the first line;
* Yaskawa INFORM: a comment instruction ``'...`` after the job's ``NOP`` (a comment holds
  `INFORM_COMMENT_WIDTH` characters: the fingerprint is cut to fit); a VAR.DAT, which holds
  no instructions, carries none;
* Staubli VAL3: an XML comment ``<!-- ... -->`` on the line after the XML declaration of each
  file written (a file without a declaration carries none);
* CSV: ``# ...`` as the first line (robocal's CSV readers skip leading ``#`` lines).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass

from robocal.core.errors import DataError
from robocal.core.version import __version__
from robocal.kinematics.model import Robot

FINGERPRINT_HEX = 12  # hex digits of the SHA-256 kept: 48 bits, a collision 1 in 2.8e14
TP_REMARK_WIDTH = 30  # characters of one FANUC TP remark line (! ...)
_SHORTEST_HEX = 8  # a FANUC remark keeps at least this many hex digits of the fingerprint
_SIGNIFICANT = 12  # significant digits of each parameter in the canonical text
MARKER_RE = re.compile(rf"robocal (?P<version>\d[\w.+-]*) "
                       rf"model (?P<model>[0-9a-f]{{{_SHORTEST_HEX},{FINGERPRINT_HEX}}})\b")
_NOTE = {"filtered": "targets filtered, do not filter again",
         "compensated": "targets compensated, do not compensate again"}
_RAPID_ANCHOR = re.compile(r"^[ \t]*MODULE\b[^\r\n]*(\r?\n)", re.M | re.I)
_KRL_ANCHOR = re.compile(r"^[ \t]*(?:GLOBAL[ \t]+)?(?:DEF|DEFDAT|DEFFCT)\b[^\r\n]*(\r?\n)", re.M | re.I)
_INFORM_NOP = re.compile(r"^NOP[ \t]*(\r?\n|\r)", re.M)
_XML_ANCHOR = re.compile(r"^(?:\xef\xbb\xbf)?<\?xml[^>]*\?>[ \t]*(\r?\n)")
MARKED_FORMATS = ("rapid", "krl", "fanuc", "urscript", "inform", "val3")  # in the dialects' names
INFORM_COMMENT_WIDTH = 32  # characters of an INFORM comment instruction ('...)
_FANUC_LINE = re.compile(r"^[ \t]*(\d+):", re.M)
_FANUC_COUNT = re.compile(r"^(LINE_COUNT\s*=\s*)(\d+)", re.M)


@dataclass(frozen=True)
class Marker:
    """A marker found in a file: the robocal ``version`` and the calibrated ``model`` fingerprint.

    Attributes
    ----------
    version : str
        The robocal version that wrote the file.
    model : str
        The calibrated model's fingerprint: ``FINGERPRINT_HEX`` hex digits of the SHA-256 of its
        parameters (fewer in a FANUC remark or an INFORM comment, cut to fit).

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


def _newline(text: str) -> str:
    return "\r\n" if "\r\n" in text else "\n"


def _insert_after(text: str, anchor: re.Pattern, line: str) -> str:
    m = anchor.search(text)
    nl = m.group(1) if m else _newline(text)
    at = m.end() if m else 0
    rest = text[at:]
    indent = re.match(r"[ \t]*", rest).group() if m and rest.strip() else ""
    return text[:at] + indent + line + nl + rest


def _short(body: str, width: int) -> str:
    """``body`` with its fingerprint cut (to no fewer than _SHORTEST_HEX digits) to fit ``width``."""
    cut = max(_SHORTEST_HEX, FINGERPRINT_HEX - max(0, len(body) - width))
    return body[:len(body) - FINGERPRINT_HEX + cut]


def _mark_inform(text: str, body: str) -> str:
    """A comment instruction after the job's NOP (the first instruction); a file without one (the
    controller's VAR.DAT, which holds no instructions) is left as it is."""
    m = _INFORM_NOP.search(text)
    if m is None:
        return text
    return text[:m.end()] + f"'{_short(body, INFORM_COMMENT_WIDTH)}{m.group(1)}" + text[m.end():]


def _mark_fanuc(text: str, body: str) -> str:
    start, stop = text.find("/MN"), text.find("/POS")
    if start < 0:
        raise DataError("a FANUC .ls program without /MN cannot carry a provenance marker")
    stop = len(text) if stop < start else stop
    numbers = [int(n) for n in _FANUC_LINE.findall(text, start, stop)]
    nl = _newline(text)
    body = _short(body, TP_REMARK_WIDTH)
    remark = f"{max(numbers, default=0) + 1:>4}:  !{body} ;{nl}"
    if stop < len(text) and not text[:stop].endswith("\n"):
        remark = nl + remark
    out = text[:stop] + remark + text[stop:]
    return _FANUC_COUNT.sub(lambda m: f"{m.group(1)}{int(m.group(2)) + 1}", out, count=1)


def mark_program(dialect: str, data: bytes, robot: Robot) -> bytes:
    """A filtered program's bytes with the marker of ``robot`` (the calibrated model) added in
    ``dialect``'s comment syntax (a name holding one of MARKED_FORMATS, as the dialects' own names
    do; see the module docstring).

    Raises
    ------
    DataError
        A format with no marker, or a FANUC program without ``/MN``.

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.trust.output_marker import mark_program, marker_text
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> out = mark_program("ABB RAPID", b"MODULE weld\\nENDMODULE\\n", robot)
    >>> out.decode().splitlines()[1] == f"! {marker_text(robot)}: targets filtered, do not filter again"
    True
    """
    text = data.decode("latin-1")
    dialect = next((k for k in MARKED_FORMATS if k in dialect.lower()), dialect)
    body = marker_text(robot)
    note = f"{body}: {_NOTE['filtered']}"
    if dialect == "rapid":
        out = _insert_after(text, _RAPID_ANCHOR, f"! {note}")
    elif dialect == "krl":
        out = _insert_after(text, _KRL_ANCHOR, f"; {note}")
    elif dialect == "fanuc":
        out = _mark_fanuc(text, body)
    elif dialect == "urscript":
        out = f"# {note}{_newline(text)}{text}"
    elif dialect == "inform":
        out = _mark_inform(text, body)
    elif dialect == "val3":
        out = _insert_after(text, _XML_ANCHOR, f"<!-- {note} -->") if _XML_ANCHOR.search(text) else text
    else:
        raise DataError(f"no provenance marker for program format {dialect!r}")
    return out.encode("latin-1")


def mark_csv(text: str, robot: Robot) -> str:
    """A compensated targets CSV with the marker of ``robot`` as a ``#`` first line.

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
