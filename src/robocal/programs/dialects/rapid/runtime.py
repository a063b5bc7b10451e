"""The run-time correction in ABB RAPID (:mod:`robocal.programs.runtime`): two LOCAL FUNCs added
before the module's last ``ENDMODULE`` between marker comments, and each routed motion's target
argument ``expr`` written ``RC_Correct(expr, tool, wobj)`` (every other byte unchanged).

``RC_FK(joints, tool)`` is the calibrated TCP pose in the world: the calibrated chain's constants
(:class:`~robocal.programs.runtime.CalibratedChain`, mm and deg, declared CONST inside the FUNC:
a module's data come before its routines) composed with PoseMult in a FOR loop over the links.
``RC_Correct(target, tool, wobj)`` runs the fixed-point iteration of
:func:`robocal.programs.runtime.reference_correction` with CalcJointT as the controller's inverse
kinematics (the target's robconf kept) and returns the target with the corrected trans/rot, its
robconf and extax unchanged. The meant pose is taken in the work object with the active program
displacement (``C_PROGDISP.pdisp``, composed after oframe), which CalcJointT applies too. Only
base-system RAPID: PoseMult, PoseInv, OrientZYX, VectMagn, Sqrt, Sin, Cos, CalcJointT, ErrWrite,
FOR, IF (no option needed).
"""

from __future__ import annotations

import re

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.dialects.rapid.campaign import RAPID_EXTAX
from robocal.programs.rotations import matrix_to_quat
from robocal.programs.runtime import ROUTINE_NAME, CalibratedChain, RuntimeSite, RuntimeWriter
from robocal.programs.target import Target
from robocal.trust.output_marker import newline as line_end

BEGIN = "! >>> robocal run-time correction: BEGIN (added by robocal filter --runtime-correction)"
END = "! <<< robocal run-time correction: END"
_ENDMODULE = re.compile(r"^[ \t]*ENDMODULE\b", re.M | re.I)
_DEFAULT_WOBJ = "wobj0"
MEANT = "RC_Meant"  # the routine returning a target's original value
# decimals of the routine's constants: positions 1 nm (mm), quaternions 1e-10, angles (deg),
# lengths (mm) and joint-error coefficients 1e-8 (RAPID num is a 32-bit float: ~1e-4 mm at 1 m)
_MM_DIGITS, _QUATERNION_DIGITS, _NUM_DIGITS = 6, 10, 8
_NAMES = re.compile(rf"\b(?:{ROUTINE_NAME}|RC_FK|{MEANT})\b", re.I)  # the added routines (RAPID: any case)


def _pose(T: np.ndarray) -> str:
    """A RAPID pose aggregate of ``T`` (4x4, m): mm and a w-first quaternion."""
    q = matrix_to_quat(T[None, :3, :3], np.array([[1.0, 0, 0, 0]]))[0]
    p = T[:3, 3] * 1e3
    return "[[" + ",".join(f"{v:.{_MM_DIGITS}f}" for v in p) + "],[" + \
        ",".join(f"{v:.{_QUATERNION_DIGITS}f}" for v in q) + "]]"


def _joint_terms(chain: CalibratedChain) -> tuple[list[str], list[str]]:
    """RAPID declarations and statements turning the commanded joints ``q{i}`` (deg) into the
    reached ones with the chain's gear / cyclic / scale terms (none: no line)."""
    n, H = len(chain.theta), chain.harmonics
    if not len(H) and chain.scale is None:
        return [], []
    scale = np.zeros(n) if chain.scale is None else chain.scale
    m = len(H)
    decls = [f"  CONST num RC_SCALE{{{n}}} := {_nums(scale)};", f"  VAR num dq{{{n}}};"]
    steps = ["  ! reached joints: q + scale * q + sum(s * Sin(f * q) + c * Cos(f * q)), deg",
             f"  FOR i FROM 1 TO {n} DO", "    dq{i} := RC_SCALE{i} * q{i};", "  ENDFOR"]
    if m:
        decls += [f"  CONST num RC_HJ{{{m}}} := {_nums(H[:, 0] + 1)};",
                  f"  CONST num RC_HF{{{m}}} := {_nums(H[:, 1])};",
                  f"  CONST num RC_HS{{{m}}} := {_nums(np.rad2deg(H[:, 2]))};",
                  f"  CONST num RC_HC{{{m}}} := {_nums(np.rad2deg(H[:, 3]))};"]
        steps += [f"  FOR h FROM 1 TO {m} DO",
                  "    dq{RC_HJ{h}} := dq{RC_HJ{h}} + RC_HS{h} * Sin(RC_HF{h} * q{RC_HJ{h}})",
                  "      + RC_HC{h} * Cos(RC_HF{h} * q{RC_HJ{h}});",
                  "  ENDFOR"]
    return decls, steps + [f"  FOR i FROM 1 TO {n} DO", "    q{i} := q{i} + dq{i};", "  ENDFOR"]


def _meant_function(meant: list[Target]) -> list[str]:
    """``RC_Meant(k)``: the original value of the k-th target a routed motion computes from (a
    target corrected offline: its numbers as written before the correction)."""
    if not meant:
        return []
    lines = ["LOCAL FUNC robtarget RC_Meant(num k)",
             "  ! the targets run-time offsets start from, as the program wrote them (uncorrected)"]
    for k, t in enumerate(meant, 1):
        v = [n.text for n in t.numbers]
        cfx, cf1, cf4, cf6 = (int(c) for c in t.config)
        extax = ",".join(repr(float(t.axes[a])) if a in t.axes else "9E+09" for a in RAPID_EXTAX)
        value = f"[[{','.join(v[:3])}],[{','.join(v[3:7])}],[{cf1},{cf4},{cf6},{cfx}],[{extax}]]"
        last = k == len(meant)  # k is 1..len(meant): the last one needs no test
        lines += [f"  ! {k}: {t.name}", *([] if last else [f"  IF k = {k} THEN"]),
                  f"  {'' if last else '  '}RETURN {value};", *([] if last else ["  ENDIF"])]
    return lines + ["ENDFUNC"]


def _nums(values: np.ndarray) -> str:
    return "[" + ",".join(f"{v:.{_NUM_DIGITS}f}" for v in values) + "]"


class RapidRuntime(RuntimeWriter):
    """The RAPID run-time correction writer."""

    def site_edits(self, text: str, site: RuntimeSite, meant: list[Target]) -> dict[tuple[int, int], str]:
        wobj = site.wobj or _DEFAULT_WOBJ
        edits = {(site.start, site.start): f"{ROUTINE_NAME}(",
                 (site.end, site.end): f", {site.tool}, {wobj})"}
        index = {id(t): k + 1 for k, t in enumerate(meant)}
        edits.update({(m.start, m.end): f"{MEANT}({index[id(m.target)]})" for m in site.meant})
        return edits

    def routine(self, text: str, chain: CalibratedChain, meant: list[Target], note: str) -> tuple[int, str]:
        self.refuse_present(text, BEGIN, _NAMES)
        ends = list(_ENDMODULE.finditer(text))
        if not ends:
            raise DataError("--runtime-correction: no ENDMODULE in the file to add the routine before")
        newline = line_end(text)  # the file's own (CRLF, LF or a lone CR)
        n = len(chain.theta)
        decls, steps = _joint_terms(chain)
        left = (f"! not computed here (the calibrated model's joint-error terms): {', '.join(chain.left_out)}"
                if chain.left_out else "! the calibrated model has no joint-error terms: the chain is all of "
                "it")
        lines = [
            BEGIN,
            f"! {note}",
            f"! {ROUTINE_NAME}(target, tool, wobj): the robtarget to program so that the real robot's",
            "! TCP lands on target: q := CalcJointT (the controller's nominal model, the target's",
            "! robconf), the calibrated TCP at q (RC_FK), the target moved by the pose error, at most",
            f"! {chain.iterations} CalcJointT calls; robconf and extax kept.",
            left,
            "LOCAL FUNC pose RC_FK(jointtarget J, PERS tooldata Tool)",
            "  ! the calibrated TCP pose in the world at the commanded joints J (its reached joints first)",
            "  ! calibrated chain: base * link{i} * Rz(theta{i} + q{i}) * Tz(d{i}) * flange * tool (mm, deg)",
            f"  CONST pose RC_BASE := {_pose(chain.base)};",
            f"  CONST pose RC_LINK{{{n}}} := [",  # one link a line: short lines for the pendant
            *[f"    {_pose(L)}{',' if i < n - 1 else '];'}" for i, L in enumerate(chain.links)],
            f"  CONST num RC_THETA{{{n}}} := {_nums(np.rad2deg(chain.theta))};",
            f"  CONST num RC_D{{{n}}} := {_nums(chain.d * 1e3)};",
            f"  CONST pose RC_FLANGE := {_pose(chain.flange)};",
            *decls,
            f"  VAR num q{{{n}}};",
            "  VAR pose P;",
            "  VAR pose Z := [[0,0,0],[1,0,0,0]];",
            *[f"  q{{{i + 1}}} := J.robax.rax_{i + 1};" for i in range(n)],
            *steps,
            "  P := RC_BASE;",
            f"  FOR i FROM 1 TO {n} DO",
            "    Z.trans.z := RC_D{i};",
            "    Z.rot := OrientZYX(RC_THETA{i} + q{i}, 0, 0);",
            "    P := PoseMult(PoseMult(P, RC_LINK{i}), Z);",
            "  ENDFOR",
            "  RETURN PoseMult(PoseMult(P, RC_FLANGE), Tool.tframe);",
            "ENDFUNC",
            f"LOCAL FUNC robtarget {ROUTINE_NAME}(robtarget Target, PERS tooldata Tool, PERS wobjdata WObj)",
            f"  CONST num RC_TOL_MM := {chain.tolerance_mm:g};",
            f"  CONST num RC_WARN_MM := {chain.warn_mm:g};",
            f"  CONST num RC_TOL_SIN := {np.sin(np.deg2rad(chain.tolerance_deg) / 2):.3e};  ! sin(angle / 2)",
            "  VAR robtarget T;",
            "  VAR jointtarget J;",
            "  VAR pose W;",
            "  VAR pose X;",
            "  VAR pose C;",
            "  VAR pose E;",
            "  VAR pose P;",
            "  T := Target;",
            "  ! the work object with the active program displacement (PDispOn/PDispSet), as in CalcJointT",
            "  W := PoseMult(PoseMult(WObj.uframe, WObj.oframe), C_PROGDISP.pdisp);",
            "  P.trans := Target.trans;",
            "  P.rot := Target.rot;",
            "  X := PoseMult(W, P);",
            "  C := X;",
            f"  FOR k FROM 1 TO {chain.iterations} DO",
            "    J := CalcJointT(T, Tool \\WObj:=WObj);",
            "    E := PoseMult(PoseInv(RC_FK(J, Tool)), X);",
            "    IF VectMagn(E.trans) <= RC_TOL_MM AND",
            "      Sqrt(E.rot.q2 * E.rot.q2 + E.rot.q3 * E.rot.q3 + E.rot.q4 * E.rot.q4) <= RC_TOL_SIN THEN",
            "      RETURN T;",
            "    ENDIF",
            "    C := PoseMult(C, E);",
            "    P := PoseMult(PoseInv(W), C);",
            "    T.trans := P.trans;",
            "    T.rot := P.rot;",
            "  ENDFOR",
            "  IF VectMagn(E.trans) > RC_WARN_MM THEN",
            "    ! not converging (near a singularity): the last iterate, said in the event log",
            f'    ErrWrite \\W, "robocal {ROUTINE_NAME}", "no convergence in {chain.iterations} steps"'
            ' \\RL2:="the target is corrected only in part (near a singularity?)";',
            "  ENDIF",
            "  RETURN T;",
            "ENDFUNC",
            *_meant_function(meant),
            END,
        ]
        at = ends[-1].start()
        return at, newline.join(lines) + newline
