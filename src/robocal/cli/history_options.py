"""``--history PATH_OR_URL --robot-id ID``: the options that record a command's result in a robot's
history (:mod:`robocal.history.store`), shared by calibrate, check and evaluate; calibrate's
``--offsets-only --start``."""

from __future__ import annotations

HISTORY_HELP = ("record the result in this history: a SQLite file (created if missing) or a "
                "postgresql:// URL; needs --robot-id. The outputs are written as files all the same")


def add_history_options(p, history_help: str = HISTORY_HELP) -> None:
    p.add_argument("--history", metavar="PATH_OR_URL", help=history_help)
    p.add_argument("--robot-id", metavar="ID", help="the robot's id in the history (e.g. its serial number)")


def check_history_options(args, existing: bool = False) -> None:
    """Both options or neither; the robot id's form; the history opens (its schema created or
    migrated) before any work is done; ``existing``: a SQLite history must exist already (it holds
    what the command reads)."""
    from pathlib import Path

    from robocal.core.errors import DataError
    from robocal.history.store import History, check_robot_id, is_postgres

    if bool(args.history) != bool(args.robot_id):
        raise DataError("--history and --robot-id go together: give both to record in a robot's history")
    if args.history and existing and not is_postgres(args.history) and not Path(args.history).is_file():
        raise DataError(f"the history {args.history} does not exist")
    if args.history:
        args.robot_id = check_robot_id(args.robot_id)
        History(args.history).close()


def record_evaluation(args, robot, summary: dict, files: list[tuple[str, str]]) -> int:
    """Record an evaluation of ``robot`` (``summary``: its statistics, mm) as derived from the
    calibration of the same model when the history holds one."""
    from robocal.core.errors import DataError
    from robocal.history.record import fingerprints
    from robocal.history.store import History, Record
    from robocal.kinematics.model_file import dump_model

    model_yaml = dump_model(robot)
    with History(args.history) as history:
        try:
            parent = history.calibration(args.robot_id, model_yaml).id
        except DataError:  # a model calibrated elsewhere, or a nominal one: no parent
            parent = None
    return record(args, Record(robot_id=args.robot_id, kind="evaluation", model_yaml=model_yaml,
                               summary=summary, data=fingerprints(files), parent=parent))


def offsets_start(args):
    """The start model of ``--offsets-only --start`` (None without them); the options that cannot go
    with it refused."""
    from robocal.core.errors import DataError
    from robocal.kinematics.model import load_model

    if bool(args.offsets_only) != bool(args.start):
        raise DataError("--offsets-only and --start go together: the joint zeros of the calibrated model "
                        "--start are re-identified")
    if not args.offsets_only:
        return None
    if args.params != "auto" or args.nongeometric.strip().lower() != "default":
        raise DataError("--offsets-only chooses its own parameters: drop --params and --nongeometric")
    return load_model(args.start)


def start_record(args, start) -> int | None:
    """The history's record of the calibration ``start`` came from (None when it holds none)."""
    from robocal.core.errors import DataError
    from robocal.history.store import History
    from robocal.kinematics.model_file import dump_model

    with History(args.history) as history:
        try:
            return history.calibration(args.robot_id, dump_model(start)).id
        except DataError:
            return None


def record(args, entry) -> int:
    """Store ``entry`` in ``args.history`` and say so; its id."""
    from robocal.history.store import History, shown

    with History(args.history) as history:
        ident = history.record(entry)
    if not args.quiet:
        print(f"recorded {entry.kind} #{ident} of robot {entry.robot_id!r} in {shown(args.history)}")
    return ident
