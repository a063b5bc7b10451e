"""The protocol every robot language implements (:class:`Dialect`): pose numbers <-> 4x4
transforms, resolutions to write them with, its configuration scheme and how to rewrite a
target's configuration, how its files are recognised, its load statements, its provenance
marker and the programs robocal writes in it."""

from __future__ import annotations

import importlib
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.kinematics.model import Robot
from robocal.programs.config import ConfigScheme
from robocal.programs.load_data.base import Load, LoadReader
from robocal.programs.model import Program
from robocal.programs.source import Number, ProgramText
from robocal.programs.target import Target


class Dialect:
    """One robot language: how its files are recognised, read and rewritten (the reader), the
    load statements it holds, the provenance marker in its comment syntax, and the campaign and
    test programs robocal writes in it. A subclass sets the attributes and overrides the methods
    its language has; the registry (:mod:`robocal.programs.registry`) maps its ``key`` to it.

    Capabilities the filter asks instead of the language's name: ``position_registers`` (a file
    of position registers the motions use, ``filter_program(position_registers=...)``),
    ``payload_schedules`` (load schedules the motions select, ``payload_schedules=...``),
    ``scara_programs`` (its programs drive a SCARA: the filter reads them for a 4-joint SCARA),
    ``runtime_correction`` (a routine in this language corrects targets computed at run time:
    ``filter --runtime-correction``), ``external_axis_names`` and ``positioner_group`` (how its
    programs name a positioner's axes,
    the controller's logical external axes of a cell file: :meth:`positioner_axes`, which the
    coordinated-motion filter and the campaign writers ask), ``arm_axes`` (which of its programs'
    external axes may carry the arm, a track or gantry the text cannot tell from a positioner:
    :mod:`robocal.programs.carrier` weighs their values)."""

    key = ""  # registry key: --format, poses --program
    name = ""  # the language as messages and results name it
    title = ""  # the language in a recognition message (default: ``name``)
    vendor = ""  # the robot maker whose controllers run it (messages about capabilities)
    suffixes: tuple[str, ...] = ()  # of its files, lower case
    signature = ""  # a regular expression (multi-line, any case) a file in this language matches
    length_unit = "mm"  # unit of the positions of --tool / --frame values
    angle_unit: str | None = None  # unit their angles are checked in ('deg', 'rad'; None: not checked)
    position_registers = False  # capability: motions to position registers kept in a file of their own
    payload_schedules = False  # capability: loads selected by number from the controller's schedules
    schedule_statement = ""  # ... by this statement
    shared_suffixes: tuple[str, ...] = ()  # suffixes another language has too (told by `recognises`)
    campaign_format = ""  # a campaign program's kind in output-name checks ('RAPID'; '': a folder)
    campaign_suffix = ""  # ... and its file suffix
    campaign_rank = 0  # the order poses writes the languages' programs in
    campaign_refuses_tracks = False  # its campaign programs are refused for an arm on a track
    campaign_scara = False  # its campaign programs drive a SCARA (4 joints, the quill in mm)
    campaign_external = False  # its campaign programs move a positioner with the arm (ExternalAxes)
    scara_programs = False  # capability: its programs drive a SCARA (its configuration data say so)
    scheme: ConfigScheme | None = None
    n_values = 6  # pose numbers per target
    shared_decimals: tuple[tuple[int, ...], ...] = ()  # pose columns written at the file's finest decimals
    keep_width = False  # numbers right-aligned after spaces keep their width (FANUC)
    euler_columns: tuple[int, ...] = ()  # pose columns that are Euler angles in deg (gimbal lock possible)
    frame_help = ""  # how --tool/--frame values are written for this dialect
    # its names of the controller's logical external axes 1, 2, ... (a robtarget's eax_a, E6POS's E1);
    # empty: its programs name no external axes
    external_axis_names: tuple[str, ...] = ()
    positioner_group = False  # a positioner moves as its own motion group / station: its axes 1..m there
    # its Target.axes names that may carry the arm (a track or gantry its text cannot tell from a
    # positioner the work object does not follow); empty: none can (a FANUC group or an INFORM
    # station moves no arm; their arm-carrying axes, an integrated rail or base axes, are named by
    # their readers)
    arm_axes: tuple[str, ...] = ()
    # capability: a run-time correction routine in this language ("module:Class" of its
    # robocal.programs.runtime.RuntimeWriter; '': none), filter --runtime-correction
    runtime_correction = ""

    def positioner_axes(self, external_axes: tuple[int, ...]) -> tuple[str, ...]:
        """The names this language's programs give a positioner's axes, which are the controller's
        logical external axes ``external_axes`` (1-based, in the positioner's axis order; a cell
        file's ``external_axes``): logical axis k is ``external_axis_names[k - 1]``; a language
        whose positioner is its own motion group or station (``positioner_group``) names its axes
        1..m there whatever their logical numbers. DataError: an axis this language has no name for.

        Examples
        --------
        >>> from robocal.programs.registry import dialect_named
        >>> dialect_named("rapid").positioner_axes((2, 3)), dialect_named("krl").positioner_axes((2, 3))
        (('eax_b', 'eax_c'), ('E2', 'E3'))
        >>> dialect_named("fanuc").positioner_axes((2, 3))  # its motion group's own axes
        ('E1', 'E2')
        """
        numbers = tuple(range(1, len(external_axes) + 1)) if self.positioner_group else tuple(external_axes)
        names = self.external_axis_names
        bad = [k for k in numbers if not 1 <= k <= len(names)]
        if bad:
            have = f"external axes 1..{len(names)} ({', '.join(names)})" if names else "no external axes"
            raise DataError(f"{self.name} programs name {have}: no name for external axis {bad[0]}")
        return tuple(names[k - 1] for k in numbers)

    def runtime_writer(self):
        """This language's :class:`robocal.programs.runtime.RuntimeWriter` (``runtime_correction``)."""
        if not self.runtime_correction:
            raise DataError(f"robocal writes no run-time correction in {self.name}")
        module, name = self.runtime_correction.split(":")
        return getattr(importlib.import_module(module), name)()

    def parse(self, sources: list[ProgramText], frames: dict[str, np.ndarray],
              tools: dict[str, np.ndarray], references: list[ProgramText] = ()) -> Program:
        """Targets, frames and tools of the files; ``references`` are read for their tool and
        frame declarations only (KUKA $config.dat, ABB system modules); ``frames``/``tools``
        from the command line (already in SI) complete or override those in the files; the
        tool and frame data the program holds without them are its ``declared_tools`` and
        ``declared_frames`` (the files are read once: a ``--tool`` / ``--frame`` that differs is
        named from this parse, :mod:`robocal.programs.overrides`)."""
        raise NotImplementedError

    def reference_outputs(self, program: Program, references: list[ProgramText],
                          corrected: dict[Path, bytes], kept: set[int]) -> dict[Path, bytes]:
        """Files written for the corrected targets that ``references`` hold (a FANUC POSREG.VA's
        registers: the TP program PR_CAL.LS; an INFORM VAR.DAT's P variables: VAR_CAL.DAT), by
        path (the reference's folder, the file's own name): ``corrected``: reference path -> its
        text with those targets' numbers corrected (the text itself when none changed); ``kept``:
        ids of the targets left uncorrected. None by default: a reference is read for
        declarations only."""
        return {}

    def to_pose(self, values: np.ndarray) -> np.ndarray:
        """Pose numbers ``(N, k)`` in the file's notation -> ``(N, 4, 4)`` (m)."""
        raise NotImplementedError

    def from_pose(self, T: np.ndarray, old: np.ndarray) -> np.ndarray:
        """``(N, 4, 4)`` (m) -> pose numbers ``(N, k)``, of all equivalent notations the one
        nearest the old numbers (quaternion sign, Euler branch, rotation-vector turn)."""
        raise NotImplementedError

    def resolutions(self) -> np.ndarray:
        """``(k,)`` finest step worth writing for each pose number, in its unit."""
        raise NotImplementedError

    def config_edits(self, target: Target, new: np.ndarray) -> dict[tuple[int, int], str]:
        """Span -> text edits writing configuration row ``new`` into ``target``."""
        raise NotImplementedError

    def number_edit(self, target: Target, num: Number, text: str) -> str:
        """The text that replaces ``num`` (its span) when it is rewritten as ``text``: the number
        itself, or, for a number the file leaves out (a zero-length span), whatever writes it
        (VAL3: the attribute)."""
        return text

    def name_key(self, name: str) -> str:
        """The key a tool or frame name has in :class:`Program` (RAPID names ignore case)."""
        return name

    def frame_from_text(self, text: str) -> np.ndarray:
        """A ``--tool``/``--frame`` value (comma-separated numbers in this dialect's pose
        notation) -> 4x4 (m)."""
        try:
            vals = np.array([float(v) for v in text.replace(" ", "").split(",") if v], dtype=float)
        except ValueError:
            raise DataError(f"frame {text!r}: expected comma-separated numbers ({self.frame_help})") from None
        if vals.size != self.n_values or not np.isfinite(vals).all():
            raise DataError(f"frame {text!r}: expected {self.n_values} numbers ({self.frame_help})")
        return self.to_pose(vals[None])[0]

    def recognises(self, head: str) -> bool:
        """``head`` (a file's first 4 kB) is in this language whatever its suffix (a Yaskawa job
        or VAR.DAT): it wins over a suffix it shares with another language."""
        return False

    def folder_files(self, folder: Path) -> list[Path] | None:
        """The program files of an application ``folder`` (a VAL3 application), None: this
        language's programs are files."""
        return None

    def load_reader(self, tools: dict[str, np.ndarray], schedules: dict[int, Load] | None) -> LoadReader:
        """The reader of this language's load statements (:mod:`robocal.programs.load_data`);
        ``tools``: the program's tool frames (4x4, m); ``schedules``: payload schedules
        (``payload_schedules`` languages)."""
        return LoadReader()

    def read_schedules(self, path: str | Path) -> dict[int, Load]:
        """The payload schedules of file ``path`` (``payload_schedules`` languages)."""
        raise DataError(f"{self.name} programs select no payload schedules")

    def mark(self, text: str, body: str, note: str) -> str:
        """``text`` (a filtered file) with the provenance marker added in a comment
        (:mod:`robocal.trust.output_marker`): ``body`` is ``robocal <version> model
        <fingerprint>``, ``note`` the same with what was done to the file."""
        raise DataError(f"no provenance marker for program format {self.name!r}")

    def marked_by_name(self, src: ProgramText) -> bool:
        """Whether file ``src`` is of a format with no comment syntax (an INFORM VAR.DAT), whose
        corrected copy robocal marks by its name (`robocal.trust.output_marker.corrected_name`)."""
        return False

    def campaign_files(self, joints: np.ndarray, robot: Robot, path: Path, **options) -> dict[str, str]:
        """A campaign program visiting ``joints`` ``(N, 6)`` (rad) of ``robot`` in order, written
        as ``path``: file path -> text (:mod:`robocal.campaign.programs`, ``options``: its
        speed_percent, settle_s, procedure, comment)."""
        raise DataError(f"robocal writes no {self.name} campaign programs")

    def campaign_paths(self, path: Path, procedure: str) -> list[str]:
        """The files ``campaign_files`` writes or overwrites as ``path`` (checked before planning)."""
        return [str(path)]

    def campaign_folder(self, path: Path) -> Path | None:
        """The folder a campaign program written as ``path`` is (created if absent), None: a file."""
        return None

    def test_program(self, folder: Path, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                     frame: np.ndarray, name: str, variables: bool = False) -> tuple[list[Path], dict, dict]:
        """A simulated program (:func:`robocal.programs.simulate.write_program`)."""
        raise NotImplementedError
