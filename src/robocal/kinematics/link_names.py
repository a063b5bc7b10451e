"""The names of a model's links (a URDF's) and the frame each rides on: what lets a marker's
``link`` column name ``arm_left_4_link`` instead of frame 4.

A robot model numbers its frames {0} (the base) to {n} (the flange); a URDF names its links. The
URDF import keeps, for every link of the chain from the root to the tip, the frame it moves with:
the number of moving joints between the root and it (links fixed to the root: 0; the tip and what
is fixed after the last moving joint: n). :attr:`robocal.kinematics.model.Robot.link_frames` holds
that mapping (the model file's ``link_frames:``); :func:`link_numbers` reads a ``link`` column
given as frame numbers, link names or both.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from robocal.core.errors import DataError, ModelError

MAX_LINK_NAME = 200  # characters of a link's name
LISTED = 30  # known link names an error lists


def check_link_frames(mapping, n: int) -> dict[str, int]:
    """``{name: frame}`` (a copy) with each name a non-empty string that is not a number and each
    frame an integer 0..``n``; ModelError naming the entry otherwise."""
    if not isinstance(mapping, Mapping):
        raise ModelError(f"link_frames: expected a mapping {{link name: frame 0..{n}}}, got {mapping!r:.60}")
    out = {}
    for name, frame in mapping.items():
        if not isinstance(name, str) or not name.strip() or len(name) > MAX_LINK_NAME or _is_number(name):
            raise ModelError(f"link_frames: {name!r:.60} is not a link name (a non-numeric text of at most "
                             f"{MAX_LINK_NAME} characters)")
        if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)) or not 0 <= frame <= n:
            raise ModelError(f"link_frames.{name}: {frame!r:.30} is not a frame number 0..{n}")
        out[name.strip()] = int(frame)
    return out


def is_frame_number(texts) -> np.ndarray:
    """Per text of ``texts`` (a str or an array of them) whether it is a frame number (an integer,
    signed or not: its range is checked where the model is known), not a link name."""
    return np.char.isdigit(np.char.lstrip(np.char.strip(np.asarray(texts, dtype=str)), "+-"))


def _is_number(text: str) -> bool:
    return bool(is_frame_number(text))


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def link_numbers(links, link_frames: dict[str, int] | None, robot_name: str) -> np.ndarray:
    """The frame numbers ``(N,)`` of a ``link`` column ``links (N,)``: integers as they are, and
    strings either integers or names of ``link_frames`` (a model's, :func:`check_link_frames`).
    DataError naming the unknown link and listing the known ones, or saying the model names none."""
    links = np.asarray(links)
    if links.dtype.kind in "iu":
        return links.astype(np.int64)
    values, inverse = np.unique(links.astype(str), return_inverse=True)
    frames = np.empty(values.size, np.int64)
    for k, value in enumerate(values):
        text = value.strip()
        if _is_number(text):
            frames[k] = int(text)
        elif link_frames and text in link_frames:
            frames[k] = link_frames[text]
        elif _is_float(text):
            raise DataError(f"the markers' link {text!r} is not a frame number: give an integer, 0 the base "
                            "to n the flange, or the link's name")
        elif not link_frames:
            raise DataError(f"the markers' link {text!r} is a name, but model {robot_name} names no links "
                            "(a model read from a URDF does): give frame numbers, 0 the base to n the flange")
        else:
            known = sorted(link_frames, key=link_frames.__getitem__)  # root to tip (a stable sort)
            more = f" and {len(known) - LISTED} more" if len(known) > LISTED else ""
            shown = ", ".join(known[:LISTED]) + more
            raise DataError(f"the markers' link {text!r} is not a link of model {robot_name}: its links "
                            f"are {shown} (or give frame numbers, 0 the base to n the flange)")
    return frames[inverse.reshape(-1)]
