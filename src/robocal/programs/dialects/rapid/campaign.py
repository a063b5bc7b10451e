"""ABB RAPID campaign programs (what they do: :mod:`robocal.campaign.programs`): one module with
``CONST jointtarget`` data, ``PROC main()`` (``VelSet`` to the speed percentage, then ``MoveAbsJ ...
fine, tool0``, ``WaitTime``, the procedure call per pose) and the procedure ``PROC name(num pose)``;
external axes are 9E9 (none). With a positioner (`ExternalAxes`), its values go in the
jointtargets' ``extax`` at its logical axes (``eax_a``..``eax_f``, the others 9E9), its mechanical
unit is activated (``ActUnit STN1``) before the first move and deactivated after the last, so each
``MoveAbsJ`` moves the arm and the table together (one task; a unit of another task is driven by
that task's own program)."""

from __future__ import annotations

import numpy as np

from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    DEGREE_DECIMALS,
    ExternalAxes,
    checked_external,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

RAPID_NAME_MAX = 32
RAPID_EXTAX = ("eax_a", "eax_b", "eax_c", "eax_d", "eax_e", "eax_f")  # a jointtarget's extax fields
UNUSED_AXIS = "9E9"


def rapid_module(joints_deg, name: str = "RobocalCampaign", *, speed_percent: float = DEFAULT_SPEED_PERCENT,
                 settle_s: float = DEFAULT_SETTLE_S, procedure: str = DEFAULT_PROCEDURE,
                 comment: str = "", external: ExternalAxes | None = None) -> str:
    """ABB RAPID program module visiting ``joints_deg (N, 6)`` in order, the positioner
    ``external`` with it (see module docstring)."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "RAPID")
    external = checked_external(external, len(q), "RAPID")
    extax = np.full((len(q), len(RAPID_EXTAX)), np.nan)
    if external is not None:
        extax[:, external.slots(RAPID_EXTAX, "RAPID")] = external.values
    name = identifier(name, "the RAPID module name", RAPID_NAME_MAX)
    procedure = identifier(procedure, "the procedure name", RAPID_NAME_MAX)
    lines = [f"MODULE {name}"]
    lines += [f"    ! {line}" for line in comment_lines(comment, len(q))]
    for k, row in enumerate(q, start=1):
        values = ",".join(fixed_point(v, DEGREE_DECIMALS) for v in row)
        axes = ",".join(UNUSED_AXIS if np.isnan(v) else fixed_point(v, DEGREE_DECIMALS) for v in extax[k - 1])
        lines.append(f"    CONST jointtarget jt{k} := [[{values}],[{axes}]];")
    lines += ["", "    PROC main()", f"        VelSet {fixed_point(speed_percent, 3)}, 5000;"]
    if external is not None:
        lines.append(f"        ActUnit {identifier(external.unit, 'the mechanical unit', RAPID_NAME_MAX)};")
    for k in range(1, len(q) + 1):
        lines += [f"        MoveAbsJ jt{k}\\NoEOffs, v1000, fine, tool0;",
                  f"        WaitTime {fixed_point(settle_s, 3)};", f"        {procedure} {k};"]
    if external is not None:
        lines.append(f"        DeactUnit {external.unit};")
    lines += ["    ENDPROC", "", f"    PROC {procedure}(num pose)",
              "        ! trigger the tracker measurement here (e.g. SetDO, a socket message)",
              '        TPWrite "robocal: measure pose "\\Num:=pose;', "    ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
