"""KUKA KRL programs (.src with its .dat, .sub, $config.dat as a reference).

* Positions ``{X x, Y y, Z z, A a, B b, C c, S s, T t, E1 ...}`` (mm; A, B, C = ZYX Euler in
  deg, R = Rz(A) Ry(B) Rx(C); S status and T turn, see :class:`robocal.programs.config.KUKAConfig`;
  external axes E1..E6 left alone) declared as ``DECL E6POS|POS|FRAME name=...`` (``DECL``
  and ``GLOBAL`` optional; array elements ``name[i]=...``) or written inline in a motion.
  A position without X, Y, Z, A, B, C (a partial aggregate) is left alone with a warning; one
  without S is solved nearest the previous target's joints, as the controller does.
* Motions ``PTP|LIN|CIRC|SPTP|SLIN|SCIRC target`` (CIRC/SCIRC: auxiliary point, end point);
  ``*_REL`` motions, ``E6AXIS``/``AXIS`` positions are left alone.
* Tool and base in effect at each motion, in text order: ``$TOOL=TOOL_DATA[n]``,
  ``$BASE=BASE_DATA[n]`` (``$NULLFRAME``: the flange / the robot base), ``BAS(#TOOL, n)``,
  ``BAS(#BASE, n)`` and ``FDAT_ACT=name`` with ``DECL FDAT name={TOOL_NO n, BASE_NO m, ...}``.
  ``TOOL_DATA[n]={X..,C..}`` / ``BASE_DATA[n]=...`` come from the files, a reference
  ($config.dat) or the command line (``--tool n=X,Y,Z,A,B,C``). World = robot base
  ($ROBROOT = $WORLD) is assumed; an external TCP (IPO_FRAME #TCP) is not filtered.

Comments (``;`` to the end of the line) and strings are masked first.
"""

from __future__ import annotations

import re

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.aggregate import split_top
from robocal.programs.config import KUKAConfig
from robocal.programs.model import Dialect, Program, Target
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.source import Number, ProgramText, mask

_COMMENT = re.compile(r";[^\n]*")
_STRING = re.compile(r'"[^"\n]*"')
_AGG = re.compile(r"\{[^{}]*\}")
_COMPONENT = re.compile(r"\b([A-Za-z]\w*)\s+([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|'[BbHh][^']*')")
_DECL = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(E6POS|POS|FRAME)\s+([A-Za-z_$]\w*)"
                   r"(?:\s*\[[^\]]*\])?\s*=\s*(?=\{)", re.IGNORECASE | re.MULTILINE)
_ELEMENT = re.compile(r"^[ \t]*([A-Za-z_]\w*\s*\[\s*\d+(?:\s*,\s*\d+)*\s*\])\s*=\s*(?=\{)", re.MULTILINE)
_FDAT = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?FDAT\s+(\w+)\s*=\s*(?=\{)",
                   re.IGNORECASE | re.MULTILINE)
_DATA = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(?:FRAME\s+)?(TOOL_DATA|BASE_DATA)\s*\[\s*(\d+)\s*\]"
                   r"\s*=\s*(?=\{)", re.IGNORECASE | re.MULTILINE)
_MOTION = re.compile(r"^[ \t]*(PTP|LIN|CIRC|SPTP|SLIN|SCIRC)\s+(.+)$", re.IGNORECASE | re.MULTILINE)
_STATE = re.compile(r"(\$TOOL|\$BASE)\s*=\s*([^\n]+)|BAS\s*\(\s*#(TOOL|BASE)\s*,\s*(\d+)\s*\)|"
                    r"FDAT_ACT\s*=\s*(\w+)", re.IGNORECASE)
_POSE_KEYS = ("X", "Y", "Z", "A", "B", "C")
_POSITION_MM = 1e-3
_ANGLE_DEG = 1e-4
NULL = "0"  # $NULLFRAME: tool 0 = flange, base 0 = robot base


def _canonical(key: str, kind: str) -> str:
    """'TOOL_DATA[3]' / '3' -> '3'."""
    m = re.fullmatch(rf"\s*(?:{kind}_DATA\s*\[\s*)?(\d+)\s*\]?\s*", key, re.IGNORECASE)
    return m.group(1) if m else key


class KRLDialect(Dialect):
    name = "KUKA KRL"
    suffixes = (".src", ".dat", ".sub")
    scheme = KUKAConfig()
    frame_help = "X,Y,Z in mm and A,B,C in deg (ZYX Euler), as in TOOL_DATA/BASE_DATA"

    def name_key(self, name):
        return _canonical(_canonical(name, "TOOL"), "BASE")

    def to_pose(self, values):
        values = np.asarray(values, float)
        R = Rotation.from_euler("ZYX", values[:, 3:6], degrees=True).as_matrix()  # Rz(A) Ry(B) Rx(C)
        return make_transform(R, values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        return np.hstack([T[:, :3, 3] * 1e3, matrix_to_zyx(T[:, :3, :3], old[:, 3:6])])

    def resolutions(self):
        return np.array([_POSITION_MM] * 3 + [_ANGLE_DEG] * 3)

    def config_edits(self, target, new):
        out = {}
        for k, num in enumerate(target.config_spans):
            if num is None:
                continue
            old = _int(num.text)
            value = int(new[k]) | (old & ~(7 if k == 0 else 63))  # keep bits this filter does not set
            if value != old:
                text = num.text
                if text.startswith("'"):
                    width = len(text.strip("'")[1:].replace(" ", ""))
                    new_text = f"'B{value:0{width}b}'"
                else:
                    new_text = str(value)
                out[(num.start, num.end)] = new_text
        return out

    # ------------------------------------------------------------------ parsing
    def _aggregate(self, src: ProgramText, masked: str, at: int) -> tuple[dict[str, Number], int]:
        m = _AGG.match(masked, at)
        if not m:
            raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed position: expected {{...}}")
        comps = {}
        for c in _COMPONENT.finditer(masked, m.start() + 1, m.end() - 1):
            comps[c.group(1).upper()] = Number(c.start(2), c.end(2), src.text[c.start(2):c.end(2)])
        return comps, m.end()

    def _target(self, src, masked, at, name, kind, prog) -> Target | None:
        comps, _ = self._aggregate(src, masked, at)
        if "A1" in comps:  # an axis position (E6AXIS/AXIS): left alone
            return None
        missing = [k for k in _POSE_KEYS if k not in comps]
        if missing:
            prog.warnings.append(f"{src.path.name}:{src.line_of(at)}: {name} lacks {', '.join(missing)} "
                                 "(a partial position): left as it is")
            return None
        nums = [comps[k] for k in _POSE_KEYS]
        for n in nums:
            if n.text.startswith("'"):
                raise DataError(f"{src.path.name}:{src.line_of(at)}: {name}: {n.text} is not a number")
        config = spans = None
        if kind != "FRAME" and "S" in comps:
            s = _int(comps["S"].text, src, at)
            t = _int(comps["T"].text, src, at) if "T" in comps else -1
            config = np.array([s, t])
            spans = (comps["S"], comps.get("T"))
        return Target(src, at, name, nums, config=config, config_spans=spans)

    def parse(self, sources, frames, tools, references=()):
        prog = Program([])
        declared: dict[str, Target] = {}
        fdat: dict[str, tuple[str, str, str]] = {}
        prog.frames[NULL] = np.eye(4)
        prog.tools[NULL] = np.eye(4)
        masks = {}
        for src in [*references, *sources]:
            masked = masks[src.path] = mask(src.text, [_COMMENT], [_STRING])
            for m in _DATA.finditer(masked):
                comps, _ = self._aggregate(src, masked, m.end())
                if any(k not in comps for k in _POSE_KEYS):
                    raise DataError(f"{src.path.name}:{src.line_of(m.start())}: {m.group(1)}[{m.group(2)}] "
                                    "needs X, Y, Z, A, B, C")
                pose = self.to_pose(np.array([[comps[k].value for k in _POSE_KEYS]]))[0]
                (prog.tools if m.group(1).upper() == "TOOL_DATA" else prog.frames)[m.group(2)] = pose
            for m in _FDAT.finditer(masked):
                comps = dict(re.findall(r"\b(TOOL_NO|BASE_NO|IPO_FRAME)\s+(#?\w+)",
                                        masked[m.end():masked.find("}", m.end())], re.IGNORECASE))
                comps = {k.upper(): v for k, v in comps.items()}
                fdat[m.group(1).upper()] = (comps.get("TOOL_NO"), comps.get("BASE_NO"),
                                            comps.get("IPO_FRAME", "#BASE").upper())
            if src in references:
                continue
            for m in _DECL.finditer(masked):
                t = self._target(src, masked, m.end(), m.group(2), m.group(1).upper(), prog)
                if t is not None:
                    declared[m.group(2).upper()] = t
            for m in _ELEMENT.finditer(masked):
                name = re.sub(r"\s+", "", m.group(1))
                if name.upper().startswith(("TOOL_DATA", "BASE_DATA")):
                    continue
                t = self._target(src, masked, m.end(), name, "E6POS", prog)
                if t is not None:
                    declared[name.upper()] = t
        prog.tools.update({self.name_key(k): v for k, v in tools.items()})
        prog.frames.update({self.name_key(k): v for k, v in frames.items()})
        self._motions(prog, sources, masks, declared, fdat)
        return prog

    def _motions(self, prog, sources, masks, declared, fdat):
        used: dict[str, tuple[str, str, str]] = {}
        order = 0
        for src in sources:
            masked = masks[src.path]
            tool, base = "?", "?"  # unknown until the program sets them
            events = sorted([(m.start(), "state", m) for m in _STATE.finditer(masked)]
                            + [(m.start(), "motion", m) for m in _MOTION.finditer(masked)],
                            key=lambda e: e[0])
            for at, kind, m in events:
                here = f"{src.path.name}:{src.line_of(at)}"
                if kind == "state":
                    if m.group(1):
                        val = m.group(2).strip()
                        d = re.fullmatch(r"(TOOL_DATA|BASE_DATA)\s*\[\s*(\d+)\s*\]", val, re.IGNORECASE)
                        new = NULL if val.upper() == "$NULLFRAME" else (d.group(2) if d else "?")
                        if m.group(1).upper() == "$TOOL":
                            tool = new
                        else:
                            base = new
                    elif m.group(3):
                        if m.group(3).upper() == "TOOL":
                            tool = m.group(4)
                        else:
                            base = m.group(4)
                    else:
                        f = fdat.get(m.group(5).upper())
                        if f is None:
                            tool = base = "?"
                        else:
                            tool, base = f[0] or tool, f[1] or base
                            if f[2] == "#TCP":
                                tool = base = "external TCP"
                    continue
                arg_start = m.start(2)
                parts = split_top(masked, arg_start, m.end(2))
                names = parts[:2] if m.group(1).upper() in ("CIRC", "SCIRC") else parts[:1]
                for a, b in names:
                    text = masked[a:b].strip()
                    if text.startswith("{"):
                        t = self._target(src, masked, masked.index("{", a), f"inline@{src.line_of(a)}",
                                         "E6POS", prog)
                        if t is not None:
                            self._use(prog, t, tool, base, here, order)
                            order += 1
                        continue
                    key = re.sub(r"\s+", "", text.split()[0] if text else "").upper()
                    if key not in declared:
                        continue
                    if key in used:
                        first_tool, first_base, first_at = used[key]
                        if (first_tool, first_base) != (tool, base):
                            raise DataError(
                                f"{here}: {declared[key].name} is used with tool {tool} and base {base}, but "
                                f"at {first_at} with tool {first_tool} and base {first_base}: one corrected "
                                "position cannot serve both; declare a copy for each use")
                        continue
                    used[key] = (tool, base, here)
                    self._use(prog, declared[key], tool, base, here, order)
                    order += 1
        for key, t in declared.items():
            if key not in used:
                prog.warnings.append(f"{t.where}: not used by a motion in these files: left as it is")

    def _use(self, prog, t, tool, base, here, order):
        if "?" in (tool, base):
            which = "tool" if tool == "?" else "base"
            raise DataError(f"{here} ({t.name}): the program does not set the {which} "
                            "before this motion ($TOOL=TOOL_DATA[n], $BASE=BASE_DATA[n], BAS(#TOOL,n) or "
                            "FDAT_ACT with TOOL_NO/BASE_NO): without it the target's frame is unknown")
        if tool == "external TCP":
            prog.unsupported[f"tool:{tool}"] = "an external TCP (IPO_FRAME #TCP) is not filtered"
        t.tool, t.frame, t.order = tool, base, order
        prog.targets.append(t)


def _int(text: str, src: ProgramText | None = None, at: int = 0) -> int:
    """A KRL integer: decimal, or a bit literal 'B0110' / hex 'H1F'."""
    t = text.strip()
    try:
        if t.startswith("'"):
            body = t.strip("'").replace(" ", "")
            return int(body[1:], 2 if body[0] in "Bb" else 16)
        v = float(t)
        if v != int(v):
            raise ValueError
        return int(v)
    except (ValueError, IndexError):
        where = f"{src.path.name}:{src.line_of(at)}: " if src is not None else ""
        raise DataError(f"{where}status/turn {text!r} is not an integer") from None
