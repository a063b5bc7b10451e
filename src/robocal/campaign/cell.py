"""``rc.plan_cell``: the measurement campaign of a work cell (issue 45).

A cell's bodies are measured in one tracker frame, each SMR on one body, so each body's parameters
are seen only by its own rows (the calibration is one ordinary calibration per body): the campaign
is planned per body. Each arm's poses as `robocal.plan_poses` plans them (the tracker in the world
frame, the arm's base its place in the world), each positioner's table angles as
`robocal.campaign.positioner.plan_table` plans them (the nests on its plate, the tracker's line of
sight to them). The measuring order visits every arm's poses, then every positioner's angles; while
one body is measured the others stand still: an arm at its park joints (default: where its last
planned pose left it, so the program adds no motion of its own; an arm not measured at its zero
joints clipped to its limits; give ``park`` to put it elsewhere), a positioner at its rest values
(default zero) while the arms are measured. With the tracker's ``arm_radius_m``, a nest whose beam
passes within that radius of a parked arm (its axis lines, frames {0}..{n} and the TCP) is not
seen.

The planned file (``CellCampaignResult.poses_csv``) is one measurement CSV of the cell without the
readings (API45 "Measurements of a cell"): a ``body`` column, the arms' joint columns (each row the
joints of the arm its body names, or of the anchor arm parked), the positioners' columns (the
table's values: planned on its rows, at rest on the others) and ``visible_smrK``: which SMRs the
tracker sees (an arm's SMR k; a positioner's nest k is SMR k, 1-based, SMR 0 its plate origin).
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from robocal.campaign.constraints import Constraints
from robocal.campaign.planner import CampaignResult, check_plan_numbers, plan_poses
from robocal.campaign.positioner import TablePlan, plan_table
from robocal.campaign.programs import DEGREE_DECIMALS, campaign_programs, fixed_point
from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.core.version import __version__
from robocal.identify import vocabulary
from robocal.programs.dialects.writing import ExternalAxes

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

FORMAT = "robocal-cell-campaign/1"


@dataclass
class CellCampaignResult:
    """A cell's planned campaign: each arm's `CampaignResult`, each positioner's `TablePlan`.

    Attributes
    ----------
    cell : Cell
        The nominal cell planned for.
    arms : dict of str to CampaignResult
        Each measured arm's poses (in the order they are measured).
    tables : dict of str to TablePlan
        Each positioner's table angles.
    park : dict of str to numpy.ndarray
        Each body's joints (rad; m on a prismatic axis) while the others are measured.
    warnings : list of str
        What limits the plan, per body.

    See Also
    --------
    robocal.campaign.plan_cell : The planner that returns it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.campaign import plan_cell
    >>> from robocal.kinematics.positioner import positioner_chain
    >>> axes = [{"type": "revolute", "axis": [1, 0, 0], "origin": [0, 0, 0.9], "limits": [-1.57, 1.57]},
    ...         {"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.25], "limits": [-3.14, 3.14]}]
    >>> mount = np.eye(4); mount[0, 3] = 1.4  # m: the tilt-and-turn table 1.4 m in front of the arm
    >>> table = rc.Positioner(positioner_chain(axes, mount), unit="STN1", external_axes=(2, 3),
    ...                       nests=[[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]])  # m, on the plate
    >>> cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")}, {"STN1": table})
    >>> tracker = rc.Tracker([1.2, 2.8, 2.0], acceptance_deg=45)  # m, world frame
    >>> plan = plan_cell(cell, {"arm": 15}, {"STN1": 12}, constraints=rc.Constraints(tracker=tracker),
    ...                  smr={"arm": [[0.02, -0.03, 0.08]]}, n_candidates=300, table_candidates=300,
    ...                  starts=1)
    >>> plan.poses_csv().splitlines()[0]
    'body,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,e1_deg,e2_deg,visible_smr0,visible_smr1,visible_smr2,visible_smr3'
    >>> len(plan.rows()), "theta2" in plan.tables["STN1"].identifiability.kept  # the turn axis' zero
    (27, True)
    >>> plan.write("poses.csv", programs=plan.programs({"rapid": "Campaign.mod"}))
    ['poses.csv', 'Campaign.mod']
    """

    cell: object
    arms: dict[str, CampaignResult]
    tables: dict[str, TablePlan]
    park: dict[str, np.ndarray]
    warnings: list[str] = field(default_factory=list)

    def rows(self) -> list[tuple[str, int]]:
        """``(body, index)`` of every planned row in measuring order: the arms' poses, then the
        positioners' angles.

        Returns
        -------
        list of tuple of (str, int)
            ``(body, index)`` a row.
        """
        return [(name, i) for name, r in self.arms.items() for i in range(r.n)] + \
            [(name, i) for name, t in self.tables.items() for i in range(t.n)]

    def joints_of(self, body: str) -> np.ndarray:
        """``(R, n)`` the joints of ``body`` (an arm, or a positioner's axes) at every row of
        `rows` (its planned values on its own rows, its park values on the others).

        Parameters
        ----------
        body : str
            An arm or a positioner of the cell.

        Returns
        -------
        numpy.ndarray, shape (R, n)
            Its joints (rad; m for a prismatic joint) at every row.
        """
        if body not in self.park:
            raise DataError(f"no body {body!r} in the cell: {', '.join(self.park)}")
        out = np.tile(self.park[body], (len(self.rows()), 1))
        plan = self.arms.get(body) or self.tables.get(body)
        if plan is not None:
            out[[k for k, (name, _) in enumerate(self.rows()) if name == body]] = plan.joints
        return out

    def columns(self) -> list[tuple[str, list[str]]]:
        """The joint columns: one group per arm joint layout (shared by the arms: each row holds
        the joints of its arm) and per positioner, ``(owner, [column, ...])``.

        Returns
        -------
        list of tuple of (str, list of str)
            ``(owner, [column, ...])`` a group.
        """
        groups: list[tuple[str, list[str]]] = []
        arm_cols: list[str] = []
        for name in self.cell.arms:
            cols = [j.column for j in self.cell.joints(name)]
            if not arm_cols:
                arm_cols = cols
                groups.append(("arms", cols))
            elif cols != arm_cols:
                raise DataError(f"arm {name!r}'s joint columns {cols} differ from {arm_cols}: one planned "
                                "file holds one arm layout")
        groups += [(name, [j.column for j in self.cell.joints(name)]) for name in self.cell.positioners]
        return groups

    def poses_csv(self) -> str:
        """The planned file (module docstring).

        Returns
        -------
        str
            The CSV text.
        """
        rows = self.rows()
        arm_name = next(iter(self.cell.arms), None)
        k = max([r.visible.shape[1] for r in self.arms.values()] +
                [t.visible.shape[1] + 1 for t in self.tables.values()])
        joints = [c for _, cols in self.columns() for c in cols]
        header = ["body", *joints, *(f"visible_smr{i}" for i in range(k))]
        table = np.empty((len(rows), len(header)), dtype=object)
        table[:, 0] = [name for name, _ in rows]
        col = 1
        for owner, cols in self.columns():
            if owner == "arms":
                values = np.vstack([self.arms[name].robot.joints_shown(self.arms[name].joints[i][None])
                                    if name in self.arms else
                                    self.cell.arms[arm_name].joints_shown(self.park[arm_name][None])
                                    for name, i in rows])
            else:
                values = self.cell.positioners[owner].chain.joints_shown(self.joints_of(owner))
            table[:, col:col + len(cols)] = [[fixed_point(v, DEGREE_DECIMALS) for v in r] for r in values]
            col += len(cols)
        seen = np.zeros((len(rows), k), int)
        for r, (name, i) in enumerate(rows):
            if name in self.arms:
                v = self.arms[name].visible[i]
                seen[r, :len(v)] = v
            else:
                v = self.tables[name].visible[i]
                seen[r, 1:1 + len(v)] = v
        table[:, col:] = seen.astype(str)
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(table.tolist())
        return out.getvalue()

    def program_joints(self, arm: str | None = None, positioner: str | None = None
                       ) -> tuple[np.ndarray, ExternalAxes | None]:
        """The joints ``(R, 6)`` rad of ``arm`` (default the anchor) at every row and the
        positioner's values (default the only one) as a program writes them (`ExternalAxes`, its
        axes the positioner's logical ``external_axes``, which each language names): the arm's
        planned poses with the table at rest, then the table's angles with the arm parked.

        Parameters
        ----------
        arm : str, optional
            The arm (default the anchor).
        positioner : str, optional
            The positioner (default the only one).

        Returns
        -------
        tuple of (numpy.ndarray, ExternalAxes or None)
            The arm's joints ``(R, 6)`` (rad) and the positioner's values.
        """
        if not self.cell.arms:
            raise DataError("the cell has no arm: campaign programs drive an arm and its positioner")
        try:
            arm = self.cell.anchor if arm is None else self.cell.pick("arm", arm)
            positioner = self.cell.pick("positioner", positioner, optional=True)
        except DataError as exc:
            raise DataError(f"{exc}: the body the programs drive") from None
        keep = [k for k, (name, _) in enumerate(self.rows()) if name in (arm, positioner)]
        q = self.joints_of(arm)[keep]
        if positioner is None:
            return q, None
        p = self.cell.positioners[positioner]
        return q, ExternalAxes(p.chain.joints_shown(self.joints_of(positioner)[keep]), p.unit,
                               prismatic=tuple(bool(x) for x in p.chain.prismatic),
                               external_axes=p.external_axes)

    def programs(self, programs: dict, *, arm: str | None = None, positioner: str | None = None,
                 pulses_per_unit=None, **options) -> dict[str, str]:
        """The campaign programs (`robocal.campaign.programs.campaign_programs`) driving ``arm``
        and ``positioner`` through the plan (`program_joints`), the positioner's logical external
        axes named as each language names them (`Dialect.positioner_axes`: ``external_axes: [2, 3]``
        is a robtarget's ``eax_b``, ``eax_c``; a motion group's or station's own axes 1..m);
        ``pulses_per_unit``: the positioner's encoder pulses per degree (mm) for INFORM;
        ``options``: speed_percent, settle_s, procedure, comment.

        Parameters
        ----------
        programs : dict of str to str or pathlib.Path
            ``{language key: path to write}``.
        arm, positioner : str, optional
            The bodies the programs drive (defaults as `program_joints`).
        pulses_per_unit : array_like, optional
            The positioner's encoder pulses per unit, for languages that command pulses.
        **options
            ``speed_percent``, ``settle_s``, ``procedure``, ``comment``.

        Returns
        -------
        dict of str to str
            ``{path: program text}``.
        """
        arm = arm or next(iter(self.cell.arms), None)
        q, external = self.program_joints(arm, positioner)
        if external is not None and pulses_per_unit is not None:
            external = replace(external, pulses_per_unit=tuple(float(v) for v in pulses_per_unit))
        return campaign_programs(q, self.cell.arms[arm], programs, external=external, **options)

    def summary(self) -> str:
        """Per body: what is measured, the predicted accuracy and how well its parameters are
        determined.

        Returns
        -------
        str
            The summary text.
        """
        lines = [f"campaign of cell {self.cell.name!r}: {len(self.rows())} rows "
                 f"({', '.join(f'{n} {len([1 for b, _ in self.rows() if b == n])}' for n in self.park)})"]
        for name, r in self.arms.items():
            lines.append(f"arm {name}:")
            lines += ["  " + line for line in r.summary().splitlines()]
        for name, t in self.tables.items():
            lines.append(f"positioner {name} ({self.cell.positioners[name].unit}):")
            lines += ["  " + line for line in t.summary().splitlines()]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Plain data (mm, deg): each body's plan.

        Returns
        -------
        dict
            Each body's plan (JSON-ready).
        """
        return {"format": FORMAT, "robocal_version": __version__, "cell": self.cell.name,
                "arms": {n: r.to_dict() for n, r in self.arms.items()},
                "positioners": {n: t.to_dict() for n, t in self.tables.items()},
                "park_deg": {n: [float(v) for v in self.cell.body(n).joints_shown(q[None])[0]]
                             for n, q in self.park.items()},
                "identifiability": {n: vocabulary.counts(p.identifiability)
                                    for n, p in {**self.arms, **self.tables}.items()},
                "warnings": self.warnings}

    def write(self, csv_path, json_path=None, programs: dict | None = None) -> list[str]:
        """Write the planned file, the JSON of `to_dict` and the program texts ``programs``
        {path: text} (all or none); the paths written.

        Parameters
        ----------
        csv_path : str or pathlib.Path
            The planned file (CSV).
        json_path : str or pathlib.Path, optional
            The campaign JSON.
        programs : dict of str to str, optional
            ``{path: program text}``.

        Returns
        -------
        list of str
            The paths written.
        """
        texts = {csv_path: self.poses_csv()}
        if json_path:
            texts[json_path] = json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"
        texts.update(programs or {})
        write_all(texts)
        return [str(p) for p in texts]


def _rest(robot, given, plan: CampaignResult | None) -> np.ndarray:
    """A body's joints while the others are measured: ``given`` (rad), else an arm's last planned pose,
    else zero clipped to the limits."""
    if given is None and plan is not None:
        return plan.joints[-1]
    if given is None:
        return np.clip(np.zeros(robot.n_joints), robot.limits[:, 0], robot.limits[:, 1])
    q = robot.check_joints(given)[0]
    if not robot.within_limits(q[None])[0]:
        raise DataError(f"the park joints of {robot.name} are outside its limits")
    return q


def _axis_lines(arm, q: np.ndarray) -> np.ndarray:
    """The segments ``(n + 1, 2, 3)`` (m, world) joining the origins of frames {0}..{n} of ``arm`` at
    joints ``q`` and the flange to its TCP: what of a parked arm can block the beam."""
    tcp, frames = arm.fk(q[None], frames=True)
    points = np.concatenate([frames[0, :, :3, 3], tcp[:, :3, 3]])
    return np.stack([points[:-1], points[1:]], axis=1)


def plan_cell(cell: Cell, arm_poses: dict[str, int], table_poses: dict[str, int], *,
              constraints: Constraints | None = None, smr: dict | None = None, nests: dict | None = None,
              park: dict | None = None, noise_mm: float = 0.02, noise_model: str = "isotropic",
              criterion: str = "I", seed: int = 0, starts: int = 4, n_candidates: int = 5000,
              table_candidates: int = 2000, progress=None) -> CellCampaignResult:
    """Plan a cell's campaign: ``arm_poses`` {arm: N} poses of each arm to measure and
    ``table_poses`` {positioner: N} table angle sets of each positioner.

    Parameters
    ----------
    cell : Cell
        The nominal cell (`robocal.load_cell`).
    arm_poses, table_poses : dict of str to int
        The bodies to measure (any label `Cell.resolve` takes) and how many poses / angle sets.
    constraints : Constraints, optional
        The arms' constraints and the tracker (world frame), whose line of sight to the nests
        decides the positioners' angles too.
    smr : dict of str to array_like, optional
        Each arm's SMR positions (k, 3) m on its flange (default: as `robocal.plan_poses`).
    nests : dict of str to array_like, optional
        For a positioner without declared nests: its SMRs' approximate plate positions (K, 3) m
        (each one's position is then estimated). A positioner with declared nests uses them.
    park : dict of str to array_like, optional
        A body's joints (rad) while the others are measured (default: an arm's last planned pose, or
        zero clipped to its limits).
    noise_mm, noise_model, criterion, seed, starts, n_candidates, table_candidates, progress
        As `robocal.plan_poses` (``table_candidates``: the positioners' candidate angle sets).

    Returns
    -------
    CellCampaignResult

    Raises
    ------
    DataError
        A body not in the cell, a positioner with neither declared nests nor ``nests``, or what
        `robocal.plan_poses` / `plan_table` refuse.

    See Also
    --------
    robocal.campaign.CellCampaignResult : What it returns.
    rc.plan_poses : One robot's campaign.
    rc.Cell : The cell planned.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.campaign import plan_cell
    >>> from robocal.kinematics.positioner import positioner_chain
    >>> turn = [{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.8], "limits": [-3.14, 3.14]}]
    >>> nests = [[0.2, 0, 0], [0, 0.2, 0], [-0.2, 0, 0]]  # m, plate frame
    >>> table = rc.Positioner(positioner_chain(turn), unit="STN1", nests=nests)
    >>> tracker = rc.Tracker([0.5, 0.0, 3.0])  # m: above the turntable, its nests face it
    >>> plan = plan_cell(rc.Cell({}, {"STN1": table}), {}, {"STN1": 10},
    ...                  constraints=rc.Constraints(tracker=tracker), table_candidates=300)
    >>> plan.tables["STN1"].n, round(plan.tables["STN1"].predicted_rms_mm, 3) < 0.05  # mm at the nests
    (10, True)
    """
    check_plan_numbers(noise_mm, seed)
    constraints = Constraints() if constraints is None else constraints
    tracker = constraints.tracker
    arms, tables, warnings = {}, {}, []
    resolved_arms = {cell.resolve(k): int(v) for k, v in arm_poses.items()}
    resolved_tables = {cell.resolve(k): int(v) for k, v in table_poses.items()}
    for name in resolved_arms:
        if name not in cell.arms:
            raise DataError(f"{name!r} is a positioner: plan its table angles (table_poses), not arm poses")
    for name in resolved_tables:
        if name not in cell.positioners:
            raise DataError(f"{name!r} is an arm: plan its poses (arm_poses), not table angles")
    if not resolved_arms and not resolved_tables:
        raise DataError("nothing to plan: give the arms' poses or the positioners' table angles")
    smr = {cell.resolve(k): v for k, v in (smr or {}).items()}
    approximate = {cell.resolve(k): v for k, v in (nests or {}).items()}
    for name, n in resolved_arms.items():
        arms[name] = plan_poses(cell.arms[name], n, constraints=constraints, smr=smr.get(name),
                                noise_mm=noise_mm, noise_model=noise_model, criterion=criterion,
                                seed=seed, starts=starts, n_candidates=n_candidates, progress=progress)
        warnings += [f"arm {name}: {w}" for w in arms[name].warnings]
    park = {cell.resolve(k): v for k, v in (park or {}).items()}
    rests = {name: _rest(cell.body(name), park.get(name), arms.get(name)) for name in cell.bodies}
    obstacles = np.concatenate([_axis_lines(cell.arms[a], rests[a]) for a in cell.arms]) \
        if cell.arms else None
    for name, n in resolved_tables.items():
        p = cell.positioners[name]
        known = p.nests is not None
        if not known and name not in approximate:
            raise DataError(f"positioner {name!r} declares no nests: give its SMRs' approximate plate "
                            "positions (nests) to plan for, or declare them in the cell file")
        tables[name] = plan_table(p.chain, n, nests=p.nests if known else approximate[name],
                                  nests_known=known, tracker=tracker, noise_mm=noise_mm,
                                  noise_model=noise_model, criterion=criterion, seed=seed,
                                  starts=starts, n_candidates=table_candidates, name=name,
                                  obstacles=obstacles)
        warnings += [f"positioner {name}: {w}" for w in tables[name].warnings]
    return CellCampaignResult(cell=cell, arms=arms, tables=tables, park=rests, warnings=warnings)

