"""Observation types: each turns measurements into residuals and Jacobian rows.

A new observation type is one new module here with a class implementing the interface of
:class:`robocal.identify.observations.base.Observation`, and one line in ``OBSERVATIONS``.
"""

from __future__ import annotations

import importlib

from robocal.core.errors import IdentificationError

# Measurements.kind -> "module:Class"
OBSERVATIONS = {
    "point": "point:PointObservation",
    "pose": "pose:PoseObservation",
    "distance": "distance:DistanceObservation",
    "plane": "plane:PlaneObservation",
}


def observation_for(data, robot, **options):
    """The observation object for a Measurements set (by its ``kind``)."""
    spec = OBSERVATIONS.get(data.kind)
    if spec is None:
        raise IdentificationError(
            f"no observation model for measurements of kind {data.kind!r}; "
            f"known kinds: {sorted(OBSERVATIONS)}")
    module, cls = spec.split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), cls)(data, robot, **options)
