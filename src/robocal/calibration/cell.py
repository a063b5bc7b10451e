"""Calibration of a work cell: one ordinary calibration per body, in one tracker frame.

Every SMR sits on one body (an arm's flange or a positioner's plate), so a body's parameters are
seen only by its own rows: the calibration problem of a cell is block-diagonal, and calibrating a
cell IS calibrating each body on its rows (`rc.calibrate`: registration, priors, identifiability,
robust rejection, uncertainty), all in the one tracker frame. No stacked solver: the relation
between bodies (a positioner's base seen from the arm's base) follows from both bases being
identified in that frame, and its uncertainty from both bases' covariances.

A positioner's plate rows:

- with ``nests:`` declared (SMR k in nest k, at a known place in the plate frame): the rows are
  ``nest`` observations (`robocal.identify.observations.nest`): the plate frame's six parameters
  are seen through the nests and identified with the axes; the turn axis' zero and the plate's
  rotation about that axis are one freedom the nests fix together (the plate frame at every table
  angle is identified);
- without nests: each SMR's place on the plate is unknown and estimated (SMR offsets on the last
  axis' frame, as a flange's); the last axis' zero (and its offset along the axis) is confounded
  with them: held at nominal, and the plate frame is the nominal one on the calibrated last axis.
  The result says so.

The calibrated cell is put in the controller's world by `robocal.kinematics.workcell.Cell.in_world`
(the anchor's identified frame {0} is where the controller believes its base is).
"""

from __future__ import annotations

import datetime
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError, IdentificationError, RobocalError
from robocal.core.io import write_all
from robocal.core.version import __version__
from robocal.core.yaml_load import dump_yaml
from robocal.data.cell_measurements import CellMeasurements
from robocal.data.measurements import Measurements
from robocal.data.registration import REGISTRATION_DEGENERATE, turns_about_one_axis, umeyama
from robocal.kinematics.positioner import nests_in_last_frame, with_positioner_priors
from robocal.kinematics.transforms import invert_transform, matrix_to_rotvec

if TYPE_CHECKING:  # annotations only
    from robocal.kinematics.workcell import Cell

CELL_RESULT_FORMAT = "robocal-cell-calibration/1"
BASE = tuple(f"base.{f}" for f in ("x", "y", "z", "rx", "ry", "rz"))
# With nests, the plate's turn about the last axis and its offset along it (tool.rz, tool.z: flange
# axes) are the last joint's zero and offset (theta_n, d_n) over again: those carry them (the turn
# axis' zero is then the figure a user masters), the plate keeps its nominal turn and height.
PLATE_HELD = ("tool.rz", "tool.z")
# A nest whose mean residual (plate frame) exceeds this many standard errors and this size (mm) is
# not where the cell file declares it (checked after the fit: the warning names it)
NEST_MISMATCH_SIGMAS = 5.0
NEST_MISMATCH_MM = 0.02
# Nests whose distances from their best line are all below this (m) are on one line (or at one point):
# the plate frame's turn about that line is not fixed by them
NEST_LINE_M = 1e-3
RELATION_STEP = 1e-7  # m / rad: the central-difference step of the relation's derivative by the bases


@dataclass(frozen=True)
class Relation:
    """A body's base seen from the anchor's base (both identified in the tracker frame).

    ``transform`` (4, 4) m: anchor frame {0} -> the body's frame {0}; ``covariance`` (6, 6): of its
    translation (m) and of its rotation (a small rotation vector, rad, about the anchor's axes),
    from both bases' covariances (independent calibrations); ``nominal`` (4, 4) m: the same in the
    cell file (each body's frame {0} is its model's: a positioner's is its first axis' frame, not the
    file's ``mount``), so that the sentence says how far the calibration found it from the file."""

    body: str
    anchor: str
    transform: np.ndarray
    covariance: np.ndarray
    nominal: np.ndarray | None = None

    @property
    def sigma(self) -> np.ndarray:
        """1-sigma of x, y, z (mm) and of the rotation about x, y, z (deg)."""
        s = np.sqrt(np.maximum(np.diag(self.covariance), 0.0))
        return np.r_[s[:3] * 1e3, np.rad2deg(s[3:])]

    def to_dict(self) -> dict:
        rpy = np.rad2deg(Rotation.from_matrix(self.transform[:3, :3]).as_euler("xyz"))
        s = self.sigma
        out = {"body": self.body, "from": self.anchor, "xyz_mm": (self.transform[:3, 3] * 1e3).tolist(),
               "rpy_deg": rpy.tolist(), "sigma_xyz_mm": s[:3].tolist(), "sigma_rotation_deg": s[3:].tolist()}
        if self.nominal is not None:
            off = invert_transform(self.nominal) @ self.transform
            rpy0 = np.rad2deg(Rotation.from_matrix(self.nominal[:3, :3]).as_euler("xyz"))
            out |= {"nominal_xyz_mm": (self.nominal[:3, 3] * 1e3).tolist(), "nominal_rpy_deg": rpy0.tolist(),
                    "off_nominal_mm": float(np.linalg.norm(off[:3, 3]) * 1e3),
                    "off_nominal_deg": float(np.rad2deg(Rotation.from_matrix(off[:3, :3]).magnitude()))}
        return out

    def sentence(self) -> str:
        d = self.to_dict()
        xyz = ", ".join(f"{v:.3f}" for v in d["xyz_mm"])
        rpy = ", ".join(f"{v:.4f}" for v in d["rpy_deg"])
        return (f"{self.body} seen from {self.anchor}: xyz [{xyz}] mm (1 sigma up to "
                f"{max(d['sigma_xyz_mm']):.3f} mm), rpy [{rpy}] deg (1 sigma up to "
                f"{max(d['sigma_rotation_deg']):.4f} deg)" + ("" if self.nominal is None else
                "; the cell file has it at xyz [" + ", ".join(f"{v:.3f}" for v in d["nominal_xyz_mm"])
                + "] mm, rpy [" + ", ".join(f"{v:.4f}" for v in d["nominal_rpy_deg"]) + "] deg, "
                f"{d['off_nominal_mm']:.3f} mm and {d['off_nominal_deg']:.4f} deg away"))


@dataclass(frozen=True)
class PlateSolution:
    """How a positioner's plate was identified: ``mode`` 'nests' or 'estimated SMRs', the sentence
    that says it, and the SMR positions estimated on the plate (``smr_mm``: SMR number -> xyz mm in
    the plate frame; empty with nests)."""

    body: str
    mode: str
    sentence: str
    smr_mm: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"body": self.body, "mode": self.mode, "says": self.sentence,
                "smr_on_plate_mm": {str(k): v for k, v in self.smr_mm.items()}}


def _pooled(parts: list[dict | None]) -> dict | None:
    """RMS (mm) and count pooled over bodies' statistics (``n``, ``rms``), None without any."""
    parts = [p for p in parts if p]
    if not parts:
        return None
    n = sum(p["n"] for p in parts)
    return {"n": n, "rms": float(np.sqrt(sum(p["n"] * p["rms"] ** 2 for p in parts) / n))}


@dataclass(eq=False)
class CellCalibration:
    """The calibration of a work cell (module docstring).

    Attributes
    ----------
    cell : Cell
        The nominal cell.
    results : dict of str to CalibrationResult
        Body name -> its ordinary calibration (in the tracker frame).
    calibrated : Cell
        The calibrated cell in the controller's world (`Cell.in_world`): what `write` saves.
    in_tracker : dict of str to Robot
        Body name -> its calibrated model in the tracker frame (an arm with its nominal tool, a
        positioner with its plate frame).
    relations : list of Relation
        Every other calibrated body's base seen from the anchor's.
    plates : list of PlateSolution
        How each measured positioner's plate was identified.
    warnings : list of str
        Each body's warnings (named), and the cell's.
    provenance : dict
        When and by which version it was made, the cell and the data's names (in the JSON).

    See Also
    --------
    rc.calibrate : The calibration that returns it (for a cell).
    rc.Cell : The cells it holds (nominal and calibrated).
    rc.CalibrationResult : Each body's result.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> mount = np.eye(4)
    >>> mount[0, 3] = 1.5  # the table 1.5 m in front of the arm
    >>> nests = [[0.2, 0, 0], [0, 0.2, 0], [-0.15, -0.15, 0]]  # m, on the plate
    >>> table = rc.Positioner.from_catalog("abb_irbp_a250", "STN1", mount, nests=nests)
    >>> cell = rc.Cell({"arm": rc.Robot.from_catalog("abb_irb2600")}, {"STN1": table})
    >>> sim = rc.simulate_cell(cell, 30, 20, seed=1)
    >>> cal = rc.calibrate(cell, sim.data, nongeometric=None)  # a cell: a CellCalibration
    >>> sorted(cal.results), cal.results["STN1"].after["rms"] < 0.1  # mm
    (['STN1', 'arm'], True)
    """

    cell: object
    results: dict
    calibrated: object
    in_tracker: dict
    relations: list
    plates: list
    warnings: list[str]
    provenance: dict = field(default_factory=dict)

    @property
    def validation(self) -> dict | None:
        """Held-out statistics pooled over the bodies (``n``, ``rms`` mm), None without held-out data."""
        return _pooled([r.validation for r in self.results.values()])

    @property
    def after(self) -> dict:
        """Calibration-set statistics after calibration pooled over the bodies (``n``, ``rms`` mm)."""
        return _pooled([r.after for r in self.results.values()])

    def summary(self) -> str:
        """Per body: before -> after (and held out), the relations, how each plate was identified,
        the warnings.

        Returns
        -------
        str
            The summary text.
        """
        lines = [f"cell {self.cell.name}: {len(self.results)} bod{'y' if len(self.results) == 1 else 'ies'} "
                 "calibrated in one tracker frame (one calibration per body: the rows of each SMR see only "
                 "its body)"]
        for name, r in self.results.items():
            line = f"  {name}: RMS {r.before['rms']:.4f} -> {r.after['rms']:.4f} mm ({r.before['n']} obs)"
            if r.validation:
                line += f", held out {r.validation_before['rms']:.4f} -> {r.validation['rms']:.4f} mm " \
                        f"({r.validation['n']} obs)"
            lines.append(line)
        if (v := self.validation) is not None:
            lines.append(f"  held out, all bodies: RMS {v['rms']:.4f} mm ({v['n']} obs)")
        lines += [f"  {rel.sentence()}" for rel in self.relations]
        lines += [f"  {plate.sentence}" for plate in self.plates]
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The result as plain data (mm, deg): each body's result (docs/result-json.md), the
        relations, the plates, pooled figures and the warnings.

        Returns
        -------
        dict
            The result (JSON-ready).
        """
        return {"format": CELL_RESULT_FORMAT, "robocal_version": __version__, "provenance": self.provenance,
                "cell": self.cell.name, "anchor": self.cell.anchor,
                "bodies": {name: r.to_dict() for name, r in self.results.items()},
                "relations": [rel.to_dict() for rel in self.relations],
                "plates": [p.to_dict() for p in self.plates],
                "after": self.after, "validation": self.validation, "warnings": list(self.warnings)}

    def write(self, output=None, json_path=None, report=None, force: bool = False) -> list[str]:
        """Write the calibrated cell file (``output``, YAML: the cell in the controller's world), the
        result JSON (``json_path``) and each body's HTML report (``report`` ``R.html``: ``R_<body>.html``
        each), together or none (`robocal.core.io.write_all`). ``force`` writes the results of a body
        whose solve did not converge; returns the paths written.

        Parameters
        ----------
        output : str or pathlib.Path, optional
            The calibrated cell file (YAML).
        json_path : str or pathlib.Path, optional
            The result JSON.
        report : str or pathlib.Path, optional
            The HTML report's path, one a body (``R_<body>.html``).
        force : bool, default False
            Write the results of a body whose solve did not converge.

        Returns
        -------
        list of str
            The paths written.
        """
        import json

        from robocal.report.html import render_report

        stalled = [n for n, r in self.results.items() if not r.solver.success]
        if stalled and not force:
            raise IdentificationError(f"the solve of {', '.join(stalled)} did not converge: nothing written "
                                      "(force writes it anyway)")
        outputs = {}
        if output is not None:
            outputs[output] = dump_yaml(self.calibrated.to_dict())
        if json_path is not None:
            outputs[json_path] = json.dumps(self.to_dict(), indent=1, default=float) + "\n"
        if report is not None:
            report = Path(report)
            outputs.update({report.with_name(f"{report.stem}_{name}{report.suffix}"):
                            render_report(r.to_dict()) for name, r in self.results.items()})
        write_all(outputs)
        return [str(p) for p in outputs]


# ---------------------------------------------------------------------------------- the bodies
def _numbered(data: Measurements, smr_numbers: np.ndarray) -> Measurements:
    """``data`` with its SMRs renumbered to their index in ``smr_numbers`` (SMR 0 the first)."""
    missing = np.setdiff1d(data.smr, smr_numbers)
    if missing.size:
        raise DataError(f"{data.label}: SMR {int(missing[0])} of these rows is not among the calibration's "
                        f"plate SMRs {smr_numbers.tolist()}: judge a calibration with the same SMRs")
    return replace(data, smr=np.searchsorted(smr_numbers, data.smr))


def check_declared_nests(data: Measurements, n_nests: int, body: str) -> None:
    """Refuse plate rows ``data`` of positioner ``body`` whose SMR is not one of its ``n_nests``
    declared nests (SMR k sits in nest k, 1-based; SMR 0, the plate's origin, is no nest)."""
    bad = data.smr[(data.smr < 1) | (data.smr > n_nests)]
    if bad.size:
        raise DataError(f"{data.label}: SMR {int(bad[0])} on {body}'s plate is not a declared nest (nests 1.."
                        f"{n_nests}; SMR 0, the plate's origin, is no nest)")


def _nest_rows(data: Measurements, n_nests: int, body: str) -> Measurements:
    """A plate's point rows as nest observations (SMR k in nest k, 1-based)."""
    if data.kind != "point":
        raise DataError(f"{data.label}: the plate of {body} declares nests: its rows must be SMR points "
                        f"(x, y, z), not {data.kind}")
    check_declared_nests(data, n_nests, body)
    return replace(data, kind="nest")


def _registered_on_nests(chain, data: Measurements):
    """``chain`` (its ``smr`` the nests in the plate frame) with its base fitted to the nests'
    rows (a rigid fit: the nests' nominal places on the plate are known)."""
    local = replace(chain, base=np.eye(4), nominal=None).fk(data.joints)
    points = np.einsum("nij,nj->ni", local[:, :3, :3], np.vstack([np.zeros(3), chain.smr])[data.smr]) \
        + local[:, :3, 3]
    return replace(chain, base=umeyama(points, data.points), nominal=None)


@dataclass(frozen=True)
class _Body:
    """What one body's calibration starts from: the model, its rows (and held-out rows) as the
    calibration takes them, the free parameters and whether the frames are registered."""

    robot: object
    data: Measurements
    validation: Measurements | None
    params: object
    register: bool
    smr_numbers: np.ndarray | None = None  # estimated plate SMRs: the rows' numbers, in order


def _body(cell, name: str, data: Measurements, validation: Measurements | None, params) -> _Body:
    if name in cell.arms:
        return _Body(cell.arms[name], data, validation, params, True)
    positioner = cell.positioners[name]
    chain = with_positioner_priors(positioner.chain)
    if positioner.nests is not None:
        chain = replace(chain, smr=np.asarray(positioner.nests, float), nominal=None)
        rows = _nest_rows(data, len(chain.smr), name)
        held = None if validation is None else _nest_rows(validation, len(chain.smr), name)
        free = params if not isinstance(params, str) else [
            n for n in chain.default_free(orientation=True)
            if not n.startswith("smr") and n not in PLATE_HELD]
        return _Body(_registered_on_nests(chain, rows), rows, held, free, False)
    numbers = np.unique(data.smr)
    chain = replace(chain, smr=np.zeros((0, 3)), nominal=None)
    held = None if validation is None else _numbered(validation, numbers)
    return _Body(chain, _numbered(data, numbers), held, params, True, numbers)


def _unfixable_plate(cell, name: str, body: _Body, exc: Exception) -> bool:
    """Whether ``exc`` is the registration's refusal of a positioner without nests whose plate turns
    about one axis only (a turntable, a headstock; a slide along its turn axis): the SMRs' unknown
    places leave the frame's turn about that axis free, which no choice of table angles cures."""
    return (name in cell.positioners and body.smr_numbers is not None and isinstance(exc, IdentificationError)
            and REGISTRATION_DEGENERATE in str(exc) and turns_about_one_axis(body.robot))


def _in_tracker(cell, name: str, body: _Body, robot):
    """The calibrated model of a body as the cell carries it: an arm with its nominal tool (the
    measured SMRs off the flange), a positioner with its plate frame (identified with nests, else
    the nominal plate on the calibrated last axis) and its nests as its chain holds them."""
    if name in cell.arms:
        nominal = cell.arms[name]
        return replace(robot, tool=nominal.tool, smr=nominal.smr, nominal=None)
    positioner = cell.positioners[name]
    if positioner.nests is None:
        return replace(robot, tool=positioner.chain.tool, smr=positioner.chain.smr, nominal=None)
    nests = np.asarray(positioner.nests, float)
    return replace(robot, smr=nests_in_last_frame(robot, nests), nominal=None)


def _plate(cell, name: str, body: _Body, result) -> PlateSolution:
    """How the plate of positioner ``name`` was identified, in words (module docstring)."""
    positioner = cell.positioners[name]
    chain, said = positioner.chain, positioner.identifiability
    zero = chain.joint_params[-1]
    ident = result.identifiability
    held = [p for p in (zero, f"d{chain.n_joints}") if p in ident.dropped or p in ident.undetermined]
    if body.smr_numbers is None:
        nests = positioner.nests
        centred = nests - nests.mean(axis=0)
        spread = np.linalg.svd(centred, compute_uv=False)[1] / np.sqrt(len(nests)) if len(nests) > 1 else 0.0
        if spread < NEST_LINE_M:
            free = [p for p in ident.dropped + ident.undetermined if p.startswith("tool.") or p == zero]
            return PlateSolution(
                name, "nests", f"positioner {chain.name}: its {len(nests)} nest(s) lie on one line or at one "
                "point: they leave the plate frame's turn about that line free; held at nominal by these "
                f"data: {', '.join(free) or 'nothing'}: a work object on the plate is only as good as "
                "those; declare at least 3 nests not on one line")
        if zero in held and chain.n_joints == 1:  # the mount's turn about the axis is the same freedom
            return PlateSolution(
                name, "nests", f"positioner {chain.name}: SMR nests at known plate positions fix the plate "
                f"frame on its one axis, whose zero ({zero}) and the mount's turn about that axis are one "
                f"freedom (the mount is identified with it): {zero} is held at nominal "
                f"({len(body.robot.smr)} nests)")
        if zero in held:
            return PlateSolution(name, "nests", f"{said}, but these data do not determine {zero}: it is held "
                                 f"at nominal ({len(body.robot.smr)} nests; measure more table angles)")
        sigma = dict(zip(result.unknowns, result.sigma, strict=True))[zero]
        shown = chain.joints[-1].shown(np.array([result.robot.get(zero) - chain.get(zero), sigma]))
        return PlateSolution(name, "nests", f"{said}: {zero} {shown[0]:+.4f} +- {shown[1]:.4f} "
                             f"{chain.joints[-1].unit} from nominal ({len(body.robot.smr)} nests)")
    tool = result.robot.tool
    offsets = np.vstack([tool[:3, 3], result.robot.smr])  # SMR offsets on the last axis' frame
    on_plate = (offsets - chain.tool[:3, 3]) @ chain.tool[:3, :3]
    smr_mm = {int(s): (on_plate[k] * 1e3).round(4).tolist() for k, s in enumerate(body.smr_numbers)}
    return PlateSolution(
        name, "estimated SMRs",
        f"{said} ({', '.join(held) or 'nothing'} held by these data); the plate frame is the nominal one on "
        "the calibrated last axis: a work object on the plate is only as good as that axis' mastering; the "
        f"places of its {len(body.smr_numbers)} SMR(s) on the plate are in the result", smr_mm)


def _nest_shape(name: str, body: _Body, result) -> list[str]:
    """A warning when the nests' measured places on the plate differ from the declared ones: each
    nest's mean residual in the plate frame beyond `NEST_MISMATCH_SIGMAS` standard errors and
    `NEST_MISMATCH_MM` (a wrong ``nests:`` entry: the fit spreads it over the plate frame, the rest
    stays at that nest)."""
    fitted = result.problem.datasets[0]  # the rows fitted (a hold-out keeps the others apart)
    r = result.problem.item_error_vectors(result.state)[0]  # (N, 3) measured - modelled, m
    R = result.robot.fk(fitted.joints)[:, :3, :3]  # the plate's orientation at each row
    local = np.einsum("nji,nj->ni", R, r)
    nests = fitted.smr
    counts = np.bincount(nests, minlength=len(body.robot.smr) + 1)[1:]
    means = np.array([local[nests == k + 1].mean(axis=0) if counts[k] else np.zeros(3)
                      for k in range(len(counts))])
    noise = float(np.sqrt(np.mean(r**2)))
    size = np.linalg.norm(means, axis=1)
    bad = np.flatnonzero((size > NEST_MISMATCH_SIGMAS * noise / np.sqrt(np.maximum(counts, 1)))
                         & (size > NEST_MISMATCH_MM * 1e-3) & (counts > 0))
    if not bad.size:
        return []
    worst = int(bad[np.argmax(size[bad])])
    beyond = ", ".join(str(k + 1) for k in bad)
    return [f"{name}: the nests' measured places on the plate differ from the declared ones (nest "
            f"{worst + 1} by {size[worst] * 1e3:.3f} mm on average; nests {beyond} beyond the noise): check "
            "the cell file's nests: (and that SMR k sat in nest k); the plate frame fitted to them is off "
            "accordingly"]


def _base_jacobian(anchor, body, which: int) -> np.ndarray:
    """d(relation)/d(base.* of the anchor (``which`` 0) or of the body (1)) ``(6, 6)``: the
    relation's translation (m) and rotation vector (rad) by central differences."""
    rel0 = invert_transform(anchor.base) @ body.base
    out = np.zeros((6, 6))
    for j, name in enumerate(BASE):
        cols = []
        for h in (RELATION_STEP, -RELATION_STEP):
            a = anchor.displaced([name], np.array([h])) if which == 0 else anchor
            b = body.displaced([name], np.array([h])) if which == 1 else body
            rel = invert_transform(a.base) @ b.base
            cols.append(np.r_[rel[:3, 3] - rel0[:3, 3], matrix_to_rotvec(rel[:3, :3] @ rel0[:3, :3].T)])
        out[:, j] = (cols[0] - cols[1]) / (2 * RELATION_STEP)
    return out


def _base_covariance(result) -> np.ndarray:
    """The covariance ``(6, 6)`` of a calibration's base parameters (0 where one was not estimated)."""
    names = list(result.unknowns)
    cov = np.zeros((6, 6))
    held = np.array([n in names for n in BASE])
    idx = [names.index(n) for n in BASE if n in names]
    cov[np.ix_(held, held)] = result.covariance[np.ix_(idx, idx)]
    return cov


def _relation(cell, name: str, models: dict, results: dict) -> Relation:
    anchor_name = cell.anchor
    a, b = models[anchor_name], models[name]
    Ja, Jb = _base_jacobian(a, b, 0), _base_jacobian(a, b, 1)
    cov = Ja @ _base_covariance(results[anchor_name]) @ Ja.T + Jb @ _base_covariance(results[name]) @ Jb.T
    nominal = invert_transform(cell.body(anchor_name).base) @ cell.body(name).base
    return Relation(name, anchor_name, invert_transform(a.base) @ b.base, cov, nominal)


def _as_cell_data(cell, data, what: str) -> CellMeasurements | None:
    if data is None or isinstance(data, CellMeasurements):
        return data
    if isinstance(data, Measurements):
        return CellMeasurements.from_bodies(cell, {cell.anchor: data})
    raise DataError(f"the {what} data of a cell must be CellMeasurements (rc.CellMeasurements.load(path, "
                    f"cell)), got {type(data).__name__}")


def calibrate_cell(cell: Cell, data: CellMeasurements | Measurements, calibrate_body: Callable, *,
                   params="auto", validation: CellMeasurements | None = None, **options) -> CellCalibration:
    """Calibrate a work cell: each body on its rows with ``calibrate_body`` (`rc.calibrate`), then
    the relations to the anchor and the calibrated cell in the controller's world.

    Parameters
    ----------
    cell : Cell
        The nominal cell.
    data : CellMeasurements
        The rows of every body in one tracker frame (a plain Measurements: the anchor's rows).
    calibrate_body : callable
        ``calibrate_body(robot, data, params=, validation=, register_frames=, **options)`` ->
        CalibrationResult: one body's calibration.
    params : 'auto', 'all' or list of str
        Each body's free parameters (names apply to every body).
    validation : CellMeasurements, optional
        Held-out rows of the same campaign (the same tracker frame and SMRs).
    **options
        Passed to every body's calibration (method, seed, force, nongeometric, ...).

    Returns
    -------
    CellCalibration

    Raises
    ------
    DataError
        No rows on the anchor (its frame ties the tracker to the world), plate rows that are not
        the declared nests, held-out rows with other SMRs.
    """
    data = _as_cell_data(cell, data, "calibration")
    validation = _as_cell_data(cell, validation, "validation")
    if cell.anchor not in data.bodies:
        raise DataError(f"the data have no rows on the anchor {cell.anchor!r}: its identified frame ties the "
                        "tracker frame to the controller's world; measure SMRs on it too")
    results, models, plates, warnings = {}, {}, [], []
    for name, rows in data.bodies.items():
        held = None if validation is None else validation.bodies.get(name)
        body = _body(cell, name, rows, held, params)
        try:
            result = calibrate_body(body.robot, body.data, params=body.params, validation=body.validation,
                                    register_frames=body.register, **options)
        except RobocalError as exc:  # which body, and for nests what to check first
            if _unfixable_plate(cell, name, body, exc):
                raise IdentificationError(
                    f"{name}: SMRs at unknown places on a plate that turns about one axis only cannot fix "
                    "its frame (its turn about that axis and its shift along it are free): declare the "
                    "nests' plate positions in the cell file (nests:)") from None
            hint = " (its nests: is SMR k in nest k, and are the cell file's nests: where they are?)" \
                if body.smr_numbers is None and name in cell.positioners else ""
            raise type(exc)(f"{name}{hint}: {exc}") from None
        results[name] = result
        models[name] = _in_tracker(cell, name, body, result.robot)
        warnings += [f"{name}: {w}" for w in result.warnings]
        if name in cell.positioners and body.smr_numbers is None:
            warnings += _nest_shape(name, body, result)
        if name in cell.positioners:
            plates.append(_plate(cell, name, body, result))
    missing = [b for b in cell.bodies if b not in data.bodies]
    if missing:
        warnings.append(f"no rows on {', '.join(missing)}: kept nominal in the calibrated cell (its place in "
                        "the world is the cell file's, not measured)")
    relations = [_relation(cell, n, models, results) for n in models if n != cell.anchor]
    return CellCalibration(
        cell=cell, results=results, calibrated=cell.in_world(models), in_tracker=models, relations=relations,
        plates=plates, warnings=warnings,
        provenance={"created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                    "robocal_version": __version__, "cell": cell.name, "data": data.label,
                    "validation": None if validation is None else validation.label})
