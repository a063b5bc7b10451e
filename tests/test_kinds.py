"""The registry of measurement kinds (robocal.data.kinds): one spec per kind, naming its observation
model, the arrays it needs and what it sees."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from robocal.core.errors import DataError
from robocal.data.kinds import KINDS, OBSERVED, kind_spec
from robocal.data.measurements import Measurements
from robocal.kinematics.model import Robot


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_names_its_observation_model(kind):
    module, cls = OBSERVED[kind].observation.split(":")
    observation = getattr(importlib.import_module(f"robocal.identify.observations.{module}"), cls)
    assert observation.kind == kind


def test_capabilities_and_readings():
    assert [k for k in KINDS if OBSERVED[k].sees_position] == ["point", "pose"]
    assert [k for k in KINDS if OBSERVED[k].sees_orientation] == ["pose"]
    assert OBSERVED["distance"].group == "pair" and OBSERVED["distance"].rows_per_placement == 2
    robot = Robot.from_catalog("abb_irb2600")
    q = np.array([[0.1, -0.2, 0.3, 0.4, 0.5, 0.6], [0.0, 0.1, 0.2, 0.0, 0.3, 0.0]])
    T = robot.fk(q)
    for kind in ("point", "pose"):
        data = Measurements.from_arrays(kind, q, **kind_spec(kind).readings(T))
        assert data.spec is OBSERVED[kind] and set(OBSERVED[kind].arrays) <= {
            f for f in ("points", "rotations") if getattr(data, f) is not None}
    assert [k for k in KINDS if OBSERVED[k].sees_tilt] == ["flush"]
    with pytest.raises(DataError, match="unknown measurement kind 'laser': use one of point, pose, plane, "
                                        "flush, distance"):
        kind_spec("laser")
