"""The loads of Yaskawa INFORM jobs (the reader interface: :mod:`robocal.programs.load_data`).

A job sets no load: each position carries its tool number (``///TOOL n`` of its ``//POS``
section) and the controller runs the motion with that tool's load from its tool file
(:mod:`robocal.programs.dialects.inform.tool_file`), given as a reference (TOOL.CND). Without one the motions
run with the model's default load (the filter's warning names it).
"""

from __future__ import annotations

from robocal.programs.dialects.inform.tool_file import ToolEntry, is_tool_file, read_tool_file
from robocal.programs.load_data.base import Load, LoadReader, ranges, unread
from robocal.programs.target import Target

UNSET_KG = 0.0  # a tool whose W is <= this has no load registered in the tool file


class InformLoads(LoadReader):
    """Yaskawa INFORM (module docstring): each motion with the load of its position's tool."""

    none = "no tool file TOOL.CND given"
    hint = "the controller's tool file with --references TOOL.CND"

    def __init__(self):
        self.tools: dict[str, ToolEntry] = {}
        self.file = ""  # the tool file's name ('' when none is given)
        self.known: dict[str, tuple[Load, str]] = {}  # tool number -> its load and where it is set

    def settings(self, sources, references):
        for ref in references:
            if is_tool_file(ref):
                self.tools.update(read_tool_file(ref))
                self.file = ref.path.name
        return []  # a job has no load statement

    def at_motion(self, state, target, instruction):
        if not self.file:
            return None
        n = target.tool
        if n not in self.known:
            self.known[n] = self._load(target)
        return self.known[n]

    def _load(self, target: Target) -> tuple[Load, str]:
        """The load of ``target``'s tool, or the error for the motion that uses it."""
        n = target.tool
        entry = self.tools.get(n)
        if entry is None:
            raise unread(target.source, target.offset, target.name, f"its tool {n} is not in the tool file "
                         f"{self.file} given (it holds tools {ranges(sorted(int(k) for k in self.tools))})")
        if entry.mass <= UNSET_KG:
            raise unread(target.source, target.offset, target.name, f"its tool {n} has no load in "
                         f"{self.file} (W {entry.mass:g} kg at line {entry.line}: not registered on the "
                         "controller)")
        name = f' "{entry.name}"' if entry.name else ""
        return (entry.mass, *entry.cog), f"{self.file} tool {n}{name}"

