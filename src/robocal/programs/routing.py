"""The run-time correction applied to a filtered program (``filter --runtime-correction``): the
one place the filter engine asks for it (:class:`Routing`), so that the capability is this module
and :mod:`robocal.programs.runtime` (what the routine computes, which motions it may take) plus
each language's writer (:attr:`Dialect.runtime_correction
<robocal.programs.dialects.base.Dialect.runtime_correction>`), not branches of the engine's
long function."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.model import Robot
from robocal.programs.dialects.base import Dialect
from robocal.programs.edits import FileEdits
from robocal.programs.external import carried_arm
from robocal.programs.model import Program, Target
from robocal.programs.registry import capable
from robocal.programs.runtime import ROUTED, ROUTINE_NAME, RunTime, calibrated_chain, routed_sites
from robocal.programs.source import ProgramText
from robocal.trust.output_marker import marker_text


@dataclass(frozen=True)
class Routing:
    """What the routine is written from: the ``calibrated`` and ``nominal`` models, the
    controller's base in the calibrated model's world (``robot_base``, 4x4, m) and whether the
    program's external axes carry no arm (``fixed_base``: ``filter --fixed-base``)."""

    calibrated: Robot
    nominal: Robot
    robot_base: np.ndarray
    fixed_base: bool = False

    @staticmethod
    def check(d: Dialect, arm_alone: bool, tcp: dict | None) -> None:
        """Refuse the run-time correction where no routine can be written: a language without the
        capability, an arm on a track or with a positioner (``arm_alone`` False), a real TCP
        (``tcp``: --tcp)."""
        if not d.runtime_correction:
            able = ", ".join(c.name for c in capable("runtime_correction"))
            raise DataError(f"--runtime-correction writes routines in {able}, not {d.name}")
        if not arm_alone:
            raise DataError("--runtime-correction corrects an arm alone: not an arm on a track or with a "
                            "positioner")
        if tcp:
            raise DataError("--runtime-correction computes with the program's tool data: it cannot be "
                            "combined with --tcp")

    def route(self, d: Dialect, program: Program, sources: list[ProgramText], corrected: set[int],
              records: list, edits: dict, warnings: list) -> tuple[list, dict]:
        """``(records, outputs)`` with the motions whose target is computed at run time routed
        through the language's run-time correction (:mod:`robocal.programs.runtime`), its routine
        added to each file holding one; every other motion's record and every other byte as they
        were. ``corrected``: ids of the targets corrected offline; ``edits``: path ->
        :class:`FileEdits` of the offline correction (each popped as its file is written);
        ``warnings`` appended to. None is routed when the program's targets move external axes
        that may carry the arm (the routine's chain is the arm alone) unless ``fixed_base`` says
        none does."""
        sites, why_not = routed_sites(program, corrected)
        used = [t for _, _, t in program.motions if isinstance(t, Target)]  # every target a motion reaches
        used += [t for s in sites for w in s.account.named if isinstance(w, RunTime) for t in w.sources]
        # the offline correction's judgement (an axis held at one value, KRL's E1..E6 = 0, moves no arm)
        axes = sorted(carried_arm(program, d, targets=list({id(t): t for t in used}.values())))
        if sites and axes and not self.fixed_base:
            why_not = [f"--runtime-correction: no motion routed: the targets move external axes "
                       f"({', '.join(axes)}) that may carry the arm, which the routine's chain (the arm "
                       "alone) does not follow; give --fixed-base if none does"]
            sites = []
        warnings += why_not
        writer = d.runtime_writer()
        chain = calibrated_chain(self.calibrated, self.nominal, self.robot_base)
        routed_at = {(s.account.source.path, s.account.source.line_of(s.account.at)) for s in sites}
        outputs = {}
        for src in sources:
            mine = {(s.start, s.end): s for s in sites if s.path == src.path}
            fe = edits.pop(src.path, FileEdits())
            if mine:
                meant = list({id(m.target): m.target for s in mine.values() for m in s.meant}.values())
                for site in mine.values():
                    fe.spans.update(writer.site_edits(src.text, site, meant))
                at, text = writer.routine(src.text, chain, meant, marker_text(self.calibrated))
                fe.spans[(at, at)] = src.in_file_line_ends(text)
            outputs[src.path] = fe.apply(src)
        if not program.runtime_sites:  # asked for, nothing to do: said, so no one counts on it
            warnings.append(f"--runtime-correction: no motion of these files computes its target at run time "
                            f"(all are corrected offline): {ROUTINE_NAME} is not added")
        if sites:
            left = f"; left out: the joint-error terms {', '.join(chain.left_out)}" if chain.left_out else ""
            warnings.append(f"{len(routed_at)} motion(s) whose target is computed at run time go through "
                            f"{ROUTINE_NAME}, added to the program: up to {chain.iterations} "
                            f"inverse-kinematics calls each at run time{left}")
        at = {(p.name, ln) for p, ln in routed_at}
        return [replace(r, reason=f"{ROUTED}: {r.reason}") if (r.file, r.line) in at else r
                for r in records], outputs
