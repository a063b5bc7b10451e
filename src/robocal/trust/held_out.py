"""Held-out figures judged against the calibration's own prediction, split into a tracker-frame
shift and the model's error.

A validation RMS means something only against what the calibration predicts at the same poses:
``p = sqrt(mean e(q_i)^2)`` with ``e(q)`` the predicted TCP error of
:meth:`robocal.trust.coverage.Prediction.error_mm` (the parameters' posterior propagated to the
pose plus the unmodelled error, which holds the instrument's noise). Per validation file of point
or pose data (items ``i = 1..N``, errors ``r_i`` measured minus modelled, m, with the calibration's
tracker frame):

- the held-out RMS ``h = sqrt(sum |r_i|^2 / N)``;
- the frame refitted on the file (6-DOF, :func:`robocal.data.registration.umeyama`, the rigid fit
  the registration of ``evaluate --fit-frame`` starts from) on the modelled points, and the model's
  error what is left, per degree of freedom: ``m = sqrt(sum |r'_i|^2 / (N - 2))`` (``3N - 6`` over
  3 coordinates); the frame shift is the RMS displacement the refitted frame makes at the file's
  points.

Verdict (:data:`HELD_OUT_FACTOR` as :data:`robocal.trust.coverage.EXTRAPOLATION_FACTOR`):

- ``h <= HELD_OUT_FACTOR p``: ``consistent``, the held-out figure is the validated one;
- else ``m <= HELD_OUT_FACTOR p``: ``frame shift``: the tracker was moved or re-registered between
  the calibration and the validation; the model is judged (and validated) on ``m``, a warning names
  the shift;
- else ``beyond the prediction``: the calibration does not explain these data, a warning headed
  "NOT VALIDATED" says so and the validated figure falls back to the calibration residual (the
  calibrated model itself owes nothing to the validation data: it is written). Up to
  :data:`ANOTHER_SETUP` ``p`` the likely cause is a calibration that does not carry over to these
  poses; beyond, it is no error a calibration leaves but another setup: another SMR nest or tool
  when refitting the SMR offsets with the frame (:func:`robocal.data.registration.register_frame`,
  as ``evaluate --fit-frame``) brings the error within :data:`ANOTHER_SETUP` ``p`` (not within the
  prediction: the calibrated wrist parameters, confounded with the calibration's tool, meet
  another tool), else another robot or a mismatched file. Nothing
  beyond the prediction is called validated.

On a small arm another SMR nest can miss by more than any robot's geometric errors: the
plausibility check of the validation data refuses the file before this judgement, and
:func:`refused_validation` names the nest there (the frame refitted alone against the frame and the
SMR offsets refitted together, as above).

The verdict compares the bulk of the items (:func:`robocal.identify.plausibility.bulk_rms_mm`: the
largest errors left out, as the plausibility checks do), so that a few gross errors in a validation
file (a mistyped row) do not make a right calibration look like another setup. Files with fewer
than :data:`MIN_FRAME_POSES` items are judged on ``h`` alone (no frame refitted).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robocal.core.errors import IdentificationError, PlausibilityError
from robocal.data.registration import refit_frame, umeyama
from robocal.identify.plausibility import bulk_rms_mm
from robocal.kinematics.transforms import matrix_to_rotvec
from robocal.trust.coverage import EXTRAPOLATION_FACTOR, Prediction

HELD_OUT_FACTOR = EXTRAPOLATION_FACTOR  # held-out RMS beyond this x the prediction: not validated
ANOTHER_SETUP = 10.0  # the model's error beyond this x the prediction: another setup, not the model
MIN_FRAME_POSES = 5  # items a file needs for its frame to be refitted (3 N - 6 degrees of freedom)
CONSISTENT, FRAME_SHIFT, BEYOND = "consistent", "frame shift", "beyond the prediction"


@dataclass(frozen=True)
class FileJudgement:
    """One validation file judged against the prediction (module docstring); figures in mm, the
    frame's rotation in deg."""

    file: str
    n: int
    predicted_mm: float
    held_out_mm: float
    model_error_mm: float
    frame_shift_mm: float
    frame_rotation_deg: float
    verdict: str
    cause: str = ""
    bulk_mm: tuple[float, float] = (0.0, 0.0)  # held out and model's error of the bulk (the verdict's)

    @property
    def ratio(self) -> float:
        """The model's error over the prediction, of the bulk of the items (the verdict's)."""
        return self.bulk_mm[1] / self.predicted_mm

    def to_dict(self) -> dict:
        return {"file": self.file, "n": self.n, "predicted_mm": self.predicted_mm,
                "held_out_mm": self.held_out_mm, "model_error_mm": self.model_error_mm,
                "frame_shift_mm": self.frame_shift_mm, "frame_rotation_deg": self.frame_rotation_deg,
                "bulk_held_out_mm": self.bulk_mm[0], "bulk_model_error_mm": self.bulk_mm[1],
                "ratio": self.ratio, "verdict": self.verdict, "cause": self.cause}

    def sentence(self) -> str:
        """The warning of a file that is not consistent with the prediction ('' if it is)."""
        figures = (f"held out {self.held_out_mm:.4g} mm RMS against {self.predicted_mm:.3g} mm predicted at "
                   f"these poses")
        if self.verdict == FRAME_SHIFT:
            return (f"the validation data {self.file}: {figures}: a tracker-frame shift of "
                    f"{self.frame_shift_mm:.3g} mm ({self.frame_rotation_deg:.3g} deg) carries it: with the "
                    "frame refitted on the validation data (as evaluate --fit-frame) the model misses them "
                    f"by {self.model_error_mm:.3g} mm, consistent with the prediction; the tracker was "
                    "moved or re-registered between the calibration and the validation. The model is judged "
                    f"on {self.model_error_mm:.3g} mm")
        if self.verdict == BEYOND:
            return (f"NOT VALIDATED: the validation data {self.file}: {figures}; with the tracker frame "
                    f"refitted on them the model still misses by {self.model_error_mm:.4g} mm, "
                    f"{self.ratio:.3g} x the prediction: {self.cause}")
        return ""


@dataclass(frozen=True)
class HeldOut:
    """Every validation file judged (:class:`FileJudgement`) and the figures over all of them (mm):
    the prediction, the held-out RMS and the model's error with each file's frame refitted."""

    files: tuple[FileJudgement, ...]

    def _rms(self, key: str) -> float:
        n = np.array([f.n for f in self.files], float)
        values = np.array([getattr(f, key) for f in self.files])
        return float(np.sqrt(np.sum(n * values**2) / n.sum()))

    @property
    def verdict(self) -> str:
        """The worst verdict of the files."""
        found = {f.verdict for f in self.files}
        return next(v for v in (BEYOND, FRAME_SHIFT, CONSISTENT) if v in found)

    @property
    def predicted_mm(self) -> float:
        return self._rms("predicted_mm")

    @property
    def model_error_mm(self) -> float:
        return self._rms("model_error_mm")

    def validated(self, prediction: Prediction, held_out_mm: float) -> Prediction:
        """``prediction`` with the validated error these files support: the held-out RMS when
        consistent, the model's error with the frames refitted after a frame shift, none (the
        calibration residual, said so) beyond the prediction."""
        if self.verdict == CONSISTENT:
            return prediction
        if self.verdict == FRAME_SHIFT:
            return replace(prediction, validated_mm=max(self.model_error_mm, 1e-6),
                           validated_from="on the validation data, tracker frame refitted")
        return replace(prediction, validated_mm=max(prediction.unmodelled_mm, 1e-6),
                       validated_from=f"NOT validated: the held-out {held_out_mm:.4g} mm is beyond the "
                                      "prediction; this is the calibration residual")

    def line(self) -> str:
        """The summary line."""
        shifted = [f for f in self.files if f.verdict == FRAME_SHIFT]
        largest = max((f.frame_shift_mm for f in shifted), default=0.0)
        shift = (f"; of it a tracker-frame shift of {largest:.4f} mm, the model's error "
                 f"{self.model_error_mm:.4f} mm") if shifted else ""
        return (f"held out against the prediction: {self._rms('held_out_mm'):.4f} mm RMS, "
                f"{self.predicted_mm:.4f} mm predicted at those poses{shift}: {self.verdict}"
                + (", NOT VALIDATED" if self.verdict == BEYOND else ""))

    def to_dict(self) -> dict:
        return {"verdict": self.verdict, "factor": HELD_OUT_FACTOR, "another_setup_factor": ANOTHER_SETUP,
                "predicted_mm": self.predicted_mm, "held_out_mm": self._rms("held_out_mm"),
                "model_error_mm": self.model_error_mm, "files": [f.to_dict() for f in self.files]}


def _frame_refit(errors: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The errors ``(N, 3)`` (m) left when the 6-DOF frame is refitted (the rigid fit of the
    modelled points ``measured - errors`` to ``measured``), the RMS displacement (m) and the rotation
    (rad) of that refit."""
    modelled = measured - errors
    B = umeyama(modelled, measured)
    moved = modelled @ B[:3, :3].T + B[:3, 3]
    shift = float(np.sqrt(np.mean(np.sum((moved - modelled) ** 2, axis=1))))
    return measured - moved, shift, float(np.linalg.norm(matrix_to_rotvec(B[:3, :3])))


class HeldOutError(PlausibilityError):
    """Validation data refused by the plausibility check, with the cause the calibrated model finds
    (:func:`refused_validation`): the nominal model's diagnosis of the data is not asked."""


def _smr_refit_mm(robot, data) -> tuple[float, float] | None:
    """The model's error (mm, per degree of freedom) on ``data`` with the tracker frame and the SMR
    offsets refitted (`register_frame`, as ``evaluate --fit-frame``) and how far the tool's SMR
    moved (mm); None where the poses cannot fix them."""
    reg = refit_frame(robot, data)
    if reg is None:
        return None
    dof = max(len(data) - 2 - data.n_smr, 1)
    return (float(np.sqrt(np.sum(reg.residuals**2) / dof)) * 1e3,
            float(np.linalg.norm(reg.offsets[0] - robot.tool[:3, 3])) * 1e3)


def _nest_sentence(refit_mm: float, moved_mm: float) -> str:
    return (f"with the SMR offset refitted too the model misses them by only {refit_mm:.3g} mm: they "
            f"were measured with another SMR nest or tool ({moved_mm:.4g} mm from the calibration's); "
            "measure the validation with the calibration's SMR and tool")


def refused_validation(error: PlausibilityError, judged) -> PlausibilityError:
    """``error`` (the plausibility check refusing validation data ``judged``: a calibration's
    `robocal.calibration.result.Judged`) as a :class:`HeldOutError` naming another SMR nest or tool
    when the frame refitted alone leaves more than :data:`ANOTHER_SETUP` times what the frame and
    the SMR offsets refitted together leave (another robot, or the same one in another tracker
    setup, is explained by neither; the sentence gives both figures); ``error`` itself otherwise."""
    data = judged.data
    if not data.spec.sees_position or len(data) < MIN_FRAME_POSES:
        return error
    errors = judged.problem.item_error_vectors(judged.states[1])[0]
    frame_only = bulk_rms_mm(_frame_refit(errors, data.points)[0])
    refit = _smr_refit_mm(judged.states[1].robot, data)
    if refit is None or frame_only <= ANOTHER_SETUP * refit[0]:
        return error
    return HeldOutError(f"NOT VALIDATED: the validation data {data.label}: with the tracker frame refitted "
                        f"on them the model still misses by {frame_only:.4g} mm; {_nest_sentence(*refit)} "
                        f"(the check: {error})")


def _cause(robot, data, predicted_mm: float, ratio: float) -> str:
    """The likely cause of held-out data the refitted frame does not explain, ``ratio`` times the
    prediction: up to :data:`ANOTHER_SETUP`, a calibration that does not carry over; beyond,
    another SMR nest or tool when the SMR offsets refitted with the frame (`register_frame`)
    explain them, else another robot or file."""
    if ratio <= ANOTHER_SETUP:
        return ("the calibration does not carry over to these poses (an error the model lacks, poses "
                "outside the calibrated region) or the setup changed between them; calibrate with poses "
                "like these")
    refit = _smr_refit_mm(robot, data)
    if refit is not None and refit[0] <= ANOTHER_SETUP * predicted_mm:  # wrist errors meet another tool
        return _nest_sentence(*refit)
    return ("they belong to another robot or another setup (another SMR or tool, a joint or point file "
            "mismatched); check the file")


def judge_file(robot, prediction: Prediction, data, errors: np.ndarray, fitted=None) -> FileJudgement:
    """One file of point or pose data judged against ``prediction`` for the calibrated ``robot``
    (module docstring): ``errors`` ``(N, 3)`` (m) measured minus modelled, one item per row of
    ``data``; ``fitted`` the model that made them (with the frame and SMR it used; default
    ``robot``), whose SMR is refitted to name a cause beyond the prediction."""
    measured = data.points  # point and pose data: one item per row
    if errors.shape != measured.shape:
        raise IdentificationError(f"internal: {len(errors)} items for {len(measured)} rows of "
                                  f"{data.label}, please report this")
    predicted = float(np.sqrt(np.mean(prediction.error_mm(robot, data.joints) ** 2)))
    n = len(errors)
    held = float(np.sqrt(np.mean(np.sum(errors**2, axis=1)))) * 1e3
    left, shift, turn, dof = errors, 0.0, 0.0, 1.0
    if n >= MIN_FRAME_POSES:
        left, shift_m, turn = _frame_refit(errors, measured)
        shift, dof = shift_m * 1e3, n / (n - 2)
    model = float(np.sqrt(np.mean(np.sum(left**2, axis=1)) * dof)) * 1e3
    bulk = (bulk_rms_mm(errors), bulk_rms_mm(left) * float(np.sqrt(dof)))
    verdict = CONSISTENT if bulk[0] <= HELD_OUT_FACTOR * predicted else \
        FRAME_SHIFT if bulk[1] <= HELD_OUT_FACTOR * predicted else BEYOND
    ratio = bulk[1] / predicted
    cause = _cause(robot if fitted is None else fitted, data, predicted, ratio) if verdict == BEYOND else ""
    return FileJudgement(data.label, n, predicted, held, model, shift, float(np.rad2deg(turn)), verdict,
                         cause, bulk)


# the calibrated model's validation RMS over the start model's beyond which the calibration is said to
# be no better (a start model already right: a calibration adds its own noise, a few percent)
WORSE_THAN_START = 1.1


def worse_than_start(before: dict | None, after: dict | None) -> str | None:
    """The warning when the calibrated model misses the validation data by more than the start
    (nominal) model does (``before``/``after``: their statistics, mm; each with its frames fitted on
    the calibration data); None otherwise. A prediction that grew with a poor fit can still call such
    a result consistent (FIGAROH's tiago set: 5.248 -> 7.388 mm, 4.10 mm predicted): the start model
    is the yardstick that is not the answer's own."""
    if not before or not after or not after["rms"] > WORSE_THAN_START * before["rms"]:
        return None
    return (f"NOT BETTER than the start model: on the validation data the calibrated model misses by "
            f"{after['rms']:.4g} mm RMS, the start model by {before['rms']:.4g} mm: the calibration does not "
            "carry over to those poses; keep the start model, or calibrate on more poses or fewer "
            "parameters (--nongeometric none)")


def held_out_of(files: list[FileJudgement], warnings: list[str] | None = None) -> HeldOut | None:
    """The :class:`HeldOut` of judged ``files`` (None without any); their warnings appended to
    ``warnings``."""
    if not files:
        return None
    if warnings is not None:
        warnings += [f.sentence() for f in files if f.verdict != CONSISTENT]
    return HeldOut(tuple(files))


def judge_held_out(robot, prediction: Prediction, judged: list, warnings: list[str] | None = None
                   ) -> HeldOut | None:
    """Judge every validation file of point or pose data in ``judged`` (a calibration's
    `robocal.calibration.result.Judged`: data, problem, states) against ``prediction`` for the
    calibrated ``robot`` (:func:`judge_file`); their warnings appended to ``warnings``. None
    without such a file."""
    return held_out_of([judge_file(robot, prediction, j.data, j.problem.item_error_vectors(j.states[1])[0],
                                j.states[1].robot) for j in judged if j.data.spec.sees_position], warnings)
