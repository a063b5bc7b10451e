"""A VAL3 project file (``.pjx``): the programs and data files the controller loads, and the user
types it declares (s7: ``<Program file>``, ``<Data file>``, ``<Type name path>``; s6.x:
``<program file>``, ``<data file>``).

A type's path is a controller path (``Disk://ros_libs/MotionCmd/MotionCmd.pjx``): ``Disk://`` is the
folder that holds the applications (the controller's ``usrapp``), so it is read from the folder
above the application's own when that folder holds it."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from robocal.core.bom import decode_utf8
from robocal.programs.dialects.val3 import s6

_FILE = re.compile(r"<(Program|program|Data|data)\b[^>]*?\bfile\s*=\s*\"([^\"]+)\"")
_TYPE = re.compile(r"<Type\b[^>]*?\bname\s*=\s*\"([^\"]+)\"[^>]*?\bpath\s*=\s*\"([^\"]+)\"")
# a library: <Library alias path> (s7), <alias name path> (s6.x)
_LIBRARY = re.compile(r"<(?:Library|alias)\b[^>]*?\b(?:alias|name)\s*=\s*\"([^\"]+)\"[^>]*?"
                      r"\bpath\s*=\s*\"([^\"]+)\"")
_DATA_TYPES = re.compile(r"<Data\b[^>]*?\bname\s*=\s*\"([^\"]+)\"[^>]*?(?<![:\w])type\s*=\s*\"([^\"]+)\"")
DISK = "Disk://"


@dataclass
class Project:
    """What one ``.pjx`` lists: program and data file names (lower case), user type -> the
    ``.pjx`` path that declares it, library alias -> its ``.pjx`` path."""

    path: Path
    programs: set[str] = field(default_factory=set)
    data: set[str] = field(default_factory=set)
    types: dict[str, str] = field(default_factory=dict)
    libraries: dict[str, str] = field(default_factory=dict)

    def type_data(self, name: str) -> list[Path]:
        """The ``.dtx`` files of user type ``name`` found on this disk (empty: none)."""
        return self.data_at(self.types.get(name, ""))

    def data_at(self, where: str) -> list[Path]:
        """The ``.dtx`` files of the project at controller path ``where`` (``Disk://...pjx``, or
        relative to the application's folder) found on this disk (empty: none)."""
        if not where:
            return []
        pjx = (self.path.parent.parent / where[len(DISK):] if where.startswith(DISK) else
               self.path.parent / where.replace("\\", "/"))  # a path of s6.x: from the application's folder
        if not pjx.is_file():
            return []
        listed = read_project(pjx).data
        return [p for p in pjx.parent.iterdir() if p.suffix.lower() == ".dtx" and p.name.lower() in listed]


def read_project(path: Path) -> Project:
    """The programs, data files and user types a ``.pjx`` lists."""
    text = decode_utf8(path.read_bytes(), errors="replace")
    out = Project(path)
    for kind, name in _FILE.findall(text):
        (out.programs if kind.lower() == "program" else out.data).add(Path(name).name.lower())
    out.types = dict(_TYPE.findall(text))
    out.libraries = dict(_LIBRARY.findall(text))
    return out


def declared_types(text: str) -> dict[str, str]:
    """Every data name of a ``.dtx`` -> its VAL3 type (with no values too: ``<Data .../>``; s6.x:
    each section's elements)."""
    found = dict(_DATA_TYPES.findall(text))
    for section, body in re.findall(r"<(\w+)Section\b[^>/]*>(.*?)</\1Section\s*>", text, re.DOTALL):
        for name in re.findall(rf"<{section}\b[^>]*?\bname\s*=\s*\"([^\"]+)\"", body):
            found.setdefault(name, s6.TYPES.get(section, section))  # others: named like the type
    return found
