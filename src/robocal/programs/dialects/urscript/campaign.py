"""URScript campaign programs (:mod:`robocal.campaign.programs`): a program ``def name(): ... end``
with ``movej([q1, .., q6], a=.., v=..)``, where ``v`` is the speed percentage of pi rad/s (Universal
Robots' joint speed limit) and ``a`` 1.4 rad/s^2, ``sleep`` and the procedure, defined inside the
program."""

from __future__ import annotations

import numpy as np

from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    RADIAN_DECIMALS,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

UR_MAX_JOINT_SPEED = np.pi         # rad/s, Universal Robots' joint speed limit
UR_ACCELERATION = 1.4              # rad/s^2, Polyscope's default joint acceleration
NAME_MAX = 32


def urscript_program(joints_rad, name: str = "robocal_campaign", *,
                     speed_percent: float = DEFAULT_SPEED_PERCENT, settle_s: float = DEFAULT_SETTLE_S,
                     procedure: str = DEFAULT_PROCEDURE, comment: str = "") -> str:
    """URScript program visiting ``joints_rad (N, 6)`` (radians) in order."""
    q = checked_joints(joints_rad, speed_percent, settle_s, "URScript")
    name = identifier(name, "the URScript program name", NAME_MAX)
    procedure = identifier(procedure, "the procedure name", NAME_MAX)
    v = UR_MAX_JOINT_SPEED * speed_percent / 100.0
    lines = [f"def {name}():"] + [f"  # {line}" for line in comment_lines(comment, len(q))]
    lines += [f"  def {procedure}(pose):",
              "    # trigger the tracker measurement here (e.g. set_digital_out)",
              '    textmsg("robocal: measure pose ", pose)', "  end"]
    for k, row in enumerate(q, start=1):
        values = ", ".join(fixed_point(x, RADIAN_DECIMALS) for x in row)
        lines += [f"  movej([{values}], a={fixed_point(UR_ACCELERATION, 3)}, v={fixed_point(v, 4)})",
                  f"  sleep({fixed_point(settle_s, 3)})", f"  {procedure}({k})"]
    lines += ["end", ""]
    return "\n".join(lines)
