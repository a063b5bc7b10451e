"""The positioner's campaign (issue 45): the nests' identification Jacobian against finite
differences, the tracker's line of sight to the nests, and the planned table angles' predicted
accuracy against simulated calibrations with a known truth (a brute-force least-squares fit of the
true FK, independent of the planner's Jacobian), better than a naive grid of as many angle sets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import least_squares

import robocal as rc
from robocal.campaign import Tracker
from robocal.campaign.positioner import (
    nest_jacobian,
    nest_visibility,
    plan_table,
    table_grid,
    table_unknowns,
)
from robocal.core.errors import DataError
from robocal.kinematics.transforms import make_transform

NESTS = np.array([[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.15, -0.15, 0.0]])  # m, plate frame
MOUNT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])        # frame {0}: z along world x


def tilt_turn() -> rc.Robot:
    """A 2-axis tilt-and-turn table: tilt about world x 0.9 m up at x = 1.4 m, turn about the plate
    normal 0.25 m above the tilt axis (world z at zero)."""
    return rc.Robot.from_mdh(alpha=[0, -90], a=[0, 0], theta=[0, 0], d=[0, 0.25], degrees=True,
                             base=make_transform(MOUNT, [1.4, 0.0, 0.9]),
                             limits=[[-90, 90], [-360, 360]], name="STN1")


def test_the_plate_is_level_and_turns_about_world_z_at_zero():
    chain = tilt_turn()
    F = chain.fk(np.zeros((1, 2)))[0]
    np.testing.assert_allclose(F[:3, 3], [1.4, 0.0, 1.15], atol=1e-12)
    np.testing.assert_allclose(F[:3, 2], [0.0, 0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize("known", [True, False])
def test_nest_jacobian_matches_finite_differences(known):
    chain = rc.Robot.from_mdh(alpha=[0, -80], a=[0, 0.01], theta=[0, 5], d=[0, 0.25], degrees=True,
                              base=make_transform(np.eye(3), [1.4, 0.0, 0.9]),
                              tool=make_transform(np.eye(3), [0.01, 0.02, 0.03]),
                              limits=[[-90, 90], [-360, 360]])
    q = np.deg2rad([[20.0, 30.0], [-50.0, 170.0], [70.0, -250.0]])
    names = table_unknowns(chain, len(NESTS), known)
    J = nest_jacobian(chain, q, NESTS, names)
    h = 1e-6

    def positions(name: str, step: float) -> np.ndarray:
        nests = NESTS.copy()
        robot = chain
        if name.startswith("smr"):
            nests[int(name[3]) - 1, "xyz".index(name[-1])] += step
        else:
            robot = chain.with_values({name: chain.get(name) + step})
        F = robot.fk(q)
        return np.einsum("nij,kj->nki", F[:, :3, :3], nests) + F[:, None, :3, 3]

    base = [j for j, nm in enumerate(names) if nm.startswith("base.")]
    for j, name in enumerate(names):
        fd = (positions(name, h) - positions(name, -h)) / (2 * h)
        if name.startswith("base.r"):  # a turn of the mount about its own origin: in the span of the
            # base columns (the Jacobian's turns are about the world origin, the rest a translation)
            B = J[..., base].reshape(-1, len(base))
            x = np.linalg.lstsq(B, fd.reshape(-1), rcond=None)[0]
            np.testing.assert_allclose(B @ x, fd.reshape(-1), atol=1e-7)
        else:
            np.testing.assert_allclose(J[..., j], fd, atol=1e-7, err_msg=name)


def test_a_nest_facing_away_or_below_the_plate_is_not_seen():
    chain = tilt_turn()
    tracker = Tracker(position=[1.6, 3.0, 2.2], acceptance_deg=45)  # above the plate, on the +y side
    q = np.deg2rad([[-40.0, 0.0], [40.0, 0.0], [0.0, 0.0], [90.0, 45.0]])
    seen = nest_visibility(chain, q, NESTS, np.tile([0.0, 0.0, 1.0], (3, 1)), tracker)
    # tilted towards the tracker: every nest; away from it or on its side: none
    np.testing.assert_array_equal(seen, [[True] * 3, [False] * 3, [False] * 3, [False] * 3])
    low = Tracker(position=[1.4, 3.0, 0.2], acceptance_deg=89)  # below the plate's level
    assert not nest_visibility(chain, np.zeros((1, 2)), NESTS, np.tile([0.0, 0.0, 1.0], (3, 1)), low).any()


def test_a_parked_arm_in_the_beam_hides_the_nests():
    chain = tilt_turn()
    q = np.deg2rad([[-40.0, 0.0]])
    normals = np.tile([0.0, 0.0, 1.0], (3, 1))
    free = Tracker(position=[1.6, 3.0, 2.2], acceptance_deg=45)
    tracker = Tracker(position=[1.6, 3.0, 2.2], acceptance_deg=45, arm_radius_m=0.1)
    plate = chain.fk(q)[0, :3, 3]
    across = plate + 0.5 * (tracker.position - plate)            # halfway along the beam
    wall = np.array([[across - [0.5, 0.0, 0.0], across + [0.5, 0.0, 0.0]]])  # a segment across it
    assert nest_visibility(chain, q, NESTS, normals, tracker).all()
    assert not nest_visibility(chain, q, NESTS, normals, tracker, wall).any()
    assert nest_visibility(chain, q, NESTS, normals, free, wall).all()  # no arm radius: not checked
    aside = wall + [0.0, 0.0, 1.0]                                 # 1 m above the beam
    assert nest_visibility(chain, q, NESTS, normals, tracker, aside).all()


def test_the_grid_covers_the_limits_without_repeating_a_turn():
    chain = tilt_turn()
    q = np.rad2deg(table_grid(chain, 24))
    assert q.shape == (24, 2) and len(np.unique(np.round(q, 6), axis=0)) == 24
    turns = np.unique(np.round(q[:, 1], 6))
    assert np.isclose(turns.min(), -359.0) and np.isclose(np.diff(turns), 360.0 / len(turns)).all()


def fitted_error(chain, truth, q, visible, nests, names, rng, q_check, noise_m=2e-5) -> float:
    """RMS 3-D error (m) at the nests over ``q_check`` of a least-squares fit of ``names`` (finite
    differences of the FK: nothing of the planner) to noisy measurements of ``truth``."""
    def world(robot, qq):
        F = robot.fk(qq)
        return np.einsum("nij,kj->nki", F[:, :3, :3], nests) + F[:, None, :3, 3]

    measured = world(truth, q)[visible] + rng.normal(0.0, noise_m, (int(visible.sum()), 3))
    x0 = chain.values_of(names)

    def residual(x):
        return (world(chain.with_values(dict(zip(names, x, strict=True))), q)[visible] - measured).reshape(-1)

    fit = least_squares(residual, x0, x_scale=np.where([nm.split(".")[-1].startswith("r") or nm.startswith(
        ("alpha", "theta")) for nm in names], 1e-3, 1e-4), diff_step=1e-9)
    model = chain.with_values(dict(zip(names, fit.x, strict=True)))
    return float(np.sqrt(np.mean(np.sum((world(model, q_check) - world(truth, q_check)) ** 2, axis=2))))


def test_planned_angles_predict_their_accuracy_and_beat_a_grid():
    chain = tilt_turn()
    tracker = Tracker(position=[1.4, 1.5, 3.5], acceptance_deg=70)  # high above: the grid sees 2 of 3 tilts
    plan = plan_table(chain, 24, nests=NESTS, tracker=tracker, n_candidates=1500, starts=2)
    assert plan.n == 24 and plan.visible.all(axis=1).sum() >= 1 and np.isfinite(plan.grid_rms_mm)
    assert plan.predicted_rms_mm < plan.grid_rms_mm
    # the plate's turn is the turn axis' zero's (as the cell calibration frees them)
    assert "theta2" in plan.identifiability.kept and "tool.rz" not in plan.parameters
    names = plan.identifiability.kept
    rng = np.random.default_rng(5)
    q_check = np.deg2rad(rng.uniform([-89, -359], [89, 359], (200, 2)))
    q_grid = table_grid(chain, 24)
    v_grid = nest_visibility(chain, q_grid, NESTS, np.tile([0.0, 0.0, 1.0], (3, 1)), tracker)
    errors = {"plan": [], "grid": []}
    angles = [nm.split(".")[-1].startswith("r") or nm.startswith(("alpha", "theta")) for nm in names]
    scale = np.where(angles, np.deg2rad(0.03), 3e-4)
    for _ in range(12):  # truths: the estimated parameters off by ~0.3 mm / 0.03 deg
        values = chain.values_of(names) + rng.normal(0, scale)
        truth = chain.with_values(dict(zip(names, values, strict=True)))
        for key, q, seen in (("plan", plan.joints, plan.visible), ("grid", q_grid, v_grid)):
            errors[key].append(fitted_error(chain, truth, q, seen, NESTS, names, rng, q_check))
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) * 1e3 for k, v in errors.items()}
    # the prediction (the priors of the link parameters included) against the brute-force fits
    assert 0.7 < rms["plan"] / plan.predicted_rms_mm < 1.4, (rms, plan.predicted_rms_mm)
    assert 0.6 < rms["grid"] / plan.grid_rms_mm < 1.5, (rms, plan.grid_rms_mm)
    assert rms["plan"] < rms["grid"]


def test_unknown_nests_hold_the_turn_zero_and_say_so():
    plan = plan_table(tilt_turn(), 20, nests=NESTS, nests_known=False, n_candidates=600, starts=1,
                      tracker=Tracker(position=[1.6, 3.0, 2.2], acceptance_deg=45))
    assert "theta2" in plan.identifiability.dropped and "smr1.x" in plan.identifiability.kept
    assert any("confounded" in w for w in plan.warnings)
    json.dumps(plan.to_dict(), allow_nan=False)


def test_a_grid_the_tracker_barely_sees_is_said_to_rest_on_the_priors():
    """One tilt of the grid in sight: the turn's axis is seen, not the tilt's; its figure is the
    priors' spread, and the summary says which parameters the grid leaves to them."""
    plan = plan_table(tilt_turn(), 24, nests=NESTS, n_candidates=600, starts=1,
                      tracker=Tracker(position=[1.4, 1.5, 3.5], acceptance_deg=60))
    assert {"theta2", "d2"} <= set(plan.grid_not_determined)
    assert plan.grid_rms_mm > 100 * plan.predicted_rms_mm
    assert "to their priors" in plan.summary() and any("does not determine" in w for w in plan.warnings)
    assert plan.to_dict()["grid_not_determined"] == plan.grid_not_determined
    blind = plan_table(tilt_turn(), 24, nests=NESTS, n_candidates=600, starts=1,  # no tilt of the grid seen
                       tracker=Tracker(position=[1.2, 3.0, 1.6], acceptance_deg=30))
    assert not np.isfinite(blind.grid_rms_mm) or blind.grid_not_determined
    json.dumps(blind.to_dict(), allow_nan=False)


def test_known_nests_on_one_line_leave_the_turn_about_it_to_the_analysis():
    line = [[0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]]  # m, along the plate's x
    plan = plan_table(tilt_turn(), 16, nests=line, n_candidates=400, starts=1,
                      tracker=Tracker(position=[1.6, 3.0, 2.2], acceptance_deg=45))
    assert "tool.rx" in plan.identifiability.dropped and "tool.ry" in plan.identifiability.kept
    assert "tool.rx" in plan.summary()


@pytest.mark.parametrize("kwargs, message", [
    ({"nests": [[0.1, 0]]}, "finite"),
    ({"nests": NESTS, "tracker": Tracker(position=[1.4, 0.0, -2.0])}, "sees no nest"),
    ({"nests": NESTS, "criterion": "O4"}, "criterion is I or D"),
])
def test_bad_input_is_refused(kwargs, message):
    with pytest.raises(DataError, match=message):
        plan_table(tilt_turn(), 12, n_candidates=200, starts=1, **kwargs)
