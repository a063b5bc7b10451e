"""``rc.plan_poses``: choose the poses of a calibration campaign before anything is measured.

From the nominal model alone: candidate poses (generated inside the joint limits, or read from a
file) are filtered by the constraints (:mod:`robocal.campaign.constraints`), each candidate's
information about the identifiable parameters is computed (:mod:`robocal.campaign.information`),
an exchange search picks the best ``n`` (:mod:`robocal.campaign.exchange`), and the chosen poses
are put in a short measuring order (:mod:`robocal.campaign.order`). ``M`` is the posterior
information matrix, the data's plus the priors' the calibration carries (``J^T W J + P^-1``), so
the predicted accuracy ``sqrt(trace(M^-1 A))`` is the expected RMS of the calibrated model's TCP
position error over the region of interest (default: the workspace sample of
:func:`robocal.trust.coverage.workspace_sample`) from the measurement noise and what the priors
leave of the parameters the poses do not determine (m; reported in mm): the predicted accuracy
``calibrate`` reports, before the unmodelled error. Frame parameters that stay unidentifiable
(no prior) are held at their values and their own errors are not part of that figure.

Given the robot's unmodelled error (``unmodelled_mm``, e.g. what a previous calibration left),
the design is then polished for the error the fit will absorb from it
(:mod:`robocal.campaign.unmodelled`) and the predicted accuracy includes it.

When no SMR is given, its place on the flange is an unknown with a prior, and the criterion and
the predicted accuracy are their expectation over it (:mod:`robocal.campaign.hypotheses`). The
predicted RMS of held-out check measurements adds their own noise (the noise model's, or the
residual of the measured candidates' calibration, whose noise then also enters the predicted
accuracy).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

import numpy as np

import robocal.campaign.constraints as cons
from robocal.campaign.exchange import CRITERIA, ExchangeResult, averaged_search, criterion_value
from robocal.campaign.files import CandidateFile, poses_csv
from robocal.campaign.hypotheses import SMR_BOX_MM, mean_criterion, smr_hypotheses
from robocal.campaign.information import Information, candidate_data, candidate_information
from robocal.campaign.order import measuring_order
from robocal.campaign.programs import DEGREE_DECIMALS, fixed_point
from robocal.campaign.unmodelled import (
    DEFAULT_TERMS,
    Unmodelled,
    mean_square,
    measured_values,
    search,
    unmodelled_error,
)
from robocal.core.errors import DataError, RobocalError
from robocal.core.io import write_all
from robocal.core.magnitudes import check_tool
from robocal.core.progress import Progress
from robocal.core.version import __version__
from robocal.data.kinds import OBSERVED, kind_spec
from robocal.data.measurements import Measurements, robot_reach
from robocal.data.simulate import smr_in_link_frame
from robocal.identify import vocabulary
from robocal.identify.identifiability import Identifiability
from robocal.identify.structural import separate, unidentifiable
from robocal.ik.path import default_weights, travel
from robocal.kinematics.transforms import make_transform
from robocal.trust.coverage import WORKSPACE_SAMPLES, WORKSPACE_SEED, workspace_sample
from robocal.trust.posterior import Noise

DEFAULT_CANDIDATES = 5000
DEFAULT_REGION_SIZE = WORKSPACE_SAMPLES
DEFAULT_STARTS = 4
MAX_DRAWS = 50              # candidate batches drawn before constraints are declared too tight
ROUND_DECIMALS_DEG = 4      # generated joints are rounded to 1e-4 deg (1e-4 mm): what poses.csv says
CURVE_POINTS = 12           # N values of an accuracy curve given as start:stop
CURVE_RANDOM_DESIGNS = 9    # random designs per N for the curve's random baseline
FORMAT = "robocal-campaign/1"
MAX_NOISE_MM = 100.0        # an instrument noisier than this (1 sigma) measures no calibration


@dataclass(frozen=True)
class CurvePoint:
    """Predicted accuracy (mm) with ``n`` planned poses and the median of random designs.

    One point of `CampaignResult.curve` (``plan_poses(..., curve=...)``).

    Attributes
    ----------
    n : int
        The number of poses.
    predicted_rms_mm : float
        Predicted RMS TCP error over the region with the ``n`` best poses, mm.
    random_median_mm : float
        The same for random sets of ``n`` poses (median), mm.

    See Also
    --------
    rc.CampaignResult : Holds the curve.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> plan = rc.plan_poses(robot, 15, n_candidates=200, region_size=50, starts=1, curve=[12, 15])
    >>> [point.n for point in plan.curve]
    [12, 15]
    >>> all(p.predicted_rms_mm <= p.random_median_mm for p in plan.curve)  # better than chance
    True
    """

    n: int
    predicted_rms_mm: float
    random_median_mm: float


@dataclass
class CampaignResult:
    """A planned campaign: the poses `robocal.plan_poses` chose, in measuring order.

    Attributes
    ----------
    robot : Robot
        The nominal model planned for.
    kind : str
        What is measured (``'point'``, ``'pose'``, ``'plane'``, ``'flush'``, ``'distance'``).
    joints : numpy.ndarray, shape (N, n)
        The chosen poses, radians, in measuring order (one row per pose; per contact or distance
        end for plane and distance data).
    candidate_index : numpy.ndarray of int, shape (N,)
        The row of each in the given candidates (joints array rows, the file's distinct poses,
        or the contact / distance rows of Measurements; for generated candidates, the row among
        those that met the constraints).
    visible : numpy.ndarray of bool, shape (N, k)
        Which SMRs the tracker sees at each pose.
    predicted_rms_mm : float
        Predicted RMS error of the calibrated model's TCP position over the region, mm.
    predicted_heldout_mm : float
        Predicted 3-D RMS of held-out check measurements over the region, mm: the model's error
        and the measurement's own noise (the noise model's, or the residual of the measured
        candidates' calibration: the noise the data show).
    criterion : str
        The design criterion (``'I'``, ``'D'`` or ``'O4'``) and ``criterion_value`` its value.
    identifiability : Identifiability
        The identifiability of the chosen set (rank, condition number, dropped parameters).
    parameters : list of str
        The identifiable parameters the design is for.
    travel, travel_unordered : float
        The measuring route's weighted joint travel, and the travel in the order the search found
        the poses.
    weights : numpy.ndarray, shape (n,)
        The joints' travel weights.
    curve : list of CurvePoint
        The accuracy curve: predicted RMS (mm) against the pose count, and the median of random
        designs.
    funnel : Funnel
        How many candidates each constraint removed (``funnel.left``: the candidates the search
        chose from, also ``n_candidates``).
    noise : Noise
        The measurement noise model of the prediction.
    settings : dict
        The planning settings.
    source : CandidateFile, optional
        The candidate file the poses came from.
    source_rows : numpy.ndarray of int, shape (N,), optional
        The chosen poses' rows in that file.
    warnings : list of str
        What limits the plan (e.g. an SMR on the flange axis).
    criterion_value : float
        The value of the design criterion ``criterion`` at the chosen poses.

    See Also
    --------
    rc.plan_poses : The planner that returns it.
    robocal.campaign.CurvePoint : A point of its accuracy curve.
    robocal.campaign.read_planned : Read a planned file back.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> plan = rc.plan_poses(robot, 20, n_candidates=300, region_size=100, starts=1,
    ...                      smr=[[0.03, 0.0, 0.1]])
    >>> plan.n, plan.joints.shape, plan.visible.shape
    (20, (20, 6), (20, 1))
    >>> plan.predicted_rms_mm < 0.05  # mm, with 0.02 mm tracker noise
    True
    >>> plan.poses_csv().splitlines()[0]  # the file to measure from: joints and SMR, deg and mm
    'q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,smr0_x_mm,smr0_y_mm,smr0_z_mm'
    """

    robot: object
    kind: str
    joints: np.ndarray
    candidate_index: np.ndarray
    visible: np.ndarray
    predicted_rms_mm: float
    predicted_heldout_mm: float
    criterion: str
    criterion_value: float
    identifiability: Identifiability
    parameters: list[str]
    travel: float
    travel_unordered: float
    weights: np.ndarray
    curve: list[CurvePoint]
    funnel: cons.Funnel
    noise: Noise
    settings: dict
    source: CandidateFile | None = None
    source_rows: np.ndarray | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        """The number of planned rows."""
        return len(self.joints)

    @property
    def n_candidates(self) -> int:
        """The candidates the search chose from (what the funnel left)."""
        return self.funnel.left

    def poses_csv(self) -> str:
        """The text of ``poses.csv`` (see `robocal.campaign.files`).

        Returns
        -------
        str
            The CSV text.
        """
        return poses_csv(self.joints, self.visible, self.source, self.source_rows,
                         smr_mm=self.settings["smr_mm"], tracker_mm=self.settings["tracker_mm"],
                         spec=self.robot.joints)

    def write(self, csv, json_path=None, html=None, programs: dict | None = None) -> list[str]:
        """Write ``poses.csv`` (``csv``), the JSON of `to_dict` (``json_path``), the HTML page
        (``html``) and the robot programs ``programs`` {path: text} (all or none); the paths
        written.

        Parameters
        ----------
        csv : str or pathlib.Path
            ``poses.csv``.
        json_path : str or pathlib.Path, optional
            The campaign JSON.
        html : str or pathlib.Path, optional
            The HTML page.
        programs : dict of str to str, optional
            ``{path: program text}``.

        Returns
        -------
        list of str
            The paths written.

        Examples
        --------
        >>> result.write("poses.csv", json_path="campaign.json")  # doctest: +SKIP
        ['poses.csv', 'campaign.json']
        """
        texts = {csv: self.poses_csv()}
        if json_path:
            texts[json_path] = json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"
        if html:
            from robocal.report.campaign import render_campaign

            texts[html] = render_campaign(self.to_dict())
        texts.update(programs or {})
        write_all(texts)
        return [str(path) for path in texts]

    def summary(self) -> str:
        """A short human summary: poses, predicted accuracy, identifiability, route, candidates.

        Returns
        -------
        str
            The summary text.
        """
        ident = self.identifiability
        o = ident.observability
        noise = (f"isotropic {self.noise.sigma_m * 1e3:g} mm" if self.noise.model == "isotropic"
                 else "the tracker's anisotropic model")
        unmodelled = self.settings.get("unmodelled_mm", 0.0)
        source = " (the candidates' measurements show it)" \
            if self.settings.get("unmodelled_from") == "the candidates' measurements" else ""
        noise += (f"; unmodelled error {unmodelled:.4g} mm as {', '.join(self.settings['unmodelled_terms'])}"
                  f"{source}" if unmodelled else "; before the unmodelled error")
        box = self.settings.get("smr_prior_box_mm", 0.0)
        unknown = f"; averaged over the SMR's place within +-{box:g} mm of the nominal" if box else ""
        lines = [f"{self.n} poses of {self.robot.name} ({self.kind} measurements) chosen from "
                 f"{self.n_candidates} candidates ({self.criterion}-optimal{unknown})",
                 f"predicted accuracy: {self.predicted_rms_mm:.4f} mm RMS of the TCP position over the "
                 f"region (noise {noise}); held-out check measurements: {self.predicted_heldout_mm:.4f} mm "
                 f"RMS (including their noise floor, {self.settings['heldout_noise_mm']:.4f} mm, from "
                 f"{self.settings['heldout_noise_from']})",
                 f"{vocabulary.counts(ident)}; condition number {ident.condition_number:.3g} "
                 f"({ident.condition_class}); " + " ".join(f"{k} {v:.3g}" for k, v in o.items()),
                 f"measuring order: weighted travel {self.travel:.4g} (in the search's order "
                 f"{self.travel_unordered:.4g})",
                 f"candidates: {self.funnel.text()}"]
        lines += vocabulary.lines(ident, indent="  ")
        if self.curve:
            lines.append("poses  predicted RMS (mm)  random poses, median (mm)")
            lines += [f"{p.n:5d}  {p.predicted_rms_mm:18.4f}  {p.random_median_mm:25.4f}" for p in self.curve]
        lines += [f"WARNING: {w}" for w in self.warnings]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Plain data (mm, deg) for JSON and the HTML page.

        Returns
        -------
        dict
            The campaign (JSON-ready).
        """
        ident = self.identifiability
        shown, k = self.robot.joints_shown(self.joints), self.robot.external_axes
        return {
            "format": FORMAT, "robocal_version": __version__,
            "robot": self.robot.section(),
            "kind": self.kind, "criterion": self.criterion, "n_poses": self.n,
            "predicted_rms_mm": self.predicted_rms_mm, "predicted_heldout_mm": self.predicted_heldout_mm,
            "noise": {"model": self.noise.model, "sigma_mm": self.noise.sigma_m * 1e3},
            "joints_deg": [[float(fixed_point(v, DEGREE_DECIMALS)) for v in row]  # as in poses.csv (mm on
                           for row in shown[:, k:]],                           # a prismatic joint)
            **({"e1_mm": [float(fixed_point(v, DEGREE_DECIMALS)) for v in shown[:, 0]]} if k else {}),
            "candidate_index": self.candidate_index.tolist(),
            "visible": self.visible.astype(int).tolist(),
            "tcp_mm": (self.robot.fk(self.joints)[:, :3, 3] * 1e3).tolist(),
            "travel": self.travel, "travel_unordered": self.travel_unordered,
            "travel_weights": self.weights.tolist(),
            "identifiability": {key: v for key, v in ident.to_dict().items()
                                if key not in ("kept", "dropped", "undetermined", "confounded_with")},
            "parameters": self.parameters,
            "dropped": vocabulary.entries(ident.dropped + ident.undetermined, ident),
            "curve": [{"n": p.n, "predicted_rms_mm": p.predicted_rms_mm,
                       "random_median_mm": p.random_median_mm} for p in self.curve],
            "candidates": self.funnel.to_dict(),
            "settings": self.settings,
            "warnings": self.warnings,
        }


def _planning_robot(robot, smr, normals):
    """The robot with its TCP on the first SMR and the others as extra SMRs; SMR positions and
    facing directions ``(k, 3)`` in the flange (tool) frame."""
    R, t = robot.tool[:3, :3], robot.tool[:3, 3]
    given = smr is not None
    if smr is None:
        smr = np.vstack([np.zeros(3), (robot.smr - t) @ R])
    smr = np.asarray(smr, dtype=float).reshape(-1, 3)
    if not len(smr) or not np.isfinite(smr).all():
        raise DataError("SMR positions must be finite (k, 3) coordinates in m (flange frame)")
    for i, xyz in enumerate(smr if given else ()):  # another unit than m (the CLI asks in its mm first)
        check_tool(xyz, "m", f"smr[{i}]")
    normals = np.tile([0.0, 0.0, 1.0], (len(smr), 1)) if normals is None else \
        np.asarray(normals, dtype=float).reshape(-1, 3)
    if normals.shape != smr.shape or not np.isfinite(normals).all() or \
            (np.linalg.norm(normals, axis=1) < 1e-9).any():
        raise DataError(f"give one non-zero facing direction per SMR ({len(smr)} SMRs)")
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    placed = smr_in_link_frame(robot, smr)
    plan = replace(robot, tool=make_transform(R, placed[0]), smr=placed[1:], nominal=None)
    return plan, smr, normals


def _curve_values(curve, n: int, n_min: int, n_max: int) -> list[int]:
    """Pose counts of the accuracy curve: a tuple ``(start, stop[, step])`` (default step: about
    ``CURVE_POINTS`` values; the start is raised to the fewest poses that identify the parameters,
    and the planned ``n`` is added), or a list of counts."""
    if curve is None:
        return []
    values = [int(v) for v in curve]
    if isinstance(curve, tuple):
        if len(values) not in (2, 3) or values[0] >= values[1] or (len(values) == 3 and values[2] < 1):
            raise DataError(f"a curve range is (start, stop[, step]) with start < stop, got {curve}")
        start, stop = values[:2]
        step = values[2] if len(values) == 3 else max(1, int(np.ceil((stop - start) / (CURVE_POINTS - 1))))
        values = list(range(max(start, n_min), stop + 1, step)) + [stop] + ([n] if start <= n <= stop else [])
    out = sorted({v for v in values if n_min <= v <= n_max})
    if not out:
        raise DataError(f"no curve point between {n_min} (the fewest poses that can identify the parameters) "
                        f"and {n_max} (the candidates available)")
    return out


def _draw(robot, count: int, limits: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    q = rng.uniform(limits[:, 0], limits[:, 1], (count, robot.n_joints))
    return np.where(robot.prismatic, np.round(q * 1e3, ROUND_DECIMALS_DEG) / 1e3,
                    np.deg2rad(np.round(np.rad2deg(q), ROUND_DECIMALS_DEG)))


def _generate(robot, count, constraints, smr, normals, limits, rng, funnel):
    """Candidates drawn uniformly in the limits until ``count`` pass the constraints (the last
    batch's surplus is recorded in ``funnel`` as removed)."""
    kept_q, kept_v = [], []
    total = 0
    for _ in range(MAX_DRAWS):
        q = _draw(robot, count, limits, rng)
        funnel.start += len(q)
        keep, visible = cons.apply(robot, q, constraints, smr, normals, funnel, limits)
        kept_q.append(q[keep])
        kept_v.append(visible[keep])
        total += int(keep.sum())
        if total >= count:
            break
    if total > count:
        funnel.record(f"keeping the {count} asked for", total - count)
    return np.concatenate(kept_q)[:count], np.concatenate(kept_v)[:count]


def _region(robot, region, size, constraints, limits, rng, smr, normals):
    """Joints ``(R, n)`` of the region of interest: given joints, random poses in the limits inside
    the TCP boxes (inside ``region`` when it is a box), or without boxes the workspace sample the
    predicted accuracy of a calibration uses (``size`` of them)."""
    if region is None and not constraints.boxes:
        return workspace_sample(robot, size, WORKSPACE_SEED)
    if region is not None:
        arr = np.asarray(region, dtype=float)
        if arr.shape == (2, 3):
            constraints = cons.Constraints(margin_deg=constraints.margin_deg, boxes=(arr,))
        else:
            return robot.check_joints(arr)
    else:
        constraints = cons.Constraints(margin_deg=constraints.margin_deg, boxes=constraints.boxes)
    funnel = cons.Funnel()
    q, _ = _generate(robot, size, constraints, smr[:1], normals[:1], limits, rng, funnel)
    if len(q) < min(size, 100):
        raise DataError(f"only {len(q)} random poses fall inside the region box: check the box (m, robot "
                        "base frame) or give the region as joints")
    return q


def _fail_empty(funnel: cons.Funnel, what: str) -> None:
    last = next((name for name, count in reversed(funnel.steps.items()) if count), "the joint limits")
    raise DataError(f"{what}: {funnel.text()}. The last candidates were removed by {last}: relax it "
                    "(or, for the tracker, move it or the SMRs)")


def check_plan_numbers(noise_mm: float, seed: int | None) -> None:
    """DataError unless the noise (mm, 1 sigma) is finite in (0, `MAX_NOISE_MM`] and the seed a
    whole number >= 0 or None (an infinite noise or a negative seed was an internal error)."""
    if not (isinstance(noise_mm, int | float | np.number) and 0 < float(noise_mm) <= MAX_NOISE_MM):
        raise DataError(f"the measurement noise must be a number in (0, {MAX_NOISE_MM:g}] mm, got "
                        f"{noise_mm!r}")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0):
        raise DataError(f"the random seed must be a whole number >= 0, got {seed!r}")


def plan_poses(robot, n: int, *, kind: str = "point", candidates=None, n_candidates: int = DEFAULT_CANDIDATES,
               constraints: cons.Constraints | None = None, smr=None, smr_normals=None,
               noise_mm: float = 0.02, noise_model: str = "isotropic", rotation_noise_deg: float = 0.001,
               criterion: str = "I", region=None, region_size: int = DEFAULT_REGION_SIZE,
               starts: int = DEFAULT_STARTS, curve=None, seed: int = 0, progress=None,
               params="auto", unmodelled_mm: float | None = None,
               unmodelled_terms=DEFAULT_TERMS) -> CampaignResult:
    """Choose ``n`` calibration poses for ``robot`` (the nominal model).

    Candidates are filtered by the constraints, an exchange search picks the ``n`` that best
    determine the identifiable parameters for the chosen criterion, and the poses are put in a
    short measuring order.

    Parameters
    ----------
    robot : Robot
        The nominal model.
    n : int
        Number of poses to choose.
    kind : {'point', 'pose', 'plane', 'flush', 'distance'}
        What is measured; ``'plane'``, ``'flush'`` and ``'distance'`` need ``candidates``.
    candidates : array_like, shape (C, n), CandidateFile or Measurements, optional
        Joints in radians, a candidate file (`robocal.campaign.read_candidates`) or
        Measurements (contacts / distances); default: generate ``n_candidates`` inside the
        limits.
    n_candidates : int, default 5000
        Number of generated candidates.
    constraints : Constraints, optional
        Limits margin, TCP boxes, joint distance, singularity distances, the `Tracker`.
    smr, smr_normals : array_like, shape (k, 3), optional
        SMR positions (m) and facing directions in the flange frame (default: one SMR at the
        model's TCP facing along the flange z axis, its place unknown within a box of
        ``SMR_BOX_MM`` about it: the I or D criterion averaged over that prior, see
        `robocal.campaign.hypotheses`).
    noise_mm : float, default 0.02
        Measurement noise (1 sigma per axis), millimetres.
    noise_model : {'isotropic', 'tracker'}
        Isotropic noise, or the tracker's own model (needs ``constraints.tracker``).
    rotation_noise_deg : float, default 0.001
        Orientation noise of ``pose`` data, degrees.
    criterion : {'I', 'D', 'O4'}
        I-optimal (average predicted TCP variance over the region, default), D-optimal or O4.
    region : array_like, shape (R, n), or tuple of array_like, shape (3,) each, optional
        Where the accuracy matters: joints in radians, or a box ``(lower, upper)`` in metres
        (default: given candidates, the poses of the cell they are (``region_size`` of them at
        random when there are more); else ``region_size`` random poses in the limits, seeded as
        the workspace sample of a calibration's predicted accuracy; inside the TCP boxes when
        there are any).
    region_size : int, default 1000
        Number of random region poses.
    starts : int, default 4
        Random starts of the exchange search.
    curve : tuple or list of int, optional
        ``(start, stop[, step])`` or a list of pose counts for the accuracy curve.
    seed : int, default 0
        The random seed.
    progress : bool, optional
        True shows a bar on a terminal.
    params : 'auto' or list of str, default 'auto'
        The unknowns the campaign is to determine: the calibration's default set, or a list of
        names (e.g. the joint zeros with the frame and SMR, for a check campaign).
    unmodelled_mm : float, optional
        The robot's error the calibrated model will not describe, 3-D RMS over the region, mm
        (a previous calibration's ``unmodelled_mm``): the I-optimal design is polished for the
        error the fit absorbs from it, and the predicted accuracy includes it. 0: noise only.
        Default: with candidates that carry their measurements (Measurements of points or poses,
        or a candidate file with measured columns: an earlier campaign) and the I criterion, the
        error they show (the unmodelled terms' values in their calibration with
        ``unmodelled_terms``: each term's variance in the shape of its magnitude, scaled to the
        error they make together); else 0.
    unmodelled_terms : sequence of str, default ('compliance', 'backlash', 'travel')
        The joint-error terms that model that error (their priors' shape, scaled to
        ``unmodelled_mm``); those the calibration fits are left out.

    Returns
    -------
    CampaignResult
        The chosen joints in measuring order, the SMRs seen, the predicted accuracy, the
        identifiability, the candidate funnel; ``poses_csv()`` gives the file to measure from.

    Raises
    ------
    DataError
        Invalid counts, kind, criterion or shapes, or no candidate left after the constraints
        (the message names the constraint that removed the last ones).

    See Also
    --------
    rc.CampaignResult : What it returns.
    rc.Constraints : The limits the poses keep.
    rc.Tracker : The tracker's place and line of sight.
    robocal.campaign.plan_cell : A work cell's campaign.
    robocal.campaign.read_candidates : Candidate poses from a file.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> plan = rc.plan_poses(robot, 20, n_candidates=300, region_size=100, starts=1,
    ...                      smr=[[0.03, 0.0, 0.1]])  # the SMR 30 mm off the flange axis
    >>> plan.joints.shape, bool(robot.within_limits(plan.joints).all())
    ((20, 6), True)
    >>> round(plan.predicted_rms_mm, 2)  # mm over the region, 0.02 mm noise
    0.02
    """
    if not isinstance(n, int | np.integer) or n < 1:
        raise DataError(f"the number of poses must be a positive integer, got {n!r}")
    check_plan_numbers(noise_mm, seed)
    kind_spec(kind)  # an unknown kind: DataError
    if criterion not in CRITERIA:
        raise DataError(f"unknown criterion {criterion!r}: use one of {', '.join(CRITERIA)}")
    if unmodelled_mm and criterion != "I":
        raise DataError("an unmodelled error is planned for with the I criterion (the predicted accuracy)")
    measured = candidates.measured if isinstance(candidates, CandidateFile) else candidates \
        if isinstance(candidates, Measurements) and candidates.points is not None else None
    if unmodelled_mm is not None or criterion != "I" or not OBSERVED[kind].sees_position:
        measured = None
    if int(starts) < 1 or int(n_candidates) < 1 or int(region_size) < 1:
        raise DataError("starts, n_candidates and region_size must be >= 1")
    constraints = cons.Constraints() if constraints is None else constraints
    if constraints.margin_deg is None:
        margin = cons.DEFAULT_MARGIN_DEG if candidates is None else 0.0
        constraints = replace(constraints, margin_deg=margin)
    tracker = constraints.tracker
    noise = Noise(sigma_m=float(noise_mm) * 1e-3, model=noise_model,
                  tracker_position=None if tracker is None else tracker.position,
                  rotation_sigma_rad=np.deg2rad(float(rotation_noise_deg)))
    smr_given = smr
    plan_robot, smr, normals = _planning_robot(robot, smr, smr_normals)
    geometry = replace(robot, smr=np.zeros((0, 3)), nominal=None, joint_errors=None)  # flange = tool
    rng = np.random.default_rng(seed)
    limits = cons.limits_with_margin(robot, constraints.margin_deg)
    if tracker is not None:
        cons.check_tracker_placement(robot, tracker, robot_reach(plan_robot))
    funnel = cons.Funnel()
    source = candidates if isinstance(candidates, CandidateFile) else None
    file_data = source.data if source is not None else \
        candidates if isinstance(candidates, Measurements) else None
    if OBSERVED[kind].sees_position:  # candidates generated from joints
        file_data = None
    elif file_data is None or file_data.kind != kind:
        raise DataError(f"{kind} candidates come from a measurement file of {kind} data (contacts or pairs): "
                        "give them as candidates (robocal poses --from FILE)")
    if candidates is None:
        q, visible = _generate(geometry, int(n_candidates), constraints, smr, normals, limits, rng, funnel)
        given = np.arange(len(q))
    else:
        q_all = robot.check_joints(_given_joints(candidates, file_data))
        funnel.start = len(q_all)
        keep, visible = cons.apply(geometry, q_all, constraints, smr, normals, funnel, limits)
        given = np.flatnonzero(keep)
        q, visible = q_all[given], visible[given]
    if not len(q):
        _fail_empty(funnel, "no candidate pose is left")
    if file_data is None:
        data = candidate_data(plan_robot, kind, q, visible)   # pose_id = row of q
    else:
        data = file_data.subset(given)
        if OBSERVED[kind].group == "pair":  # a pair needs both ends
            pair_of = np.unique(data.pair, return_inverse=True)[1]
            whole = np.flatnonzero(np.bincount(pair_of)[pair_of] == 2)
            if len(whole) < len(given):
                funnel.record("distances missing an end", len(given) - len(whole))
            data, given = data.subset(whole), given[whole]
    shown, residual_mm, warnings = None, None, []
    if measured is not None:
        try:
            shown, residual_mm = measured_values(robot, measured, unmodelled_terms)
        except RobocalError as e:  # placeholder points, too few poses: plan for the noise alone
            warnings.append(f"the candidates' measurements do not show their unmodelled error ({e}): "
                            "planned for the measurement noise alone; give unmodelled_mm (--unmodelled-mm) "
                            "to plan for one")
            measured = None
    info = candidate_information(plan_robot, data, noise, params)
    C, p = len(info.G), info.identifiable  # the data must determine those without a prior
    rows_min = int(info.rows.min())
    n_min = p // rows_min + 1
    if n < n_min:
        raise DataError(f"{n} poses cannot identify the {p} parameters that {kind} data determine here "
                        f"({rows_min} residual(s) per pose; more residuals than unknowns are needed): "
                        f"plan at least {n_min} poses")
    if n > C:
        _fail_empty(funnel, f"only {C} candidates meet the constraints, fewer than the {n} poses asked for")
    region_from = "given" if region is not None else "the TCP boxes" if constraints.boxes else \
        "the candidates" if candidates is not None else "workspace sample"
    if region_from == "the candidates":  # the cell's own poses
        region = q if len(q) <= int(region_size) else q[np.sort(rng.choice(len(q), int(region_size), False))]
    q_region = _region(geometry, region, int(region_size), constraints, limits, rng, smr, normals)
    A = info.region_matrix(plan_robot, q_region)
    first_row = np.unique(info.group, return_index=True)[1]
    cand_q = data.joints[first_row]                           # one joint vector per candidate
    conflicts = (cons.conflict_rows(cand_q, constraints.min_joint_distance_deg, robot.prismatic)
                 if constraints.min_joint_distance_deg > 0 else None)
    values = _curve_values(curve, n, n_min, C)
    heldout_noise_model = _noise_rms(noise, plan_robot.fk(q_region)[:, :3, 3]) \
        if OBSERVED[kind].sees_position else noise.sigma_m  # a contact's or a distance's one residual
    heldout_from = "the noise model" if residual_mm is None else "the residual of the candidates' calibration"
    # the noise the candidates' calibration shows, never below the noise model's (clean or simulated
    # candidates fit to nothing: a check measurement still carries the instrument's noise)
    heldout_noise = heldout_noise_model if residual_mm is None else \
        max(residual_mm * 1e-3, heldout_noise_model)
    um = unmodelled_error(plan_robot, data, noise, info, q_region, float(unmodelled_mm or 0.0),
                          unmodelled_terms, shown)
    unknown_smr = (smr_given is None and len(smr) == 1 and file_data is None and um is None
                   and criterion in ("I", "D"))
    problems = [(info.G, A, info.prior)] if not unknown_smr else \
        _smr_problems(robot, kind, q, visible, noise, params, q_region, smr[0], normals[:1])

    def predicted(indices) -> float:  # m^2: the mean squared TCP error over the region
        return mean_criterion(problems, indices) if um is None else \
            mean_square(info.G, A, info.prior, um, indices)

    with Progress(int(starts) + len(values), "poses", quiet=progress is not True) as bar:
        found = averaged_search(problems, n, criterion=criterion, starts=int(starts), seed=seed,
                                conflicts=conflicts, progress=bar)
        if um is not None:
            found = ExchangeResult(*search(info.G, A, info.prior, um, found.indices, conflicts,
                                           np.random.default_rng([seed, 2]), int(starts)))
        points = _curve(problems, values, criterion, seed, conflicts, bar, (n, found.indices), predicted)
    weights = default_weights(robot)
    chosen = found.indices[measuring_order(robot, cand_q[found.indices], weights)]
    if file_data is None:  # one output row per pose, with the SMRs it shows
        rows = first_row[chosen]
        visible_out = np.zeros((n, len(smr)), bool)
        sel = np.isin(info.group, chosen)
        visible_out[_positions(chosen, info.group[sel]), data.smr[sel]] = True
    else:  # every contact / distance end of the chosen candidates (a loop over the N chosen only)
        rows = np.concatenate([np.flatnonzero(info.group == c) for c in chosen])
        visible_out = np.ones((len(rows), 1), bool)
    index = given[data.pose_id[rows]] if file_data is None else given[rows]
    joints = data.joints[rows]
    if candidates is None and int(n_candidates) > C:
        warnings.append(f"only {C} of the {int(n_candidates)} candidates asked for met the constraints in "
                        f"{funnel.start} random poses: the constraints leave a small part of the workspace")
    if len(smr) == 1 and np.linalg.norm(smr[0, :2]) < 1e-6 and OBSERVED[kind].several_smrs:
        warnings.append("the SMR is on the flange axis: the last joint's zero offset cannot be identified; "
                        "give the SMR's position on the flange (smr / --smr-mm) if it is off the axis")
    model_ms = predicted(chosen)
    if residual_mm is not None and OBSERVED[kind].sees_position:  # the noise the measurements show
        model_ms = _shown_noise_ms(info, A, um, chosen, heldout_noise / float(heldout_noise_model))
    return CampaignResult(
        robot=plan_robot, kind=kind, joints=joints, candidate_index=index, visible=visible_out,
        predicted_rms_mm=float(np.sqrt(model_ms) * 1e3),
        predicted_heldout_mm=float(np.sqrt(model_ms + heldout_noise**2) * 1e3),
        criterion=criterion, criterion_value=found.value, identifiability=separate(
            info.analyze_subset(chosen), unidentifiable(plan_robot, kind, info.all_names, max(len(smr), 1)),
            plan_robot),
        parameters=list(info.names),
        travel=travel(joints, weights), travel_unordered=travel(cand_q[found.indices], weights),
        weights=weights, curve=points, funnel=funnel, noise=noise,
        settings={"seed": int(seed), "starts": int(starts), "criterion": criterion,
                  "region_size": len(q_region), "margin_deg": constraints.margin_deg,
                  "unmodelled_mm": 0.0 if um is None else um.rms_m * 1e3,
                  "unmodelled_terms": [] if um is None else list(um.terms),
                  "unmodelled_from": "the candidates' measurements" if measured is not None else
                                     "given" if unmodelled_mm else "none (noise only)",
                  "region": region_from, "smr_prior_box_mm": SMR_BOX_MM if unknown_smr else 0.0,
                  "heldout_noise_mm": heldout_noise * 1e3, "heldout_noise_from": heldout_from,
                  "min_joint_distance_deg": constraints.min_joint_distance_deg,
                  "smr_mm": (smr * 1e3).tolist(), "smr_normals": normals.tolist(),
                  "tracker_mm": None if tracker is None else (tracker.position * 1e3).tolist()},
        source=source, source_rows=None if source is None else source.rows[index], warnings=warnings)


def _smr_problems(robot, kind: str, q: np.ndarray, visible: np.ndarray, noise: Noise, params,
                  q_region: np.ndarray, smr: np.ndarray, normal: np.ndarray) -> list[tuple]:
    """``(G, A, prior)`` of the candidates ``q (C, n)`` with the SMR at each point of
    :func:`robocal.campaign.hypotheses.smr_hypotheses` around the nominal ``smr (3,)`` m (flange
    frame): the hypotheses the criterion is averaged over when the SMR's place is not given."""
    problems, structure = [], None
    for point in smr_hypotheses(smr):  # a loop over the four quadrature points
        hyp_robot = _planning_robot(robot, point[None], normal)[0]
        data = candidate_data(hyp_robot, kind, q, visible[:, :1])
        hyp = candidate_information(hyp_robot, data, noise, params, structure)  # one structure off the axis
        problems.append((hyp.G, hyp.region_matrix(hyp_robot, q_region), hyp.prior))
        structure = hyp.structure
    return problems


def _shown_noise_ms(info: Information, A: np.ndarray, um: Unmodelled | None, chosen: np.ndarray,
                    ratio: float) -> float:
    """The predicted mean square TCP error (m^2) of the design ``chosen`` when the measurements'
    noise is ``ratio`` times the noise model's (the whitened rows, data and unmodelled, divided by
    it; the priors unchanged): what the calibration's posterior will be with the noise the
    candidates' measurements show."""
    G = info.G / ratio
    if um is None:
        return criterion_value(G, A, chosen, "I", info.prior)
    return mean_square(G, A, info.prior, replace(um, N=um.N / ratio), chosen)


def _noise_rms(noise: Noise, points: np.ndarray) -> float:
    """The 3-D RMS (m) of the measurement noise at ``points (R, 3)`` m (robot base frame):
    ``sqrt(mean trace(Sigma))`` of the noise model's covariances (``sqrt(3) sigma`` isotropic)."""
    W = noise.whitener(points)
    return float(np.sqrt(np.mean(np.trace(np.linalg.inv(np.swapaxes(W, 1, 2) @ W), axis1=1, axis2=2))))


def _given_joints(candidates, file_data) -> np.ndarray:
    """Candidate joints: every row of contact / distance data, else one row per distinct pose."""
    if isinstance(candidates, CandidateFile):
        return candidates.joints
    if isinstance(candidates, Measurements):
        if file_data is not None:
            return candidates.joints
        return candidates.joints[np.unique(candidates.pose_id, return_index=True)[1]]
    return candidates


def _positions(chosen: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Position in ``chosen`` of each of ``values`` (all present in ``chosen``)."""
    order = np.argsort(chosen)
    return order[np.searchsorted(chosen, values, sorter=order)]


def _curve(problems, values, criterion, seed, conflicts, bar, main, predicted) -> list[CurvePoint]:
    """Predicted accuracy (``predicted(indices)``, m^2) against the number of poses, the designs
    searched for the hypotheses ``problems`` (``(G, A, prior)`` each): each N warm-started from the
    previous."""
    C = len(problems[0][0])
    points = []
    rng = np.random.default_rng([seed, 1])
    previous = None
    for n in values:
        if n == main[0]:
            idx = main[1]
        else:
            init = previous if previous is not None and len(previous) <= n else None
            idx = averaged_search(problems, n, criterion=criterion, starts=DEFAULT_STARTS, seed=seed,
                                  conflicts=conflicts, init=init).indices
        random = [predicted(rng.choice(C, n, replace=False)) for _ in range(CURVE_RANDOM_DESIGNS)]
        points.append(CurvePoint(n, float(np.sqrt(predicted(idx)) * 1e3),
                                 float(np.sqrt(np.median(random)) * 1e3)))
        previous = idx
        bar.update(info=f"curve {n} poses")
    return points
