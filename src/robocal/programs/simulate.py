"""Simulated robot programs with known truth, for tests and benchmarks.

:func:`write_program` writes a program in a vendor's syntax that visits given joint positions
with a real tool in a work object (base, user frame, feature), with the configuration data the
nominal controller shows at those joints. :func:`execute` runs a program as the controller
would: its targets through the nominal model's IK in the program's configuration, then the
TCP poses a robot (the true one) really reaches with those joints.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.ik import solve
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform
from robocal.programs.filter import as_frames, controller_joints, dialect_for, target_poses
from robocal.programs.source import ProgramText

SUFFIX = {"rapid": ".mod", "krl": ".src", "fanuc": ".ls", "urscript": ".script", "inform": ".JBI",
          "val3": ".pgx"}


def _quat(R):
    q = Rotation.from_matrix(R).as_quat(scalar_first=True)
    return np.where(q[:, :1] < 0, -q, q)


def _zyx(R):
    return Rotation.from_matrix(R).as_euler("ZYX", degrees=True)  # (a, b, c): R = Rz(a) Ry(b) Rx(c)


def write_program(dialect: str, folder, nominal: Robot, q: np.ndarray, tool: np.ndarray,
                  frame: np.ndarray, name: str = "sim", variables: bool = False
                  ) -> tuple[list[Path], dict, dict]:
    """Write a program visiting joints ``q`` ``(N, 6)`` (rad) of ``nominal`` with TCP ``tool``
    in ``frame`` (4x4, m). Returns the files and the ``tools`` / ``frames`` to give the filter
    (text in the dialect's notation; empty when the program declares them). ``variables``
    (URScript): one pose variable per waypoint, ``global Waypoint_i_p=p[...]``, as PolyScope
    exports them, instead of literals in the motions."""
    folder = Path(folder)
    d = dialect_for([], dialect)
    P = invert_transform(frame) @ nominal.fk(q) @ tool
    cfg = d.scheme.encode(nominal, q) if d.scheme is not None else None
    p_mm = P[:, :3, 3] * 1e3
    n = len(q)
    if dialect == "rapid":
        qt, qf = _quat(tool[None, :3, :3])[0], _quat(frame[None, :3, :3])[0]
        t_mm, f_mm = tool[:3, 3] * 1e3, frame[:3, 3] * 1e3
        quat = _quat(P[:, :3, :3])
        lines = [f"MODULE {name}", "    ! simulated program", "    PERS tooldata tReal:=[TRUE,[["
                 + ",".join(f"{v:.3f}" for v in t_mm) + "],[" + ",".join(f"{v:.8f}" for v in qt)
                 + "]],[1,[0,0,50],[1,0,0,0],0,0,0]];",
                 "    PERS wobjdata wCell:=[FALSE,TRUE,\"\",[[" + ",".join(f"{v:.3f}" for v in f_mm) + "],["
                 + ",".join(f"{v:.8f}" for v in qf) + "]],[[0,0,0],[1,0,0,0]]];"]
        for i in range(n):
            cx, c1, c4, c6 = cfg[i]
            lines.append(f"    CONST robtarget p{i}:=[[{p_mm[i, 0]:.2f},{p_mm[i, 1]:.2f},{p_mm[i, 2]:.2f}],["
                         + ",".join(f"{v:.8f}" for v in quat[i]) + f"],[{c1},{c4},{c6},{cx}],"
                         "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];")
        moves = [f"        Move{'J' if i % 5 == 0 else 'L'} p{i}, v500, z1, tReal\\WObj:=wCell;"
                 for i in range(n)]
        lines += ["    PROC main()", *moves, "    ENDPROC", "ENDMODULE", ""]
        path = folder / f"{name}.mod"
        path.write_text("\r\n".join(lines))
        return [path], {}, {}
    if dialect == "krl":
        abc = _zyx(P[:, :3, :3])
        src = [f"DEF {name}( )", "  $TOOL = TOOL_DATA[1]", "  $BASE = BASE_DATA[1]"]
        src += [f"  {'PTP' if i % 5 == 0 else 'LIN'} XP{i}" for i in range(n)] + ["END", ""]
        dat = [f"DEFDAT {name}"] + [
            f"DECL E6POS XP{i}={{X {p_mm[i, 0]:.3f},Y {p_mm[i, 1]:.3f},Z {p_mm[i, 2]:.3f},A {abc[i, 0]:.3f},"
            f"B {abc[i, 1]:.3f},C {abc[i, 2]:.3f},S {cfg[i, 0]},T {cfg[i, 1]},E1 0.0,E2 0.0}}"
            for i in range(n)]
        dat += ["ENDDAT", ""]
        paths = [folder / f"{name}.src", folder / f"{name}.dat"]
        paths[0].write_text("\n".join(src))
        paths[1].write_text("\n".join(dat))
        return paths, {"1": _frame_text(tool, "zyx")}, {"1": _frame_text(frame, "zyx")}
    if dialect == "fanuc":
        rpw = _zyx(P[:, :3, :3])
        mn = [f"{i + 1:4d}:{'J' if i % 5 == 0 else 'L'} P[{i + 1}] {'100%' if i % 5 == 0 else '500mm/sec'} "
              "CNT50    ;" for i in range(n)]
        pos = []
        for i in range(n):
            pos += [f"P[{i + 1}]{{", "   GP1:", f"\tUF : 1, UT : 1,\t\tCONFIG : '{d.scheme.text(cfg[i])}',",
                    f"\tX = {p_mm[i, 0]:9.3f}  mm,\tY = {p_mm[i, 1]:9.3f}  mm,\tZ = {p_mm[i, 2]:9.3f}  mm,",
                    f"\tW = {rpw[i, 2]:9.3f} deg,\tP = {rpw[i, 1]:9.3f} deg,\tR = {rpw[i, 0]:9.3f} deg", "};"]
        text = [f"/PROG  {name.upper()}", "/ATTR", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN",
                "   0:  UFRAME_NUM=1 ;", "   0:  UTOOL_NUM=1 ;", *mn, "/POS", *pos, "/END", ""]
        path = folder / f"{name}.ls"
        path.write_text("\r\n".join(text))
        return [path], {"1": fanuc_frame_text(tool)}, {"1": fanuc_frame_text(frame)}
    if dialect == "inform":
        values = d.from_pose(P, np.zeros((n, 6)))
        pos, last = [], ""
        for i in range(n):
            form = d.scheme.text(cfg[i])
            if form != last:
                pos.append(f"///RCONF {form},0,0")
                last = form
            pos.append(f"C{i:05d}=" + ",".join([f"{v:.3f}" for v in values[i, :3]]
                                                + [f"{v:.4f}" for v in values[i, 3:]]))
        moves = [f"MOVJ C{i:05d} VJ=50.00" if i % 5 == 0 else f"MOVL C{i:05d} V=500.0 PL=3" for i in range(n)]
        text = ["/JOB", f"//NAME {name.upper()}", "//POS", f"///NPOS {n},0,0,0,0,0", "///USER 1", "///TOOL 1",
                "///POSTYPE USER", "///RECTAN", *pos, "//INST", "///DATE 2000/01/01 00:00", "///ATTR SC,RW",
                "///GROUP1 RB1", "NOP", *moves, "END", ""]
        path = folder / f"{name.upper()}.JBI"
        path.write_bytes("\r\n".join(text).encode())
        return [path], {"1": fanuc_frame_text(tool)}, {"1": fanuc_frame_text(frame)}
    if dialect == "val3":
        return _val3(folder, d, P, cfg, tool, frame, name)
    rv = Rotation.from_matrix(P[:, :3, :3]).as_rotvec()
    lines = [f"def {name}():", "  set_tcp(p[" + _frame_text(tool, "rotvec") + "])",
             "  global Cell=p[" + _frame_text(frame, "rotvec") + "]",
             "  movej([" + ", ".join(f"{v:.6f}" for v in q[0]) + "], a=1.4, v=1.05)"]
    poses = ["p[" + ", ".join(f"{v:.6f}" for v in (*P[i, :3, 3], *rv[i])) + "]" for i in range(n)]
    if variables:
        lines += [f"  global Waypoint_{i + 1}_p={pose}" for i, pose in enumerate(poses)]
        poses = [f"Waypoint_{i + 1}_p" for i in range(n)]
    lines += [f"  movel(pose_trans(Cell, {pose}), a=1.2, v=0.25)" for pose in poses]
    lines += ["end", f"{name}()", ""]
    path = folder / f"{name}.script"
    path.write_text("\n".join(lines))
    return [path], {}, {}


def _val3(folder: Path, d, P: np.ndarray, cfg: np.ndarray, tool: np.ndarray, frame: np.ndarray, name: str):
    """A VAL3 application: points ``P`` in frame fCell, tool tReal, movel / movej to each."""
    from robocal.programs.val3 import words_of

    def attrs(values) -> str:
        return " ".join(f'{k}="{v:.3f}"' if k in "xyz" else f'{k}="{v:.4f}"'
                        for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), values, strict=True))

    zero = np.zeros((1, 6))
    values = d.from_pose(P, np.zeros((len(P), 6)))
    words = [words_of(row) for row in cfg]
    points = [f'      <Value key="{i}" {attrs(v)} shoulder="{w[0]}" elbow="{w[1]}" wrist="{w[2]}" '
              'fatherId="fCell[0]" />' for i, (v, w) in enumerate(zip(values, words, strict=True))]
    data = '    <Data name="{}" access="public" xsi:type="array" type="{}" size="{}">'
    cell, real = attrs(d.from_pose(frame[None], zero)[0]), attrs(d.from_pose(tool[None], zero)[0])
    dtx = ['<?xml version="1.0" encoding="utf-8"?>', '<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-'
           'instance" xmlns="http://www.staubli.com/robotics/VAL3/Data/2">', "  <Datas>",
           data.format("fCell", "frame", 1), f'      <Value key="0" {cell} fatherId="world[0]" />',
           "    </Data>", data.format("tReal", "tool", 1),
           f'      <Value key="0" {real} fatherId="flange[0]" />', "    </Data>",
           data.format("pP", "pointRx", len(P)), *points, "    </Data>", "  </Datas>", "</Database>", ""]
    moves = [f"  {'movej' if i % 5 == 0 else 'movel'}(pP[{i}], tReal, mNomSpeed)" for i in range(len(P))]
    pgx = ['<?xml version="1.0" encoding="utf-8"?>', '<Programs xmlns="http://www.staubli.com/robotics/VAL3/'
           'Program/2">', '  <Program name="start" access="public">', "    <Code><![CDATA[begin", *moves,
           "end]]></Code>", "  </Program>", "</Programs>", ""]
    paths = [folder / f"{name}.dtx", folder / "start.pgx"]
    paths[0].write_text("\r\n".join(dtx))
    paths[1].write_text("\r\n".join(pgx))
    return paths, {}, {}


def _frame_text(T: np.ndarray, kind: str) -> str:
    if kind == "rotvec":
        return ", ".join(f"{v:.6f}" for v in (*T[:3, 3], *Rotation.from_matrix(T[:3, :3]).as_rotvec()))
    if kind == "zyx":  # KUKA X,Y,Z,A,B,C; FANUC X,Y,Z,W,P,R (= C, B, A)
        a, b, c = _zyx(T[None, :3, :3])[0]
        return ",".join(f"{v:.6f}" for v in (*(T[:3, 3] * 1e3), a, b, c))
    raise ValueError(kind)


def fanuc_frame_text(T: np.ndarray) -> str:
    """X,Y,Z,W,P,R (mm, deg) of a 4x4 frame, as FANUC writes user and tool frames (and Yaskawa
    X,Y,Z,Rx,Ry,Rz, the same angles)."""
    a, b, c = _zyx(T[None, :3, :3])[0]
    return ",".join(f"{v:.6f}" for v in (*(T[:3, 3] * 1e3), c, b, a))


def execute(paths, robot: Robot, nominal: Robot, *, tools=None, frames=None, references=(),
            dialect: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Run program file(s) on ``robot`` (its links and base in the controller's base frame, its
    tool the flange) through ``nominal``'s IK in the program's configuration. Returns the TCP
    poses reached and the poses the program asks for, both ``(N, 4, 4)`` (m, base frame)."""
    paths = [Path(p) for p in ([paths] if isinstance(paths, str | Path) else paths)]
    d = dialect_for(paths, dialect)
    program = d.parse([ProgramText(p) for p in paths], as_frames(d, frames), as_frames(d, tools),
                      [ProgramText(p) for p in references])
    targets = program.targets
    _, P, W, tool = target_poses(d, program, targets)
    X = W @ P
    problems, warnings = [], []
    q = controller_joints(d, program, targets, nominal, X @ invert_transform(tool), problems, warnings)
    if problems:
        raise AssertionError(f"the controller cannot run {problems[:5]}")
    return robot.fk(q) @ tool, X


def touch_poses(robot: Robot, tool: np.ndarray, point: np.ndarray, n: int, rng, seed=None) -> np.ndarray:
    """Joints ``(n, 6)`` at which ``robot`` (flange model) touches ``point`` with ``tool``'s TCP,
    tilted up to +-35 deg about x and y and turned about z (a 4-point tool calibration);
    ``seed`` (6,) rad starts the numeric IK of robots without a closed form."""
    R = Rotation.from_euler("xyz", np.column_stack([180 + rng.uniform(-35, 35, n), rng.uniform(-35, 35, n),
                                                    rng.uniform(-90, 90, n)]), degrees=True).as_matrix()
    F = np.tile(np.eye(4), (n, 1, 1))
    F[:, :3, :3] = R
    F[:, :3, 3] = point - R @ tool[:3, 3]
    res = solve(robot, F, None if seed is None else np.tile(seed, (n, 1)))
    return res.joints[res.converged]
