"""Does a calibration still hold? A short check campaign judged against it by a stated test.

Model of the check residuals ``r = y - f(q)`` (``3N`` coordinates, tracker frame) under the
hypothesis that the robot did not change since its calibration::

    r ~ N(0, C),   C = s^2 I + J_c Sigma J_c^T

``s`` the instrument's noise per coordinate, ``J_c`` the Jacobian of the calibrated link (and
joint-error) parameters at the check poses and ``Sigma`` their covariance from the calibration (its
own predicted error). The tracker frame and the SMR offsets are refitted (the tracker moved since):
first by the nonlinear registration, then one generalised least-squares step in the metric
``C^-1``. The statistic ``T = min |L^-1 (r - J_f d)|^2`` (``L L^T = C``) has ``m = 3N - k_f``
degrees of freedom. With the noise estimated by the calibration (``s`` from its residuals, ``nu``
degrees of freedom, and ``Sigma`` proportional to ``s^2``), ``T / m ~ F(m, nu)``: the test counts
the uncertainty of the noise estimate. With the noise stated (``noise_mm``), ``T ~ chi2(m)``.
The verdict is ``changed`` exactly when ``p_value < ALPHA``.

What moved: without a frame fit, first the frames the model kept (the SMR offsets, the tracker
frame), greedily, each while it explains a significant part: a re-seated SMR or a bumped tracker is
not the robot, and a check with ``--fit-frame`` would hold (``frame_change``). Then re-identify a
small set of parameters on the check data, in the same metric, greedily (the one that lowers ``T``
most, joint zeros first, other link parameters only when no joint zero explains a significant
part), until the rest is consistent with the hypothesis. Each carries its shift (new minus
calibrated) and a 1-sigma that includes the calibration's uncertainty. A parameter whose column
lies in the span of the tracker frame's and the SMR offsets' columns (`confounded`: alpha1, a1,
theta1, d1 with the base frame, theta{n}, d{n} with the SMR on a 6-axis arm, found by the columns,
not the names) is never named: to the data its change is a moved tracker or SMR; with the frame
refitted a change of theirs does not show at all (the note lists them).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np
from scipy import linalg, stats

from robocal.core.errors import DataError, PlausibilityError
from robocal.core.io import load_json, write_all
from robocal.data.registration import register
from robocal.history.expected import expected_uncertainty
from robocal.history.store import History, uncertainty_fault
from robocal.identify.plausibility import check_residual
from robocal.identify.space import block_of
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.model import Robot
from robocal.kinematics.model_file import dump_model
from robocal.trust.diagnosis import diagnosed

ALPHA = 0.01  # the false-alarm rate the verdict is taken at: changed exactly when p_value < ALPHA
MIN_CHECK_POSES = 8  # fewer poses leave too few degrees of freedom after the frame fit
MAX_CHANGED = 3  # parameters re-identified at most to explain a change
RANK_RTOL = 1e-9  # relative singular value below which a refitted column adds nothing
FRAME_NAMES = ("base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz", "tool.x", "tool.y", "tool.z")
UNSEEN_WITH_FRAME = ("{names} cannot be told from the refitted tracker frame and SMR offset (their columns "
                     "lie in the span of the frame's and the SMR's at these poses): a change of theirs does "
                     "not show in a check")
# a parameter whose whitened column keeps less than this fraction of its norm outside the span of the
# tracker frame's and the SMR offsets' columns is confounded with them: never named as what moved
# (measured on 25 poses of a GP25, a KR 6 R700 and a UR10e: alpha1, a1, theta1, d1 with the tracker
# frame, theta{n}, d{n} with the SMR keep 1e-13 to 1e-16; the next parameter 0.81 or more)
CONFOUNDED_FRACTION = 0.02
# what a check without --fit-frame tests first, before any link parameter: the frames it kept fixed
FRAME_GROUPS = {"smr": "the SMR on the tool (re-seated or moved to another nest)",
                "tracker": "the tracker frame (the tracker or the robot's base moved)"}
_LINK_KINDS = ("alpha", "a", "beta", "d")
TRACKER_KINDS = ("point",)  # calibrations whose residuals give the tracker's noise per coordinate


@dataclass(frozen=True)
class Uncertainty:
    """What a check needs of a calibration: ``names`` of its estimated link (and joint-error)
    parameters, their ``covariance`` ``(k, k)`` (SI), the noise ``noise_m`` (m per coordinate) its
    residuals showed, the degrees of freedom ``dof`` of that estimate and the ``kind`` of data the
    calibration used (its noise is the tracker's per coordinate only on point data)."""

    names: tuple[str, ...]
    covariance: np.ndarray
    noise_m: float
    dof: int
    kind: str = "point"

    @classmethod
    def from_dict(cls, d: dict) -> Uncertainty:
        """From a history record's ``uncertainty``
        (`robocal.history.record.calibration_uncertainty`)."""
        cov = np.asarray(d["covariance"], float).reshape(len(d["names"]), len(d["names"]))
        return cls(tuple(d["names"]), cov, float(d["noise_m"]), int(d["dof"]), str(d.get("kind", "point")))

    @classmethod
    def from_result(cls, result: dict) -> Uncertainty:
        """From a calibration's result JSON (docs/result-json.md): the covariance from the
        parameters' sigma and the correlation matrix, the noise from the calibration residuals
        (point data)."""
        settings = result.get("settings") if isinstance(result, dict) else None
        if isinstance(settings, dict) and settings.get("offsets_only"):
            raise DataError("this result JSON is an offsets-only re-fit: its residual holds what the joint "
                            "zeros could not absorb, not the robot's noise floor; give the full "
                            "calibration's result JSON (--result) or the history that holds both (--history)")
        try:
            corr_names = list(result["correlation"]["names"])
            corr = np.asarray(result["correlation"]["matrix"], float)
            rows = {r["name"]: r for r in result["parameters"]}
            n_points, rms_mm = int(result["after"]["n"]), float(result["after"]["rms"])
            keep = [i for i, n in enumerate(corr_names) if block_of(n) in ("links", "joint_errors")]
            names = [corr_names[i] for i in keep]
            scale = np.array([rows[n]["sigma"] / (1e3 if rows[n]["unit"] == "mm" else 180 / np.pi)
                              for n in names])  # a null sigma: TypeError (was exit 3)
            cov = corr[np.ix_(keep, keep)] * np.outer(scale, scale)
            dof = max(3 * n_points - len(corr_names), 1)
            noise = float(np.sqrt(n_points * (rms_mm * 1e-3) ** 2 / dof))  # rms 1e308: OverflowError
        except (KeyError, TypeError, ValueError, IndexError, OverflowError) as exc:
            raise DataError(f"the result JSON lacks what a check needs ({exc}): give the --json of "
                            "robocal calibrate") from None
        fault = uncertainty_fault({"names": names, "covariance": cov, "noise_m": noise, "dof": dof})
        if fault:
            raise DataError(f"the result JSON's uncertainty is not one a calibration makes: its {fault}; "
                            "give the --json robocal calibrate wrote")
        kind = str(result.get("data", {}).get("kind"))
        return cls(tuple(names), cov, noise, dof, kind)


def load_calibration(model: str, result: str | None, history: str | None, robot_id: str | None):
    """(the calibrated model of ``model``, its `Uncertainty`, the id of its history record or
    None): the uncertainty from the calibration's result JSON ``result`` or else from the history
    (``history``, ``robot_id``: the calibration recorded with this model).

    Raises
    ------
    DataError
        Neither a result JSON nor a history, or no calibration of this model in the history.
    """
    if not history and not result:
        raise DataError("the check needs the calibration's uncertainty: give --history and --robot-id (where "
                        "calibrate recorded it) or --result RESULT.json (calibrate --json)")
    robot = Robot.load(model)
    parent = uncertainty = None
    if result:
        uncertainty = Uncertainty.from_result(load_json(result, "a calibration result JSON"))
    if history:
        with History(history, readonly=True) as store:
            calibration = store.calibration(robot_id, dump_model(robot))
            expected = None if uncertainty else expected_uncertainty(store, calibration)  # never a re-fit's
        parent = calibration.id
        if uncertainty is None and expected is None:
            raise DataError(f"the history's calibration #{parent} of robot id {robot_id!r} has no "
                            "uncertainty (NULL; calibrate records it): give --result RESULT.json of that "
                            "calibration")
        uncertainty = uncertainty or Uncertainty.from_dict(expected)
    return robot, uncertainty, parent


@dataclass
class CheckResult:
    """The verdict of a check; `to_dict` is its JSON (docs/reference/check-json.md).

    Attributes
    ----------
    verdict : str
        "holds" or "changed" (p-value below ``ALPHA``).
    p_value, statistic : float
        The test's p-value and its statistic (whitened sum of squares).
    dof : int
        Degrees of freedom of the statistic (rows minus the refitted frame's rank).
    noise_dof : int or None
        Degrees of freedom of the noise estimate (F-test), None for a stated noise (chi-square).
    noise_m : float
        The noise used, m per coordinate; ``noise_source`` says where it came from.
    n_poses : int
        Poses of the check campaign.
    rms_mm, predicted_rms_mm : float
        The residual RMS (mm) and the RMS expected if nothing changed (mm).
    changed_parameters : list of dict
        ``{name, unit, shift, sigma}`` (mm, deg) of the parameters that most likely moved (never
        one confounded with the tracker frame or the SMR offset: ``CONFOUNDED_FRACTION``).
    frame_change : dict or None
        Without ``fit_frame``: what of the frames the model kept moved, tested before any link
        parameter: ``{moved: [smr, tracker], smr (the index, as the data's smr column, of the
        SMR that moved most), smr_shift_mm: [x, y, z] (its shift, flange frame),
        smr_shift_norm_mm, translation_mm: [x, y, z], rotation_deg: [rx, ry, rz] (the base
        frame's, about the world axes), points_moved_rms_mm (how far that moves the check's
        points), explained_p_value}`` (the keys of what moved).
    explained_p_value : float or None
        The p-value once those parameters are refitted.
    notes : list of str
        Remarks for the reader.
    noise_source : str
        Where the noise comes from: ``"calibration"`` (its estimate) or ``"stated"`` (``noise_mm``).
    warnings : list of str
        Always empty: the verdict says what matters (the result protocol).

    See Also
    --------
    robocal.history.check.check_calibration : The check that returns it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.history.check import Uncertainty, check_calibration
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(nominal, 20, noise_mm=0.01, seed=3)
    >>> unc = Uncertainty(names=("a2",), covariance=np.array([[1e-10]]), noise_m=1e-5, dof=200)
    >>> result = check_calibration(sim.truth, sim.data, unc)
    >>> d = result.to_dict()
    >>> d["verdict"], d["test"]["kind"], d["n_poses"], result.rms_mm < 0.05  # mm
    ('holds', 'F', 20, True)
    """

    verdict: str
    p_value: float
    statistic: float
    dof: int
    noise_dof: int | None
    noise_m: float
    noise_source: str
    n_poses: int
    rms_mm: float
    predicted_rms_mm: float
    changed_parameters: list[dict] = field(default_factory=list)
    explained_p_value: float | None = None
    frame_change: dict | None = None
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)  # the verdict says what matters: none today

    def write(self, json_path=None, **header) -> list[str]:
        """Write ``header`` (e.g. the model and data files) and `to_dict` as JSON to
        ``json_path`` (atomically); the paths written.

        Parameters
        ----------
        json_path : str or pathlib.Path, optional
            The JSON file (None: nothing written).
        **header
            Entries written first (the model and data files...).

        Returns
        -------
        list of str
            The paths written.
        """
        if json_path is None:
            return []
        write_all({json_path: json.dumps({**header, **self.to_dict()}, indent=2, allow_nan=False) + "\n"})
        return [str(json_path)]

    def to_dict(self) -> dict:
        """The verdict, the p-value, the test (statistic, degrees of freedom, noise), the RMS (mm),
        the notes and, when the verdict is ``changed``, the parameters most likely moved.

        Returns
        -------
        dict
            The check (JSON-ready).
        """
        out = {"verdict": self.verdict, "p_value": self.p_value, "alpha": ALPHA,
               "test": {"kind": "F" if self.noise_dof else "chi2", "statistic": self.statistic,
                        "dof": self.dof, "noise_dof": self.noise_dof, "noise_mm": self.noise_m * 1e3,
                        "noise_source": self.noise_source},
               "n_poses": self.n_poses, "rms_mm": self.rms_mm, "predicted_rms_mm": self.predicted_rms_mm,
               "notes": self.notes}
        if self.verdict == "changed":
            out["changed_parameters"] = self.changed_parameters
            out["explained_p_value"] = self.explained_p_value
            out["frame_change"] = self.frame_change
        return out

    def summary(self) -> str:
        """The verdict with its p-value and RMS (mm), the parameters most likely moved, the notes.

        Returns
        -------
        str
            The summary text.
        """
        lines = [f"check of {self.n_poses} poses: {self.verdict} (p = {self.p_value:.3g}; "
                 f"RMS {self.rms_mm:.4f} mm, expected {self.predicted_rms_mm:.4f} mm if unchanged)"]
        moved = [*self._frame_words(), *(f"{c['name']} {c['shift']:+.4f} ± {c['sigma']:.4f} {c['unit']}"
                                         for c in self.changed_parameters)]
        if moved:
            lines.append("most likely moved: " + ", ".join(moved))
        return "\n".join(lines + [f"note: {note}" for note in self.notes])


    def _frame_words(self) -> list[str]:
        """`frame_change` in words, with the option that refits what moved."""
        f = self.frame_change
        if not f:
            return []
        out = []
        if "smr" in f["moved"]:
            x, y, z = f["smr_shift_mm"]
            which = f" (smr index {f['smr']})" if f["smr"] else ""
            out.append(f"{FRAME_GROUPS['smr']}{which} by {f['smr_shift_norm_mm']:.4f} mm (x {x:+.4f}, "
                       f"y {y:+.4f}, z {z:+.4f} mm in the flange frame)")
        if "tracker" in f["moved"]:
            out.append(f"{FRAME_GROUPS['tracker']}: it moves the check's points by "
                       f"{f['points_moved_rms_mm']:.4f} mm RMS (translation "
                       f"{np.linalg.norm(f['translation_mm']):.4f} mm, rotation "
                       f"{np.linalg.norm(f['rotation_deg']):.4f} deg about the tracker's origin)")
        out[-1] += (" (not the robot: check again with --fit-frame, which refits them"
                    + (")" if f["explained_p_value"] >= ALPHA else "; the rest follows)"))
        return out


class _Whitened:
    """The check's residuals and refitted columns in the metric of ``C`` (whitened by its Cholesky
    factor); `fit` is the generalised least-squares fit of extra columns with the frame."""

    def __init__(self, r: np.ndarray, J_frame: np.ndarray, C: np.ndarray) -> None:
        self.L = linalg.cholesky(C, lower=True)
        self.r = linalg.solve_triangular(self.L, r, lower=True)
        self.F = self._whiten(J_frame)
        self.rank = int(np.linalg.matrix_rank(self.F, tol=None)) if self.F.shape[1] else 0

    def _whiten(self, J: np.ndarray) -> np.ndarray:
        return linalg.solve_triangular(self.L, J, lower=True)

    def fit(self, J_extra: np.ndarray | None = None) -> tuple[float, int, np.ndarray, np.ndarray]:
        """``(T, rank, estimate, covariance)`` of the frame columns plus ``J_extra`` (unwhitened)."""
        A = self.F if J_extra is None else np.hstack([self.F, self._whiten(J_extra)])
        U, s, Vt = linalg.svd(A, full_matrices=False)
        keep = s > RANK_RTOL * s[0]
        x = Vt[keep].T @ ((U[:, keep].T @ self.r) / s[keep])
        e = self.r - A @ x
        cov = (Vt[keep].T / s[keep] ** 2) @ Vt[keep]
        return float(e @ e), int(keep.sum()), x, cov


def _p_value(T: float, dof: int, noise_dof: int | None) -> float:
    if noise_dof is None:
        return float(stats.chi2.sf(T, dof))
    return float(stats.f.sf(T / dof, dof, noise_dof))


def _display(name: str, robot) -> tuple[str, float]:
    unit = robot.parameter_units()[robot.parameter_names.index(name)]
    return ("deg", 180.0 / np.pi) if unit == "rad" else ("mm", 1e3)


def candidates(robot) -> tuple[list[str], list[str]]:
    """The parameters a change is looked for in: joint zeros first, then the other link
    parameters (beta only on nominally parallel axes); those confounded with the frames are
    removed by `confounded`, by their columns, not their names."""
    n = robot.n_joints
    zeros = [f"theta{i}" for i in range(1, n + 1)]
    others = [f"{k}{i}" for i in range(1, n + 1) for k in _LINK_KINDS
              if k != "beta" or robot.parallel[i - 1]]
    return zeros, others


def confounded(names, blocks: np.ndarray, frame: np.ndarray, L: np.ndarray) -> list[str]:
    """Of ``names`` (columns ``blocks`` ``(3N, k)``), those whose column in the metric ``L``
    (``C = L L^T``) keeps less than `CONFOUNDED_FRACTION` of its norm outside the span of the
    tracker frame's and the SMR offsets' columns ``frame`` ``(3N, m)``: a change of theirs is a
    moved tracker or SMR to the data (d1 or theta1 and the base frame, d{n} or theta{n} and the SMR)."""
    W = linalg.solve_triangular(L, np.hstack([frame, blocks]), lower=True)
    F, B = W[:, :frame.shape[1]], W[:, frame.shape[1]:]
    U, sv, _ = linalg.svd(F, full_matrices=False)
    Q = U[:, sv > RANK_RTOL * sv[0]]
    outside = np.linalg.norm(B - Q @ (Q.T @ B), axis=0)
    norm = np.linalg.norm(B, axis=0)
    return [n for n, o, b in zip(names, outside, norm, strict=True) if b == 0 or o < CONFOUNDED_FRACTION * b]


def check_calibration(robot, data, uncertainty: Uncertainty, *, fit_frame: bool = True,
                      noise_mm: float | None = None, force: bool = False) -> CheckResult:
    """Judge the calibrated ``robot`` on the check campaign ``data`` (point measurements) with the
    calibration's ``uncertainty``; ``fit_frame``: refit the tracker frame and SMR offsets first (the
    tracker moved since); ``noise_mm``: the instrument's 1-sigma per coordinate (mm), else the
    calibration's noise estimate (an F-test then). See the module docstring.

    Parameters
    ----------
    robot : Robot
        The calibrated model under check.
    data : Measurements
        The check campaign: point (laser tracker) measurements of at least ``MIN_CHECK_POSES``
        poses, joints ``(n, dof)`` rad, points ``(n, 3)`` m.
    uncertainty : Uncertainty
        What the calibration left uncertain: parameter names, covariance ``(k, k)`` (SI), noise
        (m per coordinate) and its degrees of freedom.
    fit_frame : bool, optional
        Refit the tracker frame and SMR offsets before judging (the tracker moved since).
    noise_mm : float, optional
        The instrument's 1-sigma noise per coordinate (mm, in (0, 10)); None: the calibration's
        estimate, tested with an F-test.
    force : bool, optional
        Judge even when the residuals are far beyond what the instrument explains.

    Returns
    -------
    CheckResult
        ``verdict`` "holds" or "changed" (at the significance ``ALPHA``), the p-value, the RMS
        (mm) against the RMS expected if nothing changed, and the parameters that most likely moved.

    Raises
    ------
    DataError
        Not point data, too few poses, uncertainty naming parameters the model lacks, a noise out
        of range, or residuals no calibration explains (without ``force``).

    See Also
    --------
    robocal.history.check.CheckResult : What it returns.
    robocal.history.History : Where calibrations and checks are recorded.
    robocal.history.offsets.recalibrate_offsets : What to do when only offsets moved.
    rc.evaluate : A model's errors on data, without a verdict.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.history.check import Uncertainty, check_calibration
    >>> nominal = rc.Robot.from_catalog("abb_irb2600")
    >>> sim = rc.simulate_tracker(nominal, 20, noise_mm=0.01, seed=3)
    >>> unc = Uncertainty(names=("a2",), covariance=np.array([[1e-10]]), noise_m=1e-5, dof=200)
    >>> check_calibration(sim.truth, sim.data, unc).verdict  # the true model: nothing moved
    'holds'
    >>> moved = sim.truth.with_values({"a2": sim.truth.get("a2") + 0.001})  # a model 1 mm off
    >>> result = check_calibration(moved, sim.data, unc)
    >>> result.verdict, result.changed_parameters[0]["name"], round(result.changed_parameters[0]["shift"])
    ('changed', 'a2', -1)
    """
    if data.kind != "point":
        raise DataError(f"a check needs point (laser tracker) measurements, not {data.kind}")
    data.check_against(robot)
    if data.n_poses < MIN_CHECK_POSES:
        raise DataError(f"a check needs at least {MIN_CHECK_POSES} poses, the data have {data.n_poses}")
    unknown = [n for n in uncertainty.names if n not in robot.parameter_names]
    if unknown:
        raise DataError(f"the calibration's uncertainty names {unknown}, which this model does not have: "
                        "give the calibrated model that calibration wrote")
    if noise_mm is not None and not 0 < noise_mm < 10:
        raise DataError(f"--noise-mm must be between 0 and 10 mm, got {noise_mm}")
    start = register(robot, data) if fit_frame else robot
    kw = {"smr": data.smr, "conditions": Conditions(data.approach, data.travel)}
    modelled = start.fk(data.joints, **kw)[:, :3, 3]
    r = (data.points - modelled).reshape(-1)
    rms_mm = float(np.sqrt(np.mean(np.sum((data.points - modelled) ** 2, axis=1)))) * 1e3
    try:
        check_residual(rms_mm, modelled, "the check data (calibrated model, "
                       + ("frame fitted)" if fit_frame else "its own frame)"), force=force)
    except PlausibilityError as exc:  # the data's own diagnosis first (flipped joints, a frame, a unit)
        raise diagnosed(exc, robot, [data], frame_fitted=fit_frame) from None
    smr_names = ["tool.x", "tool.y", "tool.z", *(f"smr{k}.{c}" for k in range(1, data.n_smr) for c in "xyz")]
    groups = {"tracker": list(FRAME_NAMES[:6]), "smr": smr_names}
    every_frame = [*groups["tracker"], *smr_names]
    frame = every_frame if fit_frame else []

    zeros, others = candidates(start)
    names = [*zeros, *others]
    every = list(dict.fromkeys([*uncertainty.names, *every_frame, *names]))  # one Jacobian for all
    J_all, at = start.jacobian(data.joints, every, **kw).reshape(len(r), len(every)), \
        {n: i for i, n in enumerate(every)}

    def columns(names) -> np.ndarray:
        return J_all[:, [at[n] for n in names]]

    if noise_mm is None and uncertainty.kind not in TRACKER_KINDS:
        raise DataError(f"the calibration used {uncertainty.kind} data, whose noise is not the tracker's "
                        "per coordinate: state the tracker's noise with --noise-mm")
    if noise_mm is None:
        noise, noise_dof, source = uncertainty.noise_m, uncertainty.dof, "calibration"
    else:
        noise, noise_dof, source = noise_mm * 1e-3, None, "stated"
    Jc = columns(uncertainty.names)
    C = noise ** 2 * np.eye(len(r)) + Jc @ uncertainty.covariance @ Jc.T
    space = _Whitened(r, columns(frame) if frame else np.zeros((len(r), 0)), C)
    T = space.fit()[0] if frame else float(space.r @ space.r)
    dof = len(r) - space.rank
    p = _p_value(T, dof, noise_dof)
    predicted = float(np.sqrt(np.trace(C) / data.n_poses)) * 1e3
    result = CheckResult(verdict="changed" if p < ALPHA else "holds", p_value=p, statistic=T, dof=dof,
                         noise_dof=noise_dof, noise_m=noise, noise_source=source, n_poses=data.n_poses,
                         rms_mm=rms_mm, predicted_rms_mm=predicted)
    blocks = columns(names)
    hidden = confounded(names, blocks, columns(every_frame), space.L)
    if fit_frame and hidden:
        result.notes.append(UNSEEN_WITH_FRAME.format(names=", ".join(hidden)))
    if result.verdict == "changed":
        if not fit_frame:  # the frames kept fixed first: a moved tracker or SMR is not the robot
            space, T, p, dof = _frame_change(result, r, C, columns, groups, noise_dof)
        pools = [[n for n in pool if n not in hidden] for pool in (zeros, others)]
        _explain(result, space, T, p, dof, dict(zip(names, blocks.T[:, :, None], strict=True)), start, pools,
                 noise_dof)
    return result


def _significant(T: float, T_new: float, dof_new: int, k: int) -> bool:
    """Whether refitting ``k`` more columns, which leave ``T_new`` on ``dof_new`` degrees of
    freedom, explains a significant part of ``T`` (the drop against the chi-square of ``k``,
    scaled by what is left unexplained)."""
    return (T - T_new) / max(T_new / max(dof_new, 1), 1.0) > stats.chi2.isf(ALPHA, k)


def _frame_change(result: CheckResult, r: np.ndarray, C: np.ndarray, columns, groups: dict,
                  noise_dof) -> tuple[_Whitened, float, float, int]:
    """Without a frame fit: which of the frames the model kept (the SMR offsets, the tracker frame)
    moved, tested before any link parameter, greedily (the group that lowers ``T`` most, while it
    explains a significant part); fills ``frame_change`` and returns the space with those groups
    refitted, its ``T``, p-value and degrees of freedom for the link parameters that may follow."""
    chosen: list[str] = []
    T, p, dof = result.statistic, result.p_value, len(r)
    empty = _Whitened(r, np.zeros((len(r), 0)), C)
    fits = {}
    while p < ALPHA and len(chosen) < len(groups):
        trials = {g: empty.fit(columns([n for c in (*chosen, g) for n in groups[c]]))
                  for g in groups if g not in chosen}
        best = min(trials, key=lambda g: trials[g][0])
        T_new, rank = trials[best][:2]
        if not _significant(T, T_new, len(r) - rank, rank - (len(r) - dof)):
            break
        chosen.append(best)
        fits = {"T": T_new, "rank": rank, "x": trials[best][2]}
        T, dof = T_new, len(r) - rank
        p = _p_value(T, dof, noise_dof)
    if not chosen:
        return empty, result.statistic, result.p_value, len(r)
    names = [n for c in chosen for n in groups[c]]
    change = {"moved": chosen, "explained_p_value": p,
              **_frame_shift(chosen, groups, names, fits["x"], columns)}
    result.frame_change = change
    result.explained_p_value = p
    return _Whitened(r, columns(names), C), T, p, dof


def _frame_shift(chosen: list[str], groups: dict, names: list[str], estimate: np.ndarray, columns) -> dict:
    """`CheckResult.frame_change`'s figures of the frame groups ``chosen`` from their ``names``'
    ``estimate`` (SI): the SMR that moved most and its shift (mm, flange frame), the tracker
    frame's translation (mm), rotation (deg) and how far it moves the check's points (mm RMS; the
    frame's origin is the tracker's, so the translation alone says little)."""
    x = dict(zip(names, estimate, strict=True))
    out = {}
    if "smr" in chosen:
        shifts = np.array([x[n] for n in groups["smr"]]).reshape(-1, 3) * 1e3  # (SMRs, 3) mm
        k = int(np.argmax(np.linalg.norm(shifts, axis=1)))  # the SMR that moved most
        out.update(smr=k, smr_shift_mm=shifts[k].tolist(),
                   smr_shift_norm_mm=float(np.linalg.norm(shifts[k])))
    if "tracker" in chosen:
        moves = (columns(groups["tracker"]) @ np.array([x[n] for n in groups["tracker"]])).reshape(-1, 3)
        out.update(translation_mm=[x[f"base.{c}"] * 1e3 for c in "xyz"],
                   rotation_deg=[float(np.rad2deg(x[f"base.r{c}"])) for c in "xyz"],
                   points_moved_rms_mm=float(np.sqrt(np.mean(np.sum(moves**2, axis=1)))) * 1e3)
    return out


def _explain(result: CheckResult, space: _Whitened, T: float, p: float, dof: int, blocks: dict, robot,
             pools, noise_dof) -> None:
    """Greedy re-identification of what moved (module docstring), from the statistic ``T`` (p-value
    ``p``, ``dof``) of ``space``; ``blocks`` the candidates' columns: fills ``changed_parameters``."""
    chosen: list[str] = []
    while p < ALPHA and len(chosen) < MAX_CHANGED:
        for pool in pools:
            trials = {}
            for name in pool:
                if name not in chosen:
                    J = np.hstack([blocks[c] for c in (*chosen, name)])
                    T_new, rank, _, _ = space.fit(J)
                    if rank == space.rank + len(chosen) + 1:  # the column adds information
                        trials[name] = T_new
            if not trials:
                continue
            best = min(trials, key=trials.get)
            if _significant(T, trials[best], dof - len(chosen) - 1, 1):  # a significant part explained
                break
        else:
            break
        chosen.append(best)
        T = trials[best]
        p = _p_value(T, dof - len(chosen), noise_dof)
    if not chosen:
        if result.frame_change is None:
            result.notes.append("no single link parameter explains the change: the robot moved in a way "
                                "its geometric model does not describe (or the check data are wrong)")
        return
    T, _, x, cov = space.fit(np.hstack([blocks[c] for c in chosen]))
    m = dof - len(chosen)
    scale = max(T / m, 1.0)  # what the chosen set leaves unexplained widens the intervals
    k = space.F.shape[1]
    for j, name in enumerate(chosen):
        unit, f = _display(name, robot)
        result.changed_parameters.append({"name": name, "unit": unit, "shift": float(x[k + j] * f),
                                          "sigma": float(np.sqrt(cov[k + j, k + j] * scale) * f)})
    result.explained_p_value = p
