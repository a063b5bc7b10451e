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

import csv
import io
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from robocal.compensate import Compensation, compensate, controller_model
from robocal.errors import DataError, ListedError, ModelError
from robocal.ik import solve as ik_solve
from robocal.ik import solve_all
from robocal.ik.closed_form import has_closed_form
from robocal.ik.controller import JUMP_DEG, nearest_solutions
from robocal.io import check_outputs, write_all
from robocal.kinematics.joint_errors import condition_terms
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import invert_transform, matrix_to_rotvec
from robocal.programs.config import BRANCH_MISMATCH
from robocal.programs.fanuc_ls import FanucDialect
from robocal.programs.krl import KRLDialect
from robocal.programs.load import program_load
from robocal.programs.model import Dialect, Program, Target
from robocal.programs.rapid import RapidDialect
from robocal.programs.source import ProgramText, format_number
from robocal.programs.urscript import URScriptDialect

CONTROLLER_JOINTS = 6  # RAPID, KRL, FANUC TP and URScript programs here drive 6-axis arms
SAME_JOINTS = 1e-6  # rad: two executions of one target with joints this close take the same solution
SWEEPS = 4  # batched passes of the nearest-to-previous joint search (programs without configuration)
LISTED = 20  # problems listed in one error message
# A real TCP (--tcp) turned more than this from the program's tool data is another tool or a wrong
# --rotation (the 4-point method finds the position only): refused. Moved more: a warning.
TCP_TURN_MAX_DEG = 5.0
TCP_SHIFT_WARN_MM = 10.0


@dataclass
class FilterResult:
    """``outputs``: input path -> filtered bytes; ``rows``: the per-target table; ``warnings``."""

    dialect: str
    outputs: dict[Path, bytes]
    rows: list[dict]
    warnings: list[str] = field(default_factory=list)
    uncorrected: list[str] = field(default_factory=list)  # motions left as they are (also warnings)

    def table_csv(self) -> str:
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        cols = list(self.rows[0]) if self.rows else ["file", "line", "name"]
        writer.writerow(cols)
        for r in self.rows:
            writer.writerow([f"{r[c]:.6g}" if isinstance(r[c], float) else r[c] for c in cols])
        return out.getvalue()

    def table_json(self) -> str:
        return json.dumps({"dialect": self.dialect, "files": [str(p) for p in self.outputs],
                           "summary": self.summary_dict(), "warnings": self.warnings,
                           "targets": self.rows}, indent=1)

    def summary_dict(self) -> dict:
        rows = [r for r in self.rows if r["filtered"]]
        pos = np.array([r["correction_mm"] for r in rows]) if rows else np.zeros(0)
        rot = np.array([r["correction_deg"] for r in rows]) if rows else np.zeros(0)
        margin = [r["limit_margin_deg"] for r in rows]
        sig = [r["sigma_rel"] for r in rows]
        out = {"targets": len(self.rows), "filtered": len(rows),
               "configuration_changed": sum(r["configuration"] == "changed" for r in rows),
               "correction_mm": {"median": float(np.median(pos)) if pos.size else 0.0,
                                 "max": float(pos.max(initial=0.0))},
               "correction_deg": {"median": float(np.median(rot)) if rot.size else 0.0,
                                  "max": float(rot.max(initial=0.0))},
               "uncorrected_motions": len(self.uncorrected), "warnings": len(self.warnings)}
        if rows:
            i, j = int(np.argmin(margin)), int(np.argmin(sig))
            out["smallest_limit_margin"] = {"name": rows[i]["name"], "deg": margin[i],
                                            "joint": rows[i]["limit_joint"]}
            out["nearest_singularity"] = {"name": rows[j]["name"], "kind": rows[j]["nearest_singularity"],
                                          "sigma_rel": sig[j]}
        return out

    def summary(self) -> str:
        s = self.summary_dict()
        lines = [f"{self.dialect}: {s['filtered']} of {s['targets']} Cartesian target(s) filtered in "
                 f"{', '.join(p.name for p in self.outputs)}"]
        if self.uncorrected:
            lines.append(f"  {len(self.uncorrected)} motion(s) to a Cartesian pose NOT corrected (each "
                         "named in a warning below)")
        if s["filtered"]:
            lines += [f"  correction  median {s['correction_mm']['median']:.3f} mm, max "
                      f"{s['correction_mm']['max']:.3f} mm; orientation median "
                      f"{s['correction_deg']['median']:.4f} deg, max {s['correction_deg']['max']:.4f} deg",
                      f"  configuration changed on {s['configuration_changed']} target(s)",
                      f"  smallest joint-limit margin {s['smallest_limit_margin']['deg']:.2f} deg "
                      f"({s['smallest_limit_margin']['name']}, joint {s['smallest_limit_margin']['joint']})",
                      f"  nearest singularity: {s['nearest_singularity']['name']} "
                      f"({s['nearest_singularity']['kind']}, sigma_rel "
                      f"{s['nearest_singularity']['sigma_rel']:.4f})"]
        shown = collapse(self.warnings)
        for w in shown[:LISTED]:
            lines.append(f"  warning: {w}")
        if len(shown) > LISTED:
            lines.append(f"  ... {len(shown) - LISTED} more warning(s) in the table")
        return "\n".join(lines)

    def write(self, outputs: dict[Path, Path] | Path | str, table: str | Path | None = None) -> list[Path]:
        """Write the filtered files (input path -> output path, or one output path for a single
        input) and the table (``table`` ending .csv or .json: that one; otherwise both
        ``table.csv`` and ``table.json``), all together or none. Refuses to overwrite an input.
        Returns the paths written."""
        if not isinstance(outputs, dict):
            if len(self.outputs) != 1:
                raise DataError("several program files: give one output path per input")
            outputs = {next(iter(self.outputs)): Path(outputs)}
        files: dict[Path, bytes] = {Path(dst): self.outputs[Path(src)] for src, dst in outputs.items()}
        for t in table_paths(table) if table is not None else []:
            files[t] = (self.table_csv() if t.suffix.lower() == ".csv" else self.table_json()).encode()
        check_outputs(files, self.outputs)
        write_all(files)
        return list(files)


_WHERE = re.compile(r"^(\S+:\d+(?: \([^)]*\))?): (.*)$", re.DOTALL)
SHOWN_PLACES = 4  # places named in one collapsed line


def collapse(lines: list[str]) -> list[str]:
    """Messages ``file:line (name): why`` with the same ``why`` collapsed into one line naming the
    first places and how many there are; other messages as they are, in order of first
    appearance."""
    groups: dict[str, list[str]] = {}
    for line in lines:
        m = _WHERE.match(line)
        where, why = (m.group(1), m.group(2)) if m else ("", line)
        groups.setdefault(why, []).append(where)
    out = []
    for why, places in groups.items():
        places = [p for p in places if p]
        if len(places) <= 1:
            out.append(f"{places[0]}: {why}" if places else why)
        else:
            more = f" and {len(places) - SHOWN_PLACES} more" if len(places) > SHOWN_PLACES else ""
            out.append(f"{why} ({len(places)} places: {', '.join(places[:SHOWN_PLACES])}{more})")
    return out


def table_paths(table: str | Path) -> list[Path]:
    """The table file(s) :meth:`FilterResult.write` writes for ``table``: that file when it ends
    .csv or .json, else ``table.csv`` and ``table.json``."""
    t = Path(table)
    if t.suffix.lower() in (".csv", ".json"):
        return [t]
    return [t.with_name(t.name + ".csv"), t.with_name(t.name + ".json")]


def dialect_for(paths: list[Path], name: str | None = None) -> Dialect:
    """The program dialect from ``name`` ('rapid', 'krl', 'fanuc', 'urscript') or the suffixes."""
    dialects = {"rapid": RapidDialect, "krl": KRLDialect, "fanuc": FanucDialect, "urscript": URScriptDialect}
    if name is not None:
        if name not in dialects:
            raise DataError(f"unknown program format {name!r}: use one of {', '.join(dialects)}")
        return dialects[name]()
    found = {key for p in paths for key, d in dialects.items() if p.suffix.lower() in d.suffixes}
    if len(found) != 1:
        known = ", ".join(f"{k}: {' '.join(d.suffixes)}" for k, d in dialects.items())
        raise DataError(f"cannot tell the program format of {[p.name for p in paths]} from the file "
                        f"suffixes ({known}); name it with --format")
    return dialects[found.pop()]()


def as_frames(dialect: Dialect, given) -> dict[str, np.ndarray]:
    """name -> 4x4 (m) from name -> 4x4 or text in the dialect's pose notation."""
    out = {}
    for key, val in (given or {}).items():
        out[str(key)] = dialect.frame_from_text(val) if isinstance(val, str) else np.asarray(val, float)
    return out


def _configured_joints(dialect, nominal, F, targets, problems):
    """Nominal joints ``(N, 6)`` in each target's configuration (NaN where impossible)."""
    scheme = dialect.scheme
    try:
        cands = solve_all(nominal, F, extra_turns=True)
    except ModelError as exc:
        raise ModelError(f"{dialect.name} configuration data need the nominal model's closed form: "
                         f"{exc}") from None
    valid = np.isfinite(cands).all(axis=2)
    have = scheme.encode(nominal, np.where(valid[..., None], cands, 0.0))
    want = np.array([t.config if t.config is not None else np.zeros(have.shape[-1], int) for t in targets])
    score = np.where(valid, scheme.score(have, want[:, None]), np.iinfo(np.int64).max)
    has = np.array([t.config is not None and t.monitored for t in targets])
    reach = valid.any(axis=1)
    for i in np.flatnonzero(~reach):
        problems.append((int(i), "no solution of the nominal model inside the joint limits (out of reach)"))
    q = np.full(F.shape[:1] + (nominal.n_joints,), np.nan)
    best = np.argmin(score, axis=1)
    possible = np.take_along_axis(score, best[:, None], axis=1)[:, 0] < BRANCH_MISMATCH
    for i in np.flatnonzero(has & reach & ~possible):
        problems.append((int(i), f"configuration {scheme.text(targets[i].config)} is not possible for this "
                                 "pose inside the joint limits"))
    configured = np.flatnonzero(has & reach & possible)  # the candidate their data select
    q[configured] = cands[configured, best[configured]]
    # no configuration data: in program order, the candidate nearest the previous target's joints
    last = -1  # the last target without configuration data given joints
    for i in np.flatnonzero(~has & reach):
        k = np.searchsorted(configured, i) - 1
        prev = max(configured[k] if k >= 0 else -1, last)
        d = np.where(valid[i], np.abs(cands[i] - (q[prev] if prev >= 0 else 0.0)).sum(axis=1), np.inf)
        q[i] = cands[i, int(np.argmin(d))]
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
    values = np.array([t.values() for t in targets])
    W = np.array([program.frames[t.frame] for t in targets])
    tool = np.array([program.tools[t.tool] for t in targets])
    return values, dialect.to_pose(values), W, tool


def filter_program(programs, calibrated: Robot, nominal: Robot, *, tools=None, frames=None, tcp=None,
                   robot_base=None, dialect: str | None = None, references=(),
                   keep_unreached: bool = False, payload=None,
                   temperature: float | None = None) -> FilterResult:
    """Filter robot program file(s) through ``calibrated`` (see the module docstring).

    ``programs``: one path or several (a KUKA .src with its .dat); ``references``: files read
    for their tool / frame declarations only (KUKA $config.dat, ABB modules declaring
    tooldata / wobjdata), never written. ``tools`` / ``frames``: name -> 4x4 (m) or text in the
    program's pose notation (``dialect.frame_help``), completing or overriding what the files
    declare: the tools as the controller knows them. ``tcp``: tool name -> 4x4 (m), the real TCP
    identified on the calibrated model (``robocal tool``), used with the calibrated flange
    instead of the controller's tool data. ``robot_base``: the controller's base frame (4x4, m)
    in the calibrated model's world frame (default: the calibrated frame {0} is the controller's
    base). Targets that cannot be corrected (out of reach, out of the joint limits, a
    configuration they cannot have, not converged) raise DataError naming each one; with
    ``keep_unreached`` they are left unchanged with a warning. Nothing is written here: see
    :meth:`FilterResult.write`. ``payload`` (kg, or kg and the centre of mass x, y, z in m in the
    flange frame) and ``temperature`` (deg C): the conditions every target is run at, for a model
    with payload or thermal terms (the defaults such a model assumes without them are warnings).
    """
    paths = [Path(p) for p in ([programs] if isinstance(programs, str | Path) else programs)]
    if not paths:
        raise DataError("no program file given")
    if nominal.n_joints != CONTROLLER_JOINTS:
        raise DataError(f"the programs of these controllers drive {CONTROLLER_JOINTS}-axis arms; the nominal "
                        f"model {nominal.name!r} has {nominal.n_joints} joints")
    d = dialect_for(paths, dialect)
    sources = [ProgramText(p) for p in paths]
    calibrated, load_notes = _with_load(calibrated, d, sources, payload, temperature)
    refs = [ProgramText(p) for p in ([references] if isinstance(references, str | Path) else references)]
    program = d.parse(sources, as_frames(d, frames), as_frames(d, tools), refs)
    warnings = list(program.warnings) + load_notes
    targets = _filterable(d, program, warnings, keep_unreached)
    if not targets:
        if not program.uncorrected:
            warnings.append("no motion to a Cartesian pose in these files")
        return FilterResult(d.name, {s.path: s.data for s in sources}, [], warnings, program.uncorrected)
    values, P, W, tool = target_poses(d, program, targets)
    X = W @ P
    real = {d.name_key(k): v for k, v in (tcp or {}).items()}
    unknown_tcp = sorted(set(real) - {t.tool for t in targets})
    if unknown_tcp:
        raise DataError(f"--tcp names tool(s) {unknown_tcp} that no filtered target uses; the targets use "
                        f"{sorted({t.tool for t in targets})}")
    _check_tcp(real, program.tools, warnings)
    real_tool = np.array([np.asarray(real[t.tool], float) if t.tool in real else program.tools[t.tool]
                          for t in targets])
    problems: list[tuple[int, str]] = []
    q_nom = controller_joints(d, program, targets, nominal, X @ invert_transform(tool), problems, warnings)
    ok = np.isfinite(q_nom).all(axis=1)
    warnings += _inexact_configurations(d, nominal, targets, q_nom, ok)
    comp = compensate(controller_model(calibrated, nominal, robot_base), nominal,
                      X @ invert_transform(real_tool), seeds=np.where(ok[:, None], q_nom, 0.0))
    q, sing = comp.joints, comp.singularity
    warnings += comp.assumed
    _check_joints(nominal, comp, ok, problems)
    bad = {i for i, _ in problems}
    if problems and not keep_unreached:
        problems.sort()
        raise _listed(f"{len(bad)} target(s) cannot be corrected:",
                      collapse([f"{targets[i].where}: {why}" for i, why in problems]),
                      "nothing was written; fix or remove these targets (or use --keep-unreached to leave "
                      "them unchanged)")
    warnings += [f"{targets[i].where}: left unchanged: {why}" for i, why in sorted(problems)]
    good = np.array([i not in bad for i in range(len(targets))])
    Pc = np.where(good[:, None, None], invert_transform(W) @ comp.corrected_targets @ tool, P)
    cfg = None
    if d.scheme is not None:
        cfg = (d.scheme.encode(nominal, np.where(ok[:, None], q_nom, 0.0)), d.scheme.encode(nominal, q))
    edits, changed = _edits(d, targets, values, good, Pc, cfg, warnings)
    warnings += comp.warnings([t.where for t in targets], good)  # the corrected ones near a singularity
    rows = _rows(d, targets, X, W @ Pc, nominal, q, ok, good, comp.converged & ok, changed, cfg, sing)
    outputs = {s.path: s.replaced(edits.get(s.path, {})) for s in sources}
    return FilterResult(d.name, outputs, rows, warnings, program.uncorrected)


def _with_load(calibrated: Robot, dialect: Dialect, sources, payload, temperature) -> tuple[Robot, list[str]]:
    """``calibrated`` at the given payload (else the one load the program sets, if the model has a
    payload term) and temperature, and the warnings on the program's own load."""
    if payload is not None or "payload" not in condition_terms(calibrated):
        return calibrated.with_conditions(payload, temperature), []
    load, why = program_load(dialect, sources)
    if load is None:
        return calibrated.with_conditions(None, temperature), [why] if why else []
    notes = [f"the program's load {load[0]:g} kg, centre of mass {np.round(load[1:] * 1e3, 3).tolist()} mm "
             f"({why}) applied to every motion"]
    return calibrated.with_conditions(load, temperature), notes


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


def _filterable(d: Dialect, program: Program, warnings: list, keep_unreached: bool) -> list[Target]:
    """The targets to filter: those with a supported tool and frame, all of them known, and
    without external axes (refused, or left alone with ``keep_unreached``)."""
    targets: list[Target] = []
    moving = []
    for t in program.targets:
        why = program.unsupported.get(f"tool:{t.tool}") or program.unsupported.get(f"frame:{t.frame}")
        if why:
            warnings.append(f"{t.where}: not filtered: {why}")
            program.uncorrected.append(f"{t.where}: not filtered: {why}")
        elif t.external:
            moving.append(f"{t.where}: external axes {t.external}")
        else:
            targets.append(t)
    if moving and not keep_unreached:
        raise _listed(f"{len(moving)} target(s) carry external-axis values: a track or gantry moving the "
                      "robot, or an axis moving the work, changes where they are, and the filter assumes a "
                      "fixed base and work:", moving,
                      "nothing was written (--keep-unreached leaves them unchanged with a warning)")
    moving = [f"{w}: not corrected: a fixed base and work are assumed" for w in moving]
    warnings += moving
    program.uncorrected += moving
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


def _monitored(targets: list[Target]) -> np.ndarray:
    """Which targets' configuration data the controller follows (they have some, monitored)."""
    return np.array([t.config is not None and t.monitored for t in targets])


def _inexact_configurations(d: Dialect, nominal: Robot, targets: list[Target], q_nom, ok) -> list[str]:
    """Warnings for targets whose configuration data match no solution exactly (a quadrant or
    turn no joint vector inside the limits has): the nearest solution was taken."""
    if d.scheme is None:
        return []
    has = _monitored(targets) & ok
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
        margin = np.rad2deg(np.minimum(q[i] - nominal.limits[:, 0], nominal.limits[:, 1] - q[i]))
        j = int(np.argmin(margin))
        problems.append((int(i), f"the corrected joints leave the limits (joint {j + 1} by "
                                 f"{-margin[j]:.3f} deg)"))


def _edits(d: Dialect, targets: list[Target], old: np.ndarray, good: np.ndarray, Pc: np.ndarray, cfg,
           warnings: list):
    """Span edits per file for the corrected poses ``Pc`` of targets whose numbers were ``old``
    and, where the correction crossed a configuration boundary, the configuration data; and which
    targets' configuration changed. ``cfg``: (rows of the nominal joints, rows of the corrected
    joints) or None."""
    new = d.from_pose(Pc, old)
    resolution = d.resolutions()
    moved = good[:, None] & (np.abs(new - old) > resolution / 2)  # numbers that must be rewritten
    changed = np.zeros(len(targets), bool)
    if cfg is not None:
        has = _monitored(targets)
        want = np.array([t.config if has[i] else cfg[0][i] for i, t in enumerate(targets)])
        # rewritten only when the written data describe the corrected joints worse than the nominal ones
        changed = good & has & (d.scheme.score(cfg[1], want) > d.scheme.score(cfg[0], want))
    finest: dict[tuple[Path, int], int] = {}  # (file, column) -> the file's decimals for shared columns
    for group in d.shared_decimals:
        for t in targets:
            most = max(t.numbers[j].decimals for j in group)
            for j in group:
                key = (t.source.path, j)
                finest[key] = max(finest.get(key, 0), most)
    edits: dict[Path, dict] = {}
    for i in np.flatnonzero(moved.any(axis=1) | changed):
        t = targets[i]
        mine = edits.setdefault(t.source.path, {})
        for j in np.flatnonzero(moved[i]):
            num = t.numbers[j]
            text = format_number(float(new[i, j]), num, float(resolution[j]),
                                 finest.get((t.source.path, int(j)), 0))
            mine.update(_aligned(t.source.text, num, text) if d.keep_width else {(num.start, num.end): text})
        if changed[i]:
            mine.update(d.config_edits(t, cfg[1][i]))
            warnings.append(f"{t.where}: configuration changed from {d.scheme.text(cfg[0][i])} to "
                            f"{d.scheme.text(cfg[1][i])}: the corrected joints cross a configuration "
                            "boundary; check the motion into and out of this target")
    return edits, changed


def _aligned(text: str, num, new: str) -> dict[tuple[int, int], str]:
    """The edit writing ``new`` over number ``num`` of ``text`` in the same width when the number is
    right-aligned after spaces: padded with spaces, or taking spaces before it (one is kept)."""
    if text[num.start - 1:num.start] != " " or len(new) == len(num.text):
        return {(num.start, num.end): new}
    if len(new) < len(num.text):
        return {(num.start, num.end): new.rjust(len(num.text))}
    spaces = len(text[:num.start]) - len(text[:num.start].rstrip(" "))
    take = min(len(new) - len(num.text), spaces - 1)
    return {(num.start - take, num.end): new}


def _rows(d, targets, X, Xc, nominal, q, ok, good, converged, changed, cfg, sing) -> list[dict]:
    """The per-target table (see docs/programs.md)."""
    dpos = np.linalg.norm(Xc[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    drot = np.rad2deg(np.linalg.norm(matrix_to_rotvec(Xc[:, :3, :3] @ np.swapaxes(X[:, :3, :3], 1, 2)),
                                     axis=1))
    lim = np.rad2deg(np.minimum(q - nominal.limits[:, 0], nominal.limits[:, 1] - q))
    columns = sing.columns()
    rows = []
    for i, t in enumerate(targets):
        j = int(np.argmin(lim[i]))
        rows.append({
            "file": t.source.path.name, "line": t.line, "name": t.name, "frame": t.frame, "tool": t.tool,
            "filtered": bool(good[i]),
            "correction_mm": float(dpos[i]), "correction_deg": float(drot[i]),
            "configuration": "changed" if changed[i] else ("none" if t.config is None else
                                                           "kept" if t.monitored else "not monitored"),
            "config_before": (d.scheme.text(t.config) if cfg is not None and t.config is not None else
                              d.scheme.text(cfg[0][i]) if cfg is not None and ok[i] else ""),
            "config_after": d.scheme.text(cfg[1][i]) if cfg is not None and good[i] else "",
            "reachable": bool(ok[i]), "converged": bool(converged[i]),
            "limit_margin_deg": float(lim[i, j]), "limit_joint": j + 1,
            **{name: values[i].item() for name, values in columns.items()},
        })
    return rows
