"""``robocal poses``: plan a calibration campaign (optimal poses, line of sight, robot programs)."""

from __future__ import annotations

import argparse
from pathlib import Path

from robocal.cli.args import check_format, numbers
from robocal.deploy.models import check_tool_mm

EPILOG = """Examples:
  robocal poses --robot abb_irb2600 -n 20 --smr-mm 20,-30,80 -o poses.csv --curve 10:60 --html campaign.html
  robocal poses --robot abb_irb2600 -n 25 --smr-mm 20,-30,80 --tracker-mm 2500,500,300 \\
      --box 500 -1000 0 1800 1000 1800 --min-joint-distance-deg 10 -o poses.csv \\
      --rapid campaign.mod --krl campaign.src --urscript campaign.script
  robocal poses --robot fanuc_lrmate200id -n 20 --smr-mm 20,-30,60 -o poses.csv --fanuc campaign.ls
  robocal poses --robot yaskawa_gp25 -n 20 --smr-mm 20,-30,60 -o poses.csv --inform CAMPAIGN.JBI
  robocal poses --robot staubli_tx2_140 -n 20 --smr-mm 20,-30,60 -o poses.csv --val3 campaign
  robocal poses --robot meca500 -n 20 --from taught.csv --region taught.csv -o poses.csv
  robocal poses --robot abb_irb2600 --check -n 20 --from poses.csv -o check_poses.csv --rapid check.mod
  robocal simulate --robot abb_irb2600 --joints poses.csv --smr-mm 20,-30,80 -o data.csv --truth truth.yaml
Lengths in mm in the robot's base frame (SMR positions and facing directions in the flange frame),
angles in deg; write a value that starts with a minus as --smr-mm=-50,50,60.
poses.csv: q1_deg..q6_deg in measuring order (with --from: the chosen rows' joint
cells exactly as read, and their line numbers); visible_smr0.. with several SMRs. The programs
move to each pose (MoveAbsJ / PTP / movej / J P[k]; INFORM: MOVJ to RECTAN positions in the robot
frame, TOOL 0, with the planned joints' RCONF), wait --settle-s, and call --procedure: replace its
body with your tracker trigger (FANUC: a TP program of that name, taking the pose number; INFORM: a
job of that name, the pose number in I000; VAL3: movej(jPose[k], flange, ...) and call of a program
of that name, the pose number its argument).
Every output is written, or none.
"""


def _curve(text: str) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(":"))
    except ValueError:
        values = ()
    if len(values) not in (2, 3) or not 1 <= values[0] < values[1] or min(values) < 1:
        raise argparse.ArgumentTypeError(f"expected START:STOP or START:STOP:STEP pose counts, got {text!r}")
    return values


def add_parser(sub) -> None:
    p = sub.add_parser("poses", help="plan a calibration campaign: optimal poses and robot programs",
                       description="Choose the poses that make the identification most accurate over the "
                                   "region of interest (I-optimal exchange search over candidate poses "
                                   "that meet the constraints and the tracker's line of sight), put them in "
                                   "a short measuring order, predict the accuracy, and write the pose list "
                                   "and robot programs.",
                       epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robot", required=True, help="nominal model: catalog name or model YAML")
    p.add_argument("-n", "--poses", type=int, required=True, help="number of poses to measure")
    p.add_argument("-o", "--output", required=True, metavar="poses.csv", help="planned poses CSV to write")
    g = p.add_argument_group("candidates and search")
    g.add_argument("--kind", choices=("point", "pose", "plane", "distance"), default="point",
                   help="what is measured at each pose (plane, distance: --from a file of that kind)")
    g.add_argument("--from", dest="candidates", metavar="CSV",
                   help="choose among these poses (any measurement CSV or a joints-only CSV)")
    g.add_argument("--candidates", dest="n_candidates", type=int, default=5000,
                   help="candidate poses to generate inside the limits (default 5000)")
    g.add_argument("--check", action="store_true",
                   help="a short check campaign (robocal check, calibrate --offsets-only): poses chosen "
                        "to determine the joint zeros with the tracker frame and SMR offsets, the "
                        "parameters that move in service")
    g.add_argument("--criterion", choices=("I", "D", "O4"), default="I",
                   help="I: accuracy over the region (default); D: determinant (O1); O4")
    g.add_argument("--starts", type=int, default=4, help="random starts of the exchange search")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--region", metavar="CSV", help="region of interest: joints CSV (default: random poses "
                                                   "in the limits and boxes)")
    g.add_argument("--region-box", type=float, nargs=6, help="region of interest: TCP box (mm)",
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"))
    g.add_argument("--region-size", type=int, default=1000,
                   help="random poses of the default region (default 1000: the workspace sample of a "
                        "calibration's predicted accuracy)")
    g.add_argument("--curve", type=_curve, metavar="START:STOP[:STEP]",
                   help="predicted accuracy against the number of poses, e.g. 8:60")
    g = p.add_argument_group("measurement")
    g.add_argument("--noise-mm", type=float, default=0.02, help="tracker noise sigma per axis, mm")
    g.add_argument("--noise-model", choices=("isotropic", "tracker"), default="isotropic",
                   help="tracker: the instrument's anisotropic model (needs --tracker-mm)")
    g.add_argument("--rotation-noise-deg", type=float, default=0.001, help="orientation noise (pose data)")
    g.add_argument("--unmodelled-mm", type=float, default=0.0, metavar="U",
                   help="the robot's error the calibrated model will not describe (3-D RMS over the region, "
                        "mm; e.g. the 'unmodelled' error of an earlier geometric calibration): plan for "
                        "what the fit absorbs of it, and include it in the predicted accuracy (default 0)")
    g.add_argument("--unmodelled-terms", default="compliance,backlash,travel", metavar="TERMS",
                   help="joint-error terms that model that error (comma separated)")
    g.add_argument("--smr-mm", type=numbers(3, "X,Y,Z in mm"), action="append", metavar="X,Y,Z",
                   help="an SMR position on the flange (repeat for several; default the model's TCP)")
    g.add_argument("--smr-normal", type=numbers(3, "a direction X,Y,Z"), action="append", metavar="X,Y,Z",
                   help="its facing direction on the flange (one per --smr-mm; default flange z)")
    g = p.add_argument_group("constraints")
    g.add_argument("--margin-deg", type=float,
                   help="stay this far inside the joint limits (default 1 deg; 0 for --from poses)")
    g.add_argument("--box", type=float, nargs=6, action="append",
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="the TCP must be inside this box (mm; repeat for several boxes)")
    g.add_argument("--min-joint-distance-deg", type=float, default=0.0,
                   help="minimum joint-space distance between chosen poses (Euclidean, deg)")
    g.add_argument("--min-wrist-deg", type=float, default=0.0, help="angle between axes 4 and 6, deg")
    g.add_argument("--min-elbow-deg", type=float, default=0.0,
                   help="distance from the stretched/folded arm, deg")
    g.add_argument("--min-shoulder-mm", type=float, default=0.0,
                   help="frame {5}'s origin from the plane of axis 1 and axis 2, mm")
    g.add_argument("--tracker-mm", type=numbers(3, "X,Y,Z in mm"), metavar="X,Y,Z",
                   help="tracker position (robot base frame)")
    g.add_argument("--acceptance-deg", type=float, default=30.0, help="SMR acceptance half-angle")
    g.add_argument("--tracker-range-m", type=numbers(2, "MIN,MAX in m"), metavar="MIN,MAX",
                   default=[0.5, 40.0], help="tracker measuring range (default 0.5,40)")
    g.add_argument("--clearance-mm", type=float, default=300.0, help="arm's distance from the tracker head")
    g.add_argument("--arm-radius-mm", type=float, help="check that the beam clears the arm by this radius")
    g = p.add_argument_group("outputs")
    g.add_argument("--json", metavar="campaign.json", help="the plan as JSON")
    g.add_argument("--html", metavar="campaign.html", help="HTML page with the accuracy curve")
    g.add_argument("--rapid", metavar="F.mod", help="ABB RAPID module")
    g.add_argument("--krl", metavar="F.src", help="KUKA KRL program (.src, and .dat next to it)")
    g.add_argument("--urscript", metavar="F.script", help="URScript program")
    g.add_argument("--fanuc", metavar="F.ls", help="FANUC TP program (ASCII .ls; J3 in FANUC's convention)")
    g.add_argument("--inform", metavar="F.JBI", help="Yaskawa INFORM job (RECTAN positions with their RCONF)")
    g.add_argument("--val3", metavar="FOLDER", help="Staubli VAL3 application (a folder named like the "
                                                    "application, created if absent)")
    g.add_argument("--speed-percent", type=float, default=20.0, help="programs' speed, %% of maximum")
    g.add_argument("--settle-s", type=float, default=1.0, help="wait at each pose before measuring, s")
    g.add_argument("--procedure", default="MeasurePose", help="procedure called at each pose")
    p.set_defaults(func=run)


def _outputs(args, result, robot) -> dict:
    """Every output's text, computed before anything is written (``robot``: the model as loaded,
    its tool the flange, for programs with Cartesian positions)."""
    import json

    import numpy as np

    from robocal.campaign import programs

    texts = {args.output: result.poses_csv()}
    if args.json:
        texts[args.json] = json.dumps(result.to_dict(), indent=1, allow_nan=False) + "\n"
    if args.html:
        from robocal.report.campaign import render_campaign

        texts[args.html] = render_campaign(result.to_dict())
    deg = np.rad2deg(result.joints)
    kw = {"speed_percent": args.speed_percent, "settle_s": args.settle_s, "procedure": args.procedure,
          "comment": f"robocal campaign: {result.n} poses of {result.robot.name}, predicted accuracy "
                     f"{result.predicted_rms_mm:.4f} mm"}
    if args.rapid:
        texts[args.rapid] = programs.rapid_module(deg, Path(args.rapid).stem, **kw)
    if args.krl:
        src, dat = programs.krl_program(deg, Path(args.krl).stem, **kw)
        texts[args.krl] = src
        texts[str(Path(args.krl).with_suffix(".dat"))] = dat
    if args.urscript:
        texts[args.urscript] = programs.urscript_program(result.joints, Path(args.urscript).stem, **kw)
    if args.fanuc:
        texts[args.fanuc] = programs.fanuc_ls_program(deg, Path(args.fanuc).stem, **kw)
    if args.inform:
        texts[args.inform] = programs.inform_job(deg, robot, Path(args.inform).stem, **kw)
    if args.val3:
        folder = Path(args.val3)
        for file, text in programs.val3_application(deg, folder.name, **kw).items():
            texts[str(folder / file)] = text
    return texts


def _params(args, robot):
    """The unknowns the campaign determines: the default set, or with --check the joint zeros, the
    tracker frame and the SMR offsets."""
    if not args.check:
        return "auto"
    from robocal.core.errors import DataError
    from robocal.history.offsets import offsets_params

    if args.kind not in ("point", "pose"):
        raise DataError("--check plans a tracker campaign: --kind point or pose")
    return offsets_params(robot, max(1, len(args.smr_mm or [])))


def _val3_files(args) -> list[str]:
    """The files --val3 FOLDER will write (names checked before planning); the folder is created
    when absent (its parent must exist)."""
    from robocal.campaign import programs
    from robocal.core.errors import DataError

    if args.val3 is None:
        return []
    folder = Path(args.val3)
    if folder.exists() and not folder.is_dir():
        raise DataError(f"--val3 {folder}: not a folder (a VAL3 application is a folder)")
    if not folder.exists() and not folder.resolve().parent.is_dir():
        raise DataError(f"--val3 {folder}: its parent folder does not exist")
    names = programs.val3_application([[0.0] * 6], folder.name, procedure=args.procedure)
    return [str(folder / name) for name in names]


def run(args) -> int:
    import numpy as np

    from robocal.campaign import Constraints, Tracker, plan_poses, read_candidates
    from robocal.core.errors import DataError
    from robocal.core.io import check_outputs, write_all
    from robocal.data.measurements import read_joints
    from robocal.kinematics.model import load_model

    if args.krl and Path(args.krl).suffix.lower() != ".src":
        raise DataError(f"--krl names the .src file (its .dat is written next to it), got {args.krl}")
    dat = args.krl and Path(args.krl).with_suffix(".dat")
    for path, kind, option in ((args.output, "CSV", "-o"), (args.json, "JSON", "--json"),
                               (args.html, "HTML", "--html"), (args.rapid, "RAPID", "--rapid"),
                               (args.urscript, "URScript", "--urscript"), (args.fanuc, "TP", "--fanuc"),
                               (args.inform, "JBI", "--inform")):
        check_format(path, kind, option)
    val3 = _val3_files(args)
    check_outputs([args.output, args.json, args.html, args.rapid, args.urscript, args.krl, dat, args.fanuc,
                   args.inform, *(val3 if Path(args.val3 or ".").is_dir() else [])],
                  [args.robot, args.candidates, args.region])
    for smr in args.smr_mm or []:
        check_tool_mm(smr, f"--smr-mm {','.join(f'{v:g}' for v in smr)}")
    robot = load_model(args.robot)
    params = _params(args, robot)
    wanted = [f for f in (args.rapid, args.krl, args.urscript, args.fanuc) if f]
    if wanted and robot.has_prismatic:
        raise DataError(f"{robot.name} has a prismatic joint (a track): campaign programs with external "
                        f"axes are not written ({', '.join(wanted)}); drive the poses of {args.output} "
                        "(e1_mm and the arm's joints) with your own program")
    if args.smr_normal and len(args.smr_normal) != len(args.smr_mm or []):
        raise DataError("give one --smr-normal per --smr-mm")
    if args.region and args.region_box:
        raise DataError("give either --region or --region-box, not both")
    tracker = None
    if args.tracker_mm is not None:
        tracker = Tracker(position=np.array(args.tracker_mm) * 1e-3, acceptance_deg=args.acceptance_deg,
                          range_m=tuple(args.tracker_range_m), clearance_m=args.clearance_mm * 1e-3,
                          arm_radius_m=None if args.arm_radius_mm is None else args.arm_radius_mm * 1e-3)
    boxes = tuple(np.array(b).reshape(2, 3) * 1e-3 for b in (args.box or []))
    constraints = Constraints(margin_deg=args.margin_deg, boxes=boxes,
                              min_joint_distance_deg=args.min_joint_distance_deg,
                              min_wrist_deg=args.min_wrist_deg, min_elbow_deg=args.min_elbow_deg,
                              min_shoulder_m=args.min_shoulder_mm * 1e-3, tracker=tracker)
    candidates = read_candidates(args.candidates, robot, args.kind) if args.candidates else None
    region = (read_joints(args.region, robot) if args.region else
              np.array(args.region_box).reshape(2, 3) * 1e-3 if args.region_box else None)
    result = plan_poses(
        robot, args.poses, kind=args.kind, candidates=candidates, n_candidates=args.n_candidates,
        constraints=constraints, smr=None if not args.smr_mm else np.array(args.smr_mm) * 1e-3,
        smr_normals=None if not args.smr_normal else np.array(args.smr_normal),
        noise_mm=args.noise_mm, noise_model=args.noise_model, rotation_noise_deg=args.rotation_noise_deg,
        criterion=args.criterion, region=region, region_size=args.region_size, starts=args.starts,
        curve=args.curve, seed=args.seed, progress=not args.quiet, params=params,
        unmodelled_mm=args.unmodelled_mm, unmodelled_terms=args.unmodelled_terms)
    texts = _outputs(args, result, robot)
    created = args.val3 is not None and not Path(args.val3).is_dir()
    if created:
        Path(args.val3).mkdir()
    try:
        write_all(texts)
    except BaseException:
        if created and not any(Path(args.val3).iterdir()):
            Path(args.val3).rmdir()
        raise
    print(result.summary())
    for path in texts:
        print(f"wrote {path}")
    return 0
