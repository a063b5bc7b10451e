"""``robocal poses``: plan a calibration campaign (optimal poses, line of sight, robot programs)."""

from __future__ import annotations

import argparse

from robocal.cli.args import add_model_options, check_format, numbers
from robocal.data.kinds import KINDS
from robocal.programs.language_help import POSES_EPILOG, PROGRAM_OPTION
from robocal.programs.registry import DIALECTS


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
                       epilog=POSES_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_model_options(p, "nominal model: catalog name or model YAML",
                      "a work cell (arms and positioners): -n poses of each arm, --table-poses table "
                      "angle sets of each positioner (its nests on the plate seen by the tracker)")
    p.add_argument("-n", "--poses", type=int, required=True, help="number of poses to measure")
    p.add_argument("-o", "--output", required=True, metavar="poses.csv", help="planned poses CSV to write")
    g = p.add_argument_group("candidates and search")
    g.add_argument("--kind", choices=KINDS, default="point",
                   help="what is measured at each pose (plane, flush, distance: --from a file of that kind)")
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
    g = p.add_argument_group("work cell (--model)")
    g.add_argument("--table-poses", type=int, metavar="N",
                   help="table angle sets of each positioner (default: -n)")
    g.add_argument("--nest-mm", type=numbers(3, "X,Y,Z in mm"), action="append", metavar="X,Y,Z",
                   help="a positioner without declared nests: an SMR's approximate plate position (repeat; "
                        "each one's position is then estimated, the turn axis' zero held at nominal)")
    g.add_argument("--park-deg", type=numbers(None, "the arm's joints in deg"), metavar="J1,..,J6",
                   help="the arms' joints while the table turns (default: where the last arm pose left it)")
    g.add_argument("--station-pulses-per-deg", type=numbers(None, "pulses per degree, one per axis"),
                   metavar="P1,P2", help="INFORM: the station axes' encoder pulses per degree (mm)")
    g = p.add_argument_group("measurement")
    g.add_argument("--noise-mm", type=float, default=0.02, help="tracker noise sigma per axis, mm")
    g.add_argument("--noise-model", choices=("isotropic", "tracker"), default="isotropic",
                   help="tracker: the instrument's anisotropic model (needs --tracker-mm)")
    g.add_argument("--rotation-noise-deg", type=float, default=0.001, help="orientation noise (pose data)")
    g.add_argument("--unmodelled-mm", type=float, default=None, metavar="U",
                   help="the robot's error the calibrated model will not describe (3-D RMS over the region, "
                        "mm; e.g. the 'unmodelled' error of an earlier geometric calibration): plan for "
                        "what the fit absorbs of it, and include it in the predicted accuracy (default: "
                        "what the --from file's measurements show when it has them, else 0)")
    g.add_argument("--unmodelled-terms", default="compliance,backlash,travel", metavar="TERMS",
                   help="joint-error terms that model that error (comma separated)")
    g.add_argument("--smr-mm", type=numbers(3, "X,Y,Z in mm"), action="append", metavar="X,Y,Z",
                   help="an SMR position on the flange (repeat for several; default the model's TCP)")
    g.add_argument("--smr-normal", type=numbers(3, "a direction X,Y,Z"), action="append", metavar="X,Y,Z",
                   help="its facing direction on the flange (one per --smr-mm; default flange z)")
    g = p.add_argument_group("constraints")
    g.add_argument("--margin-deg", type=float,
                   help="stay this far inside the joint limits (default 1 deg, mm on a prismatic joint; "
                        "0 for --from poses)")
    g.add_argument("--box", type=float, nargs=6, action="append",
                   metavar=("XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"),
                   help="the TCP must be inside this box (mm; repeat for several boxes)")
    g.add_argument("--min-joint-distance-deg", type=float, default=0.0,
                   help="minimum joint-space distance between chosen poses (Euclidean, deg; mm on a "
                        "prismatic joint)")
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
    g.add_argument("--program", nargs=2, action="append", default=[], metavar=("LANG", "PATH"),
                   help=PROGRAM_OPTION.format(languages=", ".join(DIALECTS)))
    for key in DIALECTS:
        g.add_argument(f"--{key}", metavar="PATH", help=f"the same as --program {key} PATH")
    g.add_argument("--speed-percent", type=float, default=20.0, help="programs' speed, %% of maximum")
    g.add_argument("--settle-s", type=float, default=1.0, help="wait at each pose before measuring, s")
    g.add_argument("--procedure", default="MeasurePose", help="procedure called at each pose")
    p.set_defaults(func=run)


def _programs(args) -> dict[str, str]:
    """Language key -> the path of its campaign program (--program LANG PATH, or --LANG PATH)."""
    from robocal.core.errors import DataError

    programs = {key: getattr(args, key) for key in DIALECTS if getattr(args, key) is not None}
    for key, path in args.program:
        if key not in DIALECTS or key in programs:
            raise DataError(f"--program {key} {path}: " + (f"LANG is one of {', '.join(DIALECTS)}" if
                                                            key not in DIALECTS else f"{key} is given twice"))
        programs[key] = path
    return programs


def _outputs(args, result, robot, programs: dict[str, str]) -> dict:
    """Every output's text, computed before anything is written (``robot``: the model as loaded,
    its tool the flange, for programs with Cartesian positions)."""
    import json

    from robocal.campaign.programs import campaign_programs

    texts = {args.output: result.poses_csv()}
    if args.json:
        texts[args.json] = json.dumps(result.to_dict(), indent=1, allow_nan=False) + "\n"
    if args.html:
        from robocal.report.campaign import render_campaign

        texts[args.html] = render_campaign(result.to_dict())
    comment = (f"robocal campaign: {result.n} poses of {result.robot.name}, predicted accuracy "
               f"{result.predicted_rms_mm:.4f} mm")
    return texts | campaign_programs(result.joints, robot, programs, speed_percent=args.speed_percent,
                                     settle_s=args.settle_s, procedure=args.procedure, comment=comment)


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


def _check_outputs(args, programs: dict[str, str]) -> None:
    """Refuse outputs named for another format, or that would overwrite an input, before planning."""
    from robocal.campaign.programs import campaign_outputs, program_options
    from robocal.core.io import check_outputs

    written = campaign_outputs(programs, args.procedure)
    for path, kind, option in ((args.output, "CSV", "-o"), (args.json, "JSON", "--json"),
                               (args.html, "HTML", "--html"), *((programs.get(d.key), d.campaign_format,
                                                                 f"--{d.key}") for d in program_options()
                                                                if d.campaign_format)):
        check_format(path, kind, option)
    check_outputs([args.output, args.json, args.html, *written],
                  [args.robot or args.model, args.candidates, args.region])


def _constraints(args):
    """The constraints on the chosen poses: joint margins, TCP boxes, distances, the tracker's
    line of sight (lengths from mm to m)."""
    import numpy as np

    from robocal.campaign import Constraints, Tracker

    tracker = None
    if args.tracker_mm is not None:
        tracker = Tracker(position=np.array(args.tracker_mm) * 1e-3, acceptance_deg=args.acceptance_deg,
                          range_m=tuple(args.tracker_range_m), clearance_m=args.clearance_mm * 1e-3,
                          arm_radius_m=None if args.arm_radius_mm is None else args.arm_radius_mm * 1e-3)
    boxes = tuple(np.array(b).reshape(2, 3) * 1e-3 for b in (args.box or []))
    return Constraints(margin_deg=args.margin_deg, boxes=boxes,
                       min_joint_distance_deg=args.min_joint_distance_deg,
                       min_wrist_deg=args.min_wrist_deg, min_elbow_deg=args.min_elbow_deg,
                       min_shoulder_m=args.min_shoulder_mm * 1e-3, tracker=tracker)


def _cell_outputs(args, result, programs: dict[str, str]) -> dict:
    """A cell plan's outputs: the planned file, its JSON and the programs driving the anchor arm and
    the positioner."""
    import json

    texts = {args.output: result.poses_csv()}
    if args.json:
        texts[args.json] = json.dumps(result.to_dict(), indent=1, allow_nan=False) + "\n"
    comment = f"robocal campaign of cell {result.cell.name}: {len(result.rows())} rows"
    return texts | (result.programs(programs, pulses_per_unit=args.station_pulses_per_deg,
                                    speed_percent=args.speed_percent, settle_s=args.settle_s,
                                    procedure=args.procedure, comment=comment) if programs else {})


def _run_cell(args, programs: dict[str, str]) -> int:
    """``poses --model CELL.yaml``: each arm's poses and each positioner's table angles."""
    import numpy as np

    from robocal.campaign import plan_cell
    from robocal.campaign.programs import refuse_tracks, write_campaign
    from robocal.core.errors import DataError
    from robocal.kinematics.workcell import load_cell

    if args.html or args.candidates or args.region or args.region_box or args.curve or args.check:
        raise DataError("--model plans a cell from generated candidates: --html, --from, --region, "
                        "--region-box, --curve and --check are for one arm (--robot)")
    cell = load_cell(args.model)
    if cell.arms:
        refuse_tracks(programs, next(iter(cell.arms.values())), args.output)
    n_table = args.poses if args.table_poses is None else args.table_poses
    nests = {name: np.array(args.nest_mm) * 1e-3 for name, p in cell.positioners.items()
             if p.nests is None and args.nest_mm}
    smr = {name: np.array(args.smr_mm) * 1e-3 for name in cell.arms} if args.smr_mm else None
    park = {name: np.deg2rad(args.park_deg) for name in cell.arms} if args.park_deg else None
    result = plan_cell(cell, {name: args.poses for name in cell.arms},
                       {name: n_table for name in cell.positioners}, constraints=_constraints(args), smr=smr,
                       nests=nests, park=park, noise_mm=args.noise_mm, noise_model=args.noise_model,
                       criterion=args.criterion, seed=args.seed, starts=args.starts,
                       n_candidates=args.n_candidates, progress=not args.quiet)
    texts = _cell_outputs(args, result, programs)
    write_campaign(texts, programs)
    print(result.summary())
    for path in texts:
        print(f"wrote {path}")
    return 0


def run(args) -> int:
    import numpy as np

    from robocal.campaign import plan_poses, read_candidates
    from robocal.campaign.programs import refuse_tracks, write_campaign
    from robocal.core.errors import DataError
    from robocal.data.measurements import read_joints
    from robocal.deploy.models import check_tool_mm
    from robocal.kinematics.model import load_model

    programs = _programs(args)
    _check_outputs(args, programs)
    for smr in args.smr_mm or []:
        check_tool_mm(smr, f"--smr-mm {','.join(f'{v:g}' for v in smr)}")
    if args.model:
        return _run_cell(args, programs)
    robot = load_model(args.robot)
    params = _params(args, robot)
    refuse_tracks(programs, robot, args.output)
    if args.smr_normal and len(args.smr_normal) != len(args.smr_mm or []):
        raise DataError("give one --smr-normal per --smr-mm")
    if args.region and args.region_box:
        raise DataError("give either --region or --region-box, not both")
    constraints = _constraints(args)
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
    texts = _outputs(args, result, robot, programs)
    write_campaign(texts, programs)
    print(result.summary())
    for path in texts:
        print(f"wrote {path}")
    return 0
