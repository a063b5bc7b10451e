"""The calibrated kinematics written into the vendor's own URDF (issue 49), checked outside robocal
on the expanded URDFs of five ROS description packages (tests/data/urdf_vendor, README there).

Per robot: a calibration of robocal's catalog model (``rc.simulate_tracker`` 150 poses, seeds 7..12,
``rc.calibrate``: a typical calibration, the truth drawn around the nominal), exported with
``rc.export_urdf_like``; then, independently of robocal's kinematics:

- pinocchio and yourdfpy parse the written file; its robot name, links, joints (names, types,
  parents, children, axes, limits), meshes, inertials and materials are the vendor's (every element
  and attribute but the moving joints' ``<origin>``);
- pinocchio's FK base_link -> tool0 on ``N_Q`` random joint vectors (within the limits) against the
  calibrated model's FK (controller frame {0} and flange, through the documented map: base_link the
  catalog base, UR's turned by pi about z; tool0 a constant pose in the flange, taken from the
  vendor's file and the nominal model at one joint vector):
  the largest position (mm) and rotation (rad) gap; the vendor's own file on the same vectors
  (how far the uncalibrated description is from the calibrated robot), and against robocal's
  nominal model through the same map (the map's independent check);
- per moving joint, how far its origin moved from the vendor's (mm, deg; the file's XML comment
  says the same) and the time of the export.

Then two cases beyond a vendor file of the controller's joints, by the command line
(``robocal simulate``, ``calibrate``, ``export --urdf-like``), pinocchio's FK on ``N_Q`` vectors:

- a joint map: the KR 16-2 file redrawn (scipy) with joint_a2 reversed, joint_a3's zero a quarter
  turn away and joint_a5's 0.3 rad away; the export must find ``u = sign * q + offset`` and its FK
  at those ``u`` be the calibrated model's;
- a work cell: ROS-Industrial's IRB 2600 file with a hand-built IRBP A-250 chain under a ``world``
  link (no public ROS description of an ABB positioner), the cell calibrated from a simulated
  campaign (``--model``); the arm's tool0 and the positioner's plate in the world, and tool0 in the
  plate, against the calibrated cell's.

``python benchmarks/bench_urdf_like.py [--poses N] [--ik] [--datasets DIR]`` (``--ik``: the IK figures of
docs/how-to/ros.md; the real IRB 120 rows when DIR/irb120-faro exists).
"""

from __future__ import annotations

import argparse
import io
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import yourdfpy

import robocal as rc
from robocal.deploy.compensation import controller_model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_urdf_like import DATA, ROBOTS, remapped  # noqa: E402  the vendor files and the test's redrawing

N_Q = 10_000
GOAL_MM, GOAL_RAD = 1e-6, 1e-6  # issue 49: FK base_link -> tool0 equal to the calibrated model's
ORIGIN_GOAL_MM, ORIGIN_GOAL_DEG = 1.0, 0.1  # issue 49: every joint origin near the vendor's


def stripped(text: str) -> list:
    """Every element of a URDF (tag, attributes, text) in document order, the moving joints'
    ``<origin>`` left out: what must be the vendor's."""
    root = ET.fromstring(text)
    moving = {j.get("name") for j in root.iter("joint") if j.get("type") != "fixed"}
    out = []
    for parent in root.iter():
        for el in parent:
            if parent.tag == "joint" and parent.get("name") in moving and el.tag == "origin":
                continue
            out.append((parent.tag, parent.get("name"), el.tag, sorted(el.attrib.items()),
                        (el.text or "").strip()))
    return [root.get("name"), *out]


def pin_fk(text: str, q: np.ndarray) -> np.ndarray:
    """``(N, 4, 4)`` base_link -> tool0 by pinocchio; ``q`` in the URDF's moving joints' order."""
    model = pin.buildModelFromXML(text)
    data = model.createData()
    base, tool = model.getFrameId("base_link"), model.getFrameId("tool0")
    out = np.empty((len(q), 4, 4))
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(model, data, qk)
        out[k] = data.oMf[base].inverse().homogeneous @ data.oMf[tool].homogeneous
    return out


def gaps(A: np.ndarray, B: np.ndarray) -> tuple[float, float]:
    dist = np.linalg.norm(A[:, :3, 3] - B[:, :3, 3], axis=1).max() * 1e3
    R = np.einsum("nji,njk->nik", A[:, :3, :3], B[:, :3, :3])
    cos = np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1)
    sin = np.linalg.norm(np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]],
                                  1), axis=1) / 2
    return float(dist), float(np.arctan2(sin, cos).max())


def one(file: str, name: str, poses: int, seed: int) -> dict:
    nominal = rc.Robot.from_catalog(name)
    sim = rc.simulate_tracker(nominal, poses, seed=seed)
    calibrated = rc.calibrate(nominal, sim.data).robot
    vendor = DATA / f"{file}.urdf"
    start = time.perf_counter()
    out = rc.export_urdf_like(calibrated, vendor, nominal=name)
    seconds = time.perf_counter() - start
    text, vendor_text = out.text, vendor.read_text(encoding="utf-8")
    same = stripped(text) == stripped(vendor_text)
    parsed = yourdfpy.URDF.load(io.StringIO(text), load_meshes=False, build_collision_scene_graph=False,
                                load_collision_meshes=False)
    q = np.random.default_rng(11).uniform(nominal.limits[:, 0], nominal.limits[:, 1], (N_Q, nominal.n_joints))
    controller = controller_model(calibrated, nominal)
    # the documented map, not the export's: base_link is the catalog base (UR's turned by pi about z),
    # tool0 a constant pose in the flange, taken from the vendor's file and the nominal model at one q
    base = np.diag([-1.0, -1.0, 1.0, 1.0]) if name.startswith("ur") else np.eye(4)
    vendor_fk = pin_fk(vendor_text, q)
    tool = np.linalg.inv(base @ nominal.fk(q[:1])[0]) @ vendor_fk[0]
    truth = base @ np.linalg.inv(controller.base) @ controller.fk(q) @ tool
    mm, rad = gaps(pin_fk(text, q), truth)
    vendor_mm, vendor_rad = gaps(vendor_fk, truth)
    map_mm, map_rad = gaps(vendor_fk, base @ np.linalg.inv(nominal.base) @ nominal.fk(q) @ tool)
    worst_mm = max(s.origin_mm for s in out.shifts)
    worst_deg = max(s.origin_deg for s in out.shifts)
    named = parsed.robot.name == ET.fromstring(vendor_text).get("name")
    return {"file": file, "robot": name, "same": same, "yourdfpy": named, "fk_mm": mm,
            "fk_rad": rad, "vendor_mm": vendor_mm, "vendor_rad": vendor_rad, "map_mm": map_mm,
            "map_rad": map_rad, "origin_mm": worst_mm,
            "origin_deg": worst_deg, "seconds": seconds, "shifts": out.shifts}


def ik_figures(name: str, seed: int, count: int = 1000) -> dict:
    """What the how-to (docs/how-to/ros.md) says of IK once the model is calibrated, on ``count``
    poses the calibrated robot reaches (random joints within the limits): the nominal closed form's
    pose error on the calibrated robot (an OPW / UR analytic plugin keeps the nominal geometry), and
    robocal's numeric IK (``rc.ik.solve``, the calibrated model) seeded by the nominal closed form
    vs seeded from all-zero joints (an unseeded numeric plugin): converged share, same joints as the
    truth, time per pose."""
    nominal = rc.Robot.from_catalog(name)
    calibrated = rc.calibrate(nominal, rc.simulate_tracker(nominal, 150, seed=seed).data).robot
    robot = controller_model(calibrated, nominal)
    q = np.random.default_rng(seed).uniform(nominal.limits[:, 0] * 0.9, nominal.limits[:, 1] * 0.9,
                                            (count, nominal.n_joints))
    poses = robot.fk(q)
    branches = rc.ik.solve_all(nominal, poses)  # (N, 8, n)
    d = np.abs(np.remainder(branches - q[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=2)
    d = np.where(np.isnan(d), np.inf, d)
    keep = np.isfinite(d.min(axis=1))  # the nominal closed form reaches the pose in some branch
    q, poses, branches, d = q[keep], poses[keep], branches[keep], d[keep]
    best = np.take_along_axis(branches, d.argmin(axis=1)[:, None, None], 1)[:, 0]
    count = len(q)
    opw_mm = np.linalg.norm(robot.fk(best)[:, :3, 3] - poses[:, :3, 3], axis=1) * 1e3
    out = {"opw_mean_mm": float(opw_mm.mean()), "opw_max_mm": float(opw_mm.max()), "poses": count}
    for label, seeds in (("closed-form seed", best), ("zero seed", np.zeros_like(q))):
        start = time.perf_counter()
        res = rc.ik.solve(robot, poses, seeds=seeds, nominal=nominal)
        ms = (time.perf_counter() - start) / count * 1e3
        same = np.abs(np.remainder(res.joints - q + np.pi, 2 * np.pi) - np.pi).max(axis=1) < 1e-6
        out[label] = (float(res.converged.mean()), float(same.mean()), ms,
                      float(res.position_error[res.converged].max(initial=0)))
    return out


def real_irb120(folder: Path) -> None:
    """The IRB 120 laser-tracker set (real, ``folder``/irb120-faro, 500 calibration poses, 500 held
    out): robocal's default calibration (joint-error terms chosen by cross-validation) is refused
    for a URDF, the geometric one is written into the vendor's irb120_3_58 file; pinocchio's FK of
    it against the calibrated model on ``N_Q`` joint vectors, the per-joint shifts."""
    from robocal.data.datasets import irb120

    cal, held = irb120(folder)
    nominal = rc.Robot.from_catalog("abb_irb120")
    vendor = DATA / "irb120_3_58.urdf"
    auto = rc.calibrate(nominal, cal, validation=held)
    try:
        rc.export_urdf_like(auto.robot, vendor)
        print("IRB 120 (real): the default model was NOT refused")
    except rc.DataError as exc:
        print(f"IRB 120 (real), default model: refused: {str(exc)[:160]}...")
    geometric = rc.calibrate(nominal, cal, validation=held, nongeometric=None)
    rms = rc.evaluate(geometric.robot, held)["rms"]
    print(f"IRB 120 (real), geometric model, held out: RMS {rms:.3f} mm "
          f"(nominal {rc.evaluate(rc.register(nominal, cal), held)['rms']:.3f} mm)")
    out = rc.export_urdf_like(geometric.robot, vendor)
    q = np.random.default_rng(11).uniform(nominal.limits[:, 0], nominal.limits[:, 1], (N_Q, 6))
    controller = controller_model(geometric.robot, nominal)
    truth = out.base @ np.linalg.inv(controller.base) @ controller.fk(q) @ out.tool
    mm, rad = gaps(pin_fk(out.text, q), truth)
    print(f"    FK gap by pinocchio ({N_Q} q): {mm:.2e} mm / {rad:.2e} rad; the vendor's content kept: "
          f"{stripped(out.text) == stripped(vendor.read_text(encoding='utf-8'))}")
    for s in out.shifts:
        print(f"    {s.joint:20} {s.origin_mm:7.4f} mm {s.origin_deg:8.5f} deg   frame at q=0 "
              f"{s.frame_mm:7.4f} mm {s.frame_deg:8.5f} deg")


def cli(*args: str) -> None:
    """``robocal ARGS`` in this process; SystemExit on a refusal."""
    from robocal.cli import main as robocal_main

    code = robocal_main(["--quiet", *args])
    if code:
        raise SystemExit(f"robocal {' '.join(args)}: exit {code}")


def pin_frames(text: str, q: np.ndarray, names: list[str]) -> np.ndarray:
    """``(len(names), N, 4, 4)``: the named frames in the root link by pinocchio."""
    model = pin.buildModelFromXML(text)
    data = model.createData()
    ids = [model.getFrameId(n) for n in names]
    out = np.empty((len(names), len(q), 4, 4))
    for k, qk in enumerate(q):
        pin.framesForwardKinematics(model, data, qk)
        for j, i in enumerate(ids):
            out[j, k] = data.oMf[i].homogeneous
    return out


POSITIONER = """<link name="world"/>
  <joint name="world-base_link" type="fixed"><parent link="world"/><child link="base_link"/></joint>
  <link name="irbp_a250_base_link"/><link name="irbp_a250_link_1"/><link name="irbp_a250_link_2"/>
  <link name="irbp_a250_tool0"/>
  <joint name="world-irbp_a250_base_link" type="fixed"><parent link="world"/>
    <child link="irbp_a250_base_link"/>
    <origin xyz="1.4 0 0" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="irbp_a250_joint_1" type="revolute"><parent link="irbp_a250_base_link"/>
    <child link="irbp_a250_link_1"/><origin xyz="0 0 0.9" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-1.5707963267948966" upper="1.5707963267948966" effort="0" velocity="1.5"/></joint>
  <joint name="irbp_a250_joint_2" type="revolute"><parent link="irbp_a250_link_1"/>
    <child link="irbp_a250_link_2"/><origin xyz="0 0 0.25" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-6.283185307179586" upper="6.283185307179586" effort="0" velocity="3"/></joint>
  <joint name="irbp_a250_link_2-tool0" type="fixed"><parent link="irbp_a250_link_2"/>
    <child link="irbp_a250_tool0"/></joint>
  """
CELL = """units: {length: mm, angle: deg}
name: irb2600 with irbp a250
robot: abb_irb2600
positioner:
  model: abb_irbp_a250
  unit: STN1
  mount: {xyz: [1400, 0, 0], rpy: [0, 0, 90]}
  nests: [[200, 0, 0], [0, 200, 0], [-150, -150, 0]]
"""


def mapped_and_cell(folder: Path) -> None:
    """The joint-map and work-cell rows (module docstring), files in ``folder``."""
    rng = np.random.default_rng(5)
    # the joint map
    changes = {"joint_a2": (-1.0, 0.0), "joint_a3": (1.0, np.pi / 2), "joint_a5": (1.0, 0.3)}
    (folder / "kr16_mapped.urdf").write_text(remapped((DATA / "kr16_2.urdf").read_text(encoding="utf-8"),
                                                     changes), encoding="utf-8")
    cli("simulate", "--robot", "kuka_kr16_2", "--poses", "150", "--seed", "8", "-o", str(folder / "kr16.csv"),
        "--truth", str(folder / "kr16_truth.yaml"))
    cli("calibrate", "--robot", "kuka_kr16_2", str(folder / "kr16.csv"), "--nongeometric", "none",
        "-o", str(folder / "kr16_cal.yaml"))
    cli("export", str(folder / "kr16_cal.yaml"), "--urdf-like", str(folder / "kr16_mapped.urdf"),
        "-o", str(folder / "kr16_mapped_cal.urdf"))
    nominal = rc.Robot.from_catalog("kuka_kr16_2")
    q = rng.uniform(nominal.limits[:, 0], nominal.limits[:, 1], (N_Q, 6))
    u = q * [1, -1, 1, 1, 1, 1] + [0, 0, np.pi / 2, 0, 0.3, 0]
    mine = pin_frames((folder / "kr16_mapped_cal.urdf").read_text(encoding="utf-8"), u, ["tool0"])[0]
    vendor = pin_frames((folder / "kr16_mapped.urdf").read_text(encoding="utf-8"), u, ["tool0"])[0]
    tool = np.linalg.inv(nominal.fk(q[:1])[0]) @ vendor[0]
    calibrated = rc.load_model(str(folder / "kr16_cal.yaml"))
    calibrated = calibrated.with_frames(base=nominal.base, tool=nominal.tool)
    print(f"KR 16-2 file redrawn (joint_a2 reversed, joint_a3 +pi/2, joint_a5 +0.3 rad): the map on the "
          f"nominal {gaps(vendor, nominal.fk(q) @ tool)[0]:.1e} mm; FK at u = sign q + offset "
          "{:.2e} mm / {:.2e} rad ({} q)".format(*gaps(mine, calibrated.fk(q) @ tool), N_Q))
    # the work cell
    from robocal.kinematics.workcell import load_cell

    (folder / "cell.yaml").write_text(CELL, encoding="utf-8")
    vendor_text = (DATA / "irb2600_12_165.urdf").read_text(encoding="utf-8")
    at = vendor_text.index("<link ")
    (folder / "cell.urdf").write_text(vendor_text[:at] + POSITIONER + vendor_text[at:], encoding="utf-8")
    cli("simulate", "--model", str(folder / "cell.yaml"), "--poses", "120", "--table-poses", "40",
        "--seed", "3",
        "-o", str(folder / "cell.csv"), "--truth", str(folder / "cell_truth.yaml"))
    cli("calibrate", "--model", str(folder / "cell.yaml"), str(folder / "cell.csv"), "--nongeometric", "none",
        "-o", str(folder / "cell_cal.yaml"))
    cli("export", str(folder / "cell_cal.yaml"), "--urdf-like", str(folder / "cell.urdf"),
        "-o", str(folder / "cell_cal.urdf"))
    cell = load_cell(folder / "cell_cal.yaml")
    arm, table = cell.arms["arm"], cell.positioners["STN1"].chain
    arm0, table0 = arm.nominal_robot(), table.nominal_robot()
    qa = rng.uniform(arm0.limits[:, 0], arm0.limits[:, 1], (N_Q, 6))
    qe = rng.uniform(table0.limits[:, 0], table0.limits[:, 1], (N_Q, 2))
    names = ["tool0", "irbp_a250_tool0"]
    both = np.hstack([qa, qe])
    mine_t, mine_p = pin_frames((folder / "cell_cal.urdf").read_text(encoding="utf-8"), both, names)
    vend_t, vend_p = pin_frames((folder / "cell.urdf").read_text(encoding="utf-8"), both, names)
    tool = np.linalg.inv(arm0.fk(qa[:1])[0]) @ vend_t[0]
    plate = np.linalg.inv(table0.fk(qe[:1])[0]) @ vend_p[0]
    truth_t = arm.with_frames(base=arm0.base, tool=arm0.tool).fk(qa) @ tool
    truth_p = table.with_frames(tool=table0.tool).fk(qe) @ plate
    relative = np.linalg.inv(truth_p) @ truth_t
    arm_mm, table_mm = gaps(mine_t, truth_t)[0], gaps(mine_p, truth_p)[0]
    rel_mm, rel_rad = gaps(np.linalg.inv(mine_p) @ mine_t, relative)
    print(f"cell IRB 2600 + IRBP A-250 ({N_Q} q): world -> tool0 {arm_mm:.2e} mm, world -> plate "
          f"{table_mm:.2e} mm, tool0 in the plate {rel_mm:.2e} mm / {rel_rad:.2e} rad; the vendor's file: "
          "tool0 in the plate "
          f"{gaps(np.linalg.inv(vend_p) @ vend_t, relative)[0]:.2f} mm")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=150, help="simulated calibration poses")
    parser.add_argument("--ik", action="store_true", help="also the IK figures of docs/how-to/ros.md")
    parser.add_argument("--datasets", type=Path,
                        default=Path(__file__).resolve().parents[2] / "shared" / "datasets",
                        help="the real data sets' folder (irb120-faro): the IRB 120 row, when it exists")
    args = parser.parse_args([] if argv is None and __name__ != "__main__" else argv)  # run.py: defaults
    print(f"{'file':16} {'robot':18} same  FK gap mm / rad ({N_Q} q)   vendor file mm / rad   "
          "worst origin mm / deg   export s")
    for seed, (file, name) in enumerate(ROBOTS.items(), start=7):
        r = one(file, name, args.poses, seed)
        ok = (r["same"] and r["yourdfpy"] and r["fk_mm"] < GOAL_MM and r["fk_rad"] < GOAL_RAD
              and r["origin_mm"] < ORIGIN_GOAL_MM and r["origin_deg"] < ORIGIN_GOAL_DEG)
        print(f"{file:16} {name:18} {str(r['same']):5} {r['fk_mm']:9.2e} / {r['fk_rad']:8.2e}        "
              f"{r['vendor_mm']:7.3f} / {r['vendor_rad']:8.2e}      {r['origin_mm']:6.3f} / "
              f"{r['origin_deg']:7.4f}"
              f"       {r['seconds']:.3f}  {'ok' if ok else 'GOAL MISSED'}")
        print(f"    the vendor's file vs robocal's nominal model through the map: {r['map_mm']:.2e} mm / "
              f"{r['map_rad']:.2e} rad")
        for s in r["shifts"]:
            print(f"    {s.joint:20} {s.origin_mm:7.4f} mm {s.origin_deg:8.5f} deg   frame at q=0 "
                  f"{s.frame_mm:7.4f} mm {s.frame_deg:8.5f} deg")
        if args.ik:
            f = ik_figures(name, seed)
            print(f"    IK ({f['poses']} poses): nominal closed form on the calibrated robot "
                  f"{f['opw_mean_mm']:.3f} mm mean, {f['opw_max_mm']:.3f} mm max")
            for label in ("closed-form seed", "zero seed"):
                conv, same, ms, err = f[label]
                print(f"    IK numeric, {label}: converged {conv:.1%}, the true joints {same:.1%}, "
                      f"{ms:.3f} ms/pose, worst converged {err * 1e3:.1e} mm")
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        mapped_and_cell(Path(folder))
    if (args.datasets / "irb120-faro").is_dir():
        real_irb120(args.datasets)


if __name__ == "__main__":
    main()

