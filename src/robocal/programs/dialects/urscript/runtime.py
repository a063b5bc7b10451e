"""The run-time correction in URScript (:mod:`robocal.programs.runtime`): two functions,
``RC_FK(q, tcp)`` and ``RC_Correct(x)``, added between marker comments at the start of the
definition that holds the routed motions (a PolyScope export's program ``def``; the file's
start when they stand at top level or in several top-level definitions), and each routed
motion's pose argument ``expr`` written ``RC_Correct(expr)`` (every other byte unchanged).

``RC_Correct(x)`` runs the fixed-point iteration of
:func:`robocal.programs.runtime.reference_correction` with the controller's ``get_inverse_kin`` as
its inverse kinematics: ``X = x`` (URScript poses are in the base frame: a feature's
``pose_trans`` is already applied), ``C = X``; at most ``ITERATIONS`` times: ``q =
get_inverse_kin(C, qnear)`` (``qnear``: the actual joints, then the last solution: the branch
the controller's own motion takes), ``E = pose_trans(pose_inv(RC_FK(q, tcp)), X)``, stop when
``E`` is within the tolerance, else ``C = pose_trans(C, E)``. ``RC_FK`` is the calibrated chain
(:class:`~robocal.programs.runtime.CalibratedChain`) unrolled into ``pose_trans`` of constant
poses (m, rotation vectors in rad), the active TCP (``get_tcp_offset()``) last.

A UR controller's ``get_inverse_kin`` / ``get_forward_kin`` are not the datasheet kinematics:
they include the robot's own factory calibration (its ``calibration.conf``). The fixed point is
``FK_cal(IK_ctrl(C)) = X`` with ``IK_ctrl`` whatever the controller computes, so the routine is
right on a factory-calibrated robot as it is (it never uses a nominal model itself); but the
``--nominal`` given to robocal, whose base frame the chain is expressed in and which the offline
filter inverts, must be that factory-calibrated model (the joint readings robocal was calibrated
from are the same encoders either way).
"""

from __future__ import annotations

import re

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.transforms import matrix_to_rotvec
from robocal.programs.dialects.urscript.reader import definitions
from robocal.programs.dialects.urscript.syntax import COMMENT_RE, STRING_RE
from robocal.programs.runtime import ROUTINE_NAME, CalibratedChain, RuntimeSite, RuntimeWriter
from robocal.programs.source import mask
from robocal.programs.target import Target

FUNCTION = ROUTINE_NAME  # RC_Correct, the name the filter's reasons give in every language
FK = "RC_FK"
BEGIN = "# >>> robocal run-time correction: BEGIN (added by robocal filter --runtime-correction)"
END = "# <<< robocal run-time correction: END"
_NAMES = re.compile(rf"\b(?:{FUNCTION}|{FK})\b")
_DEF = re.compile(r"\bdef\s+[A-Za-z_]\w*\s*\([^)]*\)\s*:[^\n]*\n")
_DIGITS = 10  # decimals of the constants: 0.1 nm and 1e-10 rad


def _num(x: float) -> str:
    text = f"{x:.{_DIGITS}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def _pose(T: np.ndarray) -> str:
    """A URScript pose literal of ``T`` (4x4, m): position and rotation vector."""
    r = matrix_to_rotvec(T[None, :3, :3])[0]
    return "p[" + ", ".join(_num(v) for v in (*T[:3, 3], *r)) + "]"


def _reached(chain: CalibratedChain, j: int) -> str:
    """The angle joint ``j`` reaches at the commanded ``q[j]`` (rad): the chain's scale, gear and
    cyclic terms of that joint (:meth:`CalibratedChain.offsets`)."""
    q = f"q[{j}]"
    terms = [f"{_num(k)} * {q}" if fn == "scale" else f"{_num(k)} * {fn}({_num(f)} * {q})"
             for fn, k, f in chain.joint_terms(j)]
    return " + ".join([q, *terms])


def routine_lines(chain: CalibratedChain, note: str) -> list[str]:
    """The marked block (unindented lines, two spaces a level)."""
    n = len(chain.theta)
    left = (f"# not computed here (the calibrated model's joint-error terms): {', '.join(chain.left_out)}"
            if chain.left_out else "# the calibrated model has no joint-error terms it leaves out")
    fk = [f"def {FK}(q, tcp):",
          "  # the calibrated TCP pose in the base frame at the commanded joints q (rad), tcp the active TCP",
          "  # base * link_i * Rz(theta_i + r_i) * Tz(d_i) ... * flange * tcp, r_i the reached joint angle",
          f"  rc_p = {_pose(chain.base)}"]
    for j in range(n):
        fk += [f"  rc_r = {_reached(chain, j)}",
               f"  rc_p = pose_trans(pose_trans(rc_p, {_pose(chain.links[j])}), "
               f"p[0, 0, {_num(chain.d[j])}, 0, 0, {_num(chain.theta[j])} + rc_r])"]
    fk += [f"  return pose_trans(pose_trans(rc_p, {_pose(chain.flange)}), tcp)", "end"]
    tol_rad = float(np.deg2rad(chain.tolerance_deg))
    correct = [
        f"def {FUNCTION}(x):",
        "  # the pose to command so that the real TCP lands on x (base frame): q = get_inverse_kin",
        "  # (the controller's model), the calibrated TCP at q (RC_FK), the command moved by the error",
        "  rc_tcp = get_tcp_offset()",
        "  rc_qn = get_actual_joint_positions()",
        "  rc_c = x",
        "  rc_mm = 0",
        "  rc_k = 0",
        f"  while rc_k < {chain.iterations}:",
        "    rc_q = get_inverse_kin(rc_c, qnear=rc_qn)",
        f"    rc_e = pose_trans(pose_inv({FK}(rc_q, rc_tcp)), x)",
        "    rc_mm = 1000 * sqrt(rc_e[0] * rc_e[0] + rc_e[1] * rc_e[1] + rc_e[2] * rc_e[2])",
        "    rc_rad = sqrt(rc_e[3] * rc_e[3] + rc_e[4] * rc_e[4] + rc_e[5] * rc_e[5])",
        f"    if rc_mm <= {_num(chain.tolerance_mm)} and rc_rad <= {_num(tol_rad)}:",
        "      return rc_c",
        "    end",
        "    rc_c = pose_trans(rc_c, rc_e)",
        "    rc_qn = rc_q",
        "    rc_k = rc_k + 1",
        "  end",
        f"  if rc_mm > {_num(chain.warn_mm)}:",
        f'    textmsg("robocal {FUNCTION}: no convergence in {chain.iterations} steps, corrected in part, '
        'mm: ", rc_mm)',
        "  end",
        "  return rc_c",
        "end"]
    return [BEGIN, f"# {note}",
            f"# {FUNCTION}(x): x corrected with the calibrated model; up to {chain.iterations} "
            "get_inverse_kin calls", left, *fk, *correct, END]


class URScriptRuntime(RuntimeWriter):
    """URScript's :class:`~robocal.programs.runtime.RuntimeWriter`."""

    def __init__(self) -> None:
        self._sites: dict[int, list[int]] = {}  # id(file text) -> offsets of its routed sites

    def site_edits(self, text: str, site: RuntimeSite, meant: list[Target]) -> dict[tuple[int, int], str]:
        if site.meant:  # the reader routes no motion computed from a target corrected offline
            raise DataError(f"{FUNCTION}: a URScript motion computed from a target corrected offline is not "
                            "routed")
        self._sites.setdefault(id(text), []).append(site.start)
        return {(site.start, site.start): f"{FUNCTION}(", (site.end, site.end): ")"}

    def routine(self, text: str, chain: CalibratedChain, meant: list[Target], note: str) -> tuple[int, str]:
        self.refuse_present(text, BEGIN, _NAMES)
        masked = mask(text, [COMMENT_RE], [STRING_RE])
        defs = definitions(masked)
        outer = [(a, b) for _, a, b in defs if not any(s < a and b <= e for _, s, e in defs)]
        sites = self._sites.get(id(text), ())
        holding = {next(((a, b) for a, b in outer if a < at < b), None) for at in sites}
        newline = "\r\n" if "\r\n" in text else "\n"
        lines = routine_lines(chain, note)
        if len(holding) == 1 and None not in holding:  # every routed motion in one def: its body's start
            at = _DEF.match(masked, holding.pop()[0]).end()
            body = re.match(r"[ \t]*", text[at:]).group() or "  "
        else:  # top-level statements or several defs: a top-level def at the file's start
            at, body = 0, ""
        return at, "".join(f"{body}{line}{newline}" for line in lines)
