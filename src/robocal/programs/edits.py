"""The text edits that write corrected targets back into their files: every pose number the
correction moves, in the file's style (:func:`format_numbers`: what
:func:`robocal.programs.source.format_number` writes, for all numbers of a program at once), and
the configuration data where the correction crossed a configuration boundary.

The numbers of a 100,000-target program are formatted by one ``%`` operation per distinct
number of decimals instead of one call per number; the rare styles (a leading '+', FANUC's
'.5' without its zero, a negative zero) are fixed one by one afterwards.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from robocal.kinematics.transforms import matrix_to_rotvec
from robocal.programs.dialects.base import Dialect
from robocal.programs.source import ProgramText
from robocal.programs.target import Target

SWING_DEG = 1.0  # Euler angles moving more than this for a smaller turn: named (gimbal lock)
_SEP = "\x00"  # joins the formats of one batch; never in a formatted number


def format_numbers(values: np.ndarray, texts: list[str], written: np.ndarray, resolutions: np.ndarray,
                   decimals: np.ndarray) -> list[str]:
    """:func:`robocal.programs.source.format_number` for many numbers at once: the text of each
    new value ``values`` ``(M,)`` replacing the number written as ``texts[m]`` with ``written[m]``
    decimals (:attr:`~robocal.programs.source.Number.decimals`), at ``resolutions`` ``(M,)`` (the
    number's unit) and at least ``decimals`` ``(M,)`` digits. Unchanged within half the
    resolution; else with the old number's decimals (at least ``decimals``) or as many more as
    the resolution needs, in the old number's style; never '-0'."""
    values = np.asarray(values, float)
    resolutions = np.asarray(resolutions, float)
    old = np.array([float(t) for t in texts]) if texts else np.zeros(0)
    needed = {r: max(0, math.ceil(-math.log10(r) - 1e-9)) for r in set(resolutions.tolist())}
    places = np.maximum(np.maximum(np.asarray(written, int), np.asarray(decimals, int)),
                        np.array([needed[r] for r in resolutions.tolist()], int).reshape(resolutions.shape))
    out = list(texts)
    with np.errstate(invalid="ignore"):  # an infinite value: inf - inf is NaN, written anew
        new = np.flatnonzero(~(np.abs(values - old) <= resolutions / 2))
    for p in np.unique(places[new]).tolist():
        rows = new[places[new] == p]
        formatted = (_SEP.join(["%." + str(p) + "f"] * rows.size) % tuple(values[rows].tolist())).split(_SEP)
        for m, text in zip(rows.tolist(), formatted, strict=True):
            out[m] = text
    for m in new.tolist():  # the styles: a negative zero, '.5' without its zero, a leading '+'
        text, was = out[m], texts[m]
        if text.startswith("-0") and float(text) == 0.0:
            text = text[1:]
        if was.lstrip("+-").startswith(".") and text.lstrip("-").startswith("0."):
            text = text.replace("0.", ".", 1)
        if was.startswith("+") and not text.startswith("-"):
            text = "+" + text
        out[m] = text
    return out


class FileEdits:
    """One file's edits: the numbers rewritten in place (``starts``, ``ends``, ``texts``: three
    lists, a 100,000-target program's 700,000 numbers without a dict entry and key each) and the
    other span -> text edits (configuration data, FANUC numbers kept in their width, numbers a
    file leaves out)."""

    def __init__(self) -> None:
        self.starts: list[int] = []
        self.ends: list[int] = []
        self.texts: list[str] = []
        self.spans: dict[tuple[int, int], str] = {}

    def apply(self, src: ProgramText) -> bytes:
        """``src``'s bytes with these edits."""
        return src.spliced(self.starts + [k[0] for k in self.spans], self.ends + [k[1] for k in self.spans],
                           self.texts + list(self.spans.values()))


def monitored(targets: list[Target]) -> np.ndarray:
    """Which targets' configuration data the controller follows (they have some, monitored)."""
    return np.array([t.config is not None and t.monitored for t in targets])


def number_edits(d: Dialect, targets: list[Target], old: np.ndarray, good: np.ndarray, Pc: np.ndarray, cfg,
                 warnings: list) -> tuple[dict[Path, FileEdits], np.ndarray]:
    """The edits of each file (:class:`FileEdits`) for the corrected poses ``Pc`` ``(N, 4, 4)`` of
    targets whose numbers
    were ``old`` ``(N, k)`` and, where the correction crossed a configuration boundary, the
    configuration data; and which targets' configuration changed. ``cfg``: (rows of the nominal
    joints, rows of the corrected joints) or None."""
    new = d.from_pose(Pc, old)
    warnings += _gimbal_swings(d, targets, old, new, good)
    resolution = d.resolutions()
    moved = good[:, None] & (np.abs(new - old) > resolution / 2)  # numbers that must be rewritten
    changed = np.zeros(len(targets), bool)
    if cfg is not None:
        has = monitored(targets)
        want = np.array([t.config if has[i] else cfg[0][i] for i, t in enumerate(targets)])
        # rewritten only when the written data describe the corrected joints worse than the nominal ones
        changed = good & has & (d.scheme.score(cfg[1], want) > d.scheme.score(cfg[0], want))
    rows, cols = np.nonzero(moved)  # in target order, each target's numbers in order
    nums = [targets[i].numbers[j] for i, j in zip(rows.tolist(), cols.tolist(), strict=True)]
    written = np.array([n.decimals for n in nums], int)
    texts = format_numbers(new[rows, cols], [n.text for n in nums], written, resolution[cols],
                           _file_decimals(d, targets, old.shape[1])[rows, cols])
    edits: dict[Path, FileEdits] = {}
    last = -1
    for i, num, text in zip(rows.tolist(), nums, texts, strict=True):
        if i != last:  # the numbers of one target come together
            t, last = targets[i], i
            mine = edits.setdefault(t.source.path, FileEdits())
        if num.start == num.end:  # a number the file leaves out: inserted (several in their order)
            key = (num.start, num.end)
            mine.spans[key] = mine.spans.get(key, "") + d.number_edit(t, num, text)
        else:
            start, end, text = (_aligned(t.source.text, num, text) if d.keep_width else
                                (num.start, num.end, text))
            mine.starts.append(start)
            mine.ends.append(end)
            mine.texts.append(text)
    for i in np.flatnonzero(changed):
        t = targets[i]
        edits.setdefault(t.source.path, FileEdits()).spans.update(d.config_edits(t, cfg[1][i]))
        warnings.append(f"{t.where}: configuration changed from {d.scheme.text(cfg[0][i])} to "
                        f"{d.scheme.text(cfg[1][i])}: the corrected joints cross a configuration "
                        "boundary; check the motion into and out of this target")
    return edits, changed


def _file_decimals(d: Dialect, targets: list[Target], k: int) -> np.ndarray:
    """``(N, k)`` the least decimals each number is written with: for the columns of a
    ``shared_decimals`` group, the most any number of the group has in the target's file (a
    quaternion at the file's precision); 0 elsewhere."""
    floor = np.zeros((len(targets), k), int)
    if not targets:
        return floor
    files: dict[Path, int] = {}
    where = np.array([files.setdefault(t.source.path, len(files)) for t in targets])
    for group in d.shared_decimals:
        most = np.array([max(t.numbers[j].decimals for j in group) for t in targets])
        finest = np.zeros(len(files), int)
        np.maximum.at(finest, where, most)
        floor[:, list(group)] = np.maximum(floor[:, list(group)], finest[where][:, None])
    return floor


def _gimbal_swings(d: Dialect, targets: list[Target], old: np.ndarray, new: np.ndarray,
                   good: np.ndarray) -> list[str]:
    """Warnings for targets whose Euler angles change by more than ``SWING_DEG`` while the
    orientation turns less: near gimbal lock (middle angle +-90 deg) the outer angles trade, and a
    turn off the pole needs them to swing (same orientation, other numbers)."""
    if not d.euler_columns:
        return []
    cols = list(d.euler_columns)
    step = new[:, cols] - old[:, cols]
    swing = np.abs(step - 360.0 * np.round(step / 360.0)).max(axis=1)
    R0, R1 = d.to_pose(old)[:, :3, :3], d.to_pose(new)[:, :3, :3]
    turn = np.rad2deg(np.linalg.norm(matrix_to_rotvec(R1 @ np.swapaxes(R0, 1, 2)), axis=1))
    pole = np.abs(90.0 - np.abs(new[:, cols[1]]))
    return [f"{targets[i].where}: its angles change by up to {swing[i]:.1f} deg for an orientation "
            f"correction of {turn[i]:.3f} deg: it is {pole[i]:.3f} deg from gimbal lock (middle angle "
            "+-90 deg), where the other two angles trade; the orientation is the corrected one"
            for i in np.flatnonzero(good & (swing > SWING_DEG) & (turn < SWING_DEG))]


def _aligned(text: str, num, new: str) -> tuple[int, int, str]:
    """The edit ``(start, end, text)`` writing ``new`` over number ``num`` of ``text`` in the same
    width when the number is right-aligned after spaces: padded with spaces, or taking spaces
    before it (one is kept)."""
    if text[num.start - 1:num.start] != " " or len(new) == len(num.text):
        return num.start, num.end, new
    if len(new) < len(num.text):
        return num.start, num.end, new.rjust(len(num.text))
    first = num.start  # the spaces right before the number (not a copy of the text before it)
    while first > 0 and text[first - 1] == " ":
        first -= 1
    take = min(len(new) - len(num.text), num.start - first - 1)
    return num.start - take, num.end, new
