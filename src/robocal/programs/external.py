"""Targets with external-axis values (a track or gantry moving the robot, a positioner moving the
work: RAPID ``extax`` not 9E9, KUKA E1..E6 not 0, FANUC E1.. values or a second motion group):
where such a target is depends on axes the filter does not model (the base and the work are
assumed fixed), so they are set aside before filtering and every motion that reaches one is named
with the axis values. This check is kept apart from the filter so that a cell model (a track as a
joint of the chain) can take these targets over in one place."""

from __future__ import annotations

from robocal.programs.model import Program


def set_aside_external(program: Program, warnings: list[str]) -> None:
    """Remove the targets that carry external-axis values from ``program.targets``; each gets a
    warning and its reason in ``program.not_corrected`` (so each motion reaching it is named)."""
    kept = []
    for t in program.targets:
        if not t.external:
            kept.append(t)
            continue
        why = (f"external axes {t.external}: the target moves with axes outside the arm (a track, gantry "
               "or positioner) and the filter assumes a fixed base and work")
        program.not_corrected[id(t)] = why
        warnings.append(f"{t.where}: not corrected: {why}")
        program.uncorrected.append(f"{t.where}: not corrected: {why}")
    program.targets = kept
