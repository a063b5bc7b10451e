"""What every program format gives the filter: Cartesian targets with the spans to rewrite.

A :class:`Target` is one Cartesian position of a program (a declaration or a literal written
in a motion instruction): the numbers of its pose in the file's units, the frame (work object,
base, user frame, feature) and the tool it is used with, and its configuration data. A
:class:`Dialect` knows one vendor's notation: pose numbers <-> 4x4 transforms, resolutions to
write them with, its configuration scheme, and how to rewrite a target's configuration.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.programs.config import ConfigScheme
from robocal.programs.motions import Account, Ledger
from robocal.programs.source import Number, ProgramText

IDENTITY = "identity"  # name of the identity frame / tool (world, wobj0, tool0, $NULLFRAME ...)


@dataclass
class Target:
    """One Cartesian target. ``numbers``: the pose numbers as written (vendor order and units);
    ``frame`` / ``tool``: keys into :attr:`Program.frames` / :attr:`Program.tools`;
    ``config``: the vendor's configuration row (None: the target has none); ``config_spans``:
    whatever the dialect needs to rewrite it; ``qnear``: joints (rad) a controller would start
    its search from (URScript ``qnear=``), else None."""

    source: ProgramText
    offset: int
    name: str
    numbers: list[Number]
    frame: str = IDENTITY
    tool: str = IDENTITY
    config: np.ndarray | None = None
    config_spans: object = None
    qnear: np.ndarray | None = None
    order: int = 0  # position in execution order (first execution, :mod:`robocal.programs.flow`)
    monitored: bool = True  # False: the motion runs with configuration monitoring off (RAPID ConfL Off)
    external: str = ""  # external-axis values the target carries (a track, gantry or positioner)

    @property
    def line(self) -> int:
        return self.source.line_of(self.offset)

    @property
    def where(self) -> str:
        return f"{self.source.path.name}:{self.line} ({self.name})"

    def values(self) -> np.ndarray:
        return np.array([n.value for n in self.numbers], dtype=float)


@dataclass
class Program:
    """Parsed program files: targets in execution order, named frames and tools (4x4, m, in the
    robot's base frame / on the flange), warnings about what was left alone, and joint targets
    ``(index of the next Cartesian target, joints rad)`` for dialects without configuration, and
    tools / frames whose targets cannot be filtered (a stationary tool, a moving frame).
    ``motions``: each motion's target or joints ``(file, offset, Target | joints)`` in text order;
    ``sequence``: the same in execution order, every execution (a routine called twice runs its
    motions twice), with the call that entered its routine (``file:line``, '' at the entry).
    ``ledger``: one :class:`~robocal.programs.motions.Account` per motion instruction to a Cartesian
    pose (:meth:`motion`); ``not_corrected``: ``id(target)`` -> why, for targets a dialect leaves
    alone although a motion reaches them (a FANUC position used only as an INC displacement).
    ``executed``: the text pieces ``(file, start, end)`` in the order the controller runs them
    (:mod:`robocal.programs.flow`; empty: not known, text order)."""

    targets: list[Target]
    frames: dict[str, np.ndarray] = field(default_factory=dict)
    tools: dict[str, np.ndarray] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    joint_targets: list[tuple[int, np.ndarray]] = field(default_factory=list)
    unsupported: dict[str, str] = field(default_factory=dict)  # 'tool:NAME' / 'frame:NAME' -> why
    uncorrected: list[str] = field(default_factory=list)  # motions left as they are, each also a warning
    used: dict[int, tuple[str, str, str]] = field(default_factory=dict)  # id(target) -> tool, frame, where
    motions: list[tuple[Path, int, Target | np.ndarray]] = field(default_factory=list)
    sequence: list[tuple[Target | np.ndarray, str]] = field(default_factory=list)
    ledger: Ledger = field(default_factory=Ledger)
    not_corrected: dict[int, str] = field(default_factory=dict)
    executed: list[tuple[Path, int, int]] = field(default_factory=list)  # text pieces in execution order

    def motion(self, source: ProgramText, at: int, instruction: str) -> Account:
        """The account of the motion instruction at offset ``at`` of ``source`` (opened once)."""
        return self.ledger.open(source, at, instruction)

    def use(self, t: Target, tool: str, frame: str, here: str, label: str, frame_word: str,
            motion: tuple[Path, int], account: Account | None = None) -> bool:
        """A motion at ``here`` (``motion``: its file and offset) reaches target ``t`` with ``tool`` in
        ``frame``: the first use appends it to :attr:`targets` (True); a later use with the same
        tool and frame adds nothing (False); one with another tool or frame is refused (one
        corrected target cannot serve both). Every use is a step of :attr:`motions`. ``label``
        names the target and ``frame_word`` its kind of frame in the message. ``account``: the
        motion instruction's account, which the target joins."""
        self.motions.append((*motion, t))
        if account is not None:
            account.reach(t)
        if id(t) in self.used:
            tool0, frame0, at0 = self.used[id(t)]
            if (tool0, frame0) != (tool, frame):
                raise DataError(f"{here}: {label} is used with tool {tool} and {frame_word} {frame}, but at "
                                f"{at0} with tool {tool0} and {frame_word} {frame0}: one corrected target "
                                "cannot serve both; declare a copy for each use")
            return False
        self.used[id(t)] = (tool, frame, here)
        t.tool, t.frame, t.order = tool, frame, len(self.targets)
        self.targets.append(t)
        return True

    def skip(self, where: str, instruction: str, why: str, account: Account | None = None,
             label: str = "") -> None:
        """Account for a motion to a Cartesian pose this filter cannot correct: a warning naming
        ``where`` (file:line), the instruction and why; ``account``: the motion instruction's account
        (None: a call of a routine not in these files, which may move there), ``label``: what the
        motion moves to as written."""
        if account is not None:
            account.name(why, label)
        text = f"{where}: {instruction}: not corrected: {why}"
        if text not in self.uncorrected:
            self.uncorrected.append(text)
            self.warnings.append(text)


class Dialect:
    """One vendor's program format (subclasses: rapid, krl, fanuc_ls, urscript)."""

    name = ""
    suffixes: tuple[str, ...] = ()
    scheme: ConfigScheme | None = None
    n_values = 6  # pose numbers per target
    shared_decimals: tuple[tuple[int, ...], ...] = ()  # pose columns written at the file's finest decimals
    keep_width = False  # numbers right-aligned after spaces keep their width (FANUC)
    euler_columns: tuple[int, ...] = ()  # pose columns that are Euler angles in deg (gimbal lock possible)
    frame_help = ""  # how --tool/--frame values are written for this dialect

    def parse(self, sources: list[ProgramText], frames: dict[str, np.ndarray],
              tools: dict[str, np.ndarray], references: list[ProgramText] = ()) -> Program:
        """Targets, frames and tools of the files; ``references`` are read for their tool and
        frame declarations only (KUKA $config.dat, ABB system modules); ``frames``/``tools``
        from the command line (already in SI) complete or override those in the files."""
        raise NotImplementedError

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
