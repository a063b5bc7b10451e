"""Prior group scales from the data (robocal.identify.evidence, robocal.identify.priors.fit_priors),
the --priors grammar and the model file's priors: block, and the "priors too tight" diagnosis."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import multivariate_normal

import robocal as rc
from robocal.cli.calibrate import _priors
from robocal.core.errors import ModelError
from robocal.identify.evidence import NormalStats, fit_group_scales, log_evidence
from robocal.identify.priors import class_defaults
from robocal.kinematics.prior_spec import PriorSpec, class_of
from robocal.trust.diagnosis import priors_too_tight

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from bench_prior_scales import far_from_drawing  # noqa: E402  (the benchmark's arms far from their drawing)


def _linear_problem(seed: int = 0, widen: float = 4.0):
    """A small linear problem: 3 columns of group 'a' drawn ``widen`` times their default scale,
    2 of group 'b' drawn at theirs, one flat column."""
    rng = np.random.default_rng(seed)
    M = 80
    J = rng.normal(size=(M, 6)) * np.array([1.0, 10.0, 0.1, 3.0, 1.0, 2.0])
    sigma = np.array([0.5, 0.05, 2.0, 0.2, 0.3, np.inf])
    x = rng.normal(size=6) * np.where(np.isfinite(sigma), sigma, 1.0) * np.array([widen] * 3 + [1.0] * 3)
    r = J @ x + 0.3 * rng.normal(size=M)
    return J, r, sigma


def test_log_evidence_is_the_gaussian_marginal_likelihood():
    J, r, sigma = _linear_problem()
    J, r, sigma = J[:, :5], r, sigma[:5]  # no flat column: the evidence is a proper density
    stats = NormalStats.of(J, r)
    for f, s in ((1.0, 0.3), (3.0, 0.5), (0.5, 0.2)):
        scale = sigma * np.array([f, f, f, 1.0, 1.0])
        C = s**2 * np.eye(len(r)) + J @ np.diag(scale**2) @ J.T
        truth = multivariate_normal(np.zeros(len(r)), C).logpdf(r)
        assert log_evidence(stats, 1.0 / scale**2, s) == pytest.approx(truth, rel=1e-9, abs=1e-6)


def test_group_scales_maximise_the_evidence_against_a_brute_force_grid():
    J, r, sigma = _linear_problem(seed=3, widen=6.0)
    groups = ["a", "a", "a", "b", "b", None]
    fit = fit_group_scales(J, r, sigma, groups, {"a", "b"}, 0.3)
    stats = NormalStats.of(J, r)
    precision = np.where(np.isfinite(sigma), 1.0 / np.where(np.isfinite(sigma), sigma, 1.0) ** 2, 0.0)
    fa = np.exp(np.linspace(0.0, np.log(20.0), 41))
    s = np.exp(np.linspace(np.log(0.15), np.log(0.6), 41))
    # group b: at its default (drawn there) the optimiser keeps it, the grid over a and the noise
    grid = np.array([[log_evidence(stats, precision / np.array([a, a, a, 1, 1, 1]) ** 2, n) for n in s]
                     for a in fa])
    i, j = np.unravel_index(np.argmax(grid), grid.shape)
    assert fit.factors["a"] > 2.0  # the data ask for the wider group
    assert fit.factors["a"] == pytest.approx(fa[i], rel=0.1)
    assert fit.noise == pytest.approx(s[j], rel=0.1)
    factors = np.array([fit.factors["a"]] * 3 + [fit.factors["b"]] * 2 + [1.0])
    best = log_evidence(stats, precision / factors**2, fit.noise)
    assert best >= grid.max() - 1e-6
    assert fit.gain > 3.0


def test_a_group_the_data_do_not_ask_for_stays_at_its_default():
    J, r, sigma = _linear_problem(seed=5, widen=1.0)
    fit = fit_group_scales(J, r, sigma, ["a", "a", "a", "b", "b", None], {"a", "b"}, 0.3)
    assert fit.factors == {"a": 1.0, "b": 1.0}
    assert fit.gain < 3.0 + 1e-9


def test_a_robot_far_from_its_drawing_gets_wider_priors_and_the_held_out_error_reaches_the_noise():
    nominal = rc.Robot.from_catalog("abb_irb120")
    true = far_from_drawing(nominal, np.random.default_rng(1), zero_deg=2.5, length_mm=10.0)
    sim = rc.simulate_tracker(true, 30, noise_mm=0.5, seed=3, as_is=True)
    fit, check = sim.data.split_poses(0.6, seed=0)
    res = rc.calibrate(nominal, fit, validation=check, nongeometric=None, force=True)
    scales = res.prior_scales
    assert scales.source["zeros"] == scales.source["lengths"] == "estimated"
    # truth: zeros 2-3 deg, lengths 10 mm (1 sigma; some of them unidentifiable): well above the defaults
    assert 1.5 < np.rad2deg(scales.scales["zeros"]) < 4.0 and 3e-3 < scales.scales["lengths"] < 20e-3
    noise_3d = 0.5 * np.sqrt(3)
    assert res.validation["rms"] < 1.5 * noise_3d
    tight = rc.calibrate(nominal, fit, validation=check, nongeometric=None, force=True, priors="estimate=no")
    assert tight.validation["rms"] > 10 * res.validation["rms"]  # measured: 35.3 vs 1.18 mm
    assert "estimated" in res.summary()
    assert res.to_dict()["priors"]["groups"]["zeros"]["source"] == "estimated"


def test_an_industrial_simulation_keeps_the_class_defaults():
    nominal = rc.Robot.from_catalog("abb_irb2600")
    sim = rc.simulate_tracker(nominal, 40, noise_mm=0.02, seed=2)
    res = rc.calibrate(nominal, sim.data, nongeometric=None)
    assert set(res.prior_scales.source.values()) == {"fixed"}
    assert res.prior_scales.robot_class == "industrial"


def test_priors_grammar_and_errors():
    spec = PriorSpec.parse("class=humanoid, zeros=3deg,lengths=10 mm,errors=2x,estimate=no")
    assert spec.robot_class == "service" and not spec.estimate
    assert spec.scales == pytest.approx({"zeros": np.deg2rad(3), "lengths": 0.01, "errors": 2.0})
    assert PriorSpec.parse("twists=17.4533mrad").scales["twists"] == pytest.approx(np.deg2rad(1), rel=1e-5)
    for bad, words in (("zeros=3", "unit"), ("zeros=3mm", "unit"), ("class=robot", "unknown robot class"),
                       ("size=3mm", "unknown key"), ("zeros", "key=value"), ("zeros=-1deg", "unit"),
                       ("lengths=0mm", "above 0"), ("zeros=1deg,zeros=2deg", "twice"),
                       ("estimate=maybe", "yes or no")):
        with pytest.raises(ModelError, match=words):
            PriorSpec.parse(bad)
    with pytest.raises(argparse.ArgumentTypeError, match="unit"):
        _priors("zeros=3")


def test_model_file_priors_block_round_trip(tmp_path):
    robot = rc.Robot.from_catalog("meca500").with_priors(PriorSpec.parse("class=service,zeros=3deg"))
    path = tmp_path / "m.yaml"
    robot.save(path)
    back = rc.Robot.load(path)
    assert back.priors.robot_class == "service"
    assert back.priors.scales["zeros"] == pytest.approx(np.deg2rad(3))
    assert class_of(back) == ("service", "named")
    text = path.read_text().replace("zeros: 3deg", "zeros: 3")
    path.write_text(text)
    with pytest.raises(ModelError, match="unit"):
        rc.Robot.load(path)


def test_class_from_the_model():
    assert class_of(rc.Robot.from_catalog("ur5"))[0] == "collaborative"
    assert class_of(rc.Robot.from_catalog("ur10e"))[0] == "collaborative"
    assert class_of(replace(rc.Robot.from_catalog("ur5"), name="urdf_arm"))[0] == "industrial"
    assert class_of(rc.Robot.from_catalog("abb_irb120"))[0] == "industrial"
    eight = rc.Robot.from_mdh(*np.zeros((4, 8)))
    assert class_of(eight)[0] == "service"
    # a tilt-and-turn table (2 joints) or a turntable (1): the positioner class and its scales
    table = rc.Robot.from_mdh([0, -90], [0, 0], [0, 0], [0, 475], degrees=True, length_unit="mm")
    assert class_of(table)[0] == "positioner"
    assert class_of(rc.Robot.from_mdh([0], [0], [0], [0]))[0] == "positioner"
    assert class_of(rc.Robot.from_mdh(*np.zeros((4, 3))))[0] == "industrial"
    name, _, scales = class_defaults(table)
    assert name == "positioner" and scales["zeros"] == pytest.approx(np.deg2rad(0.3))
    assert scales["lengths"] == pytest.approx(5e-3)  # at least 5 mm (0.475 m x 10 mm/m is less)
    assert class_of(table.with_priors(PriorSpec("industrial"))) == ("industrial", "named")


def test_priors_too_tight_is_the_diagnosis_of_a_misfit():
    nominal = rc.Robot.from_catalog("ur5")
    true = far_from_drawing(nominal, np.random.default_rng(1), zero_deg=4.0, length_mm=15.0)
    sim = rc.simulate_tracker(true, 15, noise_mm=0.02, seed=3, as_is=True)
    res = rc.calibrate(nominal, sim.data, nongeometric=None, priors="estimate=no", force=True)
    assert res.consistency.misfit
    sentence = res.consistency.diagnosis[0]
    assert sentence.startswith("priors too tight for this robot") and "--priors zeros=" in sentence
    assert priors_too_tight(None) is None
    wide = rc.calibrate(nominal, sim.data, nongeometric=None, force=True)  # estimated: nothing to say
    assert not any("priors too tight" in d for d in wide.consistency.diagnosis)


def test_cli_priors_reach_the_calibration_and_its_json(tmp_path, capsys):
    from robocal.calibration.result import load_result
    from robocal.cli import main

    sim = rc.simulate_tracker(rc.Robot.from_catalog("abb_irb2600"), 40, noise_mm=0.02, seed=2)
    sim.data.save(tmp_path / "cal.csv")
    model = tmp_path / "robot.yaml"
    rc.Robot.from_catalog("abb_irb2600").with_priors(PriorSpec.parse("class=service,twists=0.5deg")).save(model)
    assert main(["calibrate", str(tmp_path / "cal.csv"), "--robot", str(model), "--nongeometric", "none",
                 "--priors", "zeros=2deg,estimate=no", "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "priors of the service class (named): zeros 2 deg (user), twists 0.5 deg (user)" in out
    groups = load_result(tmp_path / "r.json")["priors"]["groups"]  # the JSON schema holds it
    assert groups["zeros"]["source"] == "user" and groups["lengths"]["source"] == "fixed"
    assert groups["lengths"]["scale"] == pytest.approx(groups["lengths"]["default"])


def test_the_stated_priors_widen_the_plausible_corrections():
    from robocal.core.errors import PlausibilityError
    from robocal.identify.plausibility import check_corrections
    from robocal.identify.priors import stated_sigma

    nominal = rc.Robot.from_catalog("ur5")
    names = ["a2", "theta3"]
    moved = nominal.with_values({"a2": nominal.get("a2") + 0.02,
                                 "theta3": nominal.get("theta3") + np.deg2rad(7)})
    small = {"a2": 1e-4, "theta3": 1e-4}  # determined by the data

    def check(start):
        prior = dict(zip(names, stated_sigma(start, names), strict=True))
        check_corrections(start, moved, names, sigma=small, prior=prior)

    with pytest.raises(PlausibilityError, match="a2 by \\+20 mm, theta3 by \\+7 deg"):
        check(nominal)  # an industrial class's limits: 5 mm (1 % of the reach), 5 deg
    check(nominal.with_priors(PriorSpec.parse("class=service")))  # 3 x 10 mm per metre, 3 x 3 deg
    estimated = nominal.with_priors(PriorSpec().with_estimated({"lengths": 0.01, "zeros": np.deg2rad(3)}))
    with pytest.raises(PlausibilityError):  # the scales estimated from the data do not count
        check(estimated)
