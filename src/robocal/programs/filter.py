"""Filter robot programs through a calibrated model: every Cartesian target is replaced by the
target the controller's nominal model must be given so that the real robot lands where the
program meant.

Per target: the pose the program wants, ``X = frame * pose`` (work object / base / user frame),
with its tool; the flange pose ``F = X * tool^-1``; the nominal controller's joints in the
configuration the target asks for (closed form, the branch and turns its configuration data
select; without configuration data the solution nearest the previous target's joints, as the
controller does); the joints ``q`` that reach ``F`` on the calibrated model (numeric IK seeded
with them); the corrected target ``frame^-1 * F_nominal(q) * tool``, written back in the same
frame and notation. Configuration data are rewritten only when they describe ``q`` worse than
they described the nominal joints, i.e. the correction crossed a configuration boundary (then
a warning).

Frames: the calibrated model's identified frame {0} is the controller's base frame (the nominal
model's base; ``robot_base`` gives the controller's base in the calibrated model's world frame
instead). The calibrated model's tool (the SMR or probe that was measured) is replaced by the
nominal model's flange (``nominal.tool``, ROS-I ``tool0``). The controller computes with the
program's tool data on the nominal flange; the real TCP on the calibrated flange is the tool data
too unless ``tcp`` gives the one identified on the calibrated model (``robocal tool``).
"""

from __future__ import annotations

from dataclasses import fields, replace
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError, ListedError, ModelError
from robocal.core.resources import gc_paused, heap_trimmed
from robocal.data.measurements import robot_reach
from robocal.deploy.compensation import Compensation, check_payload_given, compensate, controller_model
from robocal.deploy.models import robot_base_frame
from robocal.ik import solve as ik_solve
from robocal.ik import solve_all
from robocal.ik.closed_form import has_closed_form
from robocal.ik.controller import JUMP_DEG, nearest_solutions
from robocal.ik.scara import is_scara
from robocal.ik.singularity import SingularityDistance
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform, matrix_to_rotvec
from robocal.programs.config import BRANCH_MISMATCH
from robocal.programs.dialects.base import Dialect
from robocal.programs.edits import FileEdits, monitored, number_edits
from robocal.programs.external import sort_external, unreached_reason
from robocal.programs.given_data import (
    as_frames,
    check_language,
    check_magnitudes,
    unused_conditions,
)
from robocal.programs.load import compensate_by_load, plan_loads
from robocal.programs.model import Program, Target
from robocal.programs.motions import undeclared
from robocal.programs.overrides import frame_levers, override_disagreements
from robocal.programs.positioner import CoordinatedProgram, cell_models
from robocal.programs.registry import capable, dialect_for, program_files
from robocal.programs.result import LISTED, FilterResult, collapse
from robocal.programs.routing import Routing
from robocal.programs.source import ProgramText
from robocal.programs.track import track_program
from robocal.trust.coverage import Prediction, target_warnings
from robocal.trust.output_marker import check_unmarked, check_unmarked_name

CONTROLLER_JOINTS = 6  # the programs the dialects read drive 6-axis arms (a few a SCARA too)
SAME_JOINTS = 1e-6  # rad: two executions of one target with joints this close take the same solution
CHUNK = 5_000  # targets whose IK candidates and numeric IK are computed at once (memory)
SWEEPS = 4  # batched passes of the nearest-to-previous joint search (programs without configuration)
# A real TCP (--tcp) turned more than this from the program's tool data is another tool or a wrong
# --rotation (the 4-point method finds the position only): refused. Moved more: a warning.
TCP_TURN_MAX_DEG = 5.0
TCP_SHIFT_WARN_MM = 10.0


def _configured_joints(dialect, nominal, F, targets, problems):
    """Nominal joints ``(N, 6)`` in each target's configuration (NaN where impossible). The
    candidates are computed ``CHUNK`` targets at a time (all branches and turns of 100,000 targets
    at once would take gigabytes); only those of targets without configuration data are kept,
    for the nearest-previous search."""
    scheme = dialect.scheme
    N = len(targets)
    has = np.array([t.config is not None and t.monitored for t in targets])
    q = np.full((N, nominal.n_joints), np.nan)
    reach, possible = np.zeros(N, bool), np.zeros(N, bool)
    free: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # row without data -> (candidates, valid)
    for s in range(0, N, CHUNK):
        e = min(N, s + CHUNK)
        try:
            cands = solve_all(nominal, F[s:e], extra_turns=True)
        except ModelError as exc:
            raise ModelError(f"{dialect.name} configuration data need the nominal model's closed form: "
                             f"{exc}") from None
        valid = np.isfinite(cands).all(axis=2)
        have = scheme.encode(nominal, np.where(valid[..., None], cands, 0.0))
        want = np.array([t.config if t.config is not None else np.zeros(have.shape[-1], int)
                         for t in targets[s:e]])
        score = np.where(valid, scheme.score(have, want[:, None]), np.iinfo(np.int64).max)
        best = np.argmin(score, axis=1)
        reach[s:e] = valid.any(axis=1)
        possible[s:e] = np.take_along_axis(score, best[:, None], axis=1)[:, 0] < BRANCH_MISMATCH
        sel = np.flatnonzero(has[s:e] & reach[s:e] & possible[s:e])  # the candidate their data select
        q[s + sel] = cands[sel, best[sel]]
        for i in np.flatnonzero(~has[s:e] & reach[s:e]):
            free[s + int(i)] = (cands[i], valid[i])
    for i in np.flatnonzero(~reach):
        problems.append((int(i), "no solution of the nominal model inside the joint limits (out of reach)"))
    for i in np.flatnonzero(has & reach & ~possible):
        problems.append((int(i), scheme.mismatch(nominal, targets[i].config) or f"configuration "
                         f"{scheme.text(targets[i].config)} is not possible for this pose inside the joint "
                         "limits"))
    configured = np.flatnonzero(has & reach & possible)
    # no configuration data: in program order, the candidate nearest the previous target's joints
    last = -1  # the last target without configuration data given joints
    for i in np.flatnonzero(~has & reach):
        k = np.searchsorted(configured, i) - 1
        prev = max(configured[k] if k >= 0 else -1, last)
        cands_i, valid_i = free[int(i)]
        d = np.where(valid_i, np.abs(cands_i - (q[prev] if prev >= 0 else 0.0)).sum(axis=1), np.inf)
        q[i] = cands_i[int(np.argmin(d))]
        last = i
    return q


def _anchors(nominal, N: int, targets, program: Program, warnings) -> np.ndarray:
    """``(N, n)`` joints the robot is at right before target i (a qnear or a joint target; the
    first target: zero joints, with a warning, when the program gives none), NaN rows elsewhere."""
    n = nominal.n_joints
    anchor = np.full((N, n), np.nan)  # joints that come right before target i, if any
    for index, qj in program.joint_targets:
        if index < N:
            anchor[index] = qj
    return _first_anchor(nominal, targets, _qnear(targets, n, anchor), warnings)


def _qnear(targets, n: int, anchor: np.ndarray) -> np.ndarray:
    """``anchor`` with the rows of targets that give a qnear replaced by it."""
    qnear = np.array([t.qnear if t.qnear is not None else np.full(n, np.nan) for t in targets])
    return np.where(np.isfinite(qnear), qnear, anchor)


def _first_anchor(nominal, targets, fixed: np.ndarray, warnings) -> np.ndarray:
    """``fixed`` with zero joints (and a warning) in its first row when the program gives none."""
    if not np.isfinite(fixed[0]).all():
        fixed[0] = np.clip(0.0, nominal.limits[:, 0], nominal.limits[:, 1])
        warnings.append(f"{targets[0].where}: no joint position before the first target: the controller's "
                        "solution is taken as the one nearest zero joints")
    return fixed


def _executions(nominal, targets, program: Program, warnings):
    """``(rows, anchors, via)``: the targets (indices) in the order the controller runs them,
    every execution (:attr:`Program.sequence`; without one, each target once in list order), the
    joints known right before each (NaN rows: none) and the call each execution comes through."""
    n, N = nominal.n_joints, len(targets)
    if not program.sequence:
        return np.arange(N), _anchors(nominal, N, targets, program, warnings), [""] * N
    index = {id(t): i for i, t in enumerate(targets)}
    rows, anchors, via, pending = [], [], [], np.full(n, np.nan)
    for item, call in program.sequence:
        if not isinstance(item, Target):
            pending = np.asarray(item, float)
        elif id(item) in index:
            rows.append(index[id(item)])
            anchors.append(pending)
            via.append(call)
            pending = np.full(n, np.nan)
    rows = np.array(rows, dtype=int)
    fixed = _qnear([targets[i] for i in rows], n, np.array(anchors).reshape(len(rows), n))
    return rows, _first_anchor(nominal, [targets[i] for i in rows], fixed, warnings), via


def _nearest_solutions(nominal, F, targets, program: Program, problems, warnings):
    """The controller's own choice (:func:`robocal.ik.controller.nearest_solutions`): per target
    the closed-form solution of the nominal model nearest the previous joints (or the given qnear
    / joint target), inside the limits, in execution order. A target executed several times
    (a routine called from several places) is corrected for its first execution; a warning names
    the calls where the controller takes another solution for it."""
    rows, fixed, via = _executions(nominal, targets, program, warnings)
    choice = nearest_solutions(nominal, F[rows], fixed[0], fixed, JUMP_DEG)
    first = np.full(len(targets), -1)
    for k in range(len(rows) - 1, -1, -1):
        first[rows[k]] = k
    for k in choice.jumps[first[rows[choice.jumps]] == choice.jumps]:
        warnings.append(f"{targets[rows[k]].where}: the controller's solution nearest the previous joints "
                        f"moves a joint by {np.rad2deg(choice.move[k]):.0f} deg (no nearer solution exists): "
                        "a small change before this target can make the controller take another one; add a "
                        "joint move (or qnear) before it")
    for i in np.flatnonzero(first < 0):  # not in the sequence: NaN (out of reach) as reported below
        problems.append((int(i), "no execution of this target was found"))
    for i in rows[choice.unreachable[first[rows[choice.unreachable]] == choice.unreachable]]:
        problems.append((int(i), "no solution of the nominal model inside the joint limits (out of reach)"))
    q = np.where((first >= 0)[:, None], choice.joints[np.maximum(first, 0)], np.nan)
    for k in np.flatnonzero(first[rows] != np.arange(len(rows))):  # a later execution
        i, k0 = rows[k], first[rows[k]]
        if np.isfinite(choice.joints[k]).all() and np.isfinite(q[i]).all() and \
                np.abs(choice.joints[k] - q[i]).max() > SAME_JOINTS:
            again = f"through the call at {via[k]}" if via[k] else "by a later motion"
            was = f"through {via[k0]}" if via[k0] else "in the main routine"
            moved = np.rad2deg(np.abs(choice.joints[k] - q[i]).max())
            warnings.append(f"{targets[i].where}: executed again {again}, coming from other joints, "
                            f"where the controller takes another solution ({moved:.0f} deg away in a "
                            f"joint) than at its first execution ({was}): it is corrected for the first; "
                            "declare a copy of the target for each call")
    return q


def _nearest_joints(nominal, F, targets, program: Program, problems, warnings):
    """Nominal joints nearest the previous target's (or the given qnear / joint target), by
    numeric IK (a nominal model without a closed form).

    Batched sweeps seed every target with its predecessor's solution of the sweep before; then
    one pass in program order re-solves, from its predecessor's final joints, each target whose
    solution is not within ``JUMP_DEG`` of them (a sweep can settle on another branch)."""
    N = F.shape[0]
    fixed = _anchors(nominal, N, targets, program, warnings)
    given = np.isfinite(fixed).all(axis=1)
    seeds = fixed[np.maximum.accumulate(np.where(given, np.arange(N), 0))]  # the last known joints
    for _ in range(SWEEPS):
        res = ik_solve(nominal, F, seeds)
        new = np.where(given[:, None], fixed, np.vstack([fixed[:1], res.joints[:-1]]))
        if np.allclose(new, seeds, atol=1e-9):
            break
        seeds = new
    q, converged = res.joints.copy(), res.converged.copy()
    jump = np.zeros(N)
    limit = np.deg2rad(JUMP_DEG)
    for i in range(N):  # in program order: each target from its predecessor's final joints
        ref = fixed[i] if given[i] else q[i - 1]
        jump[i] = np.abs(q[i] - ref).max()
        if converged[i] and jump[i] <= limit:
            continue
        one = ik_solve(nominal, F[i:i + 1], ref[None])
        if one.converged[0] or not converged[i]:
            q[i], converged[i] = one.joints[0], one.converged[0]
            jump[i] = np.abs(q[i] - ref).max()
    for i in np.flatnonzero(converged & (jump > limit)):
        warnings.append(f"{targets[i].where}: the controller's solution is {np.rad2deg(jump[i]):.0f} deg "
                        "away from the previous joints in one joint: it may take another solution than "
                        "assumed here; add a joint move (or qnear) before this target")
    inside = nominal.within_limits(q)
    for i in np.flatnonzero(~converged | ~inside):
        problems.append((int(i), "the nominal controller has no solution near the previous joints inside "
                                 "the limits (out of reach)"))
        q[i] = np.nan
    return q


def controller_joints(dialect: Dialect, program: Program, targets: list[Target], nominal: Robot,
                      F: np.ndarray, problems: list, warnings: list) -> np.ndarray:
    """The nominal controller's joints ``(N, n)`` (rad) for flange poses ``F`` of ``targets``:
    in the configuration their data select, else nearest the previous joints (among the closed-form
    solutions where the nominal model has a closed form, as the controller does). Targets without
    a solution are NaN and appended to ``problems`` as ``(index, why)``."""
    if dialect.scheme is not None and any(t.config is not None for t in targets):
        return _configured_joints(dialect, nominal, F, targets, problems)
    if has_closed_form(nominal):
        return _nearest_solutions(nominal, F, targets, program, problems, warnings)
    return _nearest_joints(nominal, F, targets, program, problems, warnings)


def target_poses(dialect: Dialect, program: Program, targets: list[Target]):
    """``(values, P, W, tool)``: the pose numbers as written ``(N, k)``; target poses in their
    frames, the frames and the tools, each ``(N, 4, 4)`` m."""
    values = np.array([[float(n.text) for n in t.numbers] for t in targets], dtype=float)
    W = np.array([program.frames[t.frame] for t in targets])
    tool = np.array([program.tools[t.tool] for t in targets])
    return values, dialect.to_pose(values), W, tool


@heap_trimmed  # outermost: after the parse's objects are freed
@gc_paused
def filter_program(programs, calibrated: Robot, nominal: Robot, *, tools=None, frames=None, tcp=None,
                   robot_base=None, dialect: str | None = None, references=(),
                   keep_unreached: bool = False, strict: bool = False, force: bool = False,
                   position_registers: str | Path | None = None, payload=None,
                   temperature: float | None = None, payload_schedules=None,
                   prediction: Prediction | None = None, arm: str | None = None,
                   fixed_base: bool = False, runtime_correction: bool = False) -> FilterResult:
    """Filter robot program file(s) through ``calibrated`` (see the module docstring).

    ``programs``: one path or several (a KUKA .src with its .dat); ``references``: files read
    for their tool / frame declarations only (KUKA $config.dat, ABB modules declaring
    tooldata / wobjdata), never written. ``tools`` / ``frames``: name -> 4x4 (m) or text in the
    program's pose notation (``dialect.frame_help``), completing or overriding what the files
    declare: the tools as the controller knows them. ``tcp``: tool name -> 4x4 (m), the real TCP
    identified on the calibrated model (``robocal tool``), used with the calibrated flange
    instead of the controller's tool data. ``robot_base``: the controller's base frame (4x4, m,
    or text x,y,z,rx,ry,rz in mm and deg, its magnitudes checked) in the calibrated model's world
    frame (default: the calibrated frame {0} is the controller's base). Targets that cannot be
    corrected (out of reach, out of the joint limits, a configuration they cannot have, not
    converged) raise DataError naming each one; with
    ``keep_unreached`` they are left unchanged with a warning. A motion to a name declared in none
    of the files given is named (its record says the declaration it needs); with ``strict`` the
    run is refused instead. ``position_registers``: a FANUC position register file
    (`robocal.programs.dialects.fanuc.registers`): motions to those registers are corrected and the file's
    corrected copy is one of the outputs. Nothing is written here: see `FilterResult.write`, which
    marks the files with the calibrated model's fingerprint (`robocal.trust.output_marker`); a
    marked input (already filtered) raises DataError naming the earlier run unless ``force``.

    Parameters
    ----------
    programs : str, path-like or sequence of them
        The program file(s): ABB RAPID (.mod, .prg), KUKA KRL (a .src with its .dat), FANUC TP
        (.ls), URScript (.script), Yaskawa INFORM (.JBI, VAR.DAT) or a Staubli VAL3 application
        folder.
    calibrated : Robot or Cell
        The calibrated model; with a nominal cell, the calibrated cell (its bodies in the tracker
        frame of its calibration).
    nominal : Robot or Cell
        The controller's nominal model (6 joints, or an arm on a track), or a cell of one arm and
        its positioners: targets in a work object a positioner moves (coordinated motion) are then
        corrected on its plate (`robocal.programs.positioner`).
    tools, frames : dict of str to array_like, shape (4, 4), or str, optional
        Name -> transform (metres) or text in the program's pose notation, completing or
        overriding the tools / frames the files declare (the tools as the controller knows them).
    tcp : dict of str to array_like, shape (4, 4), optional
        Tool name -> the real TCP identified on the calibrated model (`robocal.identify_tcp`),
        metres.
    robot_base : array_like, shape (4, 4), optional
        The controller's base frame in the calibrated model's world frame, metres.
    dialect : {'rapid', 'krl', 'fanuc', 'urscript', 'inform', 'val3'}, optional
        The program language (default: from the files' suffixes, see `dialect_for`).
    references : sequence of path-like
        Files read only for their tool / frame / load declarations (a KUKA $config.dat, RAPID
        system modules, a Yaskawa TOOL.CND or UFRAME.CND), never written; a FANUC backup's
        POSREG.VA: the registers motions move to are corrected and delivered as the TP
        program ``PR_CAL.LS`` (an output keyed by that path, beside the .VA,
        `robocal.programs.dialects.fanuc.posreg`).
    keep_unreached : bool, default False
        Leave the targets that cannot be corrected unchanged, with a warning, instead of failing.
    strict : bool, default False
        Refuse a motion to a name declared in none of the files given, instead of naming it.
    force : bool, default False
        Filter a file robocal already filtered (its marker names the run).
    position_registers : path-like, optional
        A FANUC position register file: motions to those registers are corrected.
    payload : float or array_like, shape (4,), optional
        The payload every target is run with: kg, or kg and the centre of mass x, y, z in the
        flange frame (m), for a model with a payload term (default: each motion with the load the
        program sets before it, `robocal.programs.load`; none set: no payload, with a warning).
    temperature : float, optional
        The arm's temperature every target is run at, deg C, for a model with a thermal term.
    payload_schedules : path-like or dict of int to array_like, shape (4,), optional
        FANUC payload schedules for ``PAYLOAD[n]``: the controller's SYSVARS.VA or a CSV
        (`robocal.programs.read_schedules`), or schedule -> (kg, x, y, z m).
    prediction : robocal.trust.coverage.Prediction, optional
        The calibration's predicted accuracy: a warning names the targets whose predicted error
        exceeds 3 x the validated one (outside the calibrated region).
    arm : str, optional
        With cells: the arm whose program this is (a body name or its unit, ``ROB_2``); default
        the cell's only arm. Each arm's program is filtered with its own model, in the world the
        cell's first arm anchors.
    fixed_base : bool, default False
        No external axis carries the arm: targets with external-axis values in frames no unit
        moves are corrected as arm targets without weighing whether an axis is a track or gantry
        (`robocal.programs.carrier`; by default the targets of an axis that carries the arm, or
        may, are named).
    runtime_correction : bool, default False
        Add a routine in the program's language that corrects targets computed at run time with
        the calibrated model, and route the motions to such targets through it
        (`robocal.programs.runtime`; languages with the ``runtime_correction`` capability; an arm
        alone, without ``tcp``).

    Returns
    -------
    FilterResult
        The filtered files' bytes and the per-target table; `FilterResult.write` writes them.
        Its warnings begin with the ``tools`` / ``frames`` that differ from the program's own
        data of the same name (`robocal.programs.overrides`, every language) and a
        ``payload`` / ``temperature`` the model has no term for.

    Raises
    ------
    DataError
        No file, an unknown dialect, a nominal model without 6 joints, a program moving with a
        mechanical unit the cell does not have or positioner values outside its limits, an
        unknown tool or
        frame, ``tools`` / ``frames`` / ``robot_base`` text whose magnitudes say another unit, a
        ``payload`` above 1.5 times the model's rated payload (``Robot.payload_kg``),
        targets that cannot be corrected (each named), or files without a Cartesian target
        that read as another language than their suffix says.

    See Also
    --------
    rc.FilterResult : What it returns.
    robocal.programs.registry.dialect_for : The language of a program file.
    rc.compensate : Compensate targets given as a table.
    robocal.deploy.models.load_model_pair : The calibrated and nominal models, checked together.

    Examples
    --------
    >>> from pathlib import Path
    >>> import robocal as rc
    >>> target = ("[[1139.82,200.98,722.77],[0.1300295,-0.08641011,0.98767211,0.01137611],[0,0,-1,0],"
    ...           "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]")  # mm, quaternion, configuration
    >>> lines = ["MODULE Cell", f"  CONST robtarget pPick:={target};", "  PROC main()",
    ...          "    MoveJ pPick, v1000, fine, tool0;", "  ENDPROC", "ENDMODULE", ""]
    >>> _ = Path("cell.mod").write_text("\\n".join(lines))
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> real = nominal.with_values({"a2": nominal.get("a2") + 0.0005})  # a link 0.5 mm longer
    >>> result = rc.filter_program("cell.mod", real, nominal)
    >>> [str(p) for p in result.write("cell_cal.mod")]
    ['cell_cal.mod']
    >>> "[[1139.328,200.893,722.77]" in Path("cell_cal.mod").read_text()  # 0.5 mm less reach
    True
    """
    given = [Path(p) for p in ([programs] if isinstance(programs, str | Path) else programs)]
    references = [references] if isinstance(references, str | Path) else list(references)
    calibrated, nominal, coordinated = cell_models(calibrated, nominal, arm)
    if coordinated is not None and robot_base is not None:
        raise DataError("robot_base (--robot-base) is for an arm alone: a cell's world is its anchor arm's "
                        "identified frame {0} (Cell.in_world), where the controller has that arm's base")
    reach = robot_reach(nominal)
    check_magnitudes(given, dialect, tools, frames, reach)
    check_payload_given(payload, calibrated, nominal)
    # a cell's arm is in the controller's world already (Cell.in_world): its calibrated base is kept
    robot_base = np.eye(4) if coordinated is not None else robot_base_frame(robot_base, reach)
    res, program = _filtered(given, calibrated, nominal, tools, frames, tcp, robot_base, dialect,
                                    references, keep_unreached, strict, force, position_registers, payload,
                                    temperature, payload_schedules, coordinated, fixed_base,
                                    Routing(calibrated, nominal, robot_base, fixed_base) if runtime_correction
                                    else None)
    res.warnings[:0] = unused_conditions(calibrated, payload, temperature)
    if prediction is not None and res.joints is not None:
        res.warnings += target_warnings(prediction, calibrated, res.joints)
    if not res.rows:
        check_language(programs, references, dialect)
    d = res.language
    res.warnings[:0] = [*override_disagreements(d, "tool", program.declared_tools, tools, reach),
                        *override_disagreements(d, "frame", program.declared_frames, frames, reach,
                                                frame_levers(d, program) if frames else None)]
    return res


def _filtered(given: list[Path], calibrated: Robot, nominal: Robot, tools, frames, tcp, robot_base,
              dialect: str | None, references: list, keep_unreached: bool, strict: bool, force: bool,
              position_registers, payload, temperature, payload_schedules,
              coordinated: CoordinatedProgram | None, fixed_base: bool = False,
              routing: Routing | None = None) -> tuple[FilterResult, Program]:
    """:func:`filter_program` of the files ``given`` (an application folder among them), without
    the warnings and checks of what the user gave, and the parsed program (its
    `Program.declared_tools` / `Program.declared_frames`, which the ``tools`` / ``frames`` are
    checked against: :mod:`robocal.programs.overrides`); ``routing``:
    the run-time correction (``runtime_correction``), None without."""
    paths = program_files(given)  # an application folder: its files
    if not paths:
        raise DataError("no program file given")
    track = track_program(nominal)  # an arm on a track: programs/track.py
    d = dialect_for(paths, dialect)
    controller = _controller_arm(d, nominal, track)
    sources = [ProgramText(p) for p in paths]
    if position_registers is not None:
        if not d.position_registers:
            vendors = " / ".join(c.vendor for c in capable("position_registers"))
            raise DataError(f"--position-registers is for {vendors} programs, not {d.name}")
        sources.append(ProgramText(position_registers))
    if routing is not None:
        routing.check(d, track is None and coordinated is None, tcp)
    refs = [ProgramText(p) for p in references]
    forced = _check_uncorrected(d, [*sources, *refs], force)
    program = d.parse(sources, as_frames(d, frames), as_frames(d, tools), refs)
    missing = undeclared(program.ledger)
    if strict and missing:
        raise _listed(f"{len(missing)} motion(s) move to names declared in none of the files given:", missing,
                      "give the files that declare them (or --references), or run without --strict to "
                      "name these motions and correct the rest")
    warnings = forced + list(program.warnings)
    if track is not None:
        track.take(program, warnings)
    targets = _filterable(d, program, warnings, coordinated, fixed_arm=track is None, fixed_base=fixed_base)
    if not targets:
        if not program.uncorrected:
            warnings.append("no motion to a Cartesian pose in these files")
        records, outputs = _written(d, program, sources, set(), {}, routing, warnings)
        return FilterResult(d.name, outputs, [], warnings, program.uncorrected, records, language=d), program
    loads = plan_loads(d, program, targets, calibrated, sources, refs, payload, payload_schedules, nominal)
    warnings += loads.warnings
    values, P, W, tool = target_poses(d, program, targets)
    if coordinated is not None:  # frames on a positioner's plate: in the world at each target's values
        W, W_real = coordinated.frames(targets, W)
    X = W @ P
    real_tool = _real_tools(d, tcp, program, targets, warnings)
    problems: list[tuple[int, str]] = []
    F = X @ invert_transform(tool)
    q_nom = controller_joints(d, program, targets, controller, F if track is None else track.in_arm_frame(
        targets, F), problems, warnings)
    ok = np.isfinite(q_nom).all(axis=1)
    warnings += _inexact_configurations(d, controller, targets, q_nom, ok)
    seeds = np.where(ok[:, None], q_nom, 0.0)
    real_model = controller_model(calibrated, nominal, robot_base)
    Xr = (X if coordinated is None else W_real @ P) @ invert_transform(real_tool)

    def run(model: Robot, i: np.ndarray) -> Compensation:  # the targets i at one load
        if track is None:
            return _compensate(model, nominal, Xr[i], seeds[i])
        return track.compensate(model, [targets[k] for k in i], Xr[i], seeds[i])

    comp = compensate_by_load(loads, real_model, temperature, run)
    q, sing = comp.joints, comp.singularity
    warnings += comp.assumed
    _check_joints(controller, comp, ok, problems)
    # external-axis values that may move the arm (no positioner's cell), said in the reason
    loose = None if coordinated is not None else track is None and not fixed_base
    good = _left_unchanged(program, targets, problems, loose, keep_unreached, warnings)
    Pc = np.where(good[:, None, None], invert_transform(W) @ comp.corrected_targets @ tool, P)
    cfg = None
    if d.scheme is not None:
        cfg = (d.scheme.encode(controller, seeds), d.scheme.encode(controller, q))
    edits, changed = number_edits(d, targets, values, good, Pc, cfg, warnings)
    warnings += comp.target_warnings([t.where for t in targets], good)  # corrected ones near a singularity
    corrected = {id(t) for t, ok in zip(targets, good, strict=True) if ok}
    records, outputs = _written(d, program, sources, corrected, edits, routing, warnings)
    # targets a reference holds (FANUC POSREG.VA, INFORM VAR.DAT): the dialect's own file delivers them
    derived = d.reference_outputs(program, refs, {r.path: edits.pop(r.path, FileEdits()).apply(r)
                                                  for r in refs}, set(program.not_corrected))
    outputs.update(derived)
    rows = _rows(d, targets, X, W @ Pc, controller, q, ok, good, comp.converged & ok, changed, cfg, sing)
    return FilterResult(d.name, outputs, rows, warnings, program.uncorrected, records, calibrated,
                        joints=np.where(good[:, None], q, np.nan), loads=loads.lines,
                        data_files=frozenset(s.path for s in sources[len(paths):]),  # the register file
                        derived=frozenset(derived), language=d), program


def _check_uncorrected(d: Dialect, files: list[ProgramText], force: bool) -> list[str]:
    """Refuse (DataError) any of ``files`` (programs, a register file, references: whatever holds
    targets the filter corrects) that robocal already corrected: its marker, or, for a format with
    no comments (an INFORM VAR.DAT), its name (`robocal.trust.output_marker`); with ``force``, the
    warnings naming each one let through."""
    out = []
    for s in files:
        found = check_unmarked(s.text, str(s.path), "filtered", force)
        if found is not None:
            out.append(f"{s.path.name} was already filtered by {found.describe()}: filtered again "
                       "(--force): its corrections are applied twice unless it really is uncorrected")
        elif d.marked_by_name(s) and check_unmarked_name(s.path, "filtered", force):
            out.append(f"{s.path.name} is named as robocal's filtered copy: filtered again (--force)")
    return out


def _left_unchanged(program: Program, targets: list[Target], problems: list[tuple[int, str]],
                    loose: bool | None, keep_unreached: bool, warnings: list) -> np.ndarray:
    """Which ``targets`` are corrected ``(N,)`` bool: not those of ``problems`` (index, why), each
    named in ``program.not_corrected`` and ``warnings`` as left unchanged (the reason saying when
    its external-axis values may move the arm: ``loose``, None: the values are a cell's, not
    said); a ListedError naming them all unless ``keep_unreached``."""
    if loose is not None:
        problems = [(i, unreached_reason(targets[i], why, loose)) for i, why in problems]
    bad = {i for i, _ in problems}
    if problems and not keep_unreached:
        problems.sort()
        raise _listed(f"{len(bad)} target(s) cannot be corrected:",
                      collapse([f"{targets[i].where}: {why}" for i, why in problems]),
                      "nothing was written; fix or remove these targets (or use --keep-unreached to leave "
                      "them unchanged)")
    warnings += [f"{targets[i].where}: left unchanged: {why}" for i, why in sorted(problems)]
    program.not_corrected.update({id(targets[i]): f"left unchanged: {why}" for i, why in problems})
    return np.array([i not in bad for i in range(len(targets))])


def _controller_arm(d: Dialect, nominal: Robot, track) -> Robot:
    """The arm the controller solves for (``nominal``, or the arm of a track's cell ``track``);
    DataError when ``d``'s programs cannot drive it (not a 6-axis arm, nor a SCARA in a language
    whose programs drive one)."""
    scara = is_scara(nominal) and d.scara_programs  # a language whose programs drive a SCARA
    if nominal.n_joints != CONTROLLER_JOINTS and track is None and not scara:
        scara_languages = ", ".join(c.name for c in capable("scara_programs"))
        raise DataError(f"the programs of these controllers drive {CONTROLLER_JOINTS}-axis arms; the nominal "
                        f"model {nominal.name!r} has {nominal.n_joints} joints (an arm on a track: give "
                        "its cell model; a SCARA: its programs are read in "
                        f"{scara_languages} only, Epson SPEL+ is not a language robocal reads)")
    return nominal if track is None else track.arm


def _real_tools(d: Dialect, tcp, program: Program, targets: list[Target], warnings: list) -> np.ndarray:
    """The real TCP of each target ``(N, 4, 4)`` (m): ``tcp`` (tool name -> the TCP identified on
    the calibrated model, ``--tcp``) where it names the target's tool, else its tool data.
    DataError: ``tcp`` names a tool no target uses; checked against the tool data
    (:func:`_check_tcp`, ``warnings`` appended to)."""
    real = {d.name_key(k): v for k, v in (tcp or {}).items()}
    unknown_tcp = sorted(set(real) - {t.tool for t in targets})
    if unknown_tcp:
        raise DataError(f"--tcp names tool(s) {unknown_tcp} that no filtered target uses; the targets use "
                        f"{sorted({t.tool for t in targets})}")
    _check_tcp(real, program.tools, warnings)
    return np.array([np.asarray(real[t.tool], float) if t.tool in real else program.tools[t.tool]
                     for t in targets])


def _written(d: Dialect, program: Program, sources: list[ProgramText], corrected: set[int], edits: dict,
             routing: Routing | None, warnings: list) -> tuple[list, dict]:
    """``(records, outputs)``: every motion's record and each source file's bytes with its
    ``edits`` (path -> :class:`FileEdits`, each popped as its file is written: freed once used),
    its motions computed at run time routed through the routine when ``routing`` is given
    (:meth:`Routing.route`). ``corrected``: ids of the targets corrected offline."""
    records = program.ledger.records(corrected, program.not_corrected)
    if routing is not None:
        return routing.route(d, program, sources, corrected, records, edits, warnings)
    return records, {s.path: edits.pop(s.path, FileEdits()).apply(s) for s in sources}


def _compensate(model: Robot, nominal: Robot, F: np.ndarray, seeds: np.ndarray) -> Compensation:
    """:func:`robocal.deploy.compensation` of flange poses ``F`` ``(N, 4, 4)`` from ``seeds`` ``(N, n)``,
    ``CHUNK`` targets at a time (the numeric IK's arrays for 100,000 poses at once take
    gigabytes); each target's result depends on its own seed only."""
    parts = [compensate(model, nominal, F[s:s + CHUNK], seeds=seeds[s:s + CHUNK])
             for s in range(0, len(F), CHUNK)]
    if len(parts) == 1:
        return parts[0]

    def joined(items: list) -> np.ndarray:
        return np.concatenate(items)

    sing = None if parts[0].singularity is None else SingularityDistance(
        *(joined([getattr(p.singularity, f.name) for p in parts]) for f in fields(SingularityDistance)))
    return replace(parts[0], joints=joined([p.joints for p in parts]),
                   corrected_targets=joined([p.corrected_targets for p in parts]),
                   converged=joined([p.converged for p in parts]),
                   position_error=joined([p.position_error for p in parts]),
                   orientation_error=joined([p.orientation_error for p in parts]), singularity=sing)


def _check_tcp(real: dict, tools: dict, warnings: list) -> None:
    """Refuse a --tcp turned more than TCP_TURN_MAX_DEG from its tool's data; warn when it is more
    than TCP_SHIFT_WARN_MM away."""
    for name, T in real.items():
        data = np.asarray(tools[name], float)
        turn = np.rad2deg(np.linalg.norm(matrix_to_rotvec(T[:3, :3] @ data[:3, :3].T)))
        shift = np.linalg.norm(T[:3, 3] - data[:3, 3]) * 1e3
        if turn > TCP_TURN_MAX_DEG:
            raise DataError(f"--tcp {name} is turned {turn:.1f} deg from the program's tool data {name}: "
                            "the 4-point method finds the position only: give the tool data's orientation "
                            "(robocal tool --rotation, deg) in --tcp")
        if shift > TCP_SHIFT_WARN_MM:
            warnings.append(f"--tcp {name} is {shift:.1f} mm from the program's tool data {name}: check that "
                            "it is the same tool")


def _filterable(d: Dialect, program: Program, warnings: list,
                coordinated: CoordinatedProgram | None = None, fixed_arm: bool = True,
                fixed_base: bool = False) -> list[Target]:
    """The targets to filter: those with a supported tool and frame, all of them known, and
    corrected as arm targets or on a positioner's plate (``coordinated``:
    :mod:`robocal.programs.positioner`) whatever their external-axis values say
    (:func:`robocal.programs.external.sort_external`)."""
    taken = coordinated.take(program, warnings, d) if coordinated is not None else frozenset()
    positioners = frozenset() if coordinated is None else frozenset(
        a for s in coordinated.stations.values() for a in s.axes(d))  # the cell's: no arm on them
    sort_external(program, warnings, taken, fixed_arm, d, fixed_base, positioners,
                  cell=coordinated is not None)
    targets: list[Target] = []
    for t in program.targets:
        why = program.unsupported.get(f"tool:{t.tool}") or program.unsupported.get(f"frame:{t.frame}")
        if why:
            warnings.append(f"{t.where}: not filtered: {why}")
            program.uncorrected.append(f"{t.where}: not filtered: {why}")
            program.not_corrected[id(t)] = f"not filtered: {why}"
        else:
            targets.append(t)
    unknown = [f"{t.where}: unknown {kind} {name!r}" for t in targets
               for kind, name, known in (("tool", t.tool, program.tools), ("frame", t.frame, program.frames))
               if name not in known]
    if unknown:
        raise _listed("unknown tool(s) or frame(s):", collapse(unknown), "declare them in the program or "
                      f"give them with --tool NAME=... / --frame NAME=... ({d.frame_help})")
    return targets


def _listed(headline: str, items: list[str], advice: str) -> DataError:
    """The error naming ``items`` (at most ``LISTED``): one line for one item, else a
    :class:`ListedError` the CLI prints one item a line."""
    if len(items) == 1:
        return DataError(f"{headline} {items[0]}; {advice}")
    more = [f"... and {len(items) - LISTED} more"] if len(items) > LISTED else []
    return ListedError("\n".join([headline, *items[:LISTED], *more, advice]))


def _inexact_configurations(d: Dialect, nominal: Robot, targets: list[Target], q_nom, ok) -> list[str]:
    """Warnings for targets whose configuration data match no solution exactly (a quadrant or
    turn no joint vector inside the limits has): the nearest solution was taken."""
    if d.scheme is None:
        return []
    has = monitored(targets) & ok
    if not has.any():
        return []
    rows = d.scheme.encode(nominal, q_nom[has])
    want = np.array([targets[i].config for i in np.flatnonzero(has)])
    off = np.flatnonzero(has)[d.scheme.score(rows, want) > 0]
    return [f"{targets[i].where}: configuration {d.scheme.text(targets[i].config)} matches no solution "
            f"inside the joint limits; the nearest, {d.scheme.text(d.scheme.encode(nominal, q_nom[i]))}, "
            "was taken" for i in off]


def _check_joints(nominal: Robot, comp: Compensation, ok: np.ndarray, problems: list) -> None:
    """Append the targets the calibrated IK did not reach, or reached outside the limits."""
    q = comp.joints
    converged = comp.converged & ok
    for i in np.flatnonzero(ok & ~converged):
        problems.append((int(i), comp.not_reached(i)))
    inside = nominal.within_limits(q)
    for i in np.flatnonzero(converged & ~inside):
        margin = nominal.joints_shown(np.minimum(q[i] - nominal.limits[:, 0], nominal.limits[:, 1] - q[i]))
        j = int(np.argmin(margin))
        problems.append((int(i), f"the corrected joints leave the limits (joint {j + 1} by "
                                 f"{-margin[j]:.3f} {nominal.joints[j].unit})"))


def _rows(d, targets, X, Xc, nominal, q, ok, good, converged, changed, cfg, sing) -> list[dict]:
    """The per-target table (see docs/programs.md), built from columns (one conversion per column,
    not per value)."""
    dpos = np.linalg.norm(Xc[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    drot = np.rad2deg(np.linalg.norm(matrix_to_rotvec(Xc[:, :3, :3] @ np.swapaxes(X[:, :3, :3], 1, 2)),
                                     axis=1))
    lim = nominal.joints_shown(np.minimum(q - nominal.limits[:, 0], nominal.limits[:, 1] - q))  # deg; mm
    joint = np.argmin(lim, axis=1)
    units = [spec.unit for spec in nominal.joints]
    columns = {} if sing is None else {name: values.tolist() for name, values in sing.columns().items()}
    cols = zip(dpos.tolist(), drot.tolist(), lim[np.arange(len(lim)), joint].tolist(), (joint + 1).tolist(),
               good.tolist(), ok.tolist(), converged.tolist(), changed.tolist(), strict=True)
    rows = []
    for i, (t, (mm, deg, margin, j, g, reached, conv, ch)) in enumerate(zip(targets, cols, strict=True)):
        rows.append({
            "file": t.source.path.name, "line": t.line, "name": t.name, "frame": t.frame, "tool": t.tool,
            "filtered": g, "correction_mm": mm, "correction_deg": deg,
            "configuration": "changed" if ch else ("none" if t.config is None else
                                                   "kept" if t.monitored else "not monitored"),
            "config_before": (d.scheme.text(t.config) if cfg is not None and t.config is not None else
                              d.scheme.text(cfg[0][i]) if cfg is not None and reached else ""),
            "config_after": d.scheme.text(cfg[1][i]) if cfg is not None and g else "",
            "reachable": reached, "converged": conv, "limit_margin_deg": margin, "limit_joint": j,
            "limit_unit": units[j - 1],
            **{name: values[i] for name, values in columns.items()},
        })
    return rows
