"""FANUC TP source programs (.ls).

Positions in the ``/POS`` section::

    P[n] or P[n:"comment"]{
       GP1:
        UF : u, UT : t,     CONFIG : 'N U T, 0, 0, 0',
        X = x mm, Y = y mm, Z = z mm,
        W = w deg, P = p deg, R = r deg
    };

W, P, R are fixed-axis XYZ angles: R = Rz(R) Ry(P) Rx(W) (deg). CONFIG: flip (F/N), elbow
(U/D), front/back (T/B) and the turn numbers of J1, J4, J6 (see
:class:`robocal.programs.dialects.fanuc.configuration.FANUCConfig`). Each position carries its
user frame UF and tool frame UT; their values live in the controller, so they are given on the command line
(``--frame u=X,Y,Z,W,P,R``, ``--tool t=...``, mm and deg); UF 0 is the world (= robot base)
frame, UT 0 the faceplate. Joint representations (J1 = ...) are left alone. Other motion groups
(``GP2:`` ...) and a ``COORD`` motion's leader: :mod:`robocal.programs.dialects.fanuc.groups`;
extended axes of group 1 (``E1 = ...``, an integrated rail): a track cell
(:mod:`robocal.programs.track`), else named. Motions to position registers ``PR[n]``: corrected when
their values are given, the controller's backup POSREG.VA among the references
(:mod:`robocal.programs.dialects.fanuc.posreg`) or a register CSV
(:mod:`robocal.programs.dialects.fanuc.registers`).
"""

from __future__ import annotations

import re

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.core.io import short_repr
from robocal.ik.scara import is_scara
from robocal.kinematics.transforms import make_transform
from robocal.programs.dialects.base import Dialect
from robocal.programs.dialects.fanuc import marker, simulated
from robocal.programs.dialects.fanuc.campaign import fanuc_ls_program
from robocal.programs.dialects.fanuc.configuration import SCARA, FANUCConfig
from robocal.programs.dialects.fanuc.groups import COORD, coordinate, group_values, values_text
from robocal.programs.dialects.fanuc.loads import FanucLoads, read_schedules
from robocal.programs.dialects.fanuc.posreg import SETTER_NAME, is_posreg, read_posreg, setter_program
from robocal.programs.dialects.fanuc.registers import (
    ActiveFrames,
    Registers,
    assignments,
    frame_writes,
    frame_written,
    read_registers,
)
from robocal.programs.dialects.fanuc.sections import main_section, section
from robocal.programs.dialects.fanuc.sysframe import is_sysframe, read_sysframe
from robocal.programs.dialects.writing import EXTERNAL_LETTERS
from robocal.programs.model import Program, Target
from robocal.programs.motions import Undeclared
from robocal.programs.rotations import matrix_to_zyx
from robocal.programs.source import Number, ProgramText

_POS = re.compile(r"\bP\[\s*(\d+)\s*(?::\s*\"([^\"]*)\")?\s*\]\s*\{(.*?)\}\s*;", re.DOTALL)
_GROUP = re.compile(r"\bGP(\d+)\s*:")
_FRAME_NO = re.compile(r"\b(UF|UT)\s*:\s*(\w+)")
_CONFIG = re.compile(r"CONFIG\s*:\s*'\s*([NF])\s*([UD])\s*([TB])\s*,\s*([-+]?\d{1,3})\s*,"
                     r"\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3})\s*'")
_SCARA_CONFIG = re.compile(r"CONFIG\s*:\s*'\s*([LR])\s*(?:,\s*([-+]?\d{1,3})\s*,\s*([-+]?\d{1,3})\s*,"
                           r"\s*([-+]?\d{1,3}))?\s*'")  # a SCARA's (SR-series): hand, three turns (or none)
_VALUE = r"\b{}\s*=\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+))\s*(?:mm|deg)"
_KEYS = ("X", "Y", "Z", "W", "P", "R")
_VALUES = tuple(re.compile(_VALUE.format(k)) for k in _KEYS)
_JOINTS = re.compile(r"\bJ1\s*=")  # a position in joint representation
_REMOTE = re.compile(r"\bRX\s*=")  # a remote-TCP position (RX .. RR): the part carried past a fixed tool
REMOTE_TCP = ("a remote-TCP position (RX .. RR, RTCP): the arm carries the part past a tool fixed in the "
              "cell, which a calibrated arm model alone does not place: not corrected")
_NEXT = re.compile(r"\bP\[")
_NUMBER = re.compile(r"P\[(\d+)")
_EXTENDED = re.compile(r"\b(E\d)\s*=\s*([-+]?(?:\d+(?:\.\d*)?|\.\d+))")
_LINE = re.compile(r"^[ \t]*\d*[ \t]*:(.*)$", re.MULTILINE)
_MOVE = re.compile(r"\s*([JLCA])\s+(.*)$")
_ARC_END = re.compile(r"\s*(P|PR)\[")
_POSITION = re.compile(r"\b(PR|P)\[\s*((?:[A-Z]+\[\s*\d+\s*\])|\d+)\s*(?::[^\]]*)?\]")
_OFFSET = re.compile(r"\b(Tool_Offset|Offset|VOFFSET)\b(?:\s*,\s*(\w+\[[^\]]*\]))?", re.IGNORECASE)
_INCREMENTAL = re.compile(r"\bINC\b")
SHIFTED = "+"  # user frame n shifted by Offset,PR[m]: the frame "n+PR[m]"
_REGISTER = re.compile(r"^PR\[\s*(?:GP1\s*:\s*)?(\d+)\s*(?::[^\]]*)?\]$")  # an offset's PR[m]
_POSITION_MM = 1e-3
_POSITION_DIGITS = 5  # position numbers P[n] (the controller's are far below 100,000)
_ANGLE_DEG = 1e-3  # the controller writes 3 decimals: 1e-3 deg is 2 um at 120 mm from the flange


class FanucDialect(Dialect):
    name = "FANUC TP"
    key = "fanuc"
    campaign_rank = 3
    campaign_external = True  # a positioner's axes move in its campaign programs
    external_axis_names = EXTERNAL_LETTERS  # E1.. of a position: an arm group's extended axes, a group's
    positioner_group = True  # a positioner is its own motion group (GP2): its axes E1..Em there
    campaign_refuses_tracks = True
    campaign_scara = True  # an SR-series arm: J1, J2, J4 in deg, the quill J3 in mm
    scara_programs = True  # SR-series programs: CONFIG 'L|R, t1, t2, t4'
    title = "FANUC TP (.ls)"
    signature = r"^/(?:PROG|MN|POS)\b"
    angle_unit = "deg"
    position_registers = True
    payload_schedules = True
    vendor = "FANUC"
    schedule_statement = "PAYLOAD[n]"
    campaign_format, campaign_suffix = "TP", ".ls"
    suffixes = (".ls",)
    scheme = FANUCConfig()
    keep_width = True
    euler_columns = (3, 4, 5)  # W, P, R
    frame_help = "X,Y,Z in mm and W,P,R in deg, as on the teach pendant's frame screen"

    def load_reader(self, tools, schedules):
        return FanucLoads(schedules)

    def read_schedules(self, path):
        return read_schedules(path)

    def campaign_files(self, joints, robot, path, **options):
        if is_scara(robot):  # joints in their units (deg; mm on the quill), no J2/J3 coupling
            return {str(path): fanuc_ls_program(robot.joints_shown(joints), path.stem, scara=True, **options)}
        return {str(path): fanuc_ls_program(np.rad2deg(joints), path.stem, **options)}

    def mark(self, text, body, note):
        return marker.mark(text, body, note)

    def test_program(self, folder, nominal, q, tool, frame, name, variables=False):
        return simulated.write_test_program(self, folder, nominal, q, tool, frame, name, variables)

    def to_pose(self, values):
        values = np.asarray(values, float)
        R = Rotation.from_euler("ZYX", values[:, [5, 4, 3]], degrees=True).as_matrix()  # Rz(R) Ry(P) Rx(W)
        return make_transform(R, values[:, :3] * 1e-3)

    def from_pose(self, T, old):
        rpw = matrix_to_zyx(T[:, :3, :3], old[:, [5, 4, 3]], _ANGLE_DEG / 2)
        return np.hstack([T[:, :3, 3] * 1e3, rpw[:, [2, 1, 0]]])

    def resolutions(self):
        return np.array([_POSITION_MM] * 3 + [_ANGLE_DEG] * 3)

    def reference_outputs(self, program, references, corrected, kept):
        """A POSREG.VA among ``references``: the TP program setting its corrected registers
        (:func:`robocal.programs.dialects.fanuc.posreg.setter_program`), beside it as PR_CAL.LS."""
        out = {}
        for ref in (r for r in references if is_posreg(r)):
            used = {int(t.name[3:-1]): (t.frame.split(SHIFTED)[0], t.tool) for t in program.targets
                    if t.source is ref and id(t) not in kept}  # a register's value is in UF n itself
            if used:
                text = setter_program(ProgramText(ref.path, corrected[ref.path]), used, self.scheme)
                out[ref.path.with_name(f"{SETTER_NAME}.LS")] = text.encode("latin-1")
        return out

    def config_edits(self, target, new):
        spans = target.config_spans  # (flip, up, front, t1, t4, t6) as (start, end, text)
        if spans[0][2] in ("L", "R"):  # a SCARA's (hand, t1, t2, t4), or its hand alone
            texts = ["LR"[int(new[0])], *(str(int(v)) for v in new[3:])]
        else:
            letters = ("NF"[int(new[0])], "UD"[int(new[1])], "TB"[int(new[2])])
            texts = [*letters, *(str(int(v)) for v in new[3:])]
        texts = texts[:len(spans)]  # turns the file does not write stay unwritten
        return {(a, b): t for (a, b, old), t in zip(spans, texts, strict=True) if old != t}

    def parse(self, sources, frames, tools, references=()):
        prog = Program([], frames={"0": np.eye(4)}, tools={"0": np.eye(4)})
        prog.declared_tools = dict(prog.tools)  # UTOOL 0, the flange: TP files declare no tool data
        for ref in references:  # the controller's frames from its backup; --frame / --tool override them
            if is_sysframe(ref):
                user, tool = read_sysframe(ref, self.to_pose)
                prog.frames.update(user)
                prog.tools.update(tool)
                prog.declared_tools.update(tool)
            elif ref.path.name.upper() == "SYSFRAME.VA":
                raise DataError(f"{ref.path}: no [*SYSTEM*]$MNUFRAME variable: not the controller's "
                                "SYSFRAME.VA")
        prog.declared_frames = dict(prog.frames)  # UF 0, the world, and SYSFRAME.VA's user frames
        prog.frames.update(frames)
        prog.tools.update(tools)
        order = 0
        others: dict[int, tuple] = {}  # id(position) -> (its other groups' values, its extended axes)
        joint: set = set()
        remote: set = set()  # remote-TCP positions (file, number)
        registers = None  # the --position-registers file (among the sources as a .csv) or a POSREG.VA
        for src in [s for s in sources if s.path.suffix.lower() == ".csv"]:
            registers = Registers(read_registers(src), {}, f"the --position-registers file {src.path.name}")
        sources = [s for s in sources if s.path.suffix.lower() != ".csv"]
        for src in (s for s in sources if is_posreg(s)):
            raise DataError(f"{src.path.name} is the controller's backup of the position registers: give it "
                            f"with --references (its corrected registers are written as {SETTER_NAME}.LS)")
        backups = [r for r in references if is_posreg(r)]
        for r in references:
            if r.path.name.upper() == "POSREG.VA" and r not in backups:
                raise DataError(f"{r.path}: no [*POSREG*]$POSREG variable: not the controller's POSREG.VA")
        if len(backups) > 1 or backups and registers is not None:
            given = [*(r.path.name for r in backups), *([registers.origin] if registers else [])]
            raise DataError(f"the position registers are given twice ({', '.join(given)}): give one")
        if backups:
            va = read_posreg(backups[0])
            registers = Registers(va.cartesian, va.other, backups[0].path.name)
            prog.warnings.append(f"{backups[0].path.name}: the position registers' values are the backup's: "
                                 "a program not given here that writes them at run time is not seen")
        for src in sources:
            text = src.text
            start = section(text, "POS")
            if start < 0:
                prog.warnings.append(f"{src.path.name}: no /POS section: no positions")
                continue
            end = section(text, "END", start)
            end = len(text) if end < 0 else end
            after = start + len("/POS")  # the /POS section holds position blocks and nothing else
            seen: dict[int, int] = {}  # position number -> where its block starts
            for m in _POS.finditer(text, after, end):
                _nothing_between(src, text, after, m.start())
                after = m.end()
                if len(m.group(1)) > _POSITION_DIGITS:
                    raise DataError(f"{src.path.name}:{src.line_of(m.start())}: position number "
                                    f"{short_repr(m.group(1))} has more than {_POSITION_DIGITS} digits")
                first = seen.setdefault(int(m.group(1)), m.start())
                if first != m.start():  # the controller refuses the program; one copy would stay as is
                    raise DataError(f"{src.path.name}:{src.line_of(m.start())}: P[{int(m.group(1))}] is "
                                    f"given twice in /POS (first at line {src.line_of(first)}): give each "
                                    "position once")
                name = f"P[{m.group(1)}{':' + m.group(2) if m.group(2) else ''}]"
                body_start = m.start(3)
                body = m.group(3)
                groups = list(_GROUP.finditer(body))
                _check_body(src, m.start(), name, body, groups)
                if groups[0].group(1) != "1":
                    continue
                g_end = groups[1].start() if len(groups) > 1 else len(body)
                a, b = body_start + groups[0].end(), body_start + g_end
                gp = text[a:b]
                where = f"{src.path.name}:{src.line_of(m.start())}"
                if _JOINTS.search(gp):
                    joint.add((src.path, int(m.group(1))))
                    continue  # joint representation
                if _REMOTE.search(gp):
                    remote.add((src.path, int(m.group(1))))
                    continue  # every motion to it is named
                nums = []
                for k, value in zip(_KEYS, _VALUES, strict=True):
                    v = value.search(gp)
                    if not v:
                        raise DataError(f"{where}: malformed position {name}: no {k} = ... "
                                        f"{'mm' if k in 'XYZ' else 'deg'}")
                    nums.append(Number(a + v.start(1), a + v.end(1), v.group(1)))
                fr = dict(_FRAME_NO.findall(gp))
                if "UF" not in fr or "UT" not in fr \
                        or not all(fr[k].isdigit() and len(fr[k]) <= 3 for k in ("UF", "UT")):
                    raise DataError(f"{where}: position {name} needs numeric UF and UT, got {short_repr(fr)}")
                c = _CONFIG.search(gp)
                if c:
                    row = np.array(["NF".index(c.group(1)), "UD".index(c.group(2)), "TB".index(c.group(3)),
                                    int(c.group(4)), int(c.group(5)), int(c.group(6))])
                    spans = [(a + c.start(k), a + c.end(k), c.group(k)) for k in range(1, 7)]
                elif c := _SCARA_CONFIG.search(gp):  # no turns written: 0, the controller's nearest
                    row = np.array(["LR".index(c.group(1)), SCARA, SCARA,
                                    *(int(c.group(k) or 0) for k in (2, 3, 4))])
                    spans = [(a + c.start(k), a + c.end(k), c.group(k)) for k in range(1, 5) if c.group(k)]
                else:
                    raise DataError(f"{where}: position {name}: CONFIG must read 'N|F U|D T|B, t1, t4, t6' "
                                    "(a SCARA's: 'L|R, t1, t2, t4')")
                extended = [f"{e} = {v}" for e, v in _EXTENDED.findall(gp) if float(v) != 0.0]
                values = group_values(body, groups)
                # an extended axis of the arm's group (an integrated rail) carries the arm: its values
                # alone, as text (a track cell takes them, robocal.programs.track); else the other
                # groups' values, which do not move the arm's position unless coordinated, as data
                external = extended or [f"motion group GP{g} ({values_text(axes)})"
                                        for g, axes in values.items()]
                t = Target(src, m.start(), name, nums, frame=str(int(fr["UF"])), tool=str(int(fr["UT"])),
                           config=row, config_spans=spans, order=order, external=", ".join(external))
                if not extended:
                    t.axes = {f"GP{g} {k}": v for g, axes in values.items() for k, v in axes.items()}
                others[id(t)] = (values, ", ".join(extended))
                prog.targets.append(t)
                order += 1
            _nothing_between(src, text, after, end)
        self._motions(sources, prog, joint, registers, others, remote)
        return prog

    def _motions(self, sources, prog, joint, registers, others, remote=frozenset()):
        """Account for every motion of the /MN sections: positions every motion reaches are the
        /POS targets (each carries its own UF and UT, so all are corrected); an incremental
        motion's position is a displacement (named; the position is left alone unless another
        motion uses it as a pose); position registers, missing positions and run-time offsets
        are named. ``registers``: PR number -> Target from --position-registers (None: not given):
        a motion to a register given there is corrected in the user and tool frame active there.
        ``others``: id(position) -> (its other groups' values, its extended axes as text): a
        motion with ``COORD`` moves its position with the leader group
        (:func:`robocal.programs.dialects.fanuc.groups.coordinate`). ``remote``: the remote-TCP
        positions (file, number), every motion to them named."""
        numbers = {(t.source.path, int(_NUMBER.match(t.name).group(1))): t for t in prog.targets}
        incremental: dict[tuple, list] = {}  # position -> accounts of the INC motions using it
        used_registers: dict[int, Target] = {}
        plain = set()  # positions some motion uses as a pose
        shifted: dict[tuple, list] = {}  # position -> the motions moving to it shifted (Offset ...)
        pr_shifted: list[tuple] = []  # the motions to a register shifted (Offset ...), its frames known
        unshifted = set()  # positions some motion moves to as they are
        assigned, indirect = assignments(sources)  # registers written at run time -> where
        frames_written = frame_writes(sources)  # UFRAME[n]/UTOOL[n] written at run time -> where
        if indirect and registers is not None:
            prog.warnings.append(f"{', '.join(indirect[:4])}: a register whose number is known at run "
                                 "time is written (PR[R[k]]=...): any register's value may differ from the "
                                 "one given")
        first: dict[int, tuple] = {}  # id(position) -> how its first motion moves it (leader, values)
        for src in sources:
            text = src.text
            span = main_section(text)
            if span is None:
                continue
            lines = list(_LINE.finditer(text, *span))
            active = ActiveFrames(src, *span)
            for k, line in enumerate(lines):
                body = line.group(1)
                mv = _MOVE.match(body)
                if not mv or body.lstrip().startswith(("//", "!")):
                    continue
                here = f"{src.path.name}:{src.line_of(line.start())}"
                refs = [_POSITION.search(mv.group(2))]
                options = mv.group(2)
                if mv.group(1) == "C" and k + 1 < len(lines) and _ARC_END.match(lines[k + 1].group(1)):
                    refs.append(_POSITION.search(lines[k + 1].group(1)))  # the end point on the next line
                    options += " " + lines[k + 1].group(1)
                instr = mv.group(1)
                off = _OFFSET.search(options) if "OFFSET" in options.upper() else None
                for ref in refs:
                    if ref is None:  # a vision register, an expression ...: the pose is not one of these
                        prog.skip(here, instr, "its position is not a P[n] or PR[n] this filter reads",
                                  prog.motion(src, line.start(1), instr), mv.group(2).split()[0] if
                                  mv.group(2).split() else "")
                        continue
                    label = ref.group(0)
                    number = ref.group(2).isdigit() and len(ref.group(2)) <= _POSITION_DIGITS
                    if ref.group(1) == "PR" and number and registers is not None and int(ref.group(2)) \
                            not in assigned and registers.other.get(int(ref.group(2)), "") is None:
                        continue  # a joint register: nothing to correct
                    acc = None if ref.group(1) == "P" and number and (src.path, int(ref.group(2))) in joint \
                        else prog.motion(src, line.start(1), instr)
                    if acc is None:
                        continue  # a joint representation: nothing to correct
                    if ref.group(1) == "P" and number and (src.path, int(ref.group(2))) in remote:
                        prog.skip(here, instr, f"{label} is {REMOTE_TCP}", acc, label)
                        continue
                    if ref.group(1) == "PR":
                        why = _register(ref, registers, active, assigned, line.start())
                        if not isinstance(why, str) and frame_written(frames_written, why[1], why[2]):
                            why = f"{label}: {frame_written(frames_written, why[1], why[2])}"
                        if isinstance(why, str):
                            prog.skip(here, instr, why, acc, label)
                        elif "INC" in options and _INCREMENTAL.search(options):
                            prog.skip(here, instr, f"{label} is an incremental move (INC): a displacement, "
                                                   "not a pose", acc, label)
                        elif off:
                            pr_shifted.append((here, instr, label, acc, off, why, (src.path, line.start())))
                        else:
                            t, uf, ut = why
                            prog.use(t, ut, uf, here, label, "user frame", (src.path, line.start()), acc)
                            used_registers.setdefault(id(t), t)
                        continue
                    if not ref.group(2).isdigit():
                        prog.warnings.append(f"{here}: {instr} {label}: the position number is known at run "
                                             "time only; every position of /POS is corrected")
                        for (path, _), t in numbers.items():
                            if path == src.path:
                                acc.reach(t, label)
                        continue
                    if len(ref.group(2)) > _POSITION_DIGITS:
                        prog.skip(here, instr, f"P[{short_repr(ref.group(2))}] is not a position number "
                                               f"(more than {_POSITION_DIGITS} digits)", acc, label)
                        continue
                    key = (src.path, int(ref.group(2)))
                    if key not in numbers:
                        prog.skip(here, instr, Undeclared(f"P[{ref.group(2)}] is not a Cartesian position of "
                                                          "group 1 in /POS (missing or malformed)",
                                                          f"P[{ref.group(2)}] in /POS"), acc, label)
                        continue
                    acc.reach(numbers[key], label)
                    if "INC" in options and _INCREMENTAL.search(options):
                        incremental.setdefault(key, []).append((here, instr, label, acc))
                        continue
                    plain.add(key)
                    t = numbers[key]
                    if id(t) not in prog.not_corrected:
                        why = frame_written(frames_written, t.frame, t.tool)
                        why = f"{label}: {why}" if why else \
                            coordinate(prog, t, COORD.search(options), *others[id(t)], first)
                        if why:  # every motion reaching it is named
                            prog.not_corrected[id(t)] = why
                            prog.warnings.append(f"{t.where}: not corrected: {why}")
                            prog.uncorrected.append(f"{t.where}: not corrected: {why}")
                    if off:
                        shifted.setdefault(key, []).append((here, instr, label, acc, off))
                    else:
                        unshifted.add(key)
        unshifted_registers = set(used_registers)
        for here, instr, label, acc, off, (t, uf, ut), motion in pr_shifted:
            why = _shift([(here, instr, label, acc, off)], id(t) in unshifted_registers, registers, assigned,
                         used_registers, "the shifted pose is not corrected")
            if why is None:  # the register corrected in the user frame shifted by the offset's translation
                n = int(_REGISTER.search(off.group(2)).group(1))
                frame = f"{uf}{SHIFTED}PR[{n}]"
                if uf in prog.frames:
                    d = registers.values[n].values()[:3] * _POSITION_MM
                    prog.frames.setdefault(frame, prog.frames[uf] @ make_transform(np.eye(3), d))
                prog.use(t, ut, frame, here, label, "user frame", motion, acc)
                used_registers.setdefault(id(t), t)
            else:
                prog.skip(here, instr, why, acc, label)
        for key, uses in shifted.items():
            t = numbers[key]
            why = _shift(uses, key in unshifted, registers, assigned, used_registers)
            if why is None:  # a known translation d in the user frame: P[n] is corrected in UF @ Trans(d)
                n = int(_REGISTER.search(uses[0][4].group(2)).group(1))
                d = registers.values[n].values()[:3] * _POSITION_MM
                frame = f"{t.frame}{SHIFTED}PR[{n}]"
                if t.frame in prog.frames:
                    prog.frames[frame] = prog.frames[t.frame] @ make_transform(np.eye(3), d)
                t.frame = frame if t.frame in prog.frames else t.frame
                continue
            for here, instr, _, acc, _ in uses:
                prog.skip(here, instr, why, acc)
        for key, uses in incremental.items():
            for here, instr, label, acc in uses:
                why = (f"{label} is an incremental move (INC): a displacement, not a pose" if key not in plain
                       else f"{label} is an incremental move (INC) here and a pose in other motions, which "
                            "correct it: this displacement changes by that correction")
                prog.skip(here, instr, why, acc)
            if key not in plain:
                prog.not_corrected[id(numbers[key])] = "used only as an incremental (INC) displacement"
        prog.targets = [t for key, t in numbers.items() if (key in plain or key not in incremental)
                        and id(t) not in prog.not_corrected]
        prog.targets += [t for t in used_registers.values() if id(t) not in prog.not_corrected]


def _register(ref, registers, active, assigned: dict[int, str], at: int):
    """``(Target, user frame, tool frame)`` of the motion to position register ``ref`` at ``at``,
    or why it cannot be corrected. ``assigned``: register -> where a program given writes it."""
    label, n = ref.group(0), ref.group(2)
    if not n.isdigit():
        return f"{label}: the register number is known at run time only"
    if len(n) > _POSITION_DIGITS:
        return f"PR[{short_repr(n)}] is not a register number (more than {_POSITION_DIGITS} digits)"
    if int(n) in assigned:
        return f"{label} is written at {assigned[int(n)]} (PR[{int(n)}]=...): its value is computed at run " \
            "time"
    if registers is None:
        return (f"{label} is a position register: its value lives in the controller (give its backup "
                "POSREG.VA with --references, or the values with --position-registers, to correct it)")
    if registers.other.get(int(n)):
        return registers.other[int(n)]
    if int(n) not in registers.values:
        return Undeclared(f"{label} is not in {registers.origin}", f"PR[{int(n)}] in {registers.origin}")
    uf, ut = active.at(at)
    if uf is None or ut is None:
        return (f"{label}: UFRAME_NUM and UTOOL_NUM are not both set in this program before this motion "
                "(the frames its value is in are the caller's)")
    return registers.values[int(n)], str(int(uf)), str(int(ut))


def _shift(uses: list, unshifted: bool, registers, assigned: dict[int, str], used: dict,
           own: str = "") -> str | None:
    """Why the motions ``uses`` to one position (P[n] or a register), shifted (``Offset,PR[m]``,
    ...), are not corrected, or None: they are, in the user frame shifted by the translation PR[m]
    holds (FANUC adds a Cartesian offset's X, Y, Z to the position's in the user frame).
    ``unshifted``: some motion moves to the position itself; ``used``: the registers motions move
    to (by id); ``own``: what becomes of the position (default: P[n] corrected for its own pose)."""
    label, offs = uses[0][2], {u[4].group(0) for u in uses}
    own = own or f"{label} is corrected for its own pose, the shifted pose is not"
    if len(offs) > 1:
        return f"{label} is shifted by {' and by '.join(sorted(offs))}: one corrected {label} cannot serve " \
            "both"
    off = uses[0][4]
    reg = _REGISTER.search(off.group(2) or "")
    if off.group(2) is None:  # the register of the OFFSET CONDITION in effect
        return f"{label} is shifted by {off.group(0)}, the OFFSET CONDITION register in effect: {own}"
    if reg is None:  # a register number known at run time (PR[R[3]]), or not a register
        return f"{label} is shifted at run time by {off.group(0)}: {own}"
    if off.group(1).lower() != "offset":
        return f"{label} is shifted by {off.group(0)}, which robocal does not correct: {own}"
    n = int(reg.group(1))
    if n in assigned:
        return f"{label} is shifted by {off.group(0)}, written at {assigned[n]}: computed at run time; {own}"
    if registers is None:
        return (f"{label} is shifted by {off.group(0)}, whose value lives in the controller (give its backup "
                f"POSREG.VA with --references): {own}")
    if n not in registers.values:
        return f"{label} is shifted by {off.group(0)}, which {registers.origin} holds no Cartesian value " \
            f"of: {own}"
    if unshifted:
        return (f"{label} is shifted by {off.group(0)} here and a pose in other motions, which correct it: "
                f"one corrected {label} cannot serve both")
    t = registers.values[n]
    if np.any(t.values()[3:] != 0.0):
        return f"{label} is shifted by {off.group(0)}, which turns the pose (W, P, R not 0): {own}"
    if id(t) in used:
        return (f"{label} is shifted by {off.group(0)}, which motions also move to: its corrected value "
                f"would change this shift; {own}")
    return None


def _nothing_between(src, text: str, a: int, b: int) -> None:
    """Only blanks may stand between position blocks: a block whose head does not read
    ``P[n]{`` or ``P[n:"comment"]{`` would otherwise be skipped without a word."""
    gap = text[a:b]
    if gap.strip():
        k = a + len(gap) - len(gap.lstrip())
        first = gap.strip().splitlines()[0][:60]
        raise DataError(f"{src.path.name}:{src.line_of(k)}: malformed position block {first!r}: expected "
                        "P[n]{ or P[n:\"comment\"]{, the group GPn:, the values and }; (nothing else in "
                        "/POS)")


def _check_body(src, at: int, name: str, body: str, groups: list) -> None:
    """A position block starts with its first group header and holds one position."""
    where = f"{src.path.name}:{src.line_of(at)}"
    if not groups or body[:groups[0].start()].strip():
        raise DataError(f"{where}: position {name}: expected a group header GP1: (GPn:) first, got "
                        f"{' '.join(body.split())[:40]!r}")
    if _NEXT.search(body):
        raise DataError(f"{where}: position {name} is not closed with }}; before the next position")
