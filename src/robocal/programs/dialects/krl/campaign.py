"""KUKA KRL campaign programs (:mod:`robocal.campaign.programs`): a ``.src`` (``BAS(#INITMOV,0)``,
``BAS(#VEL_PTP, speed)``, then per pose ``PTP XPk``, ``WAIT SEC``, the procedure call) and its
``.dat`` declaring ``DECL AXIS XPk={A1 ..,A6 ..}`` (AXIS, not E6AXIS, so that no external axis moves).
With a positioner (`ExternalAxes`: the external kinematics' axes are the robot's E1..E6, its
machine set up in $config.dat / the machine data) the positions are ``DECL E6AXIS XPk={A1 ..,A6
..,E1 ..,E2 ..}``: each PTP moves the arm and the table together."""

from __future__ import annotations

from robocal.programs.dialects.writing import (
    DEFAULT_PROCEDURE,
    DEFAULT_SETTLE_S,
    DEFAULT_SPEED_PERCENT,
    DEGREE_DECIMALS,
    EXTERNAL_LETTERS,
    ExternalAxes,
    checked_external,
    checked_joints,
    comment_lines,
    fixed_point,
    identifier,
)

KRL_NAME_MAX = 24


def krl_program(joints_deg, name: str = "robocal_campaign", *, speed_percent: float = DEFAULT_SPEED_PERCENT,
                settle_s: float = DEFAULT_SETTLE_S, procedure: str = DEFAULT_PROCEDURE,
                comment: str = "", external: ExternalAxes | None = None) -> tuple[str, str]:
    """KUKA KRL ``(.src text, .dat text)`` visiting ``joints_deg (N, 6)`` in order, the positioner
    ``external`` with it."""
    q = checked_joints(joints_deg, speed_percent, settle_s, "KRL")
    external = checked_external(external, len(q), "KRL")
    slots = [] if external is None else external.slots(EXTERNAL_LETTERS, "KRL")
    name = identifier(name, "the KRL program name (the file name)", KRL_NAME_MAX)
    procedure = identifier(procedure, "the procedure name", KRL_NAME_MAX)
    head = ["&ACCESS RVP", "&REL 1"]
    src = head + [f"DEF {name}( )"] + [f"  ; {line}" for line in comment_lines(comment, len(q))]
    src += [";FOLD INI", "  BAS (#INITMOV,0 )", ";ENDFOLD",
            f"  BAS (#VEL_PTP,{fixed_point(speed_percent, 3)} )"]
    if external is not None:
        src.append(f"  ; external axes of {external.unit}: " + ", ".join(
            f"{EXTERNAL_LETTERS[j]} ({u})" for j, u in zip(slots, external.units(), strict=True)))
    for k in range(1, len(q) + 1):
        src += [f"  PTP XP{k}", f"  WAIT SEC {fixed_point(settle_s, 3)}", f"  {procedure}({k})"]
    src += ["END", "", f"DEF {procedure}(POSE:IN )", "  INT POSE",
            "  ; trigger the tracker measurement of pose POSE here (e.g. $OUT[...] = TRUE)", "END", ""]
    dat = head + [f"DEFDAT {name}"]
    for k, row in enumerate(q, start=1):
        axes = ",".join(f"A{i + 1} {fixed_point(v, DEGREE_DECIMALS)}" for i, v in enumerate(row))
        if external is None:
            dat.append(f"  DECL AXIS XP{k}={{{axes}}}")
            continue
        ext = sorted(zip(slots, external.values[k - 1], strict=True))
        axes += "".join(f",{EXTERNAL_LETTERS[j]} {fixed_point(v, DEGREE_DECIMALS)}" for j, v in ext)
        dat.append(f"  DECL E6AXIS XP{k}={{{axes}}}")
    dat += ["ENDDAT", ""]
    return "\n".join(src), "\n".join(dat)
