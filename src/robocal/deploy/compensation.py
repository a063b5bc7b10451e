"""Compensation: make the real robot go where it is told, given a calibrated model.

* corrected joint commands: joints q with T_calibrated(q) = target (numeric IK on the calibrated
  model, seeded by the nominal closed-form solution in the chosen branch);
* corrected Cartesian targets: T_nominal(q) for those joints, for programs written in
  Cartesian space (the controller's own nominal IK then lands on the true target). They are in
  the nominal (controller's) model's own base frame and for its own TCP: what the controller is
  given, whatever frame the targets came in;
* corrected parameters (seed 000, step 8): the identified parameters for a controller that
  accepts them. With eta the nominal link/frame parameters and q the joint zero offsets
  (theta_i), d_eta = eta_nominal - eta_calibrated and d_q = theta_nominal - theta_calibrated, so
  the seed's eta - d_eta and q - d_q are exactly the calibrated values.

Target files: CSV with a header; position ``x_mm, y_mm, z_mm`` (or ``x_m, y_m, z_m``) and
orientation either a unit quaternion ``qw, qx, qy, qz`` or fixed-axis XYZ roll-pitch-yaw
``rx_deg, ry_deg, rz_deg`` (or ``_rad``): R = Rz(rz) Ry(ry) Rx(rx), scipy's ``"xyz"``. For an arm
on a track, ``e1_mm`` (or ``e1_m``) gives each target's carriage position, which the compensation
keeps (the arm's joints reach the target with the track where the program puts it). Lines
starting with ``#`` before the header are comments (a compensated file's provenance marker).
"""

from __future__ import annotations

import csv
import io
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from robocal.core.errors import DataError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, read_text, write_all
from robocal.core.magnitudes import check_degree_set, check_payload, check_radians, check_targets
from robocal.data.measurements import robot_reach
from robocal.deploy.cell import compensate_cell
from robocal.identify.plausibility import (
    MAX_ANGLE_CORRECTION_DEG,
    MAX_LENGTH_CORRECTION_FRACTION,
    MAX_LENGTH_CORRECTION_MM,
)
from robocal.ik.closed_form import has_closed_form, seed_model
from robocal.ik.controller import ControllerChoice, followed_numerically, nearest_solutions
from robocal.ik.numeric import solve as ik_solve
from robocal.ik.opw_ik import check_poses
from robocal.ik.singularity import SingularityDistance, singularity_distance
from robocal.ik.track import solve as track_solve
from robocal.kinematics.cell import is_track_cell
from robocal.kinematics.joint_errors import condition_terms, condition_warnings
from robocal.kinematics.model import Robot
from robocal.kinematics.transforms import ROTATION_TOL, invert_transform, make_transform, pose_error
from robocal.kinematics.workcell import Cell
from robocal.trust.coverage import Prediction, target_warnings
from robocal.trust.output_marker import check_unmarked, mark_csv

MAX_TARGET_WARNINGS = 20  # targets not reached or near a singularity named in ``warnings``


@dataclass(frozen=True)
class Compensation:
    """``joints`` ``(N, n)`` rad for the controller; ``corrected_targets`` ``(N, 4, 4)`` m;
    ``converged`` ``(N,)``; ``position_error`` ``(N,)`` m / ``orientation_error`` ``(N,)`` rad
    left on the calibrated model; ``parameters``: rows (name, unit, nominal, calibrated, delta)
    in SI with delta = nominal - calibrated; ``corrected_model`` the calibrated robot;
    ``singularity``: each target's distance from the singularities at its joints (6-axis arms);
    ``controller``: the nominal controller's own choice of solutions, when seeded from it.

    Returned by `robocal.deploy.compensation`.

    Attributes
    ----------
    joints : numpy.ndarray, shape (N, n)
        The joints to send to the controller, radians.
    corrected_targets : numpy.ndarray, shape (N, 4, 4)
        The poses to program on the nominal controller (its fk of ``joints``), metres.
    converged : numpy.ndarray of bool, shape (N,)
        The calibrated model reaches the target at ``joints`` (1e-10 m, 1e-9 rad).
    position_error, orientation_error : numpy.ndarray, shape (N,)
        What is left on the calibrated model, metres and radians.
    parameters : list of dict
        Name, unit, nominal, calibrated and delta (nominal - calibrated) of each parameter, SI.
    corrected_model : Robot
        The calibrated model used.
    singularity : SingularityDistance or None
        Each target's distance from the singularities at its joints (6-axis arms).
    controller : ControllerChoice or None
        The nominal controller's own choice of solutions, when seeded from ``start``.
    warnings : list of str
        Conditions the model has no term for or assumed, the first `MAX_TARGET_WARNINGS`
        targets not reached or near a singularity, targets outside the calibrated region.
    layout : dict or None
        The targets file's columns (`read_poses_csv`), which `write` keeps (default mm, deg).
    target_shift : numpy.ndarray, shape (N, 6), or None
        How far each corrected target is from the given one (m, rad; `pose_error`), None for
        the calibrated model's own tool (its corrected targets are for another TCP).
    assumed : tuple of str
        The conditions (payload, temperature) assumed by default or beyond the calibrated ones.
    source_model : Robot or None
        The calibrated model as given: its fingerprint marks the written file.

    See Also
    --------
    rc.compensate : The compensation that returns it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> real = nominal.with_values({"d1": nominal.get("d1") + 0.001})  # the base 1 mm taller
    >>> wanted = nominal.fk(np.array([[0.1, 0.2, 0.1, 0.3, 0.4, 0.5]]))
    >>> comp = rc.compensate(real, nominal, wanted)
    >>> shift = (comp.corrected_targets - wanted)[0, :3, 3]  # m
    >>> bool(np.allclose(shift, [0.0, 0.0, -0.001], atol=1e-9))  # program the target 1 mm lower
    True
    >>> comp.warnings  # reached, far from singularities
    []
    """

    joints: np.ndarray
    corrected_targets: np.ndarray
    converged: np.ndarray
    position_error: np.ndarray
    orientation_error: np.ndarray
    parameters: list[dict]
    corrected_model: Robot
    singularity: SingularityDistance | None = None
    controller: ControllerChoice | None = None
    assumed: tuple[str, ...] = ()  # payload / temperature: defaults assumed, or beyond the calibrated ones
    warnings: list[str] = field(default_factory=list)
    layout: dict | None = None
    target_shift: np.ndarray | None = None
    source_model: Robot | None = None  # the calibrated model as given: its fingerprint marks the file

    def summary(self) -> str:
        """How many targets, how far their corrections move them (mm, deg) and the largest residual
        left on the calibrated model (mm).

        Returns
        -------
        str
            The summary text.
        """
        shift = ""
        if self.target_shift is not None:
            mm = np.linalg.norm(self.target_shift[:, :3], axis=1) * 1e3
            deg = np.rad2deg(np.linalg.norm(self.target_shift[:, 3:], axis=1))
            shift = (f": corrections largest {mm.max():.4g} mm, median {np.median(mm):.4g} mm; orientation "
                     f"largest {deg.max():.4g} deg, median {np.median(deg):.4g} deg")
        return (f"compensated {len(self.joints)} target(s){shift}; largest model residual "
                f"{self.position_error.max() * 1e3:.3g} mm")

    def to_dict(self) -> dict:
        """The commands (joints in deg or mm, corrected targets in the targets' units, converged,
        distances from the singularities) as ``{column: list}``, and the warnings.

        Returns
        -------
        dict
            The commands and the warnings (JSON-ready).
        """
        columns, values = self._table()
        return {"columns": {c: values[:, i].tolist() for i, c in enumerate(columns)},
                "warnings": self.warnings}

    def _table(self) -> tuple[list[str], np.ndarray]:
        """The commands CSV's columns and values ``(N, k)`` (objects)."""
        model = self.corrected_model
        layout = self.layout or {"length": "mm", "orientation": "deg"}
        names, values = pose_columns(self.corrected_targets, layout)
        columns = [j.column for j in model.joints] + names + ["converged"]  # a track's e1 (mm) first
        cells = [model.joints_shown(self.joints), values,
                 self.converged[:, None].astype(int)]
        if self.singularity is not None:  # how far each target is from a singularity
            sing = self.singularity.columns()
            columns += list(sing)
            cells += [np.column_stack(list(sing.values()))]
        return columns, np.concatenate([np.asarray(c, dtype=object) for c in cells], axis=1)

    def write(self, output, parameters=None) -> list[str]:
        """Write the commands CSV (``output``, marked with the calibrated model's fingerprint) and
        the corrected-parameter table (``parameters``: name, unit (mm/deg), nominal, calibrated,
        delta), all or none; the paths written.

        Parameters
        ----------
        output : str or pathlib.Path
            The commands CSV.
        parameters : str or pathlib.Path, optional
            The corrected-parameter table (CSV).

        Returns
        -------
        list of str
            The paths written.
        """
        texts = {output: mark_csv(format_csv(*self._table()), self.source_model or self.corrected_model)}
        if parameters:
            lines = ["name,unit,nominal,calibrated,delta"]
            for r in self.parameters:
                k, unit = (1e3, "mm") if r["unit"] == "m" else (180.0 / np.pi, "deg")
                lines.append(",".join([r["name"], unit] + [repr(float(r[key] * k))
                                                          for key in ("nominal", "calibrated", "delta")]))
            texts[parameters] = "\n".join(lines) + "\n"
        write_all(texts)
        return [str(path) for path in texts]

    def target_warnings(self, names: Sequence[str] | None = None,
                        which: np.ndarray | None = None) -> list[str]:
        """One line per target that was not reached or sits close to a singularity, labelled by
        ``names`` (default ``target i``, i from 0); ``which`` ``(N,)`` bool: only those targets.

        Parameters
        ----------
        names : sequence of str, optional
            One label a target.
        which : numpy.ndarray of bool, shape (N,), optional
            The targets to report on (default all).

        Returns
        -------
        list of str
            One line a target not reached or near a singularity.
        """
        out = []
        n = len(self.converged)
        close = np.zeros(n, bool) if self.singularity is None else self.singularity.close
        jumps = np.zeros(n, bool)
        if self.controller is not None:
            jumps[self.controller.jumps] = True
        asked = np.ones(n, bool) if which is None else np.asarray(which, bool)
        named = (~self.converged | close | jumps) & asked
        for i in np.flatnonzero(named):  # only the targets with something to say
            name = f"target {i}" if names is None else names[i]
            if not self.converged[i]:
                out.append(f"{name}: {self.not_reached(i)}: its correction cannot be realised in this "
                           "configuration")
            elif close[i]:
                out.append(f"{name}: close to a singularity, {self.singularity.describe(i)}: the controller "
                           "may not realise its correction")
            if jumps[i]:
                out.append(f"{name}: the controller's solution nearest the previous joints moves a joint "
                           f"by {np.rad2deg(self.controller.move[i]):.0f} deg (no nearer solution exists): "
                           "it may take another solution than assumed here")
        return out

    def not_reached(self, i: int) -> str:
        """Why target ``i`` has no correction (how far the IK stopped, the nearest singularity).

        Parameters
        ----------
        i : int
            The target's index.

        Returns
        -------
        str
            The reason, one line.
        """
        where = "" if self.singularity is None else f"; {self.singularity.describe(i)}"
        n = getattr(self.corrected_model, "n_joints", 6)
        if n < 6:  # its poses are a 5-D set: the calibrated arm's is another one than the nominal's
            where += (f"; a {n}-joint arm reaches {n} of a pose's 6 freedoms: the calibrated arm cannot meet "
                      "every pose the nominal one reaches")
        return f"not reached on the calibrated model (best {self.position_error[i] * 1e3:.3g} mm off){where}"


def check_payload_given(payload, calibrated: Robot, nominal: Robot | None = None) -> None:
    """Refuse a ``payload`` (kg, or kg and its centre of mass; None: none given) heavier than the
    rated payload allows (`robocal.core.magnitudes.check_payload`: lb or g typed as kg): the
    ``calibrated`` model's ``payload_kg``, else the ``nominal`` model's (a calibrated model saved
    without it). One that is not numbers is left to the check that names it
    (`Robot.with_conditions`, the filter's load planner)."""
    if payload is None:
        return
    try:
        mass = float(np.asarray(payload, dtype=float).reshape(-1)[0])
    except (TypeError, ValueError, IndexError):
        return
    check_masses([mass], calibrated, nominal, "--payload")


def check_masses(masses, calibrated: Robot, nominal: Robot | None, option: str) -> None:
    """Refuse ``masses`` (kg) given with ``option`` heavier than the rated payload allows
    (`robocal.core.magnitudes.check_payload`): the ``calibrated`` model's ``payload_kg``, else the
    ``nominal`` model's (a calibrated model saved without it)."""
    robot = calibrated if calibrated.payload_kg is not None or nominal is None else nominal
    check_payload(masses, robot.payload_kg, robot.name, option)


def unused_conditions(robot: Robot, payload=None, temperature: float | None = None) -> list[str]:
    """Warnings for a payload / temperature given to a model without the term that uses it."""
    terms = condition_terms(robot)
    return [f"{option} is not used: the model of {robot.name} has no {term} term"
            for option, term, value in (("--payload", "payload", payload),
                                        ("--temperature", "thermal", temperature))
            if value is not None and term not in terms]


def _check_same_robot(calibrated: Robot, nominal: Robot) -> None:
    """DataError unless both models have the same joint count and links no further apart than a
    calibration moves them (`robocal.identify.plausibility`): another robot, or the same robot
    in another parametrisation (e.g. calibrated from its URDF), whose frame {0} is not the nominal's."""
    if calibrated.n_joints != nominal.n_joints:
        raise DataError(f"calibrated model has {calibrated.n_joints} joints, nominal "
                        f"{nominal.n_joints}: they must describe the same robot")
    k = 5 * nominal.n_joints
    lengths = np.array([u == "m" for u in nominal.parameter_units()[:k]])
    diff = calibrated.values[:k] - nominal.values[:k]
    delta = np.abs(np.where(lengths, diff, np.remainder(diff + np.pi, 2 * np.pi) - np.pi))
    length_limit = max(MAX_LENGTH_CORRECTION_MM * 1e-3,
                       MAX_LENGTH_CORRECTION_FRACTION * robot_reach(nominal))
    limit = np.where(lengths, length_limit, np.deg2rad(MAX_ANGLE_CORRECTION_DEG))
    bad = np.flatnonzero(delta > limit)
    if bad.size:
        i = int(bad[np.argmax(np.where(lengths, delta * 1e3, np.rad2deg(delta))[bad])])
        size = f"{delta[i] * 1e3:.4g} mm" if lengths[i] else f"{np.rad2deg(delta[i]):.4g} deg"
        raise DataError(f"the calibrated model's {nominal.parameter_names[i]} differs from the nominal "
                        f"{nominal.name}'s by {size}, more than a calibration corrects: another robot, or a "
                        "calibration of another parametrisation (calibrate with the controller's model as "
                        "--robot, and give that model as --nominal)")


def parameter_table(calibrated: Robot, nominal: Robot) -> list[dict]:
    """Seed-000 export: every link, base and tool parameter with nominal, calibrated and
    d = nominal - calibrated (SI: m, rad); the controller loads nominal - d."""
    _check_same_robot(calibrated, nominal)
    k = 5 * calibrated.n_joints + 12
    names, units = calibrated.parameter_names[:k], calibrated.parameter_units()[:k]
    cal, nom = calibrated.values[:k], nominal.values[:k]
    return [{"name": nm, "unit": u, "nominal": float(a), "calibrated": float(b), "delta": float(a - b)}
            for nm, u, a, b in zip(names, units, nom, cal, strict=True)]


def controller_model(calibrated: Robot, nominal: Robot, robot_base=None, tool=None) -> Robot:
    """The calibrated model as the controller sees the robot: its identified frame {0} as the
    controller's base (the nominal model's base), or ``robot_base`` (4x4, m: the controller's
    base in the calibrated model's world frame); the measured SMR/probe replaced by the
    nominal flange (``nominal.tool``) carrying ``tool`` (4x4, m, rigid; default none)."""
    _check_same_robot(calibrated, nominal)
    base = nominal.base
    if robot_base is not None:
        base = invert_transform(np.asarray(robot_base, float)) @ calibrated.base
    flange = nominal.tool if tool is None else nominal.tool @ check_poses(tool)[0]
    return calibrated.with_frames(base=base, tool=flange)


def compensate(calibrated: Robot, nominal: Robot, targets, *, branch: int | None = None,
               seeds=None, start=None, targets_frame: str = "model", tool=None, e1=None, payload=None,
               temperature: float | None = None, layout: dict | None = None,
               prediction: Prediction | None = None, positioner_values=None,
               arm: str | None = None) -> Compensation:
    """Corrected joints and Cartesian targets for target poses ``(N, 4, 4)`` (m) of the
    calibrated model's TCP.

    ``targets_frame``: 'model' (default) - the targets are in the calibrated model's world frame
    (after a tracker calibration, the tracker frame); 'robot' - they are in the robot's base frame
    as the controller sees it: the calibrated model is first re-expressed with the nominal
    model's base frame (its identified frame {0} taken as the controller's frame {0}).

    ``tool`` (4x4, m): the user's real tool on the flange; the targets are then poses of that
    TCP, the calibrated flange (its measured SMR/probe replaced by ``nominal.tool``) carries it,
    and the corrected targets are for that tool on the nominal flange.

    ``payload`` (kg, or kg and the centre of mass x, y, z in m in the flange frame) and
    ``temperature`` (deg C): the conditions the targets are run at, for a model with payload or
    thermal terms (`Robot.with_conditions`); without them such a model assumes no payload
    and its reference temperature, said in ``assumed``.

    Seeds: the closed-form solution of ``nominal`` (needs its OPW form) in slot ``branch``
    (None: per target the lowest slot inside the limits, then the next ones where the calibrated
    model has no solution in it), with the calibrated base and tool; or
    explicit ``seeds`` ``(N, n)`` rad; or, with ``start`` ``(n,)`` rad (the joints before the
    first target), the controller's own choice for targets without configuration data: per
    target, in order, the nominal closed-form solution nearest the previous target's joints
    (`robocal.ik.controller.nearest_solutions`; ``controller`` in the result, its large
    joint moves among the warnings). Targets the calibrated model cannot reach to 1e-10 m /
    1e-9 rad are flagged in ``converged`` (their joints are the best found).

    An arm on a track (`robocal.kinematics.cell`) needs ``e1`` ``(N,)`` m, each target's
    carriage position, which stays as given (`robocal.ik.track.solve`; ``seeds`` are then the
    arm's ``(N, 6)``); the joints are ``(N, 7)``, e1 first.

    Parameters
    ----------
    calibrated : Robot
        The calibrated model (`robocal.calibrate`'s ``result.robot``).
    nominal : Robot
        The controller's nominal model.
    targets : array_like, shape (N, 4, 4) or (4, 4)
        Wanted TCP poses, metres, in the frame ``targets_frame`` names.
    branch : int, optional
        The closed-form slot (0-7, see `robocal.ik.solve_all`) of the nominal solution used as
        seed.
    seeds : array_like, shape (N, n), optional
        Explicit seed joints, radians.
    start : array_like, shape (n,), optional
        The joints before the first target, radians: seed each target with the controller's own
        nearest solution.
    targets_frame : {'model', 'robot'}
        The calibrated model's world frame (after a tracker calibration, the tracker frame), or
        the robot's base frame as the controller sees it.
    tool : array_like, shape (4, 4), optional
        The user's real tool on the flange, metres.
    e1 : array_like, shape (N,), optional
        An arm on a track: each target's carriage position, metres (kept as given).
    layout : dict, optional
        The columns of the targets file (`read_targets`), which `Compensation.write` keeps.
    prediction : Prediction, optional
        The calibration's accuracy prediction (`robocal.deploy.models.load_prediction`): warn of
        the targets where its predicted error exceeds 3 x the validated one.
    positioner_values : array_like, shape (N, k), optional
        With ``calibrated`` and ``nominal`` work cells (`robocal.kinematics.workcell.Cell`): the
        targets are TCP poses in the plate frame of the cell's positioner standing at these axis
        values (rad; m for a prismatic axis), reached by its arm (`robocal.deploy.cell`: returns a
        ``CellCompensation``; a cell of several positioners: ``compensate_cell`` names them).
    arm : str, optional
        With work cells of several arms: the arm (body name or unit, ``"ROB_2"``) that reaches the
        targets.
    payload : float or array_like of 4, optional
        The payload the targets are run at: kg, or kg and the centre of mass x, y, z (m, flange frame).
    temperature : float, optional
        The temperature the targets are run at (deg C).

    Returns
    -------
    Compensation
        ``joints`` ``(N, n)`` rad to send to the controller; ``corrected_targets``
        ``(N, 4, 4)`` m, the poses to program on the nominal controller; ``converged`` ``(N,)``;
        ``position_error`` ``(N,)`` m and ``orientation_error`` ``(N,)`` rad left on the
        calibrated model; ``parameters``; ``singularity``; ``controller``; ``warnings``;
        ``summary()``; ``write()``.

    Raises
    ------
    DataError
        Targets that are not rigid transforms, an unknown ``targets_frame``, a ``branch``
        outside 0-7, or more than one of ``branch``, ``seeds`` and ``start``.
    ModelError
        Closed-form seeds asked of a nominal model without an OPW or UR form.

    See Also
    --------
    robocal.deploy.compensation.Compensation : What it returns.
    rc.filter_program : Compensate a robot program.
    rc.ik.solve_all : Every inverse-kinematics solution of a model.
    robocal.deploy.models.load_model_pair : The calibrated and nominal models, checked together.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> real = nominal.with_values({"a2": nominal.get("a2") + 0.0005, "theta3": 0.0004})  # the real arm
    >>> q = np.array([[0.1, 0.2, 0.1, 0.3, 0.4, 0.5], [0.2, 0.1, 0.2, 0.0, 0.6, 0.1]])
    >>> wanted = nominal.fk(q)  # the poses the program asks for, m
    >>> comp = rc.compensate(real, nominal, wanted)
    >>> bool(comp.converged.all())
    True
    >>> bool(np.allclose(real.fk(comp.joints), wanted, atol=1e-9))  # the real arm reaches them
    True
    >>> bool(np.allclose(nominal.fk(comp.joints), comp.corrected_targets))  # what to program
    True
    """
    if isinstance(calibrated, Cell):  # targets on a positioner's plate (robocal.deploy.cell)
        return compensate_cell(calibrated, nominal, targets, positioner_values, compensate, branch=branch,
                               seeds=seeds, start=start, tool=tool, payload=payload, temperature=temperature,
                               prediction=prediction, arm=arm)
    comp = _compensate_arm(calibrated, nominal, targets, branch=branch, seeds=seeds, start=start,
                           targets_frame=targets_frame, tool=tool, e1=e1, payload=payload,
                           temperature=temperature, layout=layout, prediction=prediction)
    hint = targets_frame_hint(comp, calibrated, nominal, targets, targets_frame, branch=branch, tool=tool,
                              e1=e1, payload=payload, temperature=temperature, start=start)
    return comp if hint is None else replace(comp, warnings=[hint, *comp.warnings])


FRAME_TRIALS = 20  # targets not reached tried in the other frame at most (an IK each) ...
FRAME_REACHED_FRACTION = 0.5  # ... of which at least this fraction reached there names the other frame
OTHER_FRAME = {"robot": "model", "model": "robot"}
FRAME_WORDS = {"robot": "the robot's base frame (--targets-in robot; targets_frame='robot')",
               "model": "the calibrated model's world frame, the tracker's (--targets-in model; "
                        "targets_frame='model')"}


def targets_frame_hint(comp: Compensation, calibrated: Robot, nominal: Robot, targets,
                       targets_frame: str, **options) -> str | None:
    """When targets are not reached: the hypothesis that they are in the other frame (the tracker's
    where the robot's base frame was assumed, or the other way), tested by compensating up to
    :data:`FRAME_TRIALS` of the unreached ones in it (``options``: the same branch, tool, carriage
    positions, payload, temperature and start joints); the warning naming the option when at least
    :data:`FRAME_REACHED_FRACTION` of those tried are reached there, None otherwise (or when the
    two frames coincide)."""
    missed = np.flatnonzero(~comp.converged)
    if not missed.size or np.array_equal(calibrated.base, nominal.base):
        return None
    tried = missed[:FRAME_TRIALS]
    e1 = options.pop("e1")
    other = OTHER_FRAME[targets_frame]
    alt = _compensate_arm(calibrated, nominal, check_poses(targets)[tried], targets_frame=other,
                          e1=None if e1 is None else np.asarray(e1)[tried], **options)
    reached = int(alt.converged.sum())
    if reached < FRAME_REACHED_FRACTION * tried.size:
        return None
    return (f"{missed.size} of {len(comp.converged)} target(s) are not reached in "
            f"{FRAME_WORDS[targets_frame]}, but in {FRAME_WORDS[other]} {reached} of the {tried.size} tried "
            "are: the targets look given in that frame; compensate them with --targets-in "
            f"{other}")


def _compensate_arm(calibrated: Robot, nominal: Robot, targets, *, branch, seeds=None, start=None,
                    targets_frame: str, tool, e1, payload, temperature, layout=None,
                    prediction=None) -> Compensation:
    """`compensate` of one arm (a Robot, not a cell), without the other-frame hypothesis."""
    if targets_frame not in ("model", "robot"):
        raise DataError(f"targets_frame must be 'model' or 'robot', got {targets_frame!r}")
    given = calibrated
    check_payload_given(payload, given, nominal)  # lb or g typed as kg
    if targets_frame == "robot":
        calibrated = calibrated.with_frames(base=nominal.base)
    calibrated = calibrated.with_conditions(payload, temperature)
    assumed = tuple(condition_warnings(calibrated))
    parameters = parameter_table(calibrated, nominal)
    model, controller = calibrated, nominal
    if tool is not None:  # robot_base identity: the targets' frame (calibrated, re-expressed for 'robot')
        model = controller_model(calibrated, nominal, np.eye(4), tool)
        controller = nominal.with_frames(tool=model.tool)
    T = check_poses(targets)
    choice = None
    if start is not None:
        if seeds is not None or branch is not None:
            raise DataError("give one of branch, seeds and start (the controller's nearest-solution choice)")
        view = controller.with_frames(base=model.base, tool=model.tool)
        if has_closed_form(seed_model(view)):
            choice = nearest_solutions(view, T, start)
            seeds = choice.joints  # NaN rows (no nominal solution inside the limits): not converged
        else:  # a 5-axis or a redundant arm: the nominal joints followed numerically from start
            seeds = followed_numerically(view, T, start)
    elif seeds is None and not is_track_cell(model) and not any(
            has_closed_form(seed_model(m)) for m in (controller, model.nominal_robot())):
        raise DataError(f"{controller.name} has no closed form to seed each target's solution "
                        f"({controller.n_joints} joints: not an OPW, UR or SCARA chain): give the joints the "
                        "robot is at before the first target (--start, deg; start= in rad), and each target "
                        "is solved numerically from the previous one's joints, as the controller moves")
    if is_track_cell(model):
        if e1 is None or start is not None:
            raise DataError(f"{model.name} is an arm on a track: give each target's carriage position "
                            "(an e1_mm column) and a branch or seeds (not start)")
        res = track_solve(model, T, e1, nominal=controller, branch=branch, seeds=seeds)
    elif e1 is not None:
        raise DataError(f"the targets give e1 (a track) but {model.name} has no track: give the cell model")
    else:
        res = ik_solve(model, T, seeds, branch=branch, nominal=controller)
    sing = singularity_distance(model, res.joints) if model.n_joints == 6 else None
    corrected = controller.fk(res.joints)
    plain = T if targets_frame == "robot" else nominal.base @ invert_transform(given.base) @ T
    comp = Compensation(joints=res.joints, corrected_targets=corrected, converged=res.converged,
                        position_error=res.position_error, orientation_error=res.orientation_error,
                        parameters=parameters, corrected_model=calibrated, singularity=sing,
                        controller=choice, assumed=assumed, layout=layout, source_model=given,
                        target_shift=None if tool is None else pose_error(corrected, plain))
    warnings = [*unused_conditions(given, payload, temperature), *assumed,
                *comp.target_warnings()[:MAX_TARGET_WARNINGS]]
    if prediction is not None:
        warnings += target_warnings(prediction, given, res.joints)
    return replace(comp, warnings=warnings)  # frozen: the warnings read the targets' verdicts above


def read_targets(path, nominal: Robot, origin=(0.0, 0.0, 0.0),
                 force: bool = False) -> tuple[np.ndarray, dict]:
    """Target poses ``(N, 4, 4)`` (m) and the file's layout (`read_poses_csv`) of a targets CSV
    for the controller's model ``nominal`` (its base at ``origin``, m), refused when robocal
    already compensated it (its marker line; ``force`` lets it through) or when its magnitudes
    say another unit than its headers (`check_target_units`)."""
    check_unmarked(read_text(Path(path), "pose CSV file"), path, "compensated", force)
    targets, layout = read_poses_csv(path)
    check_target_units(targets, layout, robot_reach(nominal), path, origin)
    return targets, layout


def _numbers(text: str, count: int, what: str, form: str) -> np.ndarray:
    """``count`` finite comma-separated numbers from ``text``, else DataError saying ``form``."""
    try:
        vals = np.array([float(v) for v in text.replace(" ", "").split(",") if v], dtype=float)
    except ValueError:
        vals = np.zeros(0)
    if vals.size != count or not np.isfinite(vals).all():
        raise DataError(f"{what} {text!r}: expected {form}")
    return vals


def rotation_values(text: str, what: str = "rotation") -> np.ndarray:
    """The three angles ``(3,)`` (deg; fixed-axis XYZ: R = Rz(rz) Ry(ry) Rx(rx)) of a rotation written
    ``rx,ry,rz``, else DataError."""
    return _numbers(text, 3, what, "rx,ry,rz (deg, fixed-axis XYZ)")


def frame_values(text: str, what: str = "frame") -> np.ndarray:
    """The six numbers ``(6,)`` (mm, deg) of a frame written ``x,y,z,rx,ry,rz``, else DataError."""
    return _numbers(text, 6, what, "x,y,z,rx,ry,rz (mm, deg; fixed-axis XYZ)")


def frame_from_values(vals: np.ndarray) -> np.ndarray:
    """``x,y,z,rx,ry,rz`` ``(6,)`` (mm, deg; fixed-axis XYZ: R = Rz(rz) Ry(ry) Rx(rx), as the
    targets' ``rx_deg..`` columns) -> 4x4 (m)."""
    return make_transform(Rotation.from_euler("xyz", vals[3:], degrees=True).as_matrix(), vals[:3] * 1e-3)


def frame_from_text(text: str, what: str = "frame") -> np.ndarray:
    """A frame written ``x,y,z,rx,ry,rz`` (mm, deg; `frame_from_values`) -> 4x4 (m)."""
    return frame_from_values(frame_values(text, what))


def fixed_xyz(R: np.ndarray) -> np.ndarray:
    """Fixed-axis XYZ angles (rad) of rotations ``R (..., 3, 3)``; at a gimbal lock (pitch +-90 deg,
    a target pointing straight along x) scipy sets the yaw to 0 and says so: a valid angle set, so
    not said to the user (a UserWarning on stderr)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return Rotation.from_matrix(R).as_euler("xyz")


def frame_to_text(T: np.ndarray) -> str:
    """4x4 (m) -> ``x,y,z,rx,ry,rz`` (mm, deg, fixed-axis XYZ), the inverse of `frame_from_text`."""
    r = fixed_xyz(T[:3, :3]) * (180 / np.pi)
    return ",".join(f"{v:.4f}" for v in (*(T[:3, 3] * 1e3), *r))


# ----------------------------------------------------------------------------- pose CSV files
def _column_unit(header: list[str], stem: str, units: dict) -> tuple[str, float] | None:
    hits = [(f"{stem}_{u}", s) for u, s in units.items() if f"{stem}_{u}" in header]
    if len(hits) > 1:
        raise DataError(f"column {stem} appears with two units: {[h[0] for h in hits]}")
    return hits[0] if hits else None


def read_poses_csv(path) -> tuple[np.ndarray, dict]:
    """Poses ``(N, 4, 4)`` (m) from a targets CSV (see the module docstring) and its layout
    (``length``: 'mm'|'m', ``orientation``: 'quat'|'deg'|'rad', to write results alike; ``e1``: the
    carriage positions ``(N,)`` m of a track, when the file has an e1 column)."""
    path = Path(path)
    text = read_text(path, "pose CSV file")
    lines = text.splitlines(keepends=True)
    skip = next((i for i, ln in enumerate(lines) if not ln.lstrip().startswith("#")), len(lines))
    rows = list(csv.reader(io.StringIO("".join(lines[skip:]))))  # leading '#' lines are comments
    if not rows:
        raise DataError(f"{path} is empty: expected a header x_mm,y_mm,z_mm,qw,qx,qy,qz (or rx_deg..)")
    header = [h.strip().lower() for h in rows[0]]
    if len(header) == 1 and ";" in header[0]:
        raise DataError(f"{path}: the columns are separated by ';' (a decimal-comma export): save the file "
                        "comma-separated with '.' as the decimal separator")
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    pos = [_column_unit(header, c, LENGTH_UNITS) for c in "xyz"]
    if None in pos or len({p[0].split("_")[1] for p in pos}) != 1:
        raise DataError(f"{path}: need position columns x_mm, y_mm, z_mm (or x_m, y_m, z_m), one unit; "
                        f"header is {rows[0]}")
    rot = [_column_unit(header, c, ANGLE_UNITS) for c in ("rx", "ry", "rz")]
    quat = all(c in header for c in ("qw", "qx", "qy", "qz"))
    if quat == (None not in rot):
        raise DataError(f"{path}: give the orientation as qw,qx,qy,qz or as rx_deg,ry_deg,rz_deg "
                        f"(fixed-axis XYZ; or _rad), exactly one of them; header is {rows[0]}")
    track = _column_unit(header, "e1", LENGTH_UNITS)
    cols = [p[0] for p in pos] + (["qw", "qx", "qy", "qz"] if quat else [r[0] for r in rot]) \
        + ([track[0]] if track else [])
    idx = [header.index(c) for c in cols]
    try:
        data = np.array([[float(r[i]) for i in idx] for r in body], dtype=float).reshape(-1, len(cols))
    except (ValueError, IndexError) as exc:
        raise DataError(f"{path}: a row is short or not numeric ({exc})") from exc
    if not np.isfinite(data).all():
        bad = np.flatnonzero(~np.isfinite(data).all(axis=1)) + 2 + skip
        raise DataError(f"{path}: NaN or infinite values in line(s) {bad[:10].tolist()}")
    if data.shape[0] == 0:
        raise DataError(f"{path} has a header but no poses")
    p = data[:, :3] * pos[0][1]
    layout = {"length": pos[0][0].split("_")[1]}
    if track:
        layout["e1"] = data[:, -1] * track[1]
        data = data[:, :-1]
    if quat:
        qn = np.linalg.norm(data[:, 3:], axis=1)
        bad = np.flatnonzero(np.abs(qn - 1.0) > ROTATION_TOL) + 2 + skip
        if bad.size:
            raise DataError(f"{path}: quaternion not of unit length in line(s) {bad[:10].tolist()}")
        R = Rotation.from_quat(data[:, 3:], scalar_first=True).as_matrix()
        orient = "quat"
    else:
        R = Rotation.from_euler("xyz", data[:, 3:] * rot[0][1]).as_matrix()
        orient = rot[0][0].split("_")[1]
    layout["orientation"] = orient
    return make_transform(R, p), layout


def check_target_units(T: np.ndarray, layout: dict, reach_m: float, what: str,
                       origin_m=(0.0, 0.0, 0.0)) -> None:
    """Refuse targets ``(N, 4, 4)`` (m) read in ``layout`` (:func:`read_poses_csv`) whose magnitudes
    say another unit than their headers, for a robot of ``reach_m`` whose base is at ``origin_m``:
    positions (:func:`robocal.core.magnitudes.check_targets`) and Euler angles in degrees that are
    radians or in radians beyond a turn."""
    check_targets(T[:, :3, 3], layout["length"], reach_m, what, origin_m)
    if layout["orientation"] in ANGLE_UNITS:
        angles = fixed_xyz(T[:, :3, :3]) / ANGLE_UNITS[layout["orientation"]]
        check = check_degree_set if layout["orientation"] == "deg" else check_radians
        check(angles.reshape(-1), f"{what}: rx, ry, rz")


def pose_columns(T: np.ndarray, layout: dict) -> tuple[list[str], np.ndarray]:
    """Column names and values ``(N, 6|7)`` of poses ``(N, 4, 4)`` in a CSV ``layout``."""
    u = layout["length"]
    names = [f"x_{u}", f"y_{u}", f"z_{u}"]
    p = T[:, :3, 3] / LENGTH_UNITS[u]
    rot = Rotation.from_matrix(T[:, :3, :3])
    if layout["orientation"] == "quat":
        return names + ["qw", "qx", "qy", "qz"], np.hstack([p, rot.as_quat(scalar_first=True)])
    a = layout["orientation"]
    return names + [f"rx_{a}", f"ry_{a}", f"rz_{a}"], np.hstack([p, fixed_xyz(T[:, :3, :3]) / ANGLE_UNITS[a]])


def format_csv(columns: list[str], values: np.ndarray) -> str:
    """CSV text with a header and full-precision numbers."""
    lines = [",".join(columns)]
    lines += [",".join(repr(float(v)) if isinstance(v, float | np.floating) else str(v) for v in row)
              for row in values.tolist()]
    return "\n".join(lines) + "\n"


def residual_mm(robot: Robot, q: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Position error ``(N,)`` in mm of ``robot`` at joints ``q`` against target poses."""
    return np.linalg.norm(pose_error(targets, robot.fk(q))[:, :3], axis=1) * 1e3
