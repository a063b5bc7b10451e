"""KUKA KRL's run-time correction (``filter --runtime-correction``): a function the filter adds
to the program that corrects a target computed at run time with the calibrated model, and the
motions to such targets routed through it.

The function ``RCAL_CORRECT(P)`` (a ``DEFFCT E6POS`` appended to the ``.src``, its constants
declared in the ``.dat``, both between ``;FOLD robocal run-time correction`` and ``;ENDFOLD``):

1. the intended flange pose in the robot's base frame, ``X = INV_POS($ROBROOT):$BASE:P:INV_POS($TOOL)``
   (the ``$TOOL`` and ``$BASE`` in effect in the advance run, when the motion is planned);
2. a fixed-point iteration from ``C = X``, ``iterations`` times: the nominal joints of the command
   ``C`` from the controller's own ``INVERSE`` (with ``P``'s Status and Turn), the calibrated
   model's flange pose ``Y`` at those joints (its modified DH + beta chain written as frame
   arithmetic with the calibrated constants), and ``C = X:INV_POS(Y):C`` (the command moved by
   the calibrated model's error at ``C``);
3. the corrected target: ``P`` with ``X, Y, Z, A, B, C`` of ``INV_POS($BASE):$ROBROOT:C:$TOOL``
   (its S, T and E1..E6 unchanged).

An ``INVERSE`` that fails (its status not 0: out of reach, no solution with that Status/Turn)
returns ``P`` unchanged: the controller then moves, or stops, as it would have without the
routine. The axis position ``INVERSE`` starts from (used only where Status/Turn leave a choice)
is the previous corrected motion's (``RCAL_START``, zero at program start), not ``$AXIS_ACT``,
which would stop the advance run.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.fk import LinkArrays
from robocal.programs.aggregate import split_top
from robocal.programs.dialects.krl.syntax import COMMENT_RE, MOTION_RE, STRING_RE
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.source import ProgramText

FUNCTION = "RCAL_CORRECT"  # the added function's name (KRL names: at most 24 characters)
BEGIN = ";FOLD robocal run-time correction"  # the added text's first line (a KRL fold)
END = ";ENDFOLD robocal run-time correction"
_DIGITS = 6  # decimals of the constants: 1e-6 mm and deg (KRL REAL is 32-bit: ~1e-4 mm at 1 m)
_ENDDAT = re.compile(r"^[ \t]*ENDDAT\b", re.IGNORECASE | re.MULTILINE)
_CIRCULAR = ("CIRC", "SCIRC")  # motions with an auxiliary and an end point


def _real(x: float) -> str:
    """A KRL REAL literal."""
    text = f"{x:.{_DIGITS}f}".rstrip("0")
    return text + "0" if text.endswith(".") else text


def _frame_numbers(T: np.ndarray) -> np.ndarray:
    """A 4x4 (m) -> KRL FRAME numbers X, Y, Z (mm), A, B, C (deg: R = Rz(A) Ry(B) Rx(C))."""
    abc = matrix_to_zyx(T[None, :3, :3], np.zeros((1, 3)), 0.0)[0]
    return np.concatenate([T[:3, 3] * 1e3, abc])


def routine(base: np.ndarray, links: LinkArrays, flange: np.ndarray, iterations: int,
            note: str, newline: str = "\n") -> tuple[str, str]:
    """The function's text for the ``.src`` and its constants' declarations for the ``.dat``.

    Parameters
    ----------
    base : numpy.ndarray, shape (4, 4)
        The calibrated model's frame {0} in the controller's robot base frame ($ROBROOT), m.
    links : LinkArrays
        Its modified DH + beta rows, each ``(6,)``, rad and m (joint zero offsets in ``theta``).
    flange : numpy.ndarray, shape (4, 4)
        Its last link frame to the flange the controller's ``$TOOL`` is given on, m.
    iterations : int
        ``INVERSE`` calls per corrected target.
    note : str
        What the added text says it is (robocal's version, the model's fingerprint).
    newline : str
        The file's line end.

    Returns
    -------
    tuple of str
        (the ``DEFFCT`` for the end of the ``.src``, the declarations for the ``.dat``).
    """
    n = len(links.a)
    if n != 6:
        raise DataError(f"the KRL run-time correction is written for 6-axis arms, not {n} joints")
    if iterations < 1:
        raise DataError(f"the run-time correction needs at least 1 iteration, got {iterations}")
    rows = {"RCAL_A": links.a * 1e3, "RCAL_AL": np.rad2deg(links.alpha), "RCAL_BE": np.rad2deg(links.beta),
            "RCAL_D": links.d * 1e3, "RCAL_TH": np.rad2deg(links.theta),
            "RCAL_BASE": _frame_numbers(base), "RCAL_FL": _frame_numbers(flange)}
    dat = [BEGIN + f": constants of the calibrated model ({note})",
           "; MDH + beta links: a (mm), alpha, beta (deg), d (mm), theta offset (deg); base, flange frames"]
    for name, values in rows.items():
        dat.append(f"DECL REAL {name}[{len(values)}]")
        dat += [f"{name}[{k + 1}]={_real(float(v))}" for k, v in enumerate(values)]
    dat += ["DECL E6AXIS RCAL_START={A1 0.0,A2 0.0,A3 0.0,A4 0.0,A5 0.0,A6 0.0,E1 0.0,E2 0.0,E3 0.0,"
            "E4 0.0,E5 0.0,E6 0.0}", END]
    fields = ("X", "Y", "Z", "A", "B", "C")
    src = [BEGIN + f": added by {note}; do not edit",
           f"DEFFCT E6POS {FUNCTION}(RCAL_P:IN)",
           "; a target computed at run time, corrected with the calibrated model: the command C whose",
           "; nominal joints (INVERSE) put the calibrated model's flange on the intended pose X",
           "DECL E6POS RCAL_P, RCAL_CMD",
           "DECL FRAME RCAL_X, RCAL_C, RCAL_Y, RCAL_J",
           "DECL E6AXIS RCAL_Q",
           "DECL REAL RCAL_QA[6]",
           "DECL INT RCAL_K, RCAL_I, RCAL_ERR",
           *[f"RCAL_J.{f} = RCAL_P.{f}" for f in fields],
           "RCAL_X = INV_POS($ROBROOT):$BASE:RCAL_J:INV_POS($TOOL)",
           "RCAL_C = RCAL_X",
           "RCAL_CMD = RCAL_P",
           f"FOR RCAL_K = 1 TO {iterations}",
           "  RCAL_J = INV_POS($BASE):$ROBROOT:RCAL_C:$TOOL",
           *[f"  RCAL_CMD.{f} = RCAL_J.{f}" for f in fields],
           "  RCAL_ERR = 0",
           "  RCAL_Q = INVERSE(RCAL_CMD, RCAL_START, RCAL_ERR)",
           "  IF RCAL_ERR <> 0 THEN",
           "    RETURN RCAL_P",
           "  ENDIF",
           "  RCAL_START = RCAL_Q",
           *[f"  RCAL_QA[{k}] = RCAL_Q.A{k}" for k in range(1, 7)],
           "  RCAL_Y = RCAL_FRAME(1)",
           "  FOR RCAL_I = 1 TO 6",
           "    RCAL_J = RCAL_LINK(RCAL_I, RCAL_QA[RCAL_I])",
           "    RCAL_Y = RCAL_Y:RCAL_J",
           "  ENDFOR",
           "  RCAL_Y = RCAL_Y:RCAL_FRAME(2)",
           "  RCAL_C = RCAL_X:INV_POS(RCAL_Y):RCAL_C",
           "ENDFOR",
           "RCAL_J = INV_POS($BASE):$ROBROOT:RCAL_C:$TOOL",
           *[f"RCAL_CMD.{f} = RCAL_J.{f}" for f in fields],
           "RETURN RCAL_CMD",
           "ENDFCT",
           "",
           "DEFFCT FRAME RCAL_LINK(RCAL_N:IN, RCAL_QN:IN)",
           "; link N of the calibrated chain at axis angle QN (deg): Rx(alpha) Tx(a) Ry(beta) Rz(theta+q) Tz(d)",
           "DECL INT RCAL_N",
           "DECL REAL RCAL_QN",
           "DECL FRAME RCAL_L, RCAL_R",
           "RCAL_L = $NULLFRAME",
           "RCAL_L.X = RCAL_A[RCAL_N]",
           "RCAL_L.C = RCAL_AL[RCAL_N]",
           "RCAL_R = $NULLFRAME",
           "RCAL_R.B = RCAL_BE[RCAL_N]",
           "RCAL_L = RCAL_L:RCAL_R",
           "RCAL_R = $NULLFRAME",
           "RCAL_R.Z = RCAL_D[RCAL_N]",
           "RCAL_R.A = RCAL_TH[RCAL_N] + RCAL_QN",
           "RETURN RCAL_L:RCAL_R",
           "ENDFCT",
           "",
           "DEFFCT FRAME RCAL_FRAME(RCAL_W:IN)",
           "; the calibrated base (W = 1) or flange (W = 2) frame",
           "DECL INT RCAL_W",
           "DECL FRAME RCAL_F",
           "RCAL_F = $NULLFRAME",
           "IF RCAL_W == 1 THEN",
           *[f"  RCAL_F.{f} = RCAL_BASE[{k + 1}]" for k, f in enumerate(fields)],
           "ELSE",
           *[f"  RCAL_F.{f} = RCAL_FL[{k + 1}]" for k, f in enumerate(fields)],
           "ENDIF",
           "RETURN RCAL_F",
           "ENDFCT",
           END]
    return newline.join(src), newline.join(dat)


def _newline(text: str) -> str:
    """The line end a file uses (its first one; LF when it has none)."""
    m = re.search(r"\r\n|\n|\r", text)
    return m.group() if m else "\n"


def motion_arguments(src: ProgramText, at: int) -> list[tuple[int, int]]:
    """Spans of the target expression(s) of the motion statement at offset ``at`` of ``src`` (a
    CIRC's auxiliary and end point), without approximation flags or a WITH clause."""
    masked = src.masked([COMMENT_RE], [STRING_RE])
    m = MOTION_RE.match(masked, at)
    if m is None:
        raise DataError(f"{src.where(at)}: no motion statement here")
    end = m.end(3)
    w = re.search(r"\bWITH\b", masked[m.start(3):end], re.IGNORECASE)
    if w:
        end = m.start(3) + w.start()
    parts = split_top(masked, m.start(3), end)
    parts = parts[:2] if m.group(1).upper() in _CIRCULAR else parts[:1]
    out = []
    for a, b in parts:
        text = masked[a:b]
        flags = re.search(r"(?:\s+(?:C_[A-Z]+|CA\s+[-+]?[\d.]+))+\s*$", text, re.IGNORECASE)
        stop = a + (flags.start() if flags else len(text.rstrip()))
        start = a + len(text) - len(text.lstrip())
        out.append((start, stop))
    return out


def runtime_edits(sources: list[ProgramText], motions: list[tuple[ProgramText, int]], base: np.ndarray,
                  links: LinkArrays, flange: np.ndarray, iterations: int,
                  note: str) -> dict[Path, dict[tuple[int, int], str]]:
    """The edits routing ``motions`` (their file and offset) through ``RCAL_CORRECT`` and adding
    it: file -> span -> text (zero-length spans insert), every other byte unchanged. The function
    goes at the end of the ``.src`` holding the first motion, its constants before that module's
    ``.dat``'s ``ENDDAT``. DataError: no ``.dat`` of that module among ``sources``."""
    if not motions:
        return {}
    home = motions[0][0]
    if home.path.suffix.lower() != ".src":
        raise DataError(f"{home.path.name}: the run-time correction is added to a .src module and its .dat")
    dat = next((s for s in sources if s.path.suffix.lower() == ".dat" and s.path.stem.lower()
                == home.path.stem.lower()), None)
    if dat is None:
        raise DataError(f"--runtime-correction adds its constants to {home.path.stem}.dat: give that file too")
    ends = list(_ENDDAT.finditer(dat.masked([COMMENT_RE], [STRING_RE])))
    if not ends:
        raise DataError(f"{dat.path.name}: no ENDDAT to add the run-time correction's constants before")
    edits: dict[Path, dict[tuple[int, int], str]] = {}
    for src, at in motions:
        for a, b in motion_arguments(src, at):
            here = edits.setdefault(src.path, {})
            here[(a, a)] = f"{FUNCTION}("
            here[(b, b)] = ")"
    function, constants = routine(base, links, flange, iterations, note, _newline(home.original))
    nl = _newline(home.original)
    tail = len(home.data)
    lead = "" if home.original.endswith(("\n", "\r")) or not home.original else nl
    edits.setdefault(home.path, {})[(tail, tail)] = f"{lead}{nl}{function}{nl}"
    at = ends[-1].start()
    edits.setdefault(dat.path, {})[(at, at)] = f"{constants}{_newline(dat.original)}"
    return edits
