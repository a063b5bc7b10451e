"""KUKA KRL's run-time correction (``filter --runtime-correction``, the language-neutral part is
:mod:`robocal.programs.runtime`): a function the filter appends to the ``.src`` that corrects a
target computed at run time with the calibrated model, and each such motion's target wrapped in
a call of it (``LIN RC_CORRECT(PCUR)``; a FRAME target ``P:OFFSET`` as
``LIN RC_CORRECTF(P:OFFSET, P)``, corrected in ``P``'s Status and Turn).

``RC_CORRECT(P)`` (a ``DEFFCT E6POS`` with two helpers, between ``;FOLD robocal run-time
correction`` and ``;ENDFOLD``; nothing is added to the ``.dat``: the constants are assigned in the
helpers, so every byte of the program's own files stays as it was):

1. the TCP pose the program means, in the robot's base frame: ``X = INV_POS($ROBROOT):$BASE:P``
   with the ``$BASE``/``$TOOL`` in effect when the advance run plans the motion;
2. from ``C = X``, at most :data:`~robocal.programs.runtime.ITERATIONS` times: the nominal axes of
   the command ``C`` from the controller's own ``INVERSE`` (in ``P``'s Status and Turn), the
   calibrated model's TCP ``Y`` at those axes (its modified DH + beta chain as frame arithmetic
   with the calibrated constants, then ``$TOOL``), ``E = INV_POS(Y):X``; stop when ``E`` is within
   the tolerance, else ``C = C:E``;
3. ``P`` with ``X, Y, Z, A, B, C`` of ``INV_POS($BASE):$ROBROOT:C`` (its S, T, E1..E6 kept).

An ``INVERSE`` that fails (status not 0) ends the iteration: the last command is returned (``P``
itself when the first fails), and the controller moves, or stops, as it would have without the
routine. ``INVERSE`` starts from the axis position 0 (the Status and Turn of a POS/E6POS fix the
solution; a target without them is solved nearest that start). Reading ``$AXIS_ACT`` instead
would stop the advance run.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.runtime import ROUTINE_NAME, CalibratedChain, RuntimeSite, RuntimeWriter
from robocal.programs.target import Target

FUNCTION = ROUTINE_NAME.upper()  # RC_CORRECT (KRL names: at most 24 characters, any case)
FRAME_FUNCTION = FUNCTION + "F"  # its twin for a FRAME target (P:OFFSET), in a POS's Status and Turn
MEANT = "RC_MEANT"  # the original values of positions the filter corrects offline (XP1 in XP1:OFFS)
_NAMES = re.compile(r"\bRC_(?:CORRECTF?|CONST|JOINT|MEANT)\b", re.IGNORECASE)  # the added functions
BEGIN = ";FOLD robocal run-time correction"  # the added text's first line (a KRL fold)
END = ";ENDFOLD robocal run-time correction"
_DIGITS = 6  # decimals of the constants: 1e-6 mm and deg (KRL REAL is 32-bit: ~1e-4 mm at 1 m)
_TERM_DIGITS = 9  # decimals of a joint-error coefficient (a scale of 2e-4: 6 significant digits)
_FIELDS = ("X", "Y", "Z", "A", "B", "C")
_JOINTS = 6


def _real(x: float, digits: int = _DIGITS) -> str:
    """A KRL REAL literal with at most ``digits`` decimals."""
    text = f"{x:.{digits}f}".rstrip("0")
    text = text + "0" if text.endswith(".") else text
    return "0.0" if text in ("-0.0", "0.0") else text


def frame_numbers(T: np.ndarray) -> np.ndarray:
    """``(N, 4, 4)`` (m) -> KRL FRAME numbers ``(N, 6)``: X, Y, Z (mm), A, B, C (deg, R = Rz(A)
    Ry(B) Rx(C))."""
    return np.hstack([T[:, :3, 3] * 1e3, matrix_to_zyx(T[:, :3, :3], np.zeros((len(T), 3)))])


def _newline(text: str) -> str:
    """The line end a file uses (its first one; LF when it has none)."""
    m = re.search(r"\r\n|\n|\r", text)
    return m.group() if m else "\n"


def _frame_cases(frames: np.ndarray, var: str, extra: str = "") -> list[str]:
    """``IF N == k THEN`` blocks assigning frame k's non-zero components to ``var`` (``extra``:
    added to A, which is then always assigned)."""
    out = []
    for k, row in enumerate(frames, 1):
        body = [f"  {var}.{f} = {_real(float(v))}{extra if f == 'A' else ''}"
                for f, v in zip(_FIELDS, row, strict=True) if v != 0.0 or f == "A" and extra]
        if body:  # an identity frame (a base at the robot's root): $NULLFRAME as it is
            out += [f"IF RC_N == {k} THEN", *body, "ENDIF"]
    return out


def _joint_terms(chain: CalibratedChain) -> list[str]:
    """``IF N == j THEN RC_R = RC_R + ...`` blocks of the joint-error terms the chain computes
    (:meth:`CalibratedChain.offsets`: scale, gear and cyclic harmonics), in degrees: KRL's SIN/COS
    take degrees, so ``sin(f q)`` of q in rad is ``SIN(f * A)`` of A in deg."""
    out = []
    for j in range(len(chain.theta)):
        terms = [f"{_real(k, _TERM_DIGITS)} * RC_QN" if fn == "scale" else
                 f"{_real(float(np.rad2deg(k)), _TERM_DIGITS)} * {fn.upper()}({_real(f)} * RC_QN)"
                 for fn, k, f in chain.joint_terms(j)]
        if terms:
            out += [f"IF RC_N == {j + 1} THEN", *[f"  RC_R = RC_R + {t}" for t in terms], "ENDIF"]
    return out


def routine_text(chain: CalibratedChain, note: str, newline: str = "\n") -> str:
    """The added functions (``RC_CORRECT`` and its helpers ``RC_CONST``, ``RC_JOINT``), marked."""
    n = len(chain.theta)
    if n != _JOINTS:
        raise DataError(f"the KRL run-time correction is written for 6-axis arms, not {n} joints")
    consts = frame_numbers(np.concatenate([chain.links, chain.base[None], chain.flange[None]]))
    joints = np.zeros((n, 6))
    joints[:, 2], joints[:, 3] = chain.d * 1e3, np.rad2deg(chain.theta)
    left = f" (not computed: {', '.join(chain.left_out)})" if chain.left_out else ""
    src = [BEGIN + f" (added by {note}, do not edit)",  # no ';' in a fold's title line
           f"DEFFCT E6POS {FUNCTION}(RC_P:IN)",
           "; the target P computed at run time, corrected with the calibrated model" + left + ": the",
           "; command whose nominal axes (INVERSE) put the calibrated TCP on P in $BASE with $TOOL",
           "DECL E6POS RC_P, RC_CMD",
           "DECL FRAME RC_X, RC_C, RC_Y, RC_E",
           "DECL E6AXIS RC_Q, RC_START",
           "DECL INT RC_K, RC_I, RC_ERR, RC_GO",
           "DECL REAL RC_MM, RC_DEG",
           "RC_START = {A1 0.0, A2 0.0, A3 0.0, A4 0.0, A5 0.0, A6 0.0, E1 0.0, E2 0.0, E3 0.0, E4 0.0, "
           "E5 0.0, E6 0.0}",
           "RC_CMD = RC_P",
           "RC_X = $NULLFRAME",
           *[f"RC_X.{f} = RC_P.{f}" for f in _FIELDS],
           "RC_X = INV_POS($ROBROOT):$BASE:RC_X",
           "RC_C = RC_X",
           "RC_GO = 1",
           f"FOR RC_K = 1 TO {chain.iterations}",
           "  IF RC_GO == 1 THEN",
           "    RC_Y = INV_POS($BASE):$ROBROOT:RC_C",
           *[f"    RC_CMD.{f} = RC_Y.{f}" for f in _FIELDS],
           "    RC_ERR = 0",
           "    RC_Q = INVERSE(RC_CMD, RC_START, RC_ERR)",
           "    IF RC_ERR <> 0 THEN",
           "      IF RC_K == 1 THEN",
           "        RETURN RC_P",  # no solution for the target itself: as the program wrote it
           "      ENDIF",
           "      RC_GO = 0",
           "    ELSE",
           "      RC_Y = RC_CONST(7)",
           "      FOR RC_I = 1 TO 6",
           "        RC_Y = RC_Y:RC_CONST(RC_I):RC_JOINT(RC_I, RC_Q)",
           "      ENDFOR",
           "      RC_Y = RC_Y:RC_CONST(8):$TOOL",
           "      RC_E = INV_POS(RC_Y):RC_X",
           "      RC_MM = SQRT(RC_E.X * RC_E.X + RC_E.Y * RC_E.Y + RC_E.Z * RC_E.Z)",
           "      RC_DEG = SQRT(RC_E.A * RC_E.A + RC_E.B * RC_E.B + RC_E.C * RC_E.C)",
           f"      IF RC_MM <= {_real(chain.tolerance_mm)} THEN",
           f"        IF RC_DEG <= {_real(chain.tolerance_deg)} THEN",
           "          RC_GO = 0",
           "        ENDIF",
           "      ENDIF",
           "      IF RC_GO == 1 THEN",
           "        RC_C = RC_C:RC_E",
           "      ENDIF",
           "    ENDIF",
           "  ENDIF",
           "ENDFOR",
           "RC_Y = INV_POS($BASE):$ROBROOT:RC_C",
           "RC_CMD = RC_P",
           *[f"RC_CMD.{f} = RC_Y.{f}" for f in _FIELDS],
           "RETURN RC_CMD",
           "ENDFCT",
           "",
           f"DEFFCT FRAME {FRAME_FUNCTION}(RC_F:IN, RC_R:IN)",
           "; a FRAME target F (P:OFFSET: KRL gives ':' its right operand's type) corrected in the Status,",
           "; Turn and external axes of the position R it is computed from",
           "DECL FRAME RC_F, RC_G",
           "DECL E6POS RC_R, RC_P",
           "RC_P = RC_R",
           *[f"RC_P.{f} = RC_F.{f}" for f in _FIELDS],
           f"RC_P = {FUNCTION}(RC_P)",
           "RC_G = RC_F",
           *[f"RC_G.{f} = RC_P.{f}" for f in _FIELDS],
           "RETURN RC_G",
           "ENDFCT",
           "",
           "DEFFCT FRAME RC_CONST(RC_N:IN)",
           "; the calibrated chain's constant frames: 1..6 link N's Rx(alpha) Tx(a) Ry(beta), 7 the base",
           "; in $ROBROOT, 8 the flange (mm, deg)",
           "DECL INT RC_N",
           "DECL FRAME RC_F",
           "RC_F = $NULLFRAME",
           *_frame_cases(consts, "RC_F"),
           "RETURN RC_F",
           "ENDFCT",
           "",
           "DEFFCT FRAME RC_JOINT(RC_N:IN, RC_Q:IN)",
           "; joint N of the calibrated chain at the axes Q: Rz(theta_N + R) Tz(d_N), R the angle the",
           "; joint reaches at A_N (deg): A_N + scale A_N + sum(s SIN(f A_N) + c COS(f A_N))",
           "DECL INT RC_N",
           "DECL E6AXIS RC_Q",
           "DECL REAL RC_QA[6], RC_QN, RC_R",
           "DECL FRAME RC_F",
           *[f"RC_QA[{k}] = RC_Q.A{k}" for k in range(1, n + 1)],
           "RC_QN = RC_QA[RC_N]",
           "RC_R = RC_QN",
           *_joint_terms(chain),
           "RC_F = $NULLFRAME",
           *_frame_cases(joints, "RC_F", " + RC_R"),
           "RETURN RC_F",
           "ENDFCT",
           END]
    return newline.join(src)


class KRLRuntime(RuntimeWriter):
    """KRL's :class:`~robocal.programs.runtime.RuntimeWriter`: ``RC_CORRECT`` appended to the
    ``.src`` holding the motions, their targets wrapped in calls of it."""

    def site_edits(self, text: str, site: RuntimeSite, meant: list[Target]) -> dict[tuple[int, int], str]:
        index = {id(t): k + 1 for k, t in enumerate(meant)}
        edits = {(m.start, m.end): f"{MEANT}({index[id(m.target)]})" for m in site.meant}
        reference = getattr(site, "reference", "")  # a KRLSite's: a FRAME target and its POS
        if reference:  # the POS it offsets: its value as written when the filter corrects it offline
            same = reference.replace(" ", "").upper()
            original = next((f"{MEANT}({index[id(m.target)]})" for m in site.meant
                             if text[m.start:m.end].replace(" ", "").upper() == same), reference)
            edits |= {(site.start, site.start): f"{FRAME_FUNCTION}(", (site.end, site.end): f", {original})"}
        else:
            edits |= {(site.start, site.start): f"{FUNCTION}(", (site.end, site.end): ")"}
        return edits

    def routine(self, text: str, chain: CalibratedChain, meant: list[Target], note: str) -> tuple[int, str]:
        self.refuse_present(text, BEGIN, _NAMES, FUNCTION)
        nl = _newline(text)
        lead = nl if text and not text.endswith(("\n", "\r")) else ""
        body = routine_text(chain, note, nl)
        if meant:
            body = body[:body.rindex(END)] + nl.join(["", *_meant_function(meant), END])
        return len(text), f"{lead}{nl}{body}{nl}"


def _meant_function(meant: list[Target]) -> list[str]:
    """``RC_MEANT(k)``: target k's value as the program wrote it (before the filter corrected it
    offline), its numbers, Status, Turn and external axes as written."""
    out = [f"DEFFCT E6POS {MEANT}(RC_N:IN)",
           "; the positions as the program wrote them (the filter corrects them offline): "
           + ", ".join(f"{k} {t.name}" for k, t in enumerate(meant, 1)),
           "DECL INT RC_N",
           "DECL E6POS RC_M",
           "RC_M = {X 0.0, Y 0.0, Z 0.0, A 0.0, B 0.0, C 0.0, S 0, T 0}"]
    for k, t in enumerate(meant, 1):
        parts = [f"{f} {n.text}" for f, n in zip(_FIELDS, t.numbers, strict=True)]
        parts += [f"S {int(t.config[0])}"] + ([f"T {int(t.config[1])}"] if t.config[1] >= 0 else [])
        parts += [f"{e} {_real(float(v))}" for e, v in t.axes.items()]
        out += [f"IF RC_N == {k} THEN", f"  RC_M = {{{', '.join(parts)}}}", "ENDIF"]
    return out + ["RETURN RC_M", "ENDFCT"]
