"""ABB RAPID campaign programs (what they do: :mod:`robocal.campaign.programs`): one module with
``CONST jointtarget`` data, ``PROC main()`` (``VelSet`` to the speed percentage, then ``MoveAbsJ ...
fine, tool0``, ``WaitTime``, the procedure call per pose) and the procedure ``PROC name(num pose)``;
external axes are 9E9 (none)."""

from __future__ import annotations

from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    DEGREE_DECIMALS,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

RAPID_NAME_MAX = 32


def rapid_module(joints_deg, name: str = "RobocalCampaign", *, speed_percent: float = DEFAULT_SPEED_PERCENT,
                 settle_s: float = DEFAULT_SETTLE_S, procedure: str = DEFAULT_PROCEDURE,
                 comment: str = "") -> str:
    """ABB RAPID program module visiting ``joints_deg (N, 6)`` in order (see module docstring)."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "RAPID")
    name = identifier(name, "the RAPID module name", RAPID_NAME_MAX)
    procedure = identifier(procedure, "the procedure name", RAPID_NAME_MAX)
    lines = [f"MODULE {name}"]
    lines += [f"    ! {line}" for line in comment_lines(comment, len(q))]
    for k, row in enumerate(q, start=1):
        values = ",".join(fixed_point(v, DEGREE_DECIMALS) for v in row)
        lines.append(f"    CONST jointtarget jt{k} := [[{values}],[9E9,9E9,9E9,9E9,9E9,9E9]];")
    lines += ["", "    PROC main()", f"        VelSet {fixed_point(speed_percent, 3)}, 5000;"]
    for k in range(1, len(q) + 1):
        lines += [f"        MoveAbsJ jt{k}\\NoEOffs, v1000, fine, tool0;",
                  f"        WaitTime {fixed_point(settle_s, 3)};", f"        {procedure} {k};"]
    lines += ["    ENDPROC", "", f"    PROC {procedure}(num pose)",
              "        ! trigger the tracker measurement here (e.g. SetDO, a socket message)",
              '        TPWrite "robocal: measure pose "\\Num:=pose;', "    ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
