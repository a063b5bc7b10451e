"""Observation types: each turns measurements into residuals and Jacobian rows.

A new observation type is one new module here with a class implementing the interface of
:class:`robocal.identify.observations.base.Observation`, and its kind's line in the registry of
kinds, `robocal.data.kinds.OBSERVED` (which names the class).
"""

from __future__ import annotations

import importlib

from robocal.core.errors import IdentificationError
from robocal.data.kinds import OBSERVED


def observation_for(data, robot, **options):
    """The observation object for a Measurements set (by its ``kind``)."""
    spec = OBSERVED.get(data.kind)
    if spec is None:
        raise IdentificationError(
            f"no observation model for measurements of kind {data.kind!r}; "
            f"known kinds: {sorted(OBSERVED)}")
    module, cls = spec.observation.split(":")
    return getattr(importlib.import_module(f"{__name__}.{module}"), cls)(data, robot, **options)
