"""KUKA external kinematics: bases that a machine (a positioner, KUKA's EASYS) carries.

A KSS $config.dat declares the cell's machines and which machine each base is on:

* ``MACHINE_DEF[m]={NAME[] "DKP_400",COOP_KRC_INDEX 1,PARENT[] "WORLD",ROOT {X ..},MECH_TYPE #EASYS,
  GEOMETRY[] " "}``: machine m, its name (the mechanical unit a cell file's positioner names) and
  kind (``#EASYS`` an external axis system carrying the work, ``#ERSYS`` one carrying the robot,
  ``#ROBOT``, ``#NONE``);
* ``MACHINE_FRAME_DAT[n]={MACH_DEF_INDEX m,PARENT[] "DKP_400",GEOMETRY[] " "}``: base n is on
  machine m (0: a fixed base in the world).

A program puts its base on a machine with ``$BASE=EK(MACHINE_DEF[m].ROOT, MACHINE_DEF[m].MECH_TYPE,
BASE_DATA[n])`` (the offset ``BASE_DATA[n]`` or a literal ``{X .., C ..}`` is in the machine's
flange frame, the cell file's plate frame), or through ``BAS(#BASE, n)`` / an inline form's FDAT
``BASE_NO n`` / the spline inline forms' ``EK(K_ROOT(F.BASE_NO), K_TYPE(..), K_OFFS(..))``, which
KSS turns into that EK call when ``MACHINE_FRAME_DAT[n].MACH_DEF_INDEX`` is not 0 (else base n is a
fixed one). Such a base is a frame the machine carries (:attr:`Program.carried`), named
``n@MACHINE`` (``{X ..}@MACHINE`` for a literal offset) so that the same BASE_DATA[n] used as a
fixed base stays another frame. A machine no file given declares (no $config.dat), or an EK whose
root is a literal frame (``EK({X ..}, #EASYS, ...)``), is a unit the program does not name
(:data:`robocal.programs.external.UNNAMED`): a cell's only positioner takes it.
"""

from __future__ import annotations

import re

import numpy as np

from robocal.programs.aggregate import split_top
from robocal.programs.external import UNNAMED
from robocal.programs.source import ProgramText

_MACHINE_DEF = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(?:MACHINE_DEF_T\s+)?MACHINE_DEF\s*"
                          r"\[\s*(\d+)\s*\]\s*=\s*\{([^\n]*)", re.IGNORECASE | re.MULTILINE)
_MACHINE_FRAME = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(?:MACHINE_FRAME_T\s+)?MACHINE_FRAME_DAT\s*"
                            r"\[\s*(\d+)\s*\]\s*=\s*\{([^\n]*)", re.IGNORECASE | re.MULTILINE)
_NAME = re.compile(r'\bNAME\s*\[\s*\]\s*"([^"\n]*)"', re.IGNORECASE)
_TYPE = re.compile(r"\bMECH_TYPE\s+#(\w+)", re.IGNORECASE)
_INDEX = re.compile(r"\bMACH_DEF_INDEX\s+(\d+)", re.IGNORECASE)
_EK = re.compile(r"EK\s*\(([\s\S]*)\)\s*$", re.IGNORECASE)
_ROOT = re.compile(r"MACHINE_DEF\s*\[\s*(\d+)\s*\]\s*\.\s*ROOT", re.IGNORECASE)
_DATA = re.compile(r"BASE_DATA\s*\[\s*(\d+)\s*\]", re.IGNORECASE)
_NUMBERED = re.compile(r"K_ROOT\s*\(\s*(?:(\w+)\s*\.\s*BASE_NO|(\d+))\s*\)", re.IGNORECASE)  # KSS 8.x
CARRYING = ("EASYS", "ERSYS")  # machine kinds whose flange carries a base (not #ROBOT, #NONE)


class Machines:
    """The machines and machine frames the files declare, and the frames programs put on them."""

    def __init__(self) -> None:
        self.names: dict[str, tuple[str, str]] = {}  # m -> (name, kind upper-case)
        self.frames: dict[str, str] = {}  # base n -> machine m (MACH_DEF_INDEX > 0)
        self.literals: dict[str, np.ndarray] = {}  # carried frame key -> literal offset values X..C
        self.carried: dict[str, tuple[str, str]] = {}  # frame key -> (machine name, base n or '')
        self.notes: set[str] = set()  # what the program's warnings say of the bases read

    def read(self, src: ProgramText, masked: str) -> None:
        """The MACHINE_DEF and MACHINE_FRAME_DAT declarations of one file (strings read from its
        text: ``masked`` has them blanked)."""
        for m in _MACHINE_DEF.finditer(masked):
            line = src.text[m.start(2):m.end(2)]
            name, kind = _NAME.search(line), _TYPE.search(masked, m.start(2), m.end(2))
            self.names[m.group(1)] = (name.group(1).strip() if name else "",
                                      kind.group(1).upper() if kind else "")
        for m in _MACHINE_FRAME.finditer(masked):
            index = _INDEX.search(masked, m.start(2), m.end(2))
            if index and int(index.group(1)) > 0:
                self.frames[m.group(1)] = str(int(index.group(1)))

    def _unit(self, m: str) -> tuple[str, str]:
        """(machine m's name, '') or ('', why it carries nothing); a machine no file declares is
        unnamed (:data:`robocal.programs.external.UNNAMED`: a cell's only positioner takes it)."""
        if m not in self.names:
            return f"{UNNAMED}MACHINE_DEF[{m}], declared in no file given", ""
        name, kind = self.names[m]
        if kind not in CARRYING:
            return "", f"the base is on MACHINE_DEF[{m}] ({name}), a #{kind or '?'} machine (no base on it)"
        if not name.strip():
            return "", f"MACHINE_DEF[{m}] has no NAME: its cell positioner cannot be named"
        return name, ""

    def ek(self, value: str, fdat: dict) -> tuple[str, str] | None:
        """The base key an ``EK(root, type, offset)`` value gives, ``(key, '')`` or ``('?', why)``;
        None when ``value`` is not an EK call. ``fdat``: FDAT name -> (TOOL_NO, BASE_NO, ...), for
        the spline inline forms' ``EK(K_ROOT(F.BASE_NO), K_TYPE(..), K_OFFS(..))``."""
        m = _EK.fullmatch(value.strip())
        if m is None:
            return None
        args = [m.group(1)[a:b].strip() for a, b in split_top(m.group(1), 0, len(m.group(1)))]
        if len(args) != 3:
            return "?", f"$BASE is set from {value} (EK takes a root, a kind and an offset)"
        numbered = _NUMBERED.fullmatch(args[0])
        if numbered:  # K_ROOT(n): base n on the machine MACHINE_FRAME_DAT[n] names, as BAS(#BASE, n)
            n = numbered.group(2) or (fdat.get(numbered.group(1).upper()) or (None, None))[1]
            if n is None:
                return "?", (f"$BASE is set from {value}, but no FDAT {numbered.group(1)} with a BASE_NO is "
                             "declared")
            if not self.frames and not self.names:
                self.notes.add(f"$BASE=EK(K_ROOT(..)) of base {n}: whether a machine carries it is in "
                               "$config.dat's MACHINE_FRAME_DAT, not given (--references): taken as a fixed "
                               "base")
            return self.base(n)
        root = _ROOT.fullmatch(args[0])
        kind = args[1].lstrip("#").upper()
        if root is None and kind in ("ROBOT", "NONE"):
            return "?", f"$BASE is set from {value} (an external kinematic of kind #{kind}: no base on it)"
        unnamed = f"{UNNAMED}EK root {' '.join(args[0].split())}"
        unit, why = self._unit(root.group(1)) if root else (unnamed, "")
        if why:
            return "?", why
        data = _DATA.fullmatch(args[2])
        if data:
            return self.carry(data.group(1), unit), ""
        literal = re.fullmatch(r"\{[^{}]*\}", args[2])
        if literal is None:
            return "?", f"$BASE is set from {value} (an offset this filter cannot follow)"
        key = f"{' '.join(args[2].split())}@{unit}"
        self.carried[key] = (unit, "")
        self.literals[key] = np.array([float(v) for v in re.findall(
            r"\b[XYZABC]\s+([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)", args[2], re.IGNORECASE)])
        return key, ""

    def carry(self, n: str, unit: str) -> str:
        """The key of base ``n`` on machine ``unit`` (recorded as carried)."""
        key = f"{n}@{unit}"
        self.carried[key] = (unit, n)
        return key

    def base(self, n: str) -> tuple[str, str]:
        """``(key, why)`` of ``BAS(#BASE, n)`` / FDAT ``BASE_NO n``: the key of base n on its machine
        when MACHINE_FRAME_DAT[n] puts it on one (as KSS's BAS does), else ``n``."""
        m = self.frames.get(n)
        if m is None:
            return n, ""
        unit, why = self._unit(m)
        return ("?", why) if why else (self.carry(n, unit), "")
