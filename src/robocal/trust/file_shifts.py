"""Held-out errors split into a shift common to each validation file and the scatter within files.

A validation measured in other sessions than the calibration (another day, the tracker set up
again, the arm at another temperature) carries a shift per session that no calibration data can
predict: the held-out RMS then mixes the model's error with the sessions' differences. When the
validation comes as several files (one per session, as trackers export them), each file's mean
error is its shift and the test tells whether the shifts are real:

- per pose, the mean 3-D error of its items (the SMRs of one pose share the robot's error, so the
  poses are the independent units); files with fewer than :data:`MIN_FILE_POSES` poses are left
  out, and the test needs two files;
- ``F = [sum_f n_f |m_f|^2 / (3 F)] / [sum_f sum_i |e_i - m_f|^2 / (3 (N - F))]`` with ``m_f`` the
  mean error of file ``f``'s ``n_f`` poses: under no shift (zero-mean errors, independent poses)
  it follows Fisher's F with ``(3 F, 3 (N - F))`` degrees of freedom;
- the shifts' share of the held-out mean square (3-D, per pose), unbiased:
  ``(sum_f n_f |m_f|^2 - 3 F s^2) / N`` with ``s^2`` the within-file variance per coordinate
  (0 when negative); the rest of the mean square, ``3 s^2`` unless clipped, is the error within the
  files: what the held-out error would be without the shifts.

The shifts are reported (a warning) when ``p <`` :data:`SHIFT_ALPHA` and they carry at least
:data:`SHIFT_MIN_SHARE` of the held-out mean square. The test cannot tell a session's shift from an
error of the model that is constant over one file's poses (files covering different regions);
the sentence names both. Measured on the real Meca500 data with compliance, gear, backlash and cyclic
terms (seven validation files of ten poses, measured apart from the calibration): shifts of 6.6 um
RMS, ``p = 2.3e-4``, the error within the files 16.1 um of the held-out 17.4; ten poses held out of
each calibration file instead (the calibration's own sessions, 20 seeds) give a mean F of 1.2 and
none reported (lowest p 0.0017). Without the gear term the model's error over the files' regions
shows: 2 of those 20 reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import fdtrc  # F.sf without importing scipy.stats

SHIFT_ALPHA = 1e-3  # the shifts are reported below this p-value (as the residual test) ...
SHIFT_MIN_SHARE = 0.05  # ... when they carry at least this share of the held-out mean square
MIN_FILE_POSES = 3  # a validation file with fewer poses has no mean to test


@dataclass(frozen=True)
class FileShifts:
    """The split of the held-out error over validation files (module docstring): each file's label,
    poses and mean error (mm, 3 coordinates in the tracker frame), the F statistic with its degrees
    of freedom and p-value, and the 3-D RMS per pose (mm) of the errors, of the shifts' share and of
    the errors within the files."""

    files: tuple[str, ...]
    poses: tuple[int, ...]
    shifts_mm: np.ndarray
    statistic: float
    dof: tuple[int, int]
    p_value: float
    rms_mm: float
    shift_rms_mm: float
    within_rms_mm: float

    @property
    def significant(self) -> bool:
        """The files' shifts are real and not negligible (module docstring)."""
        return self.p_value < SHIFT_ALPHA and self.shift_rms_mm**2 >= SHIFT_MIN_SHARE * self.rms_mm**2

    def sentence(self, role: str = "validation") -> str:
        """The finding in words, for the warnings: ``role`` 'validation' (held-out files) or
        'calibration' (files calibrated together in one tracker frame)."""
        of = "the held-out" if role == "validation" else "the residual's"
        tail = ("the calibration data cannot predict the first two" if role == "validation" else
                "one tracker frame is fitted to all the files: calibrate the files of one setup together, "
                "or recalibrate the sessions apart")
        return (f"the {role} files are shifted from each other: a shift common to each file's poses "
                f"carries {self.shift_rms_mm:.3g} mm RMS of {of} {self.rms_mm:.3g} mm (F test across "
                f"{len(self.files)} files, p = {self.p_value:.2g}); within the files the model misses by "
                f"{self.within_rms_mm:.3g} mm. A shift per file is the tracker or the robot's base set up "
                "again between sessions, the arm at another temperature, or an error of the model constant "
                f"over a file's poses; {tail}")

    def to_dict(self) -> dict:
        return {"test": "F test of the validation files' mean errors", "statistic": self.statistic,
                "dof": list(self.dof), "p_value": self.p_value, "alpha": SHIFT_ALPHA,
                "rms_mm": self.rms_mm, "shift_rms_mm": self.shift_rms_mm, "within_rms_mm": self.within_rms_mm,
                "significant": self.significant,
                "files": [{"file": f, "poses": n, "shift_mm": s.tolist()}
                          for f, n, s in zip(self.files, self.poses, self.shifts_mm, strict=True)]}


def pose_means(errors: np.ndarray, pose_id: np.ndarray) -> np.ndarray:
    """The mean error ``(P, 3)`` of each pose (in the order of the pose ids) of item errors
    ``errors (N, 3)`` whose poses are ``pose_id (N,)``."""
    _, inverse, counts = np.unique(pose_id, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), errors.shape[1]))
    np.add.at(sums, inverse, errors)
    return sums / counts[:, None]


def split_by_file(labels: list[str], errors: list[np.ndarray]) -> FileShifts | None:
    """The test of the module docstring on validation (or calibration) files named ``labels``
    with their per-pose errors ``errors`` (each ``(n_f, 3)``, m); None with fewer than two files of at least
    :data:`MIN_FILE_POSES` poses."""
    kept = [(label, np.asarray(e, float)) for label, e in zip(labels, errors, strict=True)
            if len(e) >= MIN_FILE_POSES]
    if len(kept) < 2:
        return None
    n = np.array([len(e) for _, e in kept])
    means = np.array([e.mean(axis=0) for _, e in kept])  # (F, 3)
    within = sum(float(np.sum((e - m) ** 2)) for (_, e), m in zip(kept, means, strict=True))
    F, N = len(kept), int(n.sum())
    dof = (3 * F, 3 * (N - F))
    s2 = within / dof[1]  # per coordinate
    between = float(np.sum(n * np.sum(means**2, axis=1)))
    statistic = (between / dof[0]) / s2 if s2 > 0 else np.inf
    total = between + within
    shift_ms = max(0.0, (between - dof[0] * s2) / N)
    return FileShifts(files=tuple(label for label, _ in kept), poses=tuple(int(k) for k in n),
                      shifts_mm=means * 1e3, statistic=float(statistic), dof=dof,
                      p_value=float(fdtrc(dof[0], dof[1], statistic)) if np.isfinite(statistic) else 0.0,
                      rms_mm=float(np.sqrt(total / N)) * 1e3, shift_rms_mm=float(np.sqrt(shift_ms)) * 1e3,
                      within_rms_mm=float(np.sqrt(total / N - shift_ms)) * 1e3)
