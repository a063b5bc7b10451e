"""A correction that runs in the controller (``filter --runtime-correction``): the language-neutral
part, which each language's writer (a :class:`~robocal.programs.dialects.base.Dialect` whose
``runtime_correction`` names it) turns into a routine of that language.

Which motions: those whose every target is computed at run time (the reader names them with a
:class:`RunTime` reason: an Offs/RelTool by run-time amounts, a position modified or computed at
run time) and whose value depends on no target the filter corrects offline (that target is
already corrected: correcting the result again would correct twice), except as a :class:`Meant`
use: the base of an Offs/RelTool written by the target's name, which the writer replaces by the
target's original value. Motions relative to the
position the robot is at (CRobT, $POS_ACT: that position was reached through a corrected target,
so it is already in the corrected space) are not routed, and say so.

What the routine does, per motion (:func:`reference_correction` is its specification in numpy, the
tests run the generated routine against it and against :func:`robocal.deploy.compensate`):

1. ``X = wobj * target``: the TCP pose (of the tool the motion names) the program means, in the
   controller's world;
2. ``T'_0 = target``; for k = 0 .. ``ITERATIONS - 1``: ``q_k`` = the controller's own inverse
   kinematics of ``T'_k`` (its nominal model, in the target's configuration: RAPID CalcJointT,
   KRL INVERSE); ``P_k`` = the calibrated chain's TCP at ``q_k`` (:class:`CalibratedChain`: the
   calibrated MDH + beta links, base and flange as constants, the program's tool data); stop when
   ``P_k`` is within ``TOLERANCE_MM`` / ``TOLERANCE_DEG`` of ``X``; else
   ``T'_{k+1} = wobj^-1 * (wobj * T'_k) * P_k^-1 * X`` (the pose error of the TCP, in the tool frame,
   applied to the commanded pose);
3. the target ``T'`` with the original configuration data and external axes.

The fixed point is ``FK_cal(IK_nom(T')) = X``, the offline filter's answer: each step shrinks the
error by the (small) difference between the nominal and calibrated Jacobians, so 3 steps leave
sub-micrometre residuals for calibrations of a few millimetres. It costs up to ``ITERATIONS``
inverse-kinematics calls per motion. Not exact: the calibrated model's joint-error terms that
need the load, the approach direction or the temperature (:attr:`CalibratedChain.left_out`:
compliance, backlash, travel, payload, thermal) are not in the chain (gear, cyclic, scale are);
near a singularity the controller's IK is ill-conditioned (the iteration may not converge: the
routine returns its last iterate and, when the last step's error exceeds ``CALIBRATED_TCP_MM``
(:mod:`robocal.core.magnitudes`: what a calibration corrects down to), says so in the controller's
log: RAPID's event log, URScript's ``textmsg``; the KRL routine writes no message,
message functions differing between KSS versions); a correction that crosses a configuration
boundary keeps the target's configuration.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.magnitudes import CALIBRATED_TCP_MM
from robocal.deploy.compensation import controller_model
from robocal.kinematics.joint_errors import parse_name
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform, matrix_to_rotvec, rot_x, rot_y
from robocal.programs.model import Program
from robocal.programs.motions import Account
from robocal.programs.target import Target

ITERATIONS = 3  # fixed-point steps (controller IK calls) per motion at most
TOLERANCE_MM = 0.001  # the routine stops when the calibrated TCP is this close to the meant one ...
TOLERANCE_DEG = 0.0001  # ... and turned less than this from it
COMPUTED_TERMS = ("gear", "cyclic", "scale")  # joint-error terms of the joint's own angle: in the routine
ROUTINE_NAME = "RC_Correct"  # the added routine's name in every language (its marker names robocal)
ROUTED = f"corrected at run time by {ROUTINE_NAME} (--runtime-correction)"  # a routed motion's reason


class RunTime(str):
    """A reason a motion is not corrected offline: its target is computed at run time. It reads as
    the reason; ``depends``: the ids of the declared targets its value is computed from (those
    given and those of ``sources``, the targets themselves; a target
    the filter corrects offline among them: the motion is routed only when each such target is
    named in ``meant``, else the routine would correct it twice); ``meant``: :class:`Meant` uses
    of a declared target written by its name as the base of the computation (``Offs(pPick, 0, 0,
    dz)``), which the writer replaces by the target's original value; ``relative``: computed from
    the position the robot is at (CRobT, $POS_ACT), already in the corrected space: not routed."""

    depends: frozenset[int]
    sources: tuple[Target, ...]  # the targets of ``depends``
    meant: tuple[Meant, ...]
    relative: bool

    def __new__(cls, why: str, depends: Iterable[int] = (), relative: bool = False,
                meant: Iterable[Meant] = (), sources: Iterable[Target] = ()) -> RunTime:
        obj = super().__new__(cls, why)
        obj.sources = tuple({id(t): t for t in sources}.values())
        obj.depends = frozenset(depends) | {id(t) for t in obj.sources}
        obj.relative, obj.meant = relative, tuple(meant)
        return obj


@dataclass(frozen=True)
class Meant:
    """A declared target's name written at ``path`` ``start:end`` as the base of a run-time
    computation: where the routine is used, the writer writes the target's original (uncorrected)
    value there instead, so a target the filter corrects offline is not corrected twice."""

    target: Target
    path: Path
    start: int
    end: int


def merged(why: str, parts: list, meant: Iterable[Meant] = ()) -> RunTime | None:
    """A :class:`RunTime` reason ``why`` whose value is computed from ``parts`` (what the reader
    followed the target's base to: targets, or reasons) and ``meant`` (:class:`Meant`: the base
    written as a target's name), None when a part is a reason that is not :class:`RunTime` (a name
    declared nowhere...): then the motion cannot be routed either."""
    depends, sources, relative, uses = set(), [], False, list(meant)
    for p in parts:
        if isinstance(p, RunTime):
            depends |= p.depends
            sources += p.sources
            relative |= p.relative
            uses += p.meant
        elif isinstance(p, str):
            return None
        else:
            sources.append(p)
    return RunTime(why, depends, relative, uses, sources)


@dataclass(frozen=True)
class RuntimeSite:
    """One target argument of a motion instruction whose target is computed at run time:
    ``account`` (the motion's), ``path`` and the span ``start:end`` of the argument as written,
    the tool and work object as written there (``wobj`` None: the language's default) and the
    names they resolve to in :class:`Program` (``tool_name``, ``frame_name``; '' unresolved);
    ``why_not``: why the language's reader already knows it cannot be routed ('': it may be)."""

    account: Account
    path: Path
    start: int
    end: int
    tool: str
    wobj: str | None
    tool_name: str
    frame_name: str
    why_not: str = ""
    meant: tuple[Meant, ...] = ()  # the uses inside this argument the writer replaces (routed_sites)


@dataclass(frozen=True)
class CalibratedChain:
    """The calibrated model as the routine computes it, all in the controller's world frame, m and
    rad: ``FK(q) = base * prod_i(links[i] * Rz(theta[i] + r[i]) * Tz(d[i])) * flange * tool`` at
    the reached joints ``r = q + scale * q + sum_h (s_h sin(f_h q_j) + c_h cos(f_h q_j))`` (the
    joint-error terms that depend on the joint's own angle only: gear, cyclic, scale).
    ``links`` ``(n, 4, 4)``: ``Rx(alpha_i) Tx(a_i) Ry(beta_i)``; ``flange``: the nominal flange
    (the measured SMR replaced); ``harmonics`` ``(m, 4)``: rows (joint index 0-based, f, s, c),
    rad; ``scale`` ``(n,)``; ``left_out``: the calibrated model's joint-error terms the routine
    does not compute (compliance, backlash, travel, payload, thermal: they need the load, the
    approach direction or the temperature; said in the result and the routine's comment)."""

    base: np.ndarray
    links: np.ndarray
    theta: np.ndarray
    d: np.ndarray
    flange: np.ndarray
    left_out: tuple[str, ...]
    harmonics: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    scale: np.ndarray | None = None
    iterations: int = ITERATIONS
    tolerance_mm: float = TOLERANCE_MM
    tolerance_deg: float = TOLERANCE_DEG
    warn_mm: float = CALIBRATED_TCP_MM  # a last step still this far off: not converging (warned)

    def fk(self, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
        """TCP poses ``(N, 4, 4)`` (m) of joints ``q`` ``(N, n)`` (rad) with ``tool`` ``(4, 4)`` or
        ``(N, 4, 4)`` as the routine computes them (no joint-error terms)."""
        q = np.atleast_2d(np.asarray(q, float))
        q = q + self.offsets(q)
        T = np.broadcast_to(self.base, (len(q), 4, 4)).copy()
        for i in range(len(self.theta)):  # n links: a short loop over batched poses
            T = T @ self.links[i] @ _rz_tz(self.theta[i] + q[:, i], self.d[i])
        return T @ self.flange @ tool


    def joint_terms(self, j: int) -> list[tuple[str, float, float]]:
        """The terms joint ``j`` (0-based) adds to its commanded angle ``q`` (rad), as each
        routine writes them, in order, zero ones left out: ``("scale", k, 0)`` for ``k q``, then
        per harmonic of the joint ``("sin", s, f)`` and ``("cos", c, f)`` for ``s sin(f q)`` and
        ``c cos(f q)`` (``s``, ``c`` rad)."""
        scaled = self.scale is not None and self.scale[j] != 0.0
        out = [("scale", float(self.scale[j]), 0.0)] if scaled else []
        for _, f, s, c in self.harmonics[self.harmonics[:, 0].astype(int) == j]:
            out += [(fn, float(amp), float(f)) for amp, fn in ((s, "sin"), (c, "cos")) if amp != 0.0]
        return out

    def offsets(self, q: np.ndarray) -> np.ndarray:
        """The joint-error offsets ``(N, n)`` (rad) the routine computes at commanded ``q``."""
        dq = np.zeros_like(q) if self.scale is None else self.scale * q
        for j, f, s, c in self.harmonics:  # a few terms: a short loop over batched joints
            j = int(j)
            dq[:, j] += s * np.sin(f * q[:, j]) + c * np.cos(f * q[:, j])
        return dq


def _rz_tz(phi: np.ndarray, d: float) -> np.ndarray:
    """``Rz(phi) Tz(d)`` ``(N, 4, 4)``."""
    out = np.zeros((len(phi), 4, 4))
    c, s = np.cos(phi), np.sin(phi)
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = c, -s, s, c
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    out[:, 2, 3] = d
    return out


def calibrated_chain(calibrated: Robot, nominal: Robot,
                     robot_base: np.ndarray | None = None) -> CalibratedChain:
    """The constants of the routine's chain (:class:`CalibratedChain`) from the calibrated model
    as the controller sees it (:func:`robocal.deploy.compensation.controller_model`: its frame
    {0} the controller's base, or ``robot_base``, 4x4 m). DataError: a prismatic joint (the
    routines compute revolute links)."""
    model = controller_model(calibrated, nominal, robot_base)
    if model.has_prismatic:
        raise DataError("--runtime-correction computes revolute arms only: the model has a prismatic joint")
    links = np.array([_h(rot_x(al)) @ _tx(a) @ _h(rot_y(be))
                      for al, a, be in zip(model.alpha, model.a, model.beta, strict=True)])
    harmonics, scale, left = _joint_terms(model)
    return CalibratedChain(model.base.copy(), links, model.theta.copy(), model.d.copy(), model.tool.copy(),
                           left, harmonics, scale)


def _joint_terms(model: Robot) -> tuple[np.ndarray, np.ndarray | None, tuple[str, ...]]:
    """``(harmonics, scale, left_out)`` of ``model``'s joint-error terms (:class:`CalibratedChain`)."""
    errors = model.joint_errors
    if errors is None:
        return np.zeros((0, 4)), None, ()
    n = model.n_joints
    rows, scale = [], np.zeros(n)
    for name, value in zip(errors.names, errors.values.tolist(), strict=True):
        j, kind, detail = parse_name(name, n)
        if kind == "gear":
            rows.append((j, 2.0 if detail[1] == "2" else 1.0, value if detail[0] == "s" else 0.0,
                         value if detail[0] == "c" else 0.0))
        elif kind == "cyclic":
            rows.append((j, detail[1], value if detail[0] == "s" else 0.0,
                         value if detail[0] == "c" else 0.0))
        elif kind == "scale":
            scale[j] += value
    left = tuple(t for t in errors.terms if t not in COMPUTED_TERMS)
    return np.array(rows, float).reshape(-1, 4), (scale if scale.any() else None), left


def _h(R: np.ndarray) -> np.ndarray:
    """The 4x4 of rotation ``R`` (3x3)."""
    T = np.eye(4)
    T[:3, :3] = R
    return T


def _tx(a: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = a
    return T


def reference_correction(chain: CalibratedChain, X: np.ndarray, W: np.ndarray, tool: np.ndarray,
                         solve: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """What the routine computes, in numpy: the corrected targets ``(N, 4, 4)`` in their work
    objects ``W`` ``(N, 4, 4)`` for meant TCP poses ``X`` ``(N, 4, 4)`` (world, m) with ``tool``
    ``(N, 4, 4)``, and the number of IK calls each took ``(N,)``. ``solve``: the controller's IK,
    TCP poses in the world ``(N, 4, 4)`` -> joints ``(N, n)`` rad (in each target's
    configuration; NaN rows: none)."""
    N = len(X)
    Tw = X.copy()  # the commanded TCP pose in the world, wobj * T'_k
    calls = np.zeros(N, int)
    active = np.ones(N, bool)
    for _ in range(chain.iterations):
        q = solve(Tw)
        calls += active
        P = chain.fk(np.where(np.isfinite(q), q, 0.0), tool)
        E = invert_transform(P) @ X
        close = (np.linalg.norm(E[:, :3, 3], axis=1) * 1e3 <= chain.tolerance_mm) & \
            (np.rad2deg(np.linalg.norm(matrix_to_rotvec(E[:, :3, :3]), axis=1)) <= chain.tolerance_deg)
        active &= ~close & np.isfinite(q).all(axis=1)
        Tw = np.where(active[:, None, None], Tw @ E, Tw)
    return invert_transform(W) @ Tw, calls


def routed_sites(program: Program, corrected: set[int]) -> tuple[list[RuntimeSite], list[str]]:
    """The sites to route through the routine (:func:`routable`) and, for the motions with a
    run-time target that are not routed, why (one line each)."""
    by_motion: dict[int, list[RuntimeSite]] = {}
    for s in program.runtime_sites:
        by_motion.setdefault(id(s.account), []).append(s)
    out, why = [], []
    for sites in by_motion.values():
        reason = routable(program, sites, corrected)
        if reason:
            acc = sites[0].account
            why.append(f"{acc.where}: {acc.instruction}: not corrected at run time: {reason}")
        else:
            out += [replace(s, meant=_inside(s, corrected)) for s in sites]
    return out, why


def _inside(site: RuntimeSite, corrected: set[int]) -> tuple[Meant, ...]:
    """The uses of targets corrected offline written inside ``site``'s argument (once each)."""
    uses = {(m.start, m.end): m for w in site.account.named if isinstance(w, RunTime) for m in w.meant
            if id(m.target) in corrected and m.path == site.path
            and site.start <= m.start < m.end <= site.end}
    return tuple(uses[k] for k in sorted(uses))


def routable(program: Program, sites: list[RuntimeSite], corrected: set[int]) -> str:
    """'' when the motion of ``sites`` can go through the routine, else why not."""
    acc = sites[0].account
    if acc.targets:
        return "it also reaches a target corrected offline"
    others = [w for w in acc.named if not isinstance(w, RunTime)]
    if others:
        return others[0]
    if any(w.relative for w in acc.named):
        return ("its target is relative to the position the robot is at, which it reached through a "
                "corrected target: it is already in the corrected space")
    replaced = {id(m.target) for s in sites for m in _inside(s, corrected)}
    if any((w.depends & corrected) - replaced for w in acc.named):
        return ("its target is computed from a target corrected offline (correcting it again would "
                "correct twice)")
    if any(m.target.config is None for s in sites for m in _inside(s, corrected)):
        return "a target its value is computed from has no configuration data"
    for s in sites:
        if s.why_not:
            return s.why_not
        for kind, name, known in (("tool", s.tool_name, program.tools),
                                  ("frame", s.frame_name, program.frames)):
            if not name or name not in known:
                return f"its {kind} {s.tool if kind == 'tool' else s.wobj} is not known to the filter"
            if program.unsupported.get(f"{kind}:{name}"):
                return program.unsupported[f"{kind}:{name}"]
    return ""


class RuntimeWriter:
    """A language's run-time correction (:attr:`Dialect.runtime_correction` names its class): the
    edits that route one motion through the routine and the routine itself."""

    def site_edits(self, text: str, site: RuntimeSite, meant: list[Target]) -> dict[tuple[int, int], str]:
        """Span -> text edits of the file ``text`` that route ``site``'s target through the routine
        (insertions: zero-length spans; every other byte unchanged) and write each of its
        ``site.meant`` uses as the original value of its target (its index in ``meant``, the
        file's list, which :meth:`routine` writes)."""
        raise NotImplementedError

    def routine(self, text: str, chain: CalibratedChain, meant: list[Target], note: str) -> tuple[int, str]:
        """Where in file ``text`` the routine goes and its text (clearly marked, ``note``: the
        marker's words: robocal's version and the model's fingerprint), with the original values
        of the targets ``meant`` (numbers as written, configuration, external axes)."""
        raise NotImplementedError

    @staticmethod
    def refuse_present(text: str, begin: str, names: re.Pattern, function: str = ROUTINE_NAME) -> None:
        """DataError when file ``text`` already holds the routine (its first marker line
        ``begin``: its motions routed again would be corrected twice) or names one of the
        routine's functions (``names``; ``function``: the routine's name as the language writes
        it), before :meth:`routine` adds it."""
        if begin in text:
            raise DataError(f"the program already holds robocal's run-time correction ({function}): filter "
                            "the original program (routing its motions again would correct them twice)")
        clash = names.search(text)
        if clash:
            raise DataError(f"the program already names {clash.group()}: --runtime-correction cannot add its "
                            "functions under that name")
