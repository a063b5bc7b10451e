"""KUKA KRL programs (.src with its .dat, .sub, $config.dat as a reference).

* Positions ``{X x, Y y, Z z, A a, B b, C c, S s, T t, E1 ...}`` (mm; A, B, C = ZYX Euler in
  deg, R = Rz(A) Ry(B) Rx(C); S status and T turn, see
  :class:`robocal.programs.dialects.krl.configuration.KUKAConfig`;
  external axes E1..E6 left alone) declared as ``DECL E6POS|POS|FRAME name=...`` (``DECL``,
  ``GLOBAL`` and ``CONST`` optional, in any order; array elements ``name[i]=...``) or written
  inline in a motion.
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

* Targets computed at run time (``P:OFFS`` with a run-time ``OFFS``, a position modified or
  assigned at run time, ``$POS_ACT``) are named with a
  :class:`~robocal.programs.runtime.RunTime` reason and recorded as run-time sites
  (:class:`KRLSite`: a FRAME result is corrected in the Status/Turn of the POS it offsets) for
  ``--runtime-correction`` (:mod:`robocal.programs.dialects.krl.runtime`).

Comments (``;`` to the end of the line) and strings are masked first.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform
from robocal.programs.aggregate import split_top
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.krl import marker, simulated
from robocal.programs.dialects.krl.campaign import krl_program
from robocal.programs.dialects.krl.configuration import KUKAConfig
from robocal.programs.dialects.krl.loads import KRLLoads
from robocal.programs.dialects.krl.machines import Machines
from robocal.programs.dialects.krl.syntax import COMMENT_RE, MOTION_RE, STRING_RE
from robocal.programs.dialects.writing import EXTERNAL_LETTERS
from robocal.programs.flow import Flow, Routine, order_by_execution
from robocal.programs.model import Program, Target
from robocal.programs.motions import Undeclared
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.runtime import Meant, RunTime, RuntimeSite, merged
from robocal.programs.source import Number, ProgramText

_AGG = re.compile(r"\{[^{}]*\}")
_COMPONENT = re.compile(r"\b([A-Za-z]\w*)\s+([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?|'[BbHh][^']*')")
_DECL = re.compile(r"^[ \t]*(?:(?:DECL|GLOBAL|CONST)\s+)*(E6POS|POS|FRAME)\s+([A-Za-z_$]\w*)"
                   r"(?:\s*\[[^\]]*\])?\s*=\s*(?=\{)", re.IGNORECASE | re.MULTILINE)
_AXES = re.compile(r"^[ \t]*(?:(?:DECL|GLOBAL|CONST)\s+)*(?:E6AXIS|AXIS)\s+([A-Za-z_$]\w*)",
                   re.IGNORECASE | re.MULTILINE)
_ELEMENT = re.compile(r"^[ \t]*([A-Za-z_]\w*\s*\[\s*\d+(?:\s*,\s*\d+)*\s*\])\s*=\s*(?=\{)", re.MULTILINE)
_KINDS = re.compile(r"^[ \t]*(?:(?:DECL|GLOBAL|CONST)\s+)*(E6POS|POS|FRAME)\s+([^=\n]+)",
                    re.IGNORECASE | re.MULTILINE)  # the position types the names are declared with
_SYSTEM_KINDS = {"$POS_ACT": "E6POS", "$POS_INT": "E6POS", "$POS_RET": "E6POS", "$POS_BACK": "E6POS",
                 "$POS_FOR": "E6POS"}  # other system positions ($BASE, $NULLFRAME ...): FRAME
_FDAT = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?FDAT\s+(\w+)\s*=\s*(?=\{)",
                   re.IGNORECASE | re.MULTILINE)
_DATA = re.compile(r"^[ \t]*(?:DECL\s+)?(?:GLOBAL\s+)?(?:FRAME\s+)?(TOOL_DATA|BASE_DATA)\s*\[\s*(\d+)\s*\]"
                   r"\s*=\s*(?=\{)", re.IGNORECASE | re.MULTILINE)
_STATE = re.compile(r"(\$TOOL|\$BASE)\s*=\s*([^\n]+)|BAS\s*\(\s*#(TOOL|BASE)\s*,\s*(\d+)\s*\)|"
                    r"FDAT_ACT\s*=\s*(\w+)", re.IGNORECASE)
_ROUTINE = re.compile(r"^[ \t]*(?:GLOBAL\s+)?DEF\s+([A-Za-z_]\w*)\s*\(([^)]*)\)",
                      re.IGNORECASE | re.MULTILINE)
# one line (a KRL statement is): blanks, not \s, between its tokens (\s* crossing a masked comment
# block twice backtracked in quadratic time)
_ASSIGN = re.compile(r"^[ \t]*([A-Za-z_]\w*)[ \t]*(\[[^\]\n]*\])?((?:\.\w+)*)[ \t]*=(?!=)[ \t]*([^\n]+)$",
                     re.MULTILINE)
_CALL = re.compile(r"^[ \t]*([A-Za-z_]\w*)\s*\(([^\n]*)\)[ \t\r]*$", re.MULTILINE)
_APPROX = re.compile(r"(?:\s+(?:C_[A-Z]+|CA\s+[-+]?[\d.]+))+\s*$", re.IGNORECASE)  # C_DIS, CA 45 ...
_JOINT_SYSTEM = ("$H_POS", "$AXIS_ACT", "$AXIS_HOME", "$AXIS_BACK", "$AXIS_RET", "$AXIS_FOR")
_NULL_OPERAND = re.compile(r"\$NULLFRAME\s*:\s*\{[^{}]*\}\s*$", re.IGNORECASE)
_ROUTED = re.compile(r"\s*RC_CORRECTF?\s*\(", re.IGNORECASE)  # a target robocal's run-time correction routes
_HOME = re.compile(r"X?HOME\d?")  # KSS $config.dat: DECL E6AXIS XHOME, XHOME1..XHOME5
_WITH = re.compile(r"\bWITH\b", re.IGNORECASE)
_REF = re.compile(r"([A-Za-z_$]\w*)\s*(\[[^\]]*\])?((?:\.\w+)*)")
_FRAME_FN = re.compile(r"(STOOL2|SBASE)\s*\(\s*(\w+)(?:\.\w+)?\s*\)", re.IGNORECASE)
_KEYWORDS = {"IF", "ELSE", "ENDIF", "FOR", "ENDFOR", "WHILE", "ENDWHILE", "LOOP", "ENDLOOP", "REPEAT",
             "UNTIL", "SWITCH", "CASE", "DEFAULT", "ENDSWITCH", "WAIT", "HALT", "RETURN", "END", "DECL",
             "DEF", "DEFFCT", "INTERRUPT", "TRIGGER", "BAS", "EXT", "GLOBAL", "ENDDAT", "DEFDAT",
             "SPLINE", "ENDSPLINE", "PTP_SPLINE", "GOTO", "CONTINUE", "EXIT", "SIGNAL", "ANIN", "ANOUT",
             "BRAKE", "RESUME"}
_POSE_KEYS = ("X", "Y", "Z", "A", "B", "C")
_POSITION_MM = 1e-3
_ANGLE_DEG = 1e-4
_DEPTH = 12  # calls and assignments followed at most this deep
NULL = "0"  # $NULLFRAME: tool 0 = flange, base 0 = robot base


def _canonical(key: str, kind: str) -> str:
    """'TOOL_DATA[3]' / '3' -> '3'."""
    m = re.fullmatch(rf"\s*(?:{kind}_DATA\s*\[\s*)?(\d+)\s*\]?\s*", key, re.IGNORECASE)
    return m.group(1) if m else key


class KRLDialect(Dialect):
    euler_columns = (3, 4, 5)  # A, B, C
    name = "KUKA KRL"
    key = "krl"
    campaign_rank = 1
    campaign_external = True  # a positioner's axes move in its campaign programs
    external_axis_names = EXTERNAL_LETTERS  # an E6POS's / E6AXIS' E1..E6: logical axis k is E<k>
    arm_axes = external_axis_names  # any of them may be a track or gantry carrying the arm
    campaign_refuses_tracks = True
    runtime_correction = "robocal.programs.dialects.krl.runtime:KRLRuntime"  # filter --runtime-correction
    vendor = "KUKA"
    signature = r"^\s*(?:DEF\s+\w+\s*\(|DEFDAT\s|(?:PTP|LIN|CIRC)\s+\w)"
    angle_unit = "deg"
    campaign_format, campaign_suffix = "KRL", ".src"
    suffixes = (".src", ".dat", ".sub")
    scheme = KUKAConfig()
    frame_help = "X,Y,Z in mm and A,B,C in deg (ZYX Euler), as in TOOL_DATA/BASE_DATA"

    def load_reader(self, tools, schedules):
        return KRLLoads()

    def campaign_files(self, joints, robot, path, **options):
        src, dat = krl_program(np.rad2deg(joints), path.stem, **options)
        return {str(path): src, str(path.with_suffix(".dat")): dat}

    def campaign_paths(self, path, procedure):
        if path.suffix.lower() != ".src":
            raise DataError(f"--krl names the .src file (its .dat is written next to it), got {path}")
        return [str(path), str(path.with_suffix(".dat"))]

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    def name_key(self, name):
        return _canonical(_canonical(name, "TOOL"), "BASE")

    def to_pose(self, values):
        values = np.asarray(values, float)
        R = Rotation.from_euler("ZYX", values[:, 3:6], degrees=True).as_matrix()  # Rz(A) Ry(B) Rx(C)
        return make_transform(R, values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        return np.hstack([T[:, :3, 3] * 1e3, matrix_to_zyx(T[:, :3, :3], old[:, 3:6], _ANGLE_DEG / 2)])

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
    def _aggregate(self, src: ProgramText, masked: str, at: int) -> tuple[dict[str, Number], int] | None:
        """The components of the flat aggregate at ``at``; None for a nested one (not a position)."""
        m = _AGG.match(masked, at)
        if not m:
            if masked[at:at + 1] == "{":
                return None
            raise DataError(f"{src.path.name}:{src.line_of(at)}: malformed position: expected {{...}}")
        comps = {}
        for c in _COMPONENT.finditer(masked, m.start() + 1, m.end() - 1):
            comps[c.group(1).upper()] = Number(c.start(2), c.end(2), src.text[c.start(2):c.end(2)])
        return comps, m.end()

    def _target(self, src, masked, at, name, kind, prog) -> Target | None:
        found = self._aggregate(src, masked, at)
        if found is None:
            return None
        comps, _ = found
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
        axes = {k: comps[k].value for k in EXTERNAL_LETTERS
                if k in comps and not comps[k].text.startswith("'")}
        external = ", ".join(f"{k} {comps[k].text}" for k, v in axes.items() if v != 0.0)
        return Target(src, at, name, nums, config=config, config_spans=spans, external=external, axes=axes)

    def parse(self, sources, frames, tools, references=()):
        prog = Program([])
        st = _State()
        prog.frames[NULL] = np.eye(4)
        prog.tools[NULL] = np.eye(4)
        for src in [*references, *sources]:
            masked = st.masked[src.path] = src.masked([COMMENT_RE], [STRING_RE])
            for m in _DATA.finditer(masked):
                found = self._aggregate(src, masked, m.end())
                if found is None or any(k not in found[0] for k in _POSE_KEYS):
                    raise DataError(f"{src.path.name}:{src.line_of(m.start())}: {m.group(1)}[{m.group(2)}] "
                                    "needs X, Y, Z, A, B, C")
                comps = found[0]
                pose = self.to_pose(np.array([[comps[k].value for k in _POSE_KEYS]]))[0]
                (prog.tools if m.group(1).upper() == "TOOL_DATA" else prog.frames)[m.group(2)] = pose
            for m in _FDAT.finditer(masked):
                comps = dict(re.findall(r"\b(TOOL_NO|BASE_NO|IPO_FRAME)\s+(#?\w+)",
                                        masked[m.end():masked.find("}", m.end())], re.IGNORECASE))
                comps = {k.upper(): v for k, v in comps.items()}
                st.fdat[m.group(1).upper()] = (comps.get("TOOL_NO"), comps.get("BASE_NO"),
                                               comps.get("IPO_FRAME", "#BASE").upper())
            st.axes |= {m.group(1).upper() for m in _AXES.finditer(masked)}
            for m in _KINDS.finditer(masked):
                for name in re.findall(r"([A-Za-z_$]\w*)\s*(?:\[[^\]]*\])?\s*(?:,|$)", m.group(2)):
                    st.kinds[name.upper()] = m.group(1).upper()
            st.machines.read(src, masked)
            reference = src not in sources
            here: dict[str, int] = {}  # a position declared in this file -> its offset
            for m in _DECL.finditer(masked):
                t = self._target(src, masked, m.end(), m.group(2), m.group(1).upper(), prog)
                if t is not None:
                    _once(src, here, m.group(2), m.start())
                    st.declare(m.group(2).upper(), t, reference)
            for m in _ELEMENT.finditer(masked):
                name = re.sub(r"\s+", "", m.group(1))
                if name.upper().startswith(("TOOL_DATA", "BASE_DATA")):
                    continue
                found = self._aggregate(src, masked, m.end())
                if found is None or not any(k in found[0] for k in _POSE_KEYS):
                    continue  # another structure (LOAD_DATA, MACHINE_DEF ...): not a position
                t = self._target(src, masked, m.end(), name, "E6POS", prog)
                if t is not None:
                    _once(src, here, name, m.start())
                    st.declare(name.upper(), t, reference)
            for m in _ROUTINE.finditer(masked):
                st.params[m.group(1).upper()] = [p.split(":")[0].strip().upper()
                                                 for p in m.group(2).split(",") if p.strip()]
        prog.declared_tools, prog.declared_frames = dict(prog.tools), dict(prog.frames)
        prog.tools.update({self.name_key(k): v for k, v in tools.items()})
        prog.frames.update({self.name_key(k): v for k, v in frames.items()})
        flow = Flow()
        for src in sources:
            self._flow(src, st, flow)
        self._motions(prog, sources, st)
        self._carried(prog, st.machines)
        prog.warnings += sorted(st.machines.notes)
        names = {src.path.stem.upper() for src in sources if src.path.suffix.lower() == ".src"}
        flow.entry = next((flow.routines[n] for n in names if n in flow.routines), None) \
            if len(names) == 1 else None
        order_by_execution(prog, flow)
        return prog

    def _flow(self, src, st, flow):
        """Routine calls, assignments and the routine each offset is in, of one file; its
        routines (a DEF runs to the next one) and calls into ``flow``."""
        masked = st.masked[src.path]
        routines = [(m.start(), m.group(1).upper()) for m in _ROUTINE.finditer(masked)]
        st.routines[src.path] = routines
        for (start, name), end in zip(routines, [r[0] for r in routines[1:]] + [len(masked)], strict=False):
            flow.routines[name] = Routine(name, src, start, end)
        data_list = src.path.suffix.lower() == ".dat"
        for m in _ASSIGN.finditer(masked):
            name = m.group(1).upper()
            if name in _KEYWORDS or name.endswith("_ACT") or MOTION_RE.match(masked, m.start()) \
                    or data_list and m.group(4).lstrip().startswith("{"):  # a .dat's initial value
                continue
            proc = _routine_at(routines, m.start())
            literal = not m.group(3) and m.group(4).lstrip().startswith("{")  # read as the data (_DATA)
            if name in ("TOOL_DATA", "BASE_DATA") and proc and not literal:  # computed by the program
                index = re.sub(r"[\[\]\s]", "", m.group(2) or "")
                st.written.setdefault((name, index if index.isdigit() else "*"),
                                      f"{src.path.name}:{src.line_of(m.start())}")
            if m.group(3) or m.group(2) and not re.fullmatch(r"\[\s*\d+(?:\s*,\s*\d+)*\s*\]", m.group(2)):
                st.modified.setdefault(name, []).append(f"{src.path.name}:{src.line_of(m.start())}")
            else:
                key = name + re.sub(r"\s+", "", m.group(2) or "")
                st.assigned.setdefault(key, []).append((src, m.start(4), m.end(4), proc))
        for m in _CALL.finditer(masked):
            name = m.group(1).upper()
            args = split_top(masked, m.start(2), m.end(2))
            if name in st.params:
                flow.calls.append((src, m.start(1), name))
            if name in st.params and st.params[name]:
                st.calls.setdefault(name, []).append((src, args, _routine_at(routines, m.start())))
            elif name not in st.params and name not in _KEYWORDS:  # a routine of a file not given
                st.foreign.append((src, m.start(1), m.group(1), args))

    def _motions(self, prog, sources, st):
        used = prog.used
        named: set[int] = set()  # targets of motions named as not corrected
        for src in sources:
            masked = st.masked[src.path]
            state = {"tool": ("?", "the program does not set the tool before this motion "
                                   "($TOOL=TOOL_DATA[n], BAS(#TOOL,n), FDAT_ACT or WITH $TOOL=STOOL2(F))"),
                     "base": ("?", "the program does not set the base before this motion "
                                   "($BASE=BASE_DATA[n], BAS(#BASE,n), FDAT_ACT or WITH "
                                   "$BASE=SBASE(F.BASE_NO))")}
            motions = list(MOTION_RE.finditer(masked))
            starts = [m.start() for m in motions]
            states = [m for m in _STATE.finditer(masked) if not _inside(motions, starts, m.start())]
            events = sorted([(m.start(), "state", m) for m in states]
                            + [(m.start(), "motion", m) for m in motions], key=lambda e: e[0])
            for at, kind, m in events:
                here = f"{src.path.name}:{src.line_of(at)}"
                if kind == "state":
                    self._state(m, state, st)
                    continue
                instr = m.group(1).upper() + (m.group(2) or "").upper()
                args_end = m.end(3)
                w = _WITH.search(masked, m.start(3), args_end)
                if w:
                    for a, b in split_top(masked, w.end(), args_end):
                        lhs, _, rhs = masked[a:b].partition("=")
                        if lhs.strip().upper() in ("$TOOL", "$BASE"):
                            which = lhs.strip().upper()[1:].lower()
                            state[which] = _frame_value(rhs.strip(), which, st.fdat, st.machines)
                    args_end = w.start()
                acc = prog.motion(src, at, instr)
                if m.group(2):
                    prog.skip(here, instr, "a relative motion: its displacement is not a stored target", acc,
                              masked[m.start(3):args_end][:60])
                    continue
                parts = split_top(masked, m.start(3), args_end)
                names = parts[:2] if instr in ("CIRC", "SCIRC") else parts[:1]
                proc = _routine_at(st.routines[src.path], at)
                for a, b in names:
                    text = masked[a:b].strip()
                    if text.startswith("{") or _NULL_OPERAND.match(text):  # $NULLFRAME:{..} is {..}
                        first = a + masked[a:b].index("{")
                        found = [self._target(src, masked, first, f"inline@{src.line_of(a)}", "E6POS", prog)]
                        parsed = self._aggregate(src, masked, first) if found == [None] else None
                        if parsed is not None and "A1" not in parsed[0]:  # a partial position
                            found = ["a partial position: its missing components are taken from the current "
                                     "position at run time"]
                    else:
                        head = _APPROX.sub("", text)
                        routed = RunTime(f"{head} is corrected at run time by robocal's RC_CORRECT (a "
                                         "filtered program)")
                        found = [routed] if _ROUTED.match(head) else \
                            self._follow(st, head, proc, {}, 0) if head else []
                    if found and all(isinstance(f, RunTime) for f in found):
                        stop = a + len(_APPROX.sub("", masked[a:b]).rstrip())
                        tool, base = state["tool"][0], state["base"][0]
                        lead = len(masked[a:b]) - len(masked[a:b].lstrip())
                        uses = self._meant(st, src, masked, a + lead, stop, proc)
                        found = [RunTime(f, f.depends, f.relative, (*f.meant, *uses)) for f in found]
                        site = _site(st, acc, src.path, a + lead, stop,
                                     head, "" if tool == "?" else tool, "" if base == "?" else base)
                        prog.runtime_sites.append(site)
                    for f in found:
                        if isinstance(f, RunTime):  # its operands are used, by this motion's record
                            named |= f.depends
                        if f is None:
                            continue
                        if isinstance(f, str):
                            prog.skip(here, instr, f, acc, text[:60])
                            continue
                        if id(f) in st.reference:
                            prog.skip(here, instr, f"{f.name} is declared in {f.source.path.name}, given "
                                                   "as a reference: give that file as a program file (and -o "
                                                   "a folder) to correct it", acc, f.name)
                            continue
                        (tool, why_tool), (base, why_base) = state["tool"], state["base"]
                        written = _written(st, tool, base)
                        if written:  # the data the controller uses are those of run time
                            prog.skip(here, instr, f"{f.name}: {written}", acc)
                            prog.withhold(f, f"{f.name} is also moved to at {here}, where {written}")
                            named.add(id(f))
                            continue
                        if "?" in (tool, base):
                            prog.skip(here, instr, f"{f.name}: {why_tool if tool == '?' else why_base}", acc)
                            named.add(id(f))
                            continue
                        if prog.use(f, tool, base, here, f.name, "base", (src.path, a), acc) \
                                and tool == "external TCP":
                            prog.unsupported[f"tool:{tool}"] = ("an external TCP (IPO_FRAME #TCP) is not "
                                                                "filtered")
        passed = set()
        for src, at, routine, args in st.foreign:
            for a, b in args:
                key = re.sub(r"\s+", "", st.masked[src.path][a:b]).upper()
                for t in st.declared.get(key, []):
                    if id(t) not in used and id(t) not in st.reference:
                        prog.skip(f"{src.path.name}:{src.line_of(at)}", routine,
                                  f"{t.name} is passed to {routine}, a routine not in these files: if it "
                                  "moves there, give its file as a program file")
                        passed.add(id(t))
        for name in sorted(st.homes):
            prog.warnings.append(f"{name} is declared in no file given: taken as the home axis position "
                                 "$config.dat declares (E6AXIS), a joint motion")
        for t in st.all_targets():
            if id(t) not in used and id(t) not in st.reference and id(t) not in passed | named:
                prog.warnings.append(f"{t.where}: not used by a motion in these files: left as it is")

    def _meant(self, st, src, masked: str, start: int, end: int, proc: str) -> list[Meant]:
        """The operands of the ':' expression at ``start:end`` that name a declared position
        directly (``XP1`` in ``XP1:OFFS``, never assigned in the program): where the run-time
        routine is used, the writer puts that position's value as written there
        (:class:`~robocal.programs.runtime.Meant`)."""
        text = masked[start:end]
        operands = split_top(text, 0, len(text), ":")
        if len(operands) < 2:
            return []
        out = []
        for a, b in operands:
            name = text[a:b].strip()
            if not re.fullmatch(r"[A-Za-z_]\w*(?:\[\s*\d+(?:\s*,\s*\d+)*\s*\])?", name):
                continue
            key = re.sub(r"\s+", "", name).upper()
            if st.assigned.get(key) or st.modified.get(key.split("[")[0]) or \
                    key.split("[")[0] in st.params.get(proc, []):
                continue  # through a variable: its value at run time is not the declaration's
            found = self._follow(st, name, proc, {}, 0)
            if len(found) == 1 and found == st.declared.get(key):
                at = start + a + len(text[a:b]) - len(text[a:b].lstrip())
                out.append(Meant(found[0], src.path, at, at + len(name)))
        return out

    def _carried(self, prog, machines: Machines) -> None:
        """The bases the motions put on a machine: their frames (BASE_DATA[n] or the literal
        offset, in the machine's flange frame) and units (:attr:`Program.carried`)."""
        for key, (unit, n) in machines.carried.items():
            prog.carried[key] = unit
            if n and n in prog.frames:
                prog.frames[key] = prog.frames[n]
            elif key in machines.literals and machines.literals[key].size == len(_POSE_KEYS):
                prog.frames[key] = self.to_pose(machines.literals[key][None])[0]

    def _state(self, m, state, st):
        """Apply a tool/base assignment ($TOOL=, BAS(#TOOL,n), FDAT_ACT=) to ``state``."""
        if m.group(1):
            which = m.group(1).upper()[1:].lower()
            state[which] = _frame_value(m.group(2).strip(), which, st.fdat, st.machines)
        elif m.group(3):
            state[m.group(3).lower()] = (m.group(4), "") if m.group(3).upper() == "TOOL" else \
                st.machines.base(m.group(4))
        else:
            f = st.fdat.get(m.group(5).upper())
            if f is None:
                why = f"FDAT_ACT={m.group(5)} names no FDAT declared in these files"
                state["tool"] = state["base"] = ("?", why)
            elif f[2] == "#TCP":
                state["tool"] = state["base"] = ("external TCP", "")
            else:
                state["tool"] = (f[0], "") if f[0] else state["tool"]
                state["base"] = st.machines.base(f[1]) if f[1] else state["base"]

    def _follow(self, st, text, proc, scope, depth) -> list:
        """The positions (Target) a motion's argument ``text`` takes its value from, or strings
        saying why a part cannot be followed; joint positions give nothing."""
        if depth > _DEPTH:
            return [f"{text} is defined through more than {_DEPTH} assignments or calls"]
        if ":" in text:
            left, _, right = text.partition(":")
            if re.fullmatch(r"\s*\{(?:\s*[A-Za-z]\w*\s+[-+]?(?:\d+(?:\.\d*)?|\.\d+)\s*,?)*\}\s*", right):
                return self._follow(st, left.strip(), proc, scope, depth + 1)  # a constant offset
            why = f"{text} is computed at run time by the geometric operator ':'"
            parts = [p for operand in split_top(text, 0, len(text), ":")
                     for p in (self._follow(st, text[slice(*operand)].strip(), proc, scope, depth + 1)
                               if text[slice(*operand)].strip() and "{" not in text[slice(*operand)] else [])]
            return [merged(why, parts) or why]
        r = _REF.fullmatch(text.strip())
        if not r:
            return [f"{text[:40]} is not a position this filter can follow"]
        name, fields = r.group(1).upper(), r.group(3)
        index = re.sub(r"\s+", "", r.group(2) or "")
        if name.startswith("$"):
            return [] if name.split("[")[0] in _JOINT_SYSTEM else [
                RunTime(f"{text} is a system variable (the current or a computed position)", relative=True)]
        if name in st.axes:
            return []
        params = st.params.get(proc, [])
        if name in params and depth < _DEPTH:
            k = params.index(name)
            calls = st.calls.get(proc, [])
            if not calls:
                return [f"{text} is a parameter of {proc}, which no call in these files passes a position to"]
            out = []
            for src, args, caller in calls:
                if k < len(args):
                    arg = st.masked[src.path][slice(*args[k])].strip()
                    out += self._follow(st, arg, caller, scope, depth + 1)
                else:
                    out.append(f"{text} is a parameter of {proc} that the call at {src.path.name} leaves out")
            return out
        if fields:
            return [f"{text} is a field of a structure: its value is not followed"]
        if st.modified.get(name):  # the pose reached is partly computed at run time
            why = (f"{name} is modified at run time ({name}.<field> or {name}[i] = ... at "
                   f"{st.modified[name][0]})")
            parts = list(st.declared.get(name + index, []))  # what it starts from: its value, assignments
            for src, a, b, where_proc in st.assigned.get(name + index, []) + (st.assigned.get(name, [])
                                                                              if index else []):
                parts += self._follow(st, st.masked[src.path][a:b].strip(), where_proc, scope, depth + 1)
            return [merged(why, parts) or why]
        out: list = []
        key = name + index
        sources = st.assigned.get(key, []) + (st.assigned.get(name, []) if index else [])
        if sources:
            for src, a, b, where_proc in sources:
                out += self._follow(st, st.masked[src.path][a:b].strip(), where_proc, scope, depth + 1)
            return out
        if key in st.declared:
            return out + st.declared[key]
        elements = [t for k, ts in st.declared.items() if k.startswith(name + "[") for t in ts]
        if elements and (not index or not re.fullmatch(r"\[\d+(?:,\d+)*\]", index)):
            return out + elements  # a variable index: every element of the array
        if elements:
            return out + [f"{text} is not declared (the array {name} has no such element in these files)"]
        if _HOME.fullmatch(name):
            st.homes.add(name)  # $config.dat's E6AXIS XHOME1..: a joint position, nothing to correct
            return out
        return out + [Undeclared(f"{name} is not declared in these files (give the .dat, or $config.dat with "
                                 "--references, that declares it)",
                                 f"DECL E6POS/POS/FRAME {name} (in a .dat or $config.dat)")]


class _State:
    """What the files declare: positions (name -> targets), axis positions, FDATs, routine
    parameters and calls, assignments."""

    def __init__(self):
        self.masked: dict = {}
        self.declared: dict[str, list[Target]] = {}
        self.reference: set[int] = set()
        self.axes: set[str] = set()
        self.kinds: dict[str, str] = {}  # name -> FRAME / POS / E6POS, as declared
        self.fdat: dict[str, tuple] = {}
        self.params: dict[str, list[str]] = {}
        self.calls: dict[str, list] = {}
        self.assigned: dict[str, list] = {}
        self.modified: dict[str, list[str]] = {}
        self.routines: dict = {}
        self.written: dict[tuple[str, str], str] = {}  # (TOOL_DATA/BASE_DATA, n or *) -> where computed
        self.foreign: list = []  # (src, at, routine, argument spans): calls of routines not in these files
        self.homes: set[str] = set()  # XHOME names declared in no file given, taken as axis positions
        self.machines = Machines()  # external kinematics: the bases a machine carries

    def declare(self, key: str, t: Target, reference: bool) -> None:
        self.declared[key] = [t]
        if reference:
            self.reference.add(id(t))

    def all_targets(self) -> list[Target]:
        return [t for ts in self.declared.values() for t in ts]


def _once(src: ProgramText, here: dict[str, int], name: str, at: int) -> None:
    """Note position ``name`` declared at offset ``at`` of ``src``; a second declaration in the
    same file is a DataError naming both lines (the controller refuses the file; correcting one
    copy would leave the other)."""
    first = here.setdefault(name.upper(), at)
    if first != at:
        raise DataError(f"{src.where(at)}: {name} is declared twice in {src.path.name} (first at line "
                        f"{src.line_of(first)}): give each position once")


@dataclass(frozen=True)
class KRLSite(RuntimeSite):
    """A KRL run-time target argument: ``reference`` is '' for a POS/E6POS expression, else the
    POS/E6POS whose Status, Turn and external axes the FRAME it computes is corrected in (the
    left operand of ``P:OFFSET``: KRL gives ':' the right operand's type)."""

    reference: str = ""


def _kind(st: _State, operand: str) -> str:
    """The type of a KRL position expression's operand: FRAME, POS or E6POS ('' unknown)."""
    operand = operand.strip()
    if operand.startswith("{"):
        return "POS" if re.search(r"\bS\s", operand, re.IGNORECASE) else "FRAME"
    name = re.match(r"[A-Za-z_$]\w*", operand)
    if name is None:
        return ""
    key = name.group().upper()
    if key.startswith("$"):
        return _SYSTEM_KINDS.get(key, "FRAME")
    return st.kinds.get(key, "")


def _site(st: _State, acc, path, start: int, end: int, text: str, tool: str, base: str) -> KRLSite:
    """The run-time site of argument ``text`` (``start:end``); its ``why_not`` says when it cannot
    be routed: its type is declared in no file given, or it is a FRAME computed from no POS/E6POS
    (no Status/Turn to correct it in)."""
    if _ROUTED.match(text):
        return KRLSite(acc, path, start, end, "$TOOL", "$BASE", tool, base,
                       why_not="it already goes through RC_CORRECT, robocal's run-time correction (a "
                               "filtered program: routing it again would correct it twice)")
    operands = [text[slice(*o)] for o in split_top(text, 0, len(text), ":")]
    kind = _kind(st, operands[-1])
    reference = ""
    if kind == "FRAME":
        reference = operands[0].strip()
        if len(operands) < 2 or _kind(st, reference) not in ("POS", "E6POS") or "{" in reference:
            why = (f"{text} is a FRAME computed from no POS/E6POS: no Status and Turn to correct it in "
                   "(write it as P:OFFSET with P a POS/E6POS)")
            return KRLSite(acc, path, start, end, "$TOOL", "$BASE", tool, base, why_not=why)
    elif kind not in ("POS", "E6POS"):
        why = f"the type of {operands[-1].strip()} is declared in no file given (DECL E6POS/POS/FRAME)"
        return KRLSite(acc, path, start, end, "$TOOL", "$BASE", tool, base, why_not=why)
    return KRLSite(acc, path, start, end, "$TOOL", "$BASE", tool, base, reference=reference)


def _routine_at(routines: list[tuple[int, str]], at: int) -> str:
    """The routine (DEF) an offset is in: the last one that starts before it."""
    k = bisect.bisect_right([r[0] for r in routines], at) - 1
    return routines[k][1] if k >= 0 else ""


def _inside(motions: list, starts: list[int], at: int) -> bool:
    """Whether offset ``at`` is inside one of the motion lines (a WITH clause's $TOOL = ...)."""
    k = bisect.bisect_right(starts, at) - 1
    return k >= 0 and at < motions[k].end()


def _written(st: _State, tool: str, base: str) -> str:
    """Why a motion with tool ``tool`` and base ``base`` (their numbers) cannot be corrected
    because a routine of these files writes TOOL_DATA[tool] or BASE_DATA[base] ('' if none does):
    its place in the world is known only at run time."""
    for kind, n in (("TOOL_DATA", tool), ("BASE_DATA", base)):
        where = st.written.get((kind, n), st.written.get((kind, "*"))) if n.isdigit() else None
        if where:
            return f"{kind}[{n}] is written by the program at run time ({where})"
    return ""


def _frame_value(value: str, which: str, fdat: dict, machines: Machines) -> tuple[str, str]:
    """(key, '') of the tool or base a $TOOL/$BASE value names, else ('?', why); a base on an
    external kinematic (EK, or SBASE of a base MACHINE_FRAME_DAT puts on a machine) is the
    machine's (:mod:`robocal.programs.dialects.krl.machines`)."""
    v = value.strip()
    if v.upper() == "$NULLFRAME":
        return NULL, ""
    on_machine = machines.ek(v, fdat) if which == "base" else None
    if on_machine is not None:
        return on_machine
    d = re.fullmatch(r"(TOOL_DATA|BASE_DATA)\s*\[\s*(\w+)\s*\]", v, re.IGNORECASE)
    if d:
        if d.group(2).isdigit():
            return d.group(2), ""
        return "?", f"${which.upper()} is set from {v} (a variable index known at run time only)"
    f = _FRAME_FN.fullmatch(v)
    if f:
        data = fdat.get(f.group(2).upper())
        if data is None:
            return "?", f"${which.upper()} is set from {v}, but no FDAT {f.group(2)} is declared here"
        if data[2] == "#TCP":
            return "external TCP", ""
        number = data[0] if which == "tool" else data[1]
        if number is not None and which == "base":
            return machines.base(number)
        return (number, "") if number is not None else ("?", f"FDAT {f.group(2)} has no "
                                                             f"{'TOOL_NO' if which == 'tool' else 'BASE_NO'}")
    return "?", f"${which.upper()} is set from {v} (a variable or function this filter cannot follow)"


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
    except (ValueError, IndexError, OverflowError):  # OverflowError: 1e400 reads as inf
        where = f"{src.path.name}:{src.line_of(at)}: " if src is not None else ""
        raise DataError(f"{where}status/turn {text!r} is not an integer") from None
