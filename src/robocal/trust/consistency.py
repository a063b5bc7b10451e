"""Residuals against the instrument: does a fitted model miss its data by more than the measurement
noise and the error model's unmodelled budget explain, and if so, why?

**The residual test.** Each residual item (a point's 3-D error, a plane deviation, a distance) is
expected to scatter with variance ``sigma_i^2 + b^2`` per coordinate: ``sigma_i`` the
instrument's 1-sigma (the file's ``sigma_mm`` column, else the ``sigma`` given per kind, else the
documented default of the instrument, :data:`robocal.identify.problem.KIND_SIGMA`: a laser tracker
20 um, a touch probe 10 um, a ball bar 5 um) and ``b`` the unmodelled-error budget of the error
model: what a real robot's errors outside the model (compliance, gears, temperature) can leave
after a fit, :data:`UNMODELLED_MM_PER_M` per metre of the robot's reach per coordinate
(generous: the real IRB 120 data leave 0.36 mm per coordinate at 0.66 m after a geometric fit, the
Meca500 data 0.025 mm at 0.36 m). The statistic is ``X = sum_i |e_i|^2 / (sigma_i^2 + b^2)`` with
``dof = (residual components) - (estimated unknowns)``; the fit is *inconsistent* when the
chi-square upper tail ``P(chi2(dof) >= X)`` is below :data:`ALPHA`.

**Change points along the row order.** Per point or pose file, a mean shift of the 3-D residual
along the measuring order (binary segmentation's first split, CUSUM statistic
``max_k |S_k|^2 / (k (N - k) / N)`` with ``S_k`` the cumulative sum of the centred residuals),
in the tracker frame (the tracker or the base moved) and in the flange frame (the SMR was moved
to another nest or re-seated). Its p-value is a permutation test (:data:`PERMUTATIONS` seeded
shuffles of the rows, both frames in each; exact when the rows are exchangeable, as they are
for a model that fits). A change point is reported when ``p <`` :data:`STEP_ALPHA` and the step
is larger than :data:`STEP_MIN_SIGMAS` noise sigmas and :data:`STEP_MIN_RESIDUAL_RATIO` of the
residual's 3-D RMS (a real, but negligible, drift is not a finding). A linear trend that explains
the residual better than the step is called a drift. A change point where a joint starts or stops
standing still (within :data:`robocal.data.measurements.NEAR_REPEAT_RAD`) for at least a segment's
rows (a blocked scan: a positioner's tilt held while its table turns) is an error of the model at
that joint's value as much as a moved instrument: the rows are not exchangeable there, and the
sentence names the joint and says the data cannot tell the two apart (`held_joint`).

**Diagnosis** of an inconsistent fit, in order: the change point; the orientation convention of a
6-DOF pose file (quaternions scalar-last under ``qw,qx,qy,qz`` headers, or the inverse rotation:
each tried, the one that fits named); the hypotheses registered in
:data:`robocal.trust.diagnosis.HYPOTHESES`, in their order (:func:`robocal.trust.diagnosis.first_reason`:
joint columns exchanged or signs flipped, an arm mounted turned, a mirrored frame, the length unit,
FANUC's J2/J3 coupling); when none of them, priors too tight for the robot
(:func:`robocal.trust.diagnosis.priors_too_tight`).

**Worse than nominal.** A fitted model that misses its own data by more than the nominal model
with the frames fitted (beyond :data:`WORSE_TOLERANCE`) is not written
(:func:`check_not_worse`, PlausibilityError; ``force`` turns it into a warning).

False alarms measured on clean simulated campaigns: ``benchmarks/bench_trust.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation
from scipy.special import chdtrc  # chi2.sf without importing scipy.stats (a third of start-up)

from robocal.core.errors import PlausibilityError, RobocalError
from robocal.data.instruments import noise_of
from robocal.data.measurements import NEAR_REPEAT_RAD, robot_reach
from robocal.data.registration import register_frame
from robocal.identify.plausibility import FORCE_HINT
from robocal.trust.diagnosis import (
    GAIN,
    first_reason,
    fit_rms_mm,
    priors_too_tight,
)
from robocal.trust.file_shifts import FileShifts, pose_means, split_by_file

ALPHA = 1e-3  # the residual test's false-alarm probability per fit (model and noise right)
UNMODELLED_MM_PER_M = 0.5  # unmodelled-error budget: mm (1 sigma, per coordinate) per metre of reach
STEP_ALPHA = 0.01  # a change point is reported below this permutation p-value ...
STEP_MIN_SIGMAS = 5.0  # ... when the step exceeds this many noise sigmas ...
STEP_MIN_RESIDUAL_RATIO = 0.5  # ... and this fraction of the residual's 3-D RMS
PERMUTATIONS = 199  # shuffles of the change-point permutation test (seeded)
MIN_SEGMENT_FRACTION = 0.05  # a change point leaves at least this fraction of the rows on each side ...
MIN_SEGMENT_ROWS = 3  # ... and at least this many rows
MIN_CHANGE_ROWS = 12  # files with fewer point/pose rows are not searched for change points
ORIENTATION_FIT_DEG = 1.0  # a pose file's orientation convention fits when it leaves at most this RMS
WORSE_TOLERANCE = 1.001  # a fit whose RMS exceeds the nominal's by this factor is worse than nominal
_PERMUTATION_BATCH = 20  # shuffles evaluated together at most ...
# ... and fewer on long files: a batch's temporaries (per shuffle and row: the random draws and
# their order, the shuffled and the centred-and-summed copies of 2 frames x 3 floats, the sums of
# squares and their ratio; 144 bytes) stay within this many bytes, so one shuffle at a time
# beyond ~470,000 rows and the test's memory grows with the rows by ~150 bytes a row
_PERMUTATION_BYTES = 64 * 2**20
_CUSUM_BYTES_PER_VALUE = 24  # the temporaries above per row and per value of a shuffled row (2 x 3)


@dataclass(frozen=True)
class ChangePoint:
    """A mean shift of the residual along the row order of one file: the first row after it
    (``index`` 0-based among the file's rows; ``row`` the 1-based source row), the frame it is
    constant in (``"tracker"`` or ``"flange"``), the step (mm, 3-D norm of the mean difference),
    the permutation p-value and whether a step or a linear drift explains it better."""

    file: str
    index: int
    row: int
    n_rows: int
    frame: str
    step_mm: float
    p_value: float
    shape: str
    joint: str = ""  # a joint standing still on one side of it (`held_joint`): its name, ...
    joint_deg: float = 0.0  # ... the value it stood at (deg; mm for a prismatic joint) ...
    joint_rows: int = 0  # ... and for how many rows (> 0: the rows before it, < 0: the rows after)

    def _confound(self) -> str:
        """What else explains a change point where a joint stood still (module docstring)."""
        if not self.joint:
            return ""
        moves = (f"leaves {self.joint_deg:.4g} there, where it stood for the {self.joint_rows} rows before"
                 if self.joint_rows > 0 else
                 f"comes to {self.joint_deg:.4g} there and stands for the {-self.joint_rows} rows after")
        return (f"; but joint {self.joint} {moves}, so an error of the model at that {self.joint} looks the "
                "same: these data cannot tell the two apart (interleave that joint's values in the measuring "
                "order, or re-measure one block)")

    def sentence(self) -> str:
        name = self.file or "the data"
        where = f"{name} row {self.row} (of {self.n_rows})"
        if self.shape == "drift":
            return (f"the residuals drift along the measuring order of {name} ({self.step_mm:.3g} mm "
                    f"between the halves split at row {self.row}, in the {self.frame} frame, permutation "
                    f"p = {self.p_value:.2g}): the tracker, the SMR or the robot drifted during the campaign "
                    "(temperature, a loose nest); re-measure, or calibrate the stable part"
                    f"{self._confound()}")
        cause = ("the SMR was moved to another nest or re-seated on the tool" if self.frame == "flange"
                 else "the tracker or the robot base moved (bumped)")
        return (f"the residuals step by {self.step_mm:.3g} mm at {where}, constant in the {self.frame} frame "
                f"(permutation p = {self.p_value:.2g}): {cause} there; calibrate the two parts as separate "
                f"files (another SMR index or another tracker station) or re-measure{self._confound()}")

    def to_dict(self) -> dict:
        held = ({"joint": self.joint, "joint_value": self.joint_deg, "joint_rows": abs(self.joint_rows),
                 "joint_held": "before" if self.joint_rows > 0 else "after"} if self.joint else {})
        return {"file": self.file, "index": self.index, "row": self.row, "n_rows": self.n_rows,
                "frame": self.frame, "step_mm": self.step_mm, "p_value": self.p_value, "shape": self.shape,
                **held}


@dataclass
class Consistency:
    """The residual test of one fit (module docstring): the statistic, its degrees of freedom and
    upper-tail p-value, the residual and expected RMS (mm, per item: 3-D for points), the noise and
    budget (mm, per coordinate), the verdict, change points and the diagnosis sentences."""

    statistic: float
    dof: int
    p_value: float
    rms_mm: float
    expected_rms_mm: float
    noise_mm: float
    budget_mm: float
    change_points: list[ChangePoint] = field(default_factory=list)
    diagnosis: list[str] = field(default_factory=list)

    @property
    def misfit(self) -> bool:
        """The residuals exceed what the noise and the budget explain (the chi-square test)."""
        return self.p_value < ALPHA

    @property
    def verdict(self) -> str:
        """'consistent', 'step' (a change point, the residual test passes) or 'inconsistent'."""
        return "inconsistent" if self.misfit else "step" if self.change_points else "consistent"

    def warnings(self, what: str = "the fit") -> list[str]:
        """The warning lines of this test (none when consistent)."""
        out = []
        if self.misfit:
            out.append(f"{what} misses its data by more than the instrument and the error model explain: "
                       f"{self.rms_mm:.4g} mm RMS against {self.expected_rms_mm:.3g} mm expected (noise "
                       f"{self.noise_mm:.3g} mm, unmodelled budget {self.budget_mm:.3g} mm per coordinate; "
                       f"chi-square {self.statistic:.4g} on {self.dof} dof, p = {self.p_value:.2g})"
                       + ("" if self.diagnosis else ": the data do not tell why (another robot, a mistake in "
                          "the file, or errors the model lacks)"))
        out += [f"{what}: {d}" for d in self.diagnosis]
        return out

    def to_dict(self) -> dict:
        return {"test": "chi-square of the weighted residual sum", "statistic": self.statistic,
                "dof": self.dof, "p_value": self.p_value, "alpha": ALPHA, "rms_mm": self.rms_mm,
                "expected_rms_mm": self.expected_rms_mm, "noise_mm": self.noise_mm,
                "budget_mm": self.budget_mm, "verdict": self.verdict,
                "change_points": [c.to_dict() for c in self.change_points], "diagnosis": self.diagnosis}


def budget_m(robot) -> float:
    """The unmodelled-error budget (m, 1 sigma per coordinate) of ``robot``'s error model."""
    return UNMODELLED_MM_PER_M * 1e-3 * robot_reach(robot)


def item_noise(data, kind: str, n_items: int, item_of_rows: np.ndarray,
               sigma: dict | None = None) -> np.ndarray:
    """1-sigma (m) of each of ``n_items`` residual items of ``data``: its sigma column (per row,
    ``item_of_rows`` maps rows to items), else ``sigma[kind]``, else its instrument's documented
    noise (`robocal.data.instruments.noise_of`: else the kind's)."""
    default = (sigma or {}).get(kind, noise_of(data))
    out = np.full(n_items, float(default))
    if data.sigma is not None:
        out[item_of_rows] = data.sigma
    return out


def residual_test(errors: list[np.ndarray], noise: list[np.ndarray], n_unknowns: int,
                  budget: float) -> Consistency:
    """The chi-square test of item errors ``errors`` (per file: ``(N, 3)`` or ``(N,)``, m) against
    their noise ``(N,)`` (m, 1 sigma per coordinate) and the budget (m), with ``n_unknowns``
    estimated unknowns."""
    stat, comps, sq, expected, n = 0.0, 0, 0.0, 0.0, 0
    noise_sq = 0.0
    for e, s in zip(errors, noise, strict=True):
        e = e.reshape(len(e), -1)
        var = s**2 + budget**2
        stat += float(np.sum(np.sum(e**2, axis=1) / var))
        comps += e.size
        sq += float(np.sum(e**2))
        expected += float(np.sum(var) * e.shape[1])
        noise_sq += float(np.sum(s**2))
        n += len(e)
    dof = max(comps - n_unknowns, 1)
    return Consistency(statistic=stat, dof=dof, p_value=float(chdtrc(dof, stat)),
                       rms_mm=float(np.sqrt(sq / max(n, 1))) * 1e3,
                       expected_rms_mm=float(np.sqrt(expected / max(n, 1))) * 1e3,
                       noise_mm=float(np.sqrt(noise_sq / max(n, 1))) * 1e3, budget_mm=budget * 1e3)


def _cusum(X: np.ndarray, splits: np.ndarray) -> np.ndarray:
    """CUSUM statistic ``(..., K)`` of residuals ``X (..., N, 3)`` at the splits (first rows of the
    second segment)."""
    N = X.shape[-2]
    S = X - X.mean(axis=-2, keepdims=True)
    np.cumsum(S, axis=-2, out=S)  # in place: one (..., N, 3) temporary
    S = S[..., splits[0] - 1:splits[-1], :]  # the splits are consecutive rows: a view
    S *= S
    sq = S[..., 0] + S[..., 1]  # the sum over x, y, z in np.sum's order: bit-identical
    sq += S[..., 2]
    return sq / (splits * (N - splits) / N)


def _permutation_batch(n_rows: int) -> int:
    """Shuffles of ``n_rows`` rows evaluated together: :data:`_PERMUTATION_BATCH`, fewer (at least
    one) where their temporaries would exceed :data:`_PERMUTATION_BYTES`. The batch changes
    neither the random draws (one stream, row after row) nor any shuffle's statistic."""
    per_shuffle = 2 * n_rows * 3 * _CUSUM_BYTES_PER_VALUE
    return int(min(_PERMUTATION_BATCH, max(1, _PERMUTATION_BYTES // per_shuffle)))


def change_point(errors: np.ndarray, rotations: np.ndarray, noise: float, seed: int = 0):
    """The most significant mean shift of residuals ``errors (N, 3)`` (m) along the row order, in
    the tracker frame and in the flange frame (``rotations (N, 3, 3)``: flange orientation per
    row), as ``(index, frame, step_m, p_value, shape)``, or None when it is not reported (module
    docstring: p-value, step size against ``noise`` (m, 1 sigma) and the residual)."""
    N = len(errors)
    m = segment_rows(N)
    if max(MIN_CHANGE_ROWS, 2 * m + 1) > N:
        return None
    X = np.stack([errors, np.einsum("nji,nj->ni", rotations, errors)])  # tracker, flange frame
    splits = np.arange(m, N - m + 1)
    observed = _cusum(X, splits)  # (2, K)
    f, j = np.unravel_index(np.argmax(observed), observed.shape)
    best = observed[f, j]
    rng = np.random.default_rng(seed)
    exceed = 0
    batch = _permutation_batch(N)
    for start in range(0, PERMUTATIONS, batch):
        P = min(batch, PERMUTATIONS - start)
        order = np.argsort(rng.random((P, N)), axis=1)
        exceed += int(np.count_nonzero(_cusum(np.take(X, order, axis=1), splits).max(axis=(0, 2)) >= best))
    p = (1 + exceed) / (PERMUTATIONS + 1)
    k = int(splits[j])
    Y = X[f]
    step = float(np.linalg.norm(Y[k:].mean(axis=0) - Y[:k].mean(axis=0)))
    rms = float(np.sqrt(np.mean(np.sum(errors**2, axis=1))))
    if p >= STEP_ALPHA or step < STEP_MIN_SIGMAS * noise or step < STEP_MIN_RESIDUAL_RATIO * rms:
        return None
    sse_step = float(np.sum((Y[:k] - Y[:k].mean(axis=0)) ** 2) + np.sum((Y[k:] - Y[k:].mean(axis=0)) ** 2))
    t = np.arange(N) - (N - 1) / 2
    coef = (t @ (Y - Y.mean(axis=0))) / (t @ t)
    sse_trend = float(np.sum((Y - Y.mean(axis=0) - np.outer(t, coef)) ** 2))
    return k, ("tracker", "flange")[f], step, p, "drift" if sse_trend < sse_step else "step"


def segment_rows(n_rows: int) -> int:
    """The fewest rows a change point leaves on each side of it in a file of ``n_rows``."""
    return max(MIN_SEGMENT_ROWS, int(MIN_SEGMENT_FRACTION * n_rows))


def _still_rows(still: np.ndarray) -> np.ndarray:
    """``still (R, n)`` bool -> per column, how many leading rows are True."""
    return np.where(still.all(axis=0), still.shape[0], np.argmin(still, axis=0))


def held_joint(q: np.ndarray, k: int, rows: int) -> tuple[int, float, int] | None:
    """A joint that moves at row ``k`` of joints ``q (N, n)`` after standing still (within
    NEAR_REPEAT_RAD) on at least ``rows`` rows before it, or before standing still on as many
    from it on: ``(joint 0-based, the value it stood at, rows it stood)`` (rows > 0 before row k,
    < 0 from it on), the longest standing one; None when none."""
    if not 0 < k < len(q):
        return None
    before = _still_rows(np.abs(q[:k][::-1] - q[k - 1]) <= NEAR_REPEAT_RAD)
    after = _still_rows(np.abs(q[k:] - q[k]) <= NEAR_REPEAT_RAD)
    moved = np.abs(q[k] - q[k - 1]) > NEAR_REPEAT_RAD
    stood = np.where(moved, np.maximum(before, after), 0)
    i = int(np.argmax(stood))
    if stood[i] < rows:
        return None
    if before[i] >= after[i]:
        return i, float(q[k - 1, i]), int(stood[i])
    return i, float(q[k, i]), -int(stood[i])


def find_change_points(robot, observations, errors: list[np.ndarray], noise: list[np.ndarray],
                       seed: int = 0) -> list[ChangePoint]:
    """The change points (:func:`change_point`) of every point or pose file: ``observations`` their
    observation models (``.data``, ``.kind``), ``errors`` their item errors (m) with ``robot``."""
    out = []
    for obs, e, s in zip(observations, errors, noise, strict=True):
        if not obs.data.spec.sees_position:
            continue
        data = obs.data
        R = robot.fk(data.joints, smr=data.smr, conditions=data.conditions.motion)[:, :3, :3]
        found = change_point(e, R, float(np.sqrt(np.mean(s**2))), seed)
        if found is not None:
            k, frame, step, p, shape = found
            cp = ChangePoint(file=data.label, index=k, row=int(data.source_row[k]), n_rows=len(data),
                             frame=frame, step_mm=step * 1e3, p_value=p, shape=shape)
            held = held_joint(data.joints, k, segment_rows(len(data)))
            if held is not None:
                i, value, stood = held
                spec = robot.joints[i]
                cp = replace(cp, joint=spec.name, joint_deg=float(spec.shown(value)), joint_rows=stood)
            out.append(cp)
    return out


def _tool_rotation(A: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The rotation ``T`` minimising sum |A_i T - R_i| (``A, R (N, 3, 3)``)."""
    U, _, Vt = np.linalg.svd(np.einsum("nji,njk->ik", A, R))
    return U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt


def _angle_rms_deg(A: np.ndarray, R: np.ndarray) -> float:
    """RMS angle (deg) of ``R_i`` from ``A_i T`` with the best tool rotation ``T``."""
    D = np.swapaxes(A @ _tool_rotation(A, R), 1, 2) @ R
    ang = Rotation.from_matrix(D).magnitude()
    return float(np.rad2deg(np.sqrt(np.mean(ang**2))))


def orientation_convention(robot, data) -> str | None:
    """For a 6-DOF pose file: another reading of its quaternions (scalar-last under
    ``qw,qx,qy,qz`` headers, the inverse rotation, both) under which the model's orientations fit
    (within :data:`ORIENTATION_FIT_DEG` and :data:`robocal.trust.diagnosis.GAIN` times better than as
    given), as a sentence; None otherwise."""
    if not data.spec.sees_orientation or data.rotations is None:
        return None
    try:
        reg = register_frame(robot, data)
    except (RobocalError, np.linalg.LinAlgError):
        return None
    links = replace(robot, base=np.eye(4), tool=np.eye(4), smr=np.zeros((0, 3)))
    A = reg.base[:3, :3] @ links.fk(data.joints, conditions=data.conditions.motion)[:, :3, :3]
    R = data.rotations
    q = Rotation.from_matrix(R).as_quat()  # x, y, z, w: the file's qx, qy, qz, qw as read
    last = Rotation.from_quat(q[:, [3, 0, 1, 2]]).as_matrix()  # the file's columns held x, y, z, w
    inverse = "the inverse rotations (tool to tracker where tracker to tool was meant)"
    readings = {"as given": R, "scalar-last (x, y, z, w) under the qw, qx, qy, qz headers": last,
                inverse: np.swapaxes(R, 1, 2), "scalar-last and inverse": np.swapaxes(last, 1, 2)}
    fits = {what: _angle_rms_deg(A, Rv) for what, Rv in readings.items()}
    given = fits.pop("as given")
    what, best = min(fits.items(), key=lambda t: t[1])
    if best <= ORIENTATION_FIT_DEG and best * GAIN < given:
        return (f"the quaternions look {what}: read so, the orientations fit the model to {best:.3g} deg RMS "
                f"({given:.3g} deg as given); fix the column order or the rotation's direction in the file")
    return None


def diagnose_misfit(robot, datasets) -> list[str]:
    """Why ``robot`` (nominal links, frames fitted or not) misses ``datasets`` (Measurements), after
    the change points: orientation convention, then the hypotheses registered in
    :data:`robocal.trust.diagnosis.HYPOTHESES` (first that fits per file). Empty when the data do
    not tell."""
    out = []
    for d in datasets:
        if not d.spec.sees_position or len(d) < 6:
            continue
        given = fit_rms_mm(robot, d)
        reason = orientation_convention(robot, d)  # a 6-DOF file's quaternions: before its positions
        if reason is None and given > 0 and np.isfinite(given):
            reason = first_reason(robot, d, given)  # the registered hypotheses, in their order
        if reason:
            out.append((f"{d.label}: " if len(datasets) > 1 and d.label else "") + reason)
    return out


def file_shifts(observations, errors: list[np.ndarray]) -> FileShifts | None:
    """The shift common to each point or pose file's poses among files fitted in one tracker frame
    (`robocal.trust.file_shifts.split_by_file` on the per-pose mean errors): a tracker set up again
    between the files' sessions shows as one; None with fewer than two such files."""
    kept = [(obs.data.label or f"file {i + 1}", pose_means(e, obs.data.pose_id))
            for i, (obs, e) in enumerate(zip(observations, errors, strict=True))
            if obs.data.spec.sees_position and e.ndim == 2 and e.shape[1] == 3 and len(e) == len(obs.data)]
    return split_by_file([label for label, _ in kept], [e for _, e in kept]) if len(kept) > 1 else None


def check_fit(robot, start, observations, errors: list[np.ndarray], n_unknowns: int, *,
              sigma: dict | None = None, seed: int = 0, priors=None) -> Consistency:
    """The residual test, change points, the files' shifts from each other (`file_shifts`) and
    (when the test fails or a change point is found) the diagnosis of a fit: ``robot`` the
    fitted model, ``start`` the nominal model (frames fitted) the diagnosis tries its hypotheses on,
    ``observations`` the files' observation models, ``errors`` their item errors with ``robot``
    (m), ``n_unknowns`` the unknowns estimated, ``sigma`` the noise per kind (m) given for files
    without a sigma column, ``priors`` the fit's prior group scales
    (:class:`robocal.identify.priors.PriorScales`: priors too tight for the robot are a diagnosis)."""
    noise = [item_noise(obs.data, obs.kind, len(e), obs.item_of_rows(), sigma)
             for obs, e in zip(observations, errors, strict=True)]
    result = residual_test(errors, noise, n_unknowns, budget_m(robot))
    result.change_points = find_change_points(robot, observations, errors, noise, seed)
    result.diagnosis = [c.sentence() for c in result.change_points]
    shifts = file_shifts(observations, errors)
    result.diagnosis += [shifts.sentence("calibration")] if shifts is not None and shifts.significant else []
    if result.misfit and not result.change_points:
        result.diagnosis += diagnose_misfit(start, [obs.data for obs in observations])
    mistakes = [d for d in result.diagnosis if d not in {c.sentence() for c in result.change_points}]
    # a mistake in the data first; a change point may itself be a kinematic error the priors held
    tight = priors_too_tight(priors) if result.misfit and not mistakes else None
    result.diagnosis += [tight] if tight else []
    return result


def check_not_worse(before_mm: float, after_mm: float, what: str, diagnosis: list[str], *,
                    force: bool = False, warnings: list[str] | None = None, refuse: bool = True) -> None:
    """A fitted model must not miss its own data by more than the nominal one (RMS, mm): the fit
    absorbed a mistake (PlausibilityError naming ``diagnosis``; ``force``: a warning). ``refuse``
    False (a solve stopped by a limit or a threshold, not converged): a warning only."""
    if after_mm <= WORSE_TOLERANCE * before_mm:
        return
    why = "; ".join(diagnosis) if diagnosis else ("a mistake in the data (a convention, a unit, a moved "
                                                  "SMR) or data the model cannot describe")
    if not refuse:
        if warnings is not None:
            warnings.append(f"{what}: the fitted model is worse than the nominal one on its own data "
                            f"({before_mm:.4g} -> {after_mm:.4g} mm RMS): the solve stopped before it "
                            "converged, or " + why)
        return
    message = (f"{what}: the fitted model is worse than the nominal one on its own data ({before_mm:.4g} -> "
               f"{after_mm:.4g} mm RMS), so it is not written: {why}")
    if not force:
        raise PlausibilityError(f"{message}; {FORCE_HINT}")
    if warnings is not None:
        warnings.append(f"FORCED past a plausibility check: {message}")
