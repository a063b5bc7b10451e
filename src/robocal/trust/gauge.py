"""What data without a world frame can promise: accuracy up to a rigid motion (and scale).

Plane and flush contacts and distances (a scale bar, check distances) are measured in no frame of
the robot's world: moving the whole robot rigidly (the base frame, or what the first link's
parameters do, which the planes' poses absorb) changes none of them, and without a length
reference (plane, flush) scaling every length changes none either. A calibration from them is
accurate up to that motion, so its predicted accuracy (:mod:`robocal.trust.coverage`) is the TCP
error left after it: for a parameter error ``dp`` the gauge motion ``g`` (the 6 base-frame
parameters, and the scale direction ``v``: every length parameter's value, ``G(q) v = p(q)``)
that best fits its TCP error over the workspace sample ``Q`` is removed,

    dp' = dp - Gamma (Gamma^T A Gamma)^-1 Gamma^T A dp,     A = mean over Q of G(q)^T G(q)

(``Gamma (k', m)`` the gauge directions in the robot parameters ``names'`` = the estimated ones,
the base frame's and, for the scale, every length), so the posterior covariance ``C`` becomes
``T C T^T`` over ``names'``: a :class:`~robocal.trust.coverage.Prediction` like any other, whose
per-target errors (``compensate --result``) are the errors after that motion. The scale, held at
one link's nominal length (:func:`robocal.identify.observations.plane.scale_reference`), keeps its
prior: it is reported apart (:func:`scale_section`), in mm over the workspace, not added.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.identify.priors import prior_sigma

RIGID = tuple(f"base.{f}" for f in ("x", "y", "z", "rx", "ry", "rz"))  # a rigid motion of the world


@dataclass(frozen=True)
class Gauge:
    """What the data of a calibration cannot see of the world: ``kinds`` (the observation kinds,
    for the text), and ``scale``, the length parameter held for the scale when no data set
    carries a length reference (None when one does)."""

    kinds: tuple[str, ...]
    scale: str | None

    @property
    def text(self) -> str:
        """``'up to a rigid motion of the world (and scale)'``."""
        return "up to a rigid motion of the world" + (" and scale" if self.scale else "")

    @property
    def why(self) -> str:
        """Why, in words: ``'plane contacts give no world frame nor length reference'``."""
        return (f"{' and '.join(self.kinds)} data give no world frame"
                + (" nor length reference" if self.scale else ""))


def gauge_of(observations, robot) -> Gauge | None:
    """The :class:`Gauge` of a problem's ``observations`` (each with ``world_frame`` and
    ``scale_reference(robot)``, :class:`robocal.identify.observations.base.Observation`), or None
    when a data set sees the world frame (points, poses, instruments' frames)."""
    observations = list(observations)
    if not observations or any(obs.world_frame for obs in observations):
        return None
    references = [obs.scale_reference(robot) for obs in observations]
    scale = None if any(r is None for r in references) else references[0]
    return Gauge(tuple(dict.fromkeys(obs.kind for obs in observations)), scale)


def _lengths(robot) -> list[str]:
    """The geometry's length parameters (links' a_i, d_i; base and tool translations)."""
    return [n for n, u in zip(robot.geometry_names, robot.parameter_units(), strict=False) if u == "m"]


def gauge_free(robot, names: list[str], covariance: np.ndarray, gauge: Gauge,
               q: np.ndarray) -> tuple[list[str], np.ndarray]:
    """``(names', C')``: the covariance ``(k, k)`` (SI) of the robot parameters ``names`` with the
    gauge motion that best fits each error's TCP displacement over the joints ``q (R, n)`` (rad)
    removed (module docstring); ``names'`` adds the base frame and, for the scale, the lengths."""
    lengths = _lengths(robot) if gauge.scale else []
    full = list(names) + [n for n in dict.fromkeys([*RIGID, *lengths]) if n not in names]
    index = {n: i for i, n in enumerate(full)}
    k, K = len(names), len(full)
    directions = np.zeros((K, len(RIGID) + (1 if gauge.scale else 0)))
    directions[[index[n] for n in RIGID], np.arange(len(RIGID))] = 1.0
    if gauge.scale:
        directions[[index[n] for n in lengths], -1] = robot.values_of(lengths)
    G = robot.jacobian(q, full, kind="point")  # (R, 3, K)
    A = np.einsum("rik,ril->kl", G, G) / len(q)
    E = np.eye(K, k)
    AG = A @ directions
    T = E - directions @ np.linalg.lstsq(directions.T @ AG, AG.T @ E, rcond=None)[0]
    return full, T @ covariance @ T.T


def scale_section(robot, gauge: Gauge, q: np.ndarray) -> dict | None:
    """What the scale's prior leaves over the joints ``q (R, n)`` when no length reference fixes
    it: the held length ``reference``, its nominal and prior (mm), the relative scale error and
    the RMS (mm) of the TCP displacement it makes about the sample's centroid; None with a length
    reference."""
    if gauge.scale is None:
        return None
    value, sigma = abs(robot.get(gauge.scale)), float(prior_sigma(robot, [gauge.scale])[0])
    p = robot.fk(q)[:, :3, 3]
    spread = float(np.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1))))
    relative = sigma / value if value > 0 and np.isfinite(sigma) else float("nan")
    rms_mm = relative * spread * 1e3
    text = (f"the scale rests on {gauge.scale}'s nominal {value * 1e3:.1f} mm: its prior "
            f"{sigma * 1e3:.3g} mm ({relative * 100:.2g} %) is ±{rms_mm:.3g} mm RMS over the workspace, "
            "not included")
    return {"reference": gauge.scale, "nominal_mm": value * 1e3, "prior_mm": sigma * 1e3,
            "relative": relative, "workspace_rms_mm": rms_mm, "text": text}
