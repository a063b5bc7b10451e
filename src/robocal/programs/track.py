"""Programs of an arm on a linear track: targets that carry the track's position are corrected.

With a cell model (:mod:`robocal.kinematics.cell`) as the nominal model, a target whose only
external-axis value is the track's (RAPID robtarget ``extax`` ``eax_a``, KRL ``E1`` of an E6POS,
FANUC ``E1``; in mm) is filtered like any other: the controller's world (wobj0, $WORLD, the
FANUC world frame) is the cell's world with the carriage at e1 = 0 and the nominal mount; the
nominal controller puts the arm's base where the nominal cell has it at the program's e1
(:func:`robocal.kinematics.cell.carriage_frames`: ideal track, nominal mount) and solves the arm's
joints there; the calibrated cell is then driven to the intended pose with the track held at that
e1 (:func:`robocal.deploy.compensation.compensate` with ``e1``), and the corrected target is the nominal
cell's pose of those joints. e1, the configuration data (unless the correction crosses a
configuration boundary, as for any target) and every byte outside the pose numbers stay as they
are. Targets with other external axes (a second track axis, a positioner, a FANUC GP2) stay set
aside (:mod:`robocal.programs.external`), as do targets without a track value: where the
carriage stands there depends on the motion before.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace

import numpy as np

from robocal.deploy.compensation import Compensation, compensate
from robocal.ik.singularity import singularity_distance
from robocal.kinematics.cell import arm_model, carriage_frames, is_track_cell
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform
from robocal.programs.model import Program, Target
from robocal.programs.source import NUMBER_RE

# The track's value in a target's external-axis summary (the dialects write "eax_a = 1500",
# "E1 1500.0", "E1 = 1500.000"), in mm; any other axis named there is not the track's.
_NUMBER = f"({NUMBER_RE.pattern})"
_TRACK_VALUE = re.compile(r"^\s*(?:eax_a|E1)\s*=?\s*" + _NUMBER + r"\s*$")
# A zero track value is not in the summary (the dialects list only non-zero axes): a KRL E6POS
# ``E1 0.0`` or a FANUC ``E1 = 0.000 mm`` in the target's own text, up to its closing brace.
_ZERO_IN_TEXT = re.compile(r"\bE1\s*=?\s*" + _NUMBER)
MM = 1e-3  # track values in programs are millimetres
_BLOCK_CHARS = 2000  # a target's brace block (KRL aggregate, FANUC P[] position) is shorter than this


@dataclass
class TrackProgram:
    """The track of a cell model and the carriage position (m) of each target that has one."""

    cell: Robot
    e1: dict[int, float] = field(default_factory=dict)  # id(target) -> e1, m

    @property
    def arm(self) -> Robot:
        """The nominal arm (base frame identity, :func:`robocal.kinematics.cell.arm_model`): what the
        controller's configuration data, joint limits and closed form refer to."""
        return arm_model(self.cell)

    def take(self, program: Program, warnings: list[str]) -> None:
        """Keep the targets whose only external value is the track's (their e1 recorded, their
        external text cleared so that :func:`robocal.programs.external.set_aside_external` leaves
        them); set aside the targets without one."""
        kept = []
        for t in program.targets:
            value = _TRACK_VALUE.match(t.external) if t.external else _written_zero(t)
            if value is not None:
                self.e1[id(t)] = float(value.group(1)) * MM
                t.external = ""
            elif not t.external:
                why = ("no track position (eax_a / E1): where the carriage stands depends on the motion "
                       "before; give the target its track value")
                program.not_corrected[id(t)] = why
                warnings.append(f"{t.where}: not corrected: {why}")
                program.uncorrected.append(f"{t.where}: not corrected: {why}")
                continue
            kept.append(t)
        program.targets = kept

    def values(self, targets: list[Target]) -> np.ndarray:
        """``(N,)`` e1 (m) of ``targets``."""
        return np.array([self.e1[id(t)] for t in targets])

    def in_arm_frame(self, targets: list[Target], F: np.ndarray) -> np.ndarray:
        """World flange poses ``F`` ``(N, 4, 4)`` as the nominal controller's arm sees them: in its base
        frame with the carriage at each target's e1 (ideal track, nominal mount)."""
        return invert_transform(carriage_frames(self.cell, self.values(targets))) @ F

    def compensate(self, calibrated: Robot, targets: list[Target], flanges: np.ndarray,
                   seeds: np.ndarray) -> Compensation:
        """The compensation of world flange poses ``flanges`` ``(N, 4, 4)`` on the ``calibrated`` cell
        (already the controller's view: :func:`robocal.deploy.compensation.controller_model`) with the track
        at each target's e1, seeded by the controller's arm joints ``seeds`` ``(N, 6)``; returned
        in the arm's view (joints ``(N, 6)`` and their singularity distances), the corrected
        targets in the world (the nominal cell's poses)."""
        comp = compensate(calibrated, self.cell, flanges, seeds=seeds, e1=self.values(targets))
        arm_q = comp.joints[:, 1:]
        return replace(comp, joints=arm_q, singularity=singularity_distance(arm_model(calibrated), arm_q))


def _written_zero(t: Target) -> re.Match | None:
    """The track value written in target ``t``'s own text (a zero the summary leaves out), else None."""
    text = t.source.text
    end = text.find("}", t.offset)
    if end < 0 or end - t.offset > _BLOCK_CHARS:  # no brace block (RAPID): the target's line
        end = text.find("\n", t.offset) % (len(text) + 1)
    found = _ZERO_IN_TEXT.search(text, t.offset, end)
    return found if found is not None and float(found.group(1)) == 0.0 else None


def track_program(nominal: Robot) -> TrackProgram | None:
    """The track handling for ``nominal`` when it is an arm on a track, else None."""
    return TrackProgram(nominal) if is_track_cell(nominal) and nominal.n_joints == 7 else None
