"""``--history PATH_OR_URL --robot-id ID``: the options that record a command's result in a robot's
history (:mod:`robocal.history.record`), shared by calibrate, check and evaluate."""

from __future__ import annotations

HISTORY_HELP = ("record the result in this history: a SQLite file (created if missing) or a "
                "postgresql:// URL; needs --robot-id. The outputs are written as files all the same")


def add_history_options(p, history_help: str = HISTORY_HELP) -> None:
    p.add_argument("--history", metavar="PATH_OR_URL", help=history_help)
    p.add_argument("--robot-id", metavar="ID", help="the robot's id in the history (e.g. its serial number)")
