"""A simulated arm + 2-axis positioner cell with a hidden truth, and coordinated RAPID and KRL
programs on its plate (tests and benchmarks/bench_cell_programs.py).

The truth: the nominal arm and positioner with random errors (links, the positioner's axes and
its mount); the calibrated cell: the truth plus a small estimation error (what a cell
calibration leaves). The world is the controller's: the arm's frame {0}. A program's targets are
written at arm joints q and positioner values e as the nominal controller shows them (poses on
the plate, the configuration data of q); :func:`landing` runs a program as the nominal controller
would (its plate at e, its arm's IK in the program's configuration) on the true cell and says
where the tool lands on the true plate.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

import robocal as rc
from robocal.data.simulate import perturbed
from robocal.kinematics.positioner import positioner_chain as chain_of
from robocal.kinematics.transforms import invert_transform, make_transform, rot_x, rot_y, rot_z
from robocal.programs.dialects.writing import quaternions, zyx_angles
from robocal.programs.filter import controller_joints, target_poses
from robocal.programs.registry import dialect_named
from robocal.programs.source import ProgramText

ARM = "abb_irb2600"
KUKA_ARM = "kuka_kr16_2"
TOOL = make_transform(rot_y(np.deg2rad(20.0)), [0.0, 0.0, 0.25])  # a torch 250 mm long, tilted 20 deg
OFRAME = make_transform(rot_z(np.deg2rad(30.0)), [0.05, -0.04, 0.12])  # the workpiece on the plate


def positioner_chain(mount: np.ndarray) -> rc.Robot:
    """A tilt-and-turn positioner: tilt about the world x 0.45 m above its mount, turn about the
    plate's normal 0.2 m above the tilt axis; the plate frame parallel to the world at zero."""
    tilt = {"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.45], "limits": np.deg2rad([-90, 90])}
    turn = {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.2], "limits": np.deg2rad([-360, 360])}
    return chain_of([tilt, turn], mount=mount)


def _moved(T: np.ndarray, rng, mm: float, deg: float) -> np.ndarray:
    r = np.deg2rad(deg) * rng.uniform(-1, 1, 3)
    return T @ make_transform(rot_z(r[2]) @ rot_y(r[1]) @ rot_x(r[0]), rng.uniform(-1, 1, 3) * mm * 1e-3)


def _chain_error(chain: rc.Robot, rng, mm: float, deg: float) -> rc.Robot:
    n = chain.n_joints
    dl, da = rng.uniform(-1, 1, (2, n)) * mm * 1e-3, rng.uniform(-1, 1, (3, n)) * np.deg2rad(deg)
    return replace(chain, a=chain.a + dl[0], d=chain.d + dl[1], alpha=chain.alpha + da[0],
                   beta=chain.beta + da[1], theta=chain.theta + da[2]).with_frames(
        base=_moved(chain.base, rng, mm * 4, deg * 2), tool=_moved(chain.tool, rng, mm, deg))


def cells(seed: int = 0, arm: str = ARM, unit: str = "STN1", external_axes=(2, 3),
          estimate_mm: float = 0.01, estimate_deg: float = 0.001,
          two_arms: bool = False) -> tuple[rc.Cell, rc.Cell, rc.Cell]:
    """``(nominal, true, calibrated)`` cells: the true one has the arm's link errors (0.05-0.5 mm,
    0.005-0.05 deg) and the positioner's (0.5 mm, 0.05 deg on its links and plate, 2 mm and 0.1 deg
    on its mount); the calibrated one is the truth plus ``estimate_mm`` / ``estimate_deg``.
    ``two_arms``: a first arm ``left`` (ROB_1, across the positioner) anchors the world, and the
    programmed arm ``arm`` (ROB_2) really stands 1.5 mm / 0.05 deg from where the controller has it."""
    rng = np.random.default_rng(seed)
    nominal_arm = rc.Robot.from_catalog(arm)
    mount = make_transform(np.eye(3), [1.1, 0.45, 0.0])
    nominal_pos = positioner_chain(mount)
    true_arm = perturbed(nominal_arm, rng)
    true_pos = _chain_error(nominal_pos, rng, 0.5, 0.05)
    cal_arm = perturbed(true_arm, rng, length_mm=(0.0, estimate_mm), angle_deg=(0.0, estimate_deg))
    cal_pos = _chain_error(true_pos, rng, estimate_mm, estimate_deg)

    left = rc.Robot.from_catalog(ARM).with_frames(base=make_transform(rot_z(np.pi), [2.4, 0.9, 0.0]))
    true_left = perturbed(left, rng)
    cal_left = perturbed(true_left, rng, length_mm=(0.0, estimate_mm), angle_deg=(0.0, estimate_deg))
    if two_arms:  # the programmed arm's real place in the world the left arm defines
        true_arm = true_arm.with_frames(base=_moved(true_arm.base, rng, 1.5, 0.05))
        cal_arm = cal_arm.with_frames(base=_moved(true_arm.base, rng, estimate_mm, estimate_deg))

    def cell(a, p, first):
        arms = {"left": first, "arm": a} if two_arms else {"arm": a}
        return rc.Cell(arms, {"turntable": rc.Positioner(p, unit, external_axes=tuple(external_axes))},
                       arm_units={"left": "ROB_1", "arm": "ROB_2"} if two_arms else {})

    tracker = _moved(make_transform(rot_z(2.0), [2.5, -1.0, 0.3]), rng, 1.0, 1.0)  # the calibration's frame
    calibrated = cell(cal_arm.with_frames(base=tracker @ cal_arm.base),
                      cal_pos.with_frames(base=tracker @ cal_pos.base),
                      cal_left.with_frames(base=tracker @ cal_left.base))
    return cell(nominal_arm, nominal_pos, left), cell(true_arm, true_pos, true_left), calibrated


def poses(nominal: rc.Cell, n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, e_deg, T)``: ``n`` arm joints (rad) whose torch points at the plate, positioner values
    (deg) and the targets T ``(n, 4, 4)`` (m, in OFRAME on the plate) the nominal cell gives them."""
    rng = np.random.default_rng(seed)
    arm, chain = nominal.arms["arm"], nominal.positioners["turntable"].chain
    e_deg = np.column_stack([rng.uniform(-40, 40, 4 * n), rng.uniform(-180, 180, 4 * n)])
    plate = chain.fk(np.deg2rad(e_deg))
    # a point of the workpiece up to 0.15 m from its origin, approached from above with some tilt
    point = plate @ OFRAME @ make_transform(np.eye(3), np.c_[rng.uniform(-0.15, 0.15, (4 * n, 2)),
                                                              rng.uniform(0.0, 0.05, 4 * n)])
    tilt = [rot_y(np.pi + a) @ rot_x(b) @ rot_z(c) for a, b, c in rng.uniform(-0.3, 0.3, (4 * n, 3))]
    X = make_transform(np.array(tilt), point[:, :3, 3])
    from robocal.ik import solve_all

    cands = solve_all(arm, X @ invert_transform(TOOL))
    ok = np.isfinite(cands).all(axis=2)
    slot = np.argmax(ok, axis=1)
    keep = np.flatnonzero(ok.any(axis=1))[:n]
    if keep.size < n:
        raise AssertionError(f"only {keep.size} reachable poses")
    q = cands[keep, slot[keep]]
    T = invert_transform(plate[keep] @ OFRAME) @ arm.fk(q) @ TOOL
    return q, e_deg[keep], T


def rapid_program(folder: Path, nominal: rc.Cell, q, e_deg, T, name: str = "stn_weld",
                  robotstudio: bool = False) -> Path:
    """A RAPID module in the style of ABB's coordinated-motion examples: a wobjdata moved by STN1
    (uframe identity, the workpiece in oframe), ``ActUnit STN1``, robtargets with the positioner
    in eax_b / eax_c, motions ``\\WObj:=wobjSTN1``; plus one uncoordinated target (wobj0) whose
    eax_b / eax_c do not move it. ``robotstudio``: as RobotStudio exports a path, the targets
    written inline in the motions and the wobjdata's uframe the plate's world pose at zero (which
    the controller does not use for a moving work object)."""
    d = dialect_named("rapid")
    cfg = d.scheme.encode(nominal.arms["arm"], q)
    quat, p_mm = quaternions(T[:, :3, :3]), T[:, :3, 3] * 1e3
    qo = quaternions(OFRAME[None, :3, :3])[0]
    qt = quaternions(TOOL[None, :3, :3])[0]
    plate = nominal.positioners["turntable"].chain.fk(np.zeros((1, 2)))[0, :3, 3] * 1e3
    uframe = ",".join(f"{v:.3f}" for v in plate) if robotstudio else "0,0,0"
    lines = ["MODULE StnWeld", "  ! arc welding on a two-axis positioner (STN1), coordinated motion",
             "  PERS tooldata tTorch:=[TRUE,[[" + ",".join(f"{v:.3f}" for v in TOOL[:3, 3] * 1e3) + "],["
             + ",".join(f"{v:.8f}" for v in qt) + "]],[4.5,[0,0,120],[1,0,0,0],0,0,0]];",
             "  PERS wobjdata wobjSTN1:=[FALSE,FALSE,\"STN1\",[[" + uframe + "],[1,0,0,0]],[["
             + ",".join(f"{v:.3f}" for v in OFRAME[:3, 3] * 1e3) + "],[" + ",".join(f"{v:.8f}" for v in qo)
             + "]]];"]
    for i in range(len(q)):
        cx, c1, c4, c6 = cfg[i]
        lines.append(f"  CONST robtarget pW{i}:=[[{p_mm[i, 0]:.3f},{p_mm[i, 1]:.3f},{p_mm[i, 2]:.3f}],["
                     + ",".join(f"{v:.6f}" for v in quat[i]) + f"],[{c1},{c4},{c6},{cx}],"
                     f"[9E+09,{e_deg[i, 0]:.3f},{e_deg[i, 1]:.3f},9E+09,9E+09,9E+09]];")
    qh = np.deg2rad([[20.0, 10.0, 10.0, 30.0, 40.0, 30.0]])  # away from the quadrant edges
    home, hc = nominal.arms["arm"].fk(qh), d.scheme.encode(nominal.arms["arm"], qh)[0]
    hx = home[0, :3, 3] * 1e3
    lines.append(f"  CONST robtarget pHome:=[[{hx[0]:.2f},{hx[1]:.2f},{hx[2]:.2f}],["
                 + ",".join(f"{v:.6f}" for v in quaternions(home[:, :3, :3])[0])
                 + f"],[{hc[1]},{hc[2]},{hc[3]},{hc[0]}],[9E+09,0,0,9E+09,9E+09,9E+09]];")
    moves = [f"    Move{'J' if i == 0 else 'L'} pW{i},v200,z1,tTorch\\WObj:=wobjSTN1;" for i in range(len(q))]
    if robotstudio:  # each target inline, its declaration dropped
        inline = {f"pW{i}": lines[4 + i].split(":=", 1)[1].rstrip(";") for i in range(len(q))}
        lines[4:4 + len(q)] = []
        moves = [m.replace(f" pW{i},", f" {inline[f'pW{i}']},") for i, m in enumerate(moves)]
    lines += ["  PROC main()", "    ActUnit STN1;", "    MoveJ pHome,v500,z50,tool0;", *moves,
              "    MoveJ pHome,v500,fine,tool0;", "    DeactUnit STN1;", "  ENDPROC", "ENDMODULE", ""]
    path = folder / f"{name}.mod"
    path.write_bytes("\r\n".join(lines).encode())
    return path


def krl_program(folder: Path, nominal: rc.Cell, q, e_deg, T, name: str = "dkp_weld",
                form: str = "ek") -> tuple[list[Path], Path]:
    """A KRL .src/.dat and its $config.dat: machine 2 a DKP-400 (#EASYS) named ``DKP400``, base 3
    (OFRAME) on its flange; ``form`` 'ek': ``$BASE=EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,
    BASE_DATA[3])`` as offline programming systems write it, 'bas': ``BAS(#BASE,3)`` with
    MACHINE_FRAME_DAT[3] on machine 2, as the inline forms do, 'spline': KSS 8's spline inline forms,
    ``SLIN XW1 WITH $TOOL=STOOL2(FP1), $BASE=EK(K_ROOT(FP1.BASE_NO),K_TYPE(..),K_OFFS(..)) ...``."""
    d = dialect_named("krl")
    cfg = d.scheme.encode(nominal.arms["arm"], q)
    abc, p_mm = zyx_angles(T[:, :3, :3]), T[:, :3, 3] * 1e3
    o_abc, t_abc = zyx_angles(OFRAME[None, :3, :3])[0], zyx_angles(TOOL[None, :3, :3])[0]

    def frame(xyz, angles):
        values = [*(xyz * 1e3), *angles]
        return "{" + ",".join(f"{k} {v:.4f}" for k, v in zip("XYZABC", values, strict=True)) + "}"

    base = {"ek": "$BASE=EK(MACHINE_DEF[2].ROOT,MACHINE_DEF[2].MECH_TYPE,BASE_DATA[3])",
            "bas": "BAS(#BASE,3)", "spline": "$BASE=$NULLFRAME"}[form]
    src = [f"DEF {name}( )", ";FOLD INI", "  BAS(#INITMOV,0 )", ";ENDFOLD", "  $TOOL=TOOL_DATA[1]",
           f"  {base}",
           "  $ACT_EX_AX=2"]
    if form == "spline":  # KSS 8 spline inline forms: the base of FDAT FP1 in each motion's WITH
        src += [f"  {'SPTP' if i == 0 else 'SLIN'} XW{i} WITH $TOOL=STOOL2(FP1), "
                "$BASE=EK(K_ROOT(FP1.BASE_NO),K_TYPE(FP1.BASE_NO),K_OFFS(FP1.BASE_NO)), "
                "$IPO_MODE=SIPO_MODE(FP1.IPO_FRAME) C_SPL"
                for i in range(len(q))]
    else:
        src += [f"  {'PTP' if i == 0 else 'LIN'} XW{i}{'' if i == 0 else ' C_DIS'}" for i in range(len(q))]
    src += ["  $BASE=$NULLFRAME", "  PTP XFREE", "END", ""]
    dat = [f"DEFDAT  {name}"] + [
        f"DECL E6POS XW{i}={{X {p_mm[i, 0]:.3f},Y {p_mm[i, 1]:.3f},Z {p_mm[i, 2]:.3f},A {abc[i, 0]:.4f},"
        f"B {abc[i, 1]:.4f},C {abc[i, 2]:.4f},S {cfg[i, 0]},T {cfg[i, 1]},E1 {e_deg[i, 0]:.3f},"
        f"E2 {e_deg[i, 1]:.3f},E3 0.0,E4 0.0,E5 0.0,E6 0.0}}" for i in range(len(q))]
    qh = np.deg2rad([[20.0, -80.0, 100.0, 30.0, 40.0, 30.0]])  # away from the status/turn edges
    home, hc = nominal.arms["arm"].fk(qh), d.scheme.encode(nominal.arms["arm"], qh)[0]
    hx, ha = home[0, :3, 3] * 1e3, zyx_angles(home[:, :3, :3])[0]
    dat += ['DECL FDAT FP1={TOOL_NO 1,BASE_NO 3,IPO_FRAME #BASE,POINT2[] " "}']
    dat += [f"DECL E6POS XFREE={{X {hx[0]:.2f},Y {hx[1]:.2f},Z {hx[2]:.2f},A {ha[0]:.3f},B {ha[1]:.3f},"
            f"C {ha[2]:.3f},S {hc[0]},T {hc[1]},E1 15.0,E2 -30.0,E3 0.0,E4 0.0,E5 0.0,E6 0.0}}", "ENDDAT", ""]
    config = ["DEFDAT  $CONFIG", ";FOLD EXTERNAL KINEMATICS",
              'MACHINE_DEF[1]={NAME[] "KR16",COOP_KRC_INDEX 1,PARENT[] "WORLD",ROOT {X 0.0,Y 0.0,Z 0.0,'
              'A 0.0,B 0.0,C 0.0},MECH_TYPE #ROBOT,GEOMETRY[] " "}',
              'MACHINE_DEF[2]={NAME[] "DKP400",COOP_KRC_INDEX 1,PARENT[] "WORLD",ROOT {X 1100.0,Y 450.0,'
              'Z 0.0,A 0.0,B 0.0,C 0.0},MECH_TYPE #EASYS,GEOMETRY[] " "}',
              'MACHINE_FRAME_DAT[1]={MACH_DEF_INDEX 0,PARENT[] " ",GEOMETRY[] " "}',
              'MACHINE_FRAME_DAT[3]={MACH_DEF_INDEX 2,PARENT[] "DKP400",GEOMETRY[] " "}', ";ENDFOLD",
              f"TOOL_DATA[1]={frame(TOOL[:3, 3], t_abc)}", f"BASE_DATA[3]={frame(OFRAME[:3, 3], o_abc)}",
              "ENDDAT", ""]
    paths = [folder / f"{name}.src", folder / f"{name}.dat"]
    paths[0].write_bytes("\r\n".join(src).encode())
    paths[1].write_bytes("\r\n".join(dat).encode())
    (folder / "$config.dat").write_bytes("\r\n".join(config).encode())
    return paths, folder / "$config.dat"


def landing(paths, references, nominal: rc.Cell, true: rc.Cell, intended=None) -> dict:
    """Run program files as the nominal controller would on the true cell. Returns, for the
    targets on the plate, the tool's landing error on the true plate (m, ``(N,)``) against the
    pose written in ``intended`` (files of the program before filtering; default ``paths``), the
    joints reached and the positioner values read. The work object and tool are the generator's
    own (OFRAME on the plate, TOOL), not what the reader makes of the files: the controller's
    semantics, independent of the filter's."""
    d = dialect_named("rapid" if Path(paths[0]).suffix == ".mod" else "krl")
    prog = d.parse([ProgramText(Path(p)) for p in paths], {}, {}, [ProgramText(Path(p)) for p in references])
    targets = [t for t in prog.targets if t.frame in prog.carried]
    P, W, tool = target_poses(d, prog, targets)[1], OFRAME, TOOL
    names = d.positioner_axes(nominal.positioners["turntable"].external_axes)  # eax_b / E1 ...
    e = np.deg2rad([[t.axes[a] for a in names] for t in targets])
    arm, chain = nominal.arms["arm"], nominal.positioners["turntable"].chain
    F = chain.fk(e) @ W @ P @ invert_transform(tool)
    q = controller_joints(d, prog, targets, arm, F, [], [])
    if intended is not None:
        before = d.parse([ProgramText(Path(p)) for p in intended], {}, {},
                         [ProgramText(Path(p)) for p in references])
        P = target_poses(d, before, [t for t in before.targets if t.frame in before.carried])[1]
    true_arm, true_chain = true.arms["arm"], true.positioners["turntable"].chain
    on_plate = invert_transform(true_chain.fk(e) @ W) @ true_arm.fk(q) @ tool
    return {"error": np.linalg.norm(on_plate[:, :3, 3] - P[:, :3, 3], axis=1), "q": q, "e": e}


def model_error(q, e, calibrated: rc.Cell, true: rc.Cell, tool=TOOL) -> np.ndarray:
    """The calibrated cell's own error (m, ``(N,)``) at arm joints q and positioner values e: where
    it says the tool is on its plate (its bodies put in the controller's world, which the true
    cell's arm base is), against where the true cell has it on the true plate."""
    def on_plate(cell):
        arm, chain = cell.arms["arm"], cell.positioners["turntable"].chain
        return invert_transform(chain.fk(e)) @ arm.fk(q) @ tool

    in_world = true.in_world({name: calibrated.body(name) for name in calibrated.bodies})
    return np.linalg.norm(on_plate(in_world)[:, :3, 3] - on_plate(true)[:, :3, 3], axis=1)
