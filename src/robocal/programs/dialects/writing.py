"""What every language's campaign program writer shares (``dialects/<language>/campaign.py``;
what the programs do: :mod:`robocal.campaign.programs`): fixed-point numbers, identifiers, the
checks of joints, speed and settle time, and the header comment."""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.core.escape import comment_text
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform
from robocal.programs.dialects.base import Dialect

PROGRAM_JOINTS = 6                 # every language here drives a six-axis arm
DEGREE_DECIMALS = 10               # written precision of joint values in degrees
RADIAN_DECIMALS = 12               # ... in radians
DEFAULT_SPEED_PERCENT = 20.0
DEFAULT_SETTLE_S = 1.0
DEFAULT_PROCEDURE = "MeasurePose"


def fixed_point(value: float, decimals: int) -> str:
    """Fixed-point text without exponent or trailing zeros (every controller parses it)."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def identifier(name: str, what: str, limit: int) -> str:
    """``name`` as given when it is an identifier every controller accepts (a letter, then letters,
    digits or underscores, at most ``limit`` characters), else DataError naming ``what`` it is."""
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name or "") or len(name) > limit:
        raise DataError(f"{what} {name!r} is not a valid identifier: a letter, then letters, digits or "
                        f"underscores, at most {limit} characters")
    return name


def checked_joints(joints_deg: np.ndarray, speed_percent: float, settle_s: float,
                   language: str, joints: int = PROGRAM_JOINTS) -> np.ndarray:
    """``joints_deg`` as an ``(N, joints)`` float array, refused (DataError) when not finite or the
    speed or settle time is out of range; ``language`` names the program in the message."""
    q = np.asarray(joints_deg, dtype=float)
    if q.ndim != 2 or q.shape[1] != joints:
        raise DataError(f"a {language} campaign program drives a {joints}-axis robot; this robot has "
                        f"{q.shape[-1]} joints")
    if not np.isfinite(q).all():
        raise DataError("joint values must be finite")
    if not 0 < speed_percent <= 100:
        raise DataError(f"the speed must be a percentage in (0, 100], got {speed_percent}")
    if not 0 <= settle_s < 3600:
        raise DataError(f"the settle time must be in [0, 3600) s, got {settle_s}")
    return q


@dataclass(frozen=True)
class ExternalAxes:
    """A positioner's values at each pose of a campaign program (issue 45): the controller moves its
    mechanical unit with the arm, in the same motion instruction.

    Attributes
    ----------
    values : numpy.ndarray, shape (N, m)
        The positioner's axes at each pose, in the program's units: deg (mm on a prismatic axis).
    unit : str
        Its mechanical unit as the controller names it: RAPID ``STN1``, KRL the machine (its axes
        are E1.. of the robot's E6AXIS), INFORM the station (``ST1``), FANUC the motion group
        (``GP2``).
    axes : tuple of str
        The program's letter of each axis: RAPID ``eax_a``..``eax_f`` (the logical axes the unit
        is configured on), KRL / INFORM / FANUC ``E1``.. (their order in the unit); or none, with
        ``external_axes``.
    prismatic : tuple of bool
        Which axes are prismatic (mm).
    pulses_per_unit : tuple of float, optional
        Encoder pulses per degree (per mm) of each axis: INFORM writes a station's positions in
        pulses (the controller's parameters hold the ratio, not the cell file).
    external_axes : tuple of int, optional
        The controller's logical external-axis numbers of the axes (a cell file's positioner's
        ``external_axes``), which each language names (`in_language`) when ``axes`` are not given.
    """

    values: np.ndarray
    unit: str
    axes: tuple[str, ...] = ()
    prismatic: tuple[bool, ...] = ()
    pulses_per_unit: tuple[float, ...] | None = None
    external_axes: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        v = np.asarray(self.values, dtype=float)
        if v.ndim != 2 or not 1 <= v.shape[1] <= len(EXTERNAL_LETTERS) or not np.isfinite(v).all():
            raise DataError("a positioner's program values must be a finite (N, m) array, 1 <= m <= 6")
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "prismatic", tuple(self.prismatic) or (False,) * v.shape[1])
        named = self.axes or self.external_axes
        if len(named) != v.shape[1] or len(self.prismatic) != v.shape[1]:
            raise DataError(f"{self.unit}: {v.shape[1]} axes' values but {len(named)} axis letters")
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", self.unit or ""):
            raise DataError(f"the mechanical unit {self.unit!r} is not a valid identifier")
        ratios = self.pulses_per_unit
        if ratios is not None and (len(ratios) != v.shape[1] or
                                   not all(np.isfinite(r) and r > 0 for r in ratios)):
            raise DataError(f"{self.unit}: give one positive pulses-per-degree (mm) ratio per axis")

    def in_language(self, dialect: Dialect) -> ExternalAxes:
        """These values with the axes named as ``dialect``'s programs name them: the logical
        ``external_axes`` through :meth:`Dialect.positioner_axes
        <robocal.programs.dialects.base.Dialect.positioner_axes>`; without them, as given (``axes``)."""
        return replace(self, axes=dialect.positioner_axes(self.external_axes)) if self.external_axes else self

    def units(self) -> list[str]:
        """Each axis' unit in a program: ``deg`` or ``mm``."""
        return ["mm" if p else "deg" for p in self.prismatic]

    def slots(self, letters: tuple[str, ...], language: str) -> list[int]:
        """The slot (0-based) of each axis among a language's ``letters`` (RAPID ``eax_a``..): a
        letter of another language, or one used twice, is refused."""
        lower = [a.lower() for a in letters]
        out = []
        for axis in self.axes:
            if axis.lower() not in lower:
                raise DataError(f"{self.unit}: axis {axis!r} is not a {language} external axis "
                                f"({', '.join(letters)})")
            out.append(lower.index(axis.lower()))
        if len(set(out)) < len(out):
            raise DataError(f"{self.unit}: an external axis letter is given twice ({', '.join(self.axes)})")
        return out


EXTERNAL_LETTERS = ("E1", "E2", "E3", "E4", "E5", "E6")  # KRL E6AXIS, INFORM and FANUC axis order


def checked_external(external: ExternalAxes | None, n: int, language: str) -> ExternalAxes | None:
    """``external`` when it has one row per pose of ``n``; DataError naming ``language`` otherwise."""
    if external is not None and len(external.values) != n:
        raise DataError(f"a {language} campaign program of {n} poses got {len(external.values)} rows of "
                        f"{external.unit}'s values")
    return external


def comment_lines(comment: str, n: int) -> list[str]:
    """Comment text for a program header: printable ASCII only (controllers' comment charset), no
    line end (`robocal.core.escape.comment_text`); a language that puts it elsewhere than a line
    comment escapes it further (VAL3's CDATA: `robocal.core.escape.cdata_text`)."""
    clean = comment_text(comment or f"robocal measurement campaign: {n} poses")
    return [clean[i : i + 100] for i in range(0, len(clean), 100)] + [
        "joint values in the controller's joint convention; replace the measure procedure's body "
        "with your tracker trigger"]


def ascii_comment(text: str) -> str:
    """Printable ASCII without quotes (a TP comment)."""
    return "".join(ch if 32 <= ord(ch) < 127 and ch not in "\"'" else " " for ch in text)


def program_poses(d: Dialect, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                  frame: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """A test program's target poses ``(N, 4, 4)`` (m, in ``frame``) at joints ``q`` ``(N, 6)``
    (rad) of ``nominal`` with TCP ``tool``, and the configuration rows of dialect ``d`` there
    (None: it has no configuration data)."""
    P = invert_transform(frame) @ nominal.fk(q) @ tool
    return P, (d.scheme.encode(nominal, q) if d.scheme is not None else None)


def quaternions(R: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(N, 4)`` w first, w >= 0, of rotation matrices ``(N, 3, 3)``."""
    q = Rotation.from_matrix(R).as_quat(scalar_first=True)
    return np.where(q[:, :1] < 0, -q, q)


def zyx_angles(R: np.ndarray) -> np.ndarray:
    """``(N, 3)`` angles (a, b, c) deg of rotation matrices ``(N, 3, 3)``: R = Rz(a) Ry(b) Rx(c)."""
    return Rotation.from_matrix(R).as_euler("ZYX", degrees=True)


def frame_text(T: np.ndarray, kind: str) -> str:
    """A 4x4 frame as text: ``rotvec`` x,y,z (m),rx,ry,rz (rad); ``zyx`` X,Y,Z (mm),A,B,C (deg,
    R = Rz(A) Ry(B) Rx(C))."""
    if kind == "rotvec":
        return ", ".join(f"{v:.6f}" for v in (*T[:3, 3], *Rotation.from_matrix(T[:3, :3]).as_rotvec()))
    if kind == "zyx":
        a, b, c = zyx_angles(T[None, :3, :3])[0]
        return ",".join(f"{v:.6f}" for v in (*(T[:3, 3] * 1e3), a, b, c))
    raise ValueError(kind)


def wpr_text(T: np.ndarray) -> str:
    """X,Y,Z,W,P,R (mm, deg: turns about the fixed x, y, z axes) of a 4x4 frame."""
    a, b, c = zyx_angles(T[None, :3, :3])[0]
    return ",".join(f"{v:.6f}" for v in (*(T[:3, 3] * 1e3), c, b, a))
