"""The structural freedoms of a SCARA, named in a user's words.

A robot whose joints all turn (or slide) about one direction (a SCARA, RRPR: shoulder, elbow,
quill, quill rotation; :func:`robocal.data.registration.turns_about_one_axis`) cannot tilt its
flange, so several parameters move every measured point the same way on every pose set: no
campaign separates them, and the rank test (:mod:`robocal.identify.structural`) keeps one of each
group and holds the others at nominal. These are not a degenerate pose set but the robot's
structure; :func:`structural_freedoms` says which freedom each held parameter belongs to:

- **height**: the base (tracker) frame's height, every link's offset ``d`` along the vertical axes,
  the quill's zero (the ``d`` of the prismatic joint) and the SMR's height on the flange (``tool.z``,
  ``smrK.z``) move every point up or down together: one height;
- **turn of the base**: joint 1's zero (``theta1``) and the base frame's turn about the vertical;
- **tilt of the base**: axis 1's tilt (``alpha1``, ``beta1``) and the base frame's tilt;
- **place of axis 1**: ``a1`` and the base frame's x, y;
- **quill rotation**: the last joint's zero, a constant turn of the quill (``theta`` of the
  prismatic joint) and where the SMR sits around the quill (its x, y on the flange);
- **forearm length**: the quill's offset from the forearm's end (``a`` of the joints after the
  elbow's) adds to the forearm length.

A parameter outside these groups (e.g. a tilt no SMR offset can show) keeps the generic words of
:mod:`robocal.identify.vocabulary`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from robocal.data.registration import turns_about_one_axis

_LINK = re.compile(r"^(alpha|a|beta|theta|d)(\d+)$")
_FRAME = re.compile(r"^(base|tool|smr\d+)\.(x|y|z|rx|ry|rz)$")


def _group(name: str, n: int, prismatic) -> str | None:
    """The freedom (a key of :data:`WORDS`) parameter ``name`` of an ``n``-joint SCARA belongs to."""
    frame = _FRAME.match(name)
    if frame:
        owner, axis = frame.groups()
        if axis == "z":
            return "height"
        if owner == "base":
            return {"x": "axis1", "y": "axis1", "rx": "tilt", "ry": "tilt", "rz": "turn"}[axis]
        return "quill" if axis in ("x", "y", "rz") else None
    link = _LINK.match(name)
    if not link:
        return None
    field, i = link.group(1), int(link.group(2))
    if field == "d":
        return "height"
    if i == 1:
        return {"alpha": "tilt", "beta": "tilt", "theta": "turn", "a": "axis1"}[field]
    if field == "theta" and (i == n or prismatic[i - 1]):
        return "quill"
    if field == "a" and i > 2:
        return "forearm"
    return None


WORDS = {
    "height": "one height: the base (tracker) frame's height, the links' offsets d along the vertical "
              "axes, the joint-{quill} quill zero (d{quill}) and the SMR's height on the flange move "
              "every point up or down together (a SCARA cannot tilt its flange to tell them apart)",
    "turn": "one turn about the vertical: joint 1's zero (theta1) and the base frame's turn",
    "tilt": "one tilt: axis 1's tilt (alpha1, beta1) and the base frame's tilt",
    "axis1": "one place of axis 1: a1 and the base frame's x, y",
    "quill": "one quill rotation: joint {last}'s zero, a constant turn of the quill and where the SMR sits "
             "around the quill (its x, y on the flange)",
    "forearm": "one forearm length: the quill's offset from the forearm's end adds to the forearm length",
}


def structural_freedoms(robot, held: Iterable[str], estimated: Iterable[str] = ()) -> list[dict]:
    """The SCARA freedoms (module docstring) that parameters ``held`` (not identifiable) belong to:
    one dict per freedom with ``freedom`` (its key), ``words`` (what it is, for a user),
    ``held`` (its parameters held at nominal) and ``carried_by`` (its estimated parameters among
    ``estimated``, which absorb it). Empty for a robot that is not a SCARA (its joints do not all
    turn about one direction) or whose quill is not its only prismatic joint."""
    held = list(held)
    if not held or not turns_about_one_axis(robot):
        return []
    n, prismatic = robot.n_joints, robot.prismatic
    quill = [i + 1 for i in range(n) if prismatic[i]]
    if len(quill) != 1:
        return []
    keys = list(WORDS)
    groups: dict[str, list[str]] = {}
    for name in held:
        g = _group(name, n, prismatic)
        if g is not None:
            groups.setdefault(g, []).append(name)
    carried: dict[str, list[str]] = {}
    for name in estimated:
        g = _group(name, n, prismatic)
        if g in groups:
            carried.setdefault(g, []).append(name)
    return [{"freedom": g, "words": WORDS[g].format(quill=quill[0], last=n), "held": groups[g],
             "carried_by": carried.get(g, [])} for g in keys if g in groups]


def freedom_lines(freedoms: list[dict], indent: str = "") -> list[str]:
    """Summary lines: a head line, then one per freedom with its held and carrying parameters."""
    if not freedoms:
        return []
    out = [f"{indent}structural freedoms of a SCARA (the robot's structure, not the poses: no campaign "
           "separates these; each is estimated once and the rest held at nominal):"]
    for f in freedoms:
        by = f"; carried by {', '.join(f['carried_by'])}" if f["carried_by"] else ""
        out.append(f"{indent}  {f['words']} (held: {', '.join(f['held'])}{by})")
    return out
