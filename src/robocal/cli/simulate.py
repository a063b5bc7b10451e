"""``robocal simulate``: a virtual laser tracker (or plane probe) measuring a perturbed robot."""

from __future__ import annotations

import argparse

from robocal.cli.args import add_model_options, check_format, numbers
from robocal.data.kinds import KINDS

EPILOG = """Examples:
  robocal simulate --robot abb_irb2600 --poses 200 --noise-mm 0.02 --seed 1 -o data.csv --truth truth.yaml
  robocal simulate --robot model.yaml --poses 100 --smr 3 --noise-model tracker --outliers 0.02 \\
      -o data.csv --truth truth.yaml
  robocal simulate --robot model.yaml --poses 300 --kind plane --planes 3 --joint-noise-deg 0.001 \\
      -o contacts.csv --truth truth.yaml
  robocal simulate --robot abb_irb2600 --poses 90 --kind flush --planes 3 --noise-mm 0.005 \
      -o flush.csv --truth truth.yaml      # a flat tool face pressed onto three tables
  robocal simulate --robot abb_irb2600 --joints poses.csv --smr-mm 20,-30,80 --tracker-mm 2500,500,300 \\
      -o data.csv --truth truth.yaml       # rehearse a campaign planned by `robocal poses`
  robocal simulate --robot truth.yaml --as-is --kind distance --poses 8 --noise-mm 0.005 \\
      -o scalebar.csv --truth truth_bar.yaml   # a 500 mm scale bar touched by the probe of truth.yaml
  robocal simulate --robot kuka_kr210_r2700 --poses 300 --payloads 0,75,150 --temperatures 20:35 \\
      -o cell.csv --truth truth.yaml       # a campaign at three payloads while the arm warms up
  robocal simulate --robot kuka_kr210_r2700 --poses 300 --temperatures 20:35 --thermal-k forearm=23e-6 \\
      -o warm.csv --truth truth.yaml       # an aluminium forearm on a steel arm
  robocal simulate --robot ur10 --poses 40 --kind marker --links 6,6,6,4 --noise-mm 0.3 \\
      -o mocap.csv --truth truth.yaml       # motion capture: 3 markers on the hand, one on link 4
  robocal simulate --robot ur10 --poses 40 --kind eye_in_hand --noise-mm 1 --rotation-noise-deg 0.3 \\
      -o camera.csv --truth truth.yaml      # a camera on the flange watching a fixed board
  robocal simulate --model cell.yaml --poses 60 --table-poses 40 --noise-mm 0.02 --seed 1 \\
      -o cell.csv --truth true_cell.yaml   # a work cell: SMRs on the arm's flange and on the plate
The truth YAML is the true robot (tracker frame as base, SMR 0 as tool); TRUTH.sim.json next to it
holds the noise floor (3-D RMS of the added noise, mm), outlier rows and plane coefficients.
"""


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="simulate tracker measurements of a robot with known errors",
                       description="Simulate measurements of the given robot plus random parameter "
                                   "errors, seen from a tracker at a random pose 2-4 m away.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_model_options(p, "catalog name or model YAML (the nominal robot)",
                      "a work cell file: each arm measured at --poses poses (its --smr SMRs on the "
                      "flange), each positioner at --table-poses poses (the SMRs on its plate: its "
                      "nests, else 3 SMRs 200 mm from the plate's origin), one tracker frame, "
                      "isotropic noise; --truth writes the true cell (the SMRs' places as its arms' "
                      "tools and its plates' nests)")
    p.add_argument("--table-poses", type=int, default=30, help="with --model: poses of each positioner")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--poses", type=int, help="number of random poses")
    which.add_argument("--joints", metavar="CSV",
                       help="measure these poses (q1_deg.., e.g. the poses.csv of `robocal poses`; "
                            "visible_smr* columns are honoured)")
    p.add_argument("--kind", choices=KINDS, default="point",
                   help="tracker points, 6-DOF poses, plane contacts (a probe tip), flush contacts (a "
                        "flat tool face on a plane: its height and two angles), scale-bar placements "
                        "(distance), motion-capture markers (marker, see --links), or a camera's board "
                        "poses with the camera in the cell (eye_to_hand) or on the flange (eye_in_hand; "
                        "--noise-mm and --rotation-noise-deg are its noise, the frames go to TRUTH.sim.json)")
    p.add_argument("--links", type=_names, metavar="J,J,..",
                   help="kind marker: the link of each marker, a frame number (0 base .. n flange) or a "
                        "link's name in a model read from a URDF (default 3 on the flange)")
    p.add_argument("--noise-mm", type=float, default=0.02, help="isotropic noise sigma per axis, mm")
    p.add_argument("--noise-model", choices=("isotropic", "tracker"), default="isotropic")
    p.add_argument("--outliers", type=float, default=0.0, help="fraction of rows with a 1-5 mm gross error")
    p.add_argument("--smr", type=int, default=1, help="SMRs on the tool (point data)")
    p.add_argument("--planes", type=int, default=1, help="planes touched (plane and flush data)")
    p.add_argument("--joint-noise-deg", type=float, default=0.0, help="joint reading noise sigma, deg")
    p.add_argument("--rotation-noise-deg", type=float, default=0.0,
                   help="orientation noise (pose data), the face's tilt (flush data; default noise-mm "
                        "over a 50 mm rim), deg")
    p.add_argument("--box", type=float, nargs=6, metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="keep poses whose tool point is in this box (robot base frame, mm)")
    p.add_argument("--smr-mm", type=numbers(3, "X,Y,Z in mm"), action="append", metavar="X,Y,Z",
                   help="an SMR position on the flange in mm (repeat for several; default random)")
    p.add_argument("--tool-mm", type=numbers(3, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="the probe tip (SMR 0) on the flange in mm, e.g. for plane and distance kinds")
    p.add_argument("--bar-mm", type=float, default=500.0,
                   help="distance kind: the scale bar's certified length, mm (default 500)")
    p.add_argument("--as-is", action="store_true",
                   help="measure the model exactly as it is (no errors drawn, its own base and tool): "
                        "e.g. a scale bar of the truth.yaml of an earlier simulation")
    p.add_argument("--tracker-mm", type=numbers(3, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="the tracker's position in the robot base frame, mm (default random, 2-4 m away)")
    p.add_argument("--payloads", type=numbers(None, "masses in kg"), metavar="KG,KG,..",
                   help="measure the poses in equal consecutive blocks, one per payload (kg): the truth "
                        "deflects under each (point and pose data; writes the payload_kg columns)")
    p.add_argument("--payload-com-mm", type=numbers(3, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="the payloads' centre of mass in the flange frame, mm (default 0,0,250)")
    p.add_argument("--temperatures", type=_range, metavar="LO:HI",
                   help="the arm warms from LO to HI deg C within each payload block (or over the campaign): "
                        "the truth's links expand (writes the temperature_c column)")
    p.add_argument("--thermal-k", type=_thermal_k, metavar="K|GROUP=K,..",
                   help="the truth's thermal expansion per K with --temperatures: one k (default steel "
                        "11.5e-6), or per link group, e.g. forearm=23e-6 (groups base, upper_arm, forearm, "
                        "wrist; all=K for the others)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-o", "--output", required=True, help="measurement CSV to write")
    p.add_argument("--truth", required=True, help="true robot model YAML to write")
    p.set_defaults(func=run)


def _range(text: str) -> tuple[float, float]:
    """``'20:35'`` -> (20.0, 35.0)."""
    try:
        lo, hi = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a range LO:HI in deg C, e.g. 20:35, got {text!r}") \
            from None
    return lo, hi


def _thermal_k(text: str) -> float | dict[str, float]:
    """``'11.5e-6'`` -> 11.5e-6; ``'forearm=23e-6,all=11.5e-6'`` -> {group: k} (checked by the
    simulator)."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    try:
        if len(items) == 1 and "=" not in items[0]:
            return float(items[0])
        pairs = [t.split("=") for t in items]
        if not pairs or any(len(p) != 2 for p in pairs):
            raise ValueError
        return {g.strip(): float(k) for g, k in pairs}
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected K or GROUP=K,.. (per K, e.g. forearm=23e-6), "
                                         f"got {text!r}") from None


def _names(text: str) -> list[str]:
    """An argparse ``type``: comma-separated texts (link names or frame numbers, resolved against
    the model by the simulation)."""
    values = [v.strip() for v in text.split(",") if v.strip()]
    if not values:
        raise argparse.ArgumentTypeError(f"expected comma-separated link names or frame numbers, "
                                         f"got {text!r}")
    return values


def run(args) -> int:
    from pathlib import Path

    import numpy as np

    from robocal.campaign.files import read_planned
    from robocal.core.io import check_outputs
    from robocal.data.simulate import probe_and_tracker, simulate_tracker
    from robocal.data.simulate_instruments import INSTRUMENT_KINDS, simulate_kind
    from robocal.kinematics.model import load_model

    check_format(args.output, "CSV", "-o")
    check_format(args.truth, "YAML", "--truth")
    check_outputs([args.output, args.truth, Path(args.truth).with_suffix(".sim.json")],
                  [args.robot, args.model, args.joints])
    if args.model:  # a work cell (robocal.data.cell_simulation)
        return _written(_simulate_cell(args), args)
    robot = load_model(args.robot)
    if args.kind in INSTRUMENT_KINDS:
        return _written(simulate_kind(robot, args.kind, args.poses, noise_mm=args.noise_mm, seed=args.seed,
                                      rotation_noise_deg=args.rotation_noise_deg, outliers=args.outliers,
                                      links=args.links),
                        args)
    box = None if args.box is None else np.array(args.box).reshape(2, 3) * 1e-3
    smr, tracker = probe_and_tracker(args.smr_mm, args.tool_mm, args.tracker_mm)
    joints = visible = None
    if args.joints:
        plan = read_planned(args.joints, robot)
        joints, visible = plan.joints, plan.visible
        smr, tracker, lines = plan.measured_with(smr, tracker, args.joints)
        for line in lines:
            print(line)
    result = simulate_tracker(robot, args.poses, noise_mm=args.noise_mm, noise_model=args.noise_model,
                              outliers=args.outliers, n_smr=args.smr, workspace_box=box, seed=args.seed,
                              kind=args.kind, n_planes=args.planes, joint_noise_deg=args.joint_noise_deg,
                              rotation_noise_deg=args.rotation_noise_deg, joints=joints, visible=visible,
                              smr_offsets=smr, tracker_position=tracker, bar_length_m=args.bar_mm * 1e-3,
                              as_is=args.as_is, payloads=args.payloads, temperatures=args.temperatures,
                              payload_com=None if args.payload_com_mm is None else
                              np.array(args.payload_com_mm) * 1e-3, thermal_k=args.thermal_k)
    return _written(result, args)


def _written(result, args) -> int:
    """Write a simulation's files and say so."""
    written = result.write(args.output, args.truth)
    if not args.quiet:
        print(result.summary())
        print(f"wrote {', '.join(written)}")
    return 0


def _simulate_cell(args):
    """``simulate --model CELL.yaml``: the cell's campaign (``--as-is``: the cell is the truth)."""
    import robocal as rc
    from robocal.core.errors import DataError

    unsupported = [o for o, v in (("--joints", args.joints), ("--kind", args.kind != "point"),
                                  ("--noise-model", args.noise_model != "isotropic"),
                                  ("--outliers", args.outliers), ("--box", args.box),
                                  ("--tracker-mm", args.tracker_mm)) if v]
    if unsupported:
        raise DataError(f"simulate --model (a work cell) measures SMR points at random poses: not "
                        f"{', '.join(unsupported)}")
    cell = rc.load_cell(args.model)
    return rc.simulate_cell(cell, args.poses, args.table_poses, truth=cell if args.as_is else None,
                            noise_mm=args.noise_mm, n_smr=args.smr, seed=args.seed)
