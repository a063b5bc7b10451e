"""What a calibration with payload and thermal terms says of them (summary, result JSON, HTML report,
through the API and the CLI), the terms the data cannot show, and one vocabulary for the parameters
the data do not estimate across calibrate, analyze and the planner."""

from __future__ import annotations

import json

import numpy as np
import pytest
from robots import require_datasets

import robocal as rc
from robocal.calibration.pipeline import calibrate
from robocal.calibration.result import load_result
from robocal.cli import main
from robocal.data.simulate import simulate_tracker
from robocal.identify import vocabulary
from robocal.identify.identifiability import analyze as analyze_jacobian
from robocal.report.html import render_report

KR210 = "kuka_kr210_r2700"
COM_MM = (0.0, 0.0, 250.0)  # simulate's default centre of mass: on joint 6's axis (no moment about it)


@pytest.fixture(scope="module")
def campaign():
    """A KR 210 campaign at 0, 75 and 150 kg warming from 20 to 35 deg C (its forearm aluminium, the
    rest steel) and its calibration with payload, thermal and thermal_groups (API)."""
    robot = rc.Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 150, noise_mm=0.02, seed=4, payloads=[0, 75, 150], temperatures=(20, 35),
                           thermal_k={"forearm": 23e-6})
    return sim, calibrate(robot, sim.data, nongeometric="payload,thermal,thermal_groups")


def test_the_conditions_section_holds_the_numbers_of_the_calibration(campaign):
    sim, res = campaign
    c = res.to_dict()["conditions"]
    t = sim.data.temperature
    assert c["terms"] == ["payload", "thermal"]
    assert c["data"]["payload"] == {"min_kg": 0.0, "max_kg": 150.0, "masses_kg": [0.0, 75.0, 150.0],
                                    "centre_of_mass_mm": {"min": list(COM_MM), "max": list(COM_MM)}}
    assert c["data"]["temperature"] == {"min_c": t.min(), "max_c": t.max()}
    assert t.min() == pytest.approx(20.0, abs=0.5) and t.max() == pytest.approx(35.0, abs=0.5)
    assert c["reference_temperature_c"] == pytest.approx(t.mean(), rel=1e-12)
    assert c["reference_temperature_c"] == res.robot.joint_errors.reference_temperature_c
    sigma = dict(zip(res.unknowns, res.sigma, strict=True))
    k = c["thermal"]
    assert k["status"] == "estimated" and k["k_per_K"] == res.robot.get("thermal")
    assert k["sigma_per_K"] == sigma["thermal"]
    # per group: own = the shared k plus its deviation, sigma from their covariance; shared = the shared k
    groups = {g["group"]: g for g in c["thermal_groups"]}
    assert groups["forearm"]["source"] == "own"
    assert groups["forearm"]["k_per_K"] == pytest.approx(23e-6, abs=4 * groups["forearm"]["sigma_per_K"])
    i, j = res.unknowns.index("thermal"), res.unknowns.index("thermal_forearm")
    cov = res.covariance
    assert groups["forearm"]["sigma_per_K"] == pytest.approx(np.sqrt(cov[i, i] + cov[j, j] + 2 * cov[i, j]))
    own = res.robot.get("thermal") + res.robot.get("thermal_forearm")
    assert groups["forearm"]["k_per_K"] == pytest.approx(own)
    for g in groups.values():
        if g["source"] == "shared":
            assert g["k_per_K"] == k["k_per_K"] and g["sigma_per_K"] == sigma["thermal"]
    loads = {r["joint"]: r for r in c["payload"]}
    assert sorted(loads) == [2, 3, 4, 5, 6]
    assert loads[2]["status"] == "estimated" and loads[2]["unit"] == "urad/(kg m)"
    assert loads[2]["estimate"] == pytest.approx(res.robot.get("payload2") * 1e6)
    assert loads[2]["sigma"] == pytest.approx(sigma["payload2"] * 1e6)
    # the centre of mass on joint 6's axis: the payload has no moment about it
    assert loads[6]["status"] == "not identifiable" and loads[6]["detail"] == "no effect on these data"
    assert c["assumed"] == {"payload_kg": 0.0, "temperature_c": c["reference_temperature_c"]}
    assert c["not_used"] == []


def test_the_summary_and_the_report_show_the_conditions(campaign):
    _, res = campaign
    c = res.to_dict()["conditions"]
    text = res.summary()
    t_ref = c["reference_temperature_c"]
    assert "working conditions of the calibration data: payload 0-150 kg (0, 75, 150); temperature " \
           f"{c['data']['temperature']['min_c']:g}-{c['data']['temperature']['max_c']:g} deg C; " \
           f"T_ref {t_ref:.4g} deg C" in text
    k = c["thermal"]
    assert f"thermal expansion k (shared): {k['k_per_K'] * 1e6:.4g} ± {k['sigma_per_K'] * 1e6:.2g} " \
           "1e-6/K" in text
    forearm = next(g for g in c["thermal_groups"] if g["group"] == "forearm")
    assert f"forearm {forearm['k_per_K'] * 1e6:.3g} ± {forearm['sigma_per_K'] * 1e6:.2g} (own)" in text
    p2 = c["payload"][0]
    assert f"J2 {p2['estimate']:.4g} ± {p2['sigma']:.2g}" in text
    assert f"the model assumes no payload (0 kg) when none is given and T_ref {t_ref:.4g} deg C" in text
    page = render_report(res.to_dict())
    section = page[page.index('<section id="conditions"'):]
    section = section[:section.index("</section>")]
    assert "0&ndash;150 kg (0, 75, 150 kg)" in section and "(0, 0, 250) mm" in section
    assert f"{t_ref:.4g} &deg;C (the calibration data's mean)" in section
    assert f"{k['k_per_K'] * 1e6:.3f} &plusmn; {k['sigma_per_K'] * 1e6:.3f}" in section
    assert f"<td>{forearm['k_per_K'] * 1e6:.3f}</td>" in section
    assert "own (its deviation estimated)" in section
    assert f"<td>{p2['estimate']:.4f}</td>" in section
    assert "not identifiable (no effect on these data)" in section


def test_the_report_escapes_the_conditions_strings(campaign):
    _, res = campaign
    result = res.to_dict()
    result["conditions"]["not_used"] = [{"term": "<b>payload</b>", "reason": "<script>alert(1)</script>"}]
    result["conditions"]["thermal_groups"][0]["label"] = "<i>base</i>"
    page = render_report(result)
    assert "<script>alert" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;" in page
    assert "&lt;i&gt;base&lt;/i&gt;" in page and "&lt;b&gt;payload&lt;/b&gt; term not used" in page


def test_calibrate_cli_writes_the_conditions_to_json_summary_and_report(tmp_path, capsys):
    robot = rc.Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 80, noise_mm=0.02, seed=7, payloads=[0, 150], temperatures=(22, 30))
    sim.data.save(tmp_path / "kr.csv")
    out = tmp_path / "r.json"
    assert main(["calibrate", str(tmp_path / "kr.csv"), "--robot", KR210, "--nongeometric", "payload,thermal",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    c = load_result(out)["conditions"]
    assert c["data"]["payload"]["masses_kg"] == [0.0, 150.0]
    assert c["reference_temperature_c"] == pytest.approx(sim.data.temperature.mean(), abs=1e-9)
    assert c["thermal"]["k_per_K"] == pytest.approx(11.5e-6, abs=4 * c["thermal"]["sigma_per_K"])
    assert "working conditions of the calibration data: payload 0-150 kg (0, 150)" in text
    assert f"T_ref {c['reference_temperature_c']:.4g} deg C" in text
    # the report command renders the section from the JSON
    assert main(["report", str(out), "-o", str(tmp_path / "again.html")]) == 0
    again = (tmp_path / "again.html").read_text()
    assert "<h2>Payload and temperature</h2>" in again
    assert f"{c['thermal']['k_per_K'] * 1e6:.3f} &plusmn; {c['thermal']['sigma_per_K'] * 1e6:.3f}" in again


def test_a_term_without_its_column_is_not_used_and_says_why(tmp_path, capsys):
    robot = rc.Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 60, noise_mm=0.02, seed=3)
    sim.data.save(tmp_path / "plain.csv")
    out = tmp_path / "r.json"
    assert main(["calibrate", str(tmp_path / "plain.csv"), "--robot", KR210, "--nongeometric",
                 "payload,thermal", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "payload term not used: the calibration data have no payload_kg column" in text
    assert "thermal term not used: the calibration data have no temperature_c column" in text
    assert "0 parameters estimated, 0 left out" in text  # the terms not used are not 'left out'
    result = json.loads(out.read_text())
    held = {d["name"]: d for d in result["dropped"]}
    assert held["thermal"]["status"] == "not used"
    assert held["payload3"]["reason"] == "not used: the calibration data have no payload_kg column"
    rows = {r["name"]: r for r in result["parameters"]}
    assert rows["payload2"]["identification"] == "not used" and rows["payload2"]["status"] == "dropped"
    assert result["conditions"]["not_used"] == [
        {"term": "payload", "reason": "the calibration data have no payload_kg column"},
        {"term": "thermal", "reason": "the calibration data have no temperature_c column"}]
    assert result["conditions"]["assumed"] == {}  # the delivered model carries neither term
    page = render_report(result)
    assert "0 term(s) the data cannot separate from the geometry were left out (highlighted); 12 not " \
           "used" in page
    assert "<b>payload term not used:</b> the calibration data have no payload_kg column" in page


def test_one_temperature_in_every_row_is_said(tmp_path):
    robot = rc.Robot.from_catalog(KR210)
    sim = simulate_tracker(robot, 60, noise_mm=0.02, seed=5, payloads=[0, 50], temperatures=(25, 25))
    res = calibrate(robot, sim.data, nongeometric="payload,thermal")
    c = res.to_dict()["conditions"]
    one = "the temperature_c column has one value (25 deg C)"
    assert c["not_used"] == [{"term": "thermal", "reason": one}]
    assert c["thermal"]["status"] == "not used" and c["payload"][0]["status"] == "estimated"
    assert c["assumed"] == {"payload_kg": 0.0}
    assert "thermal term not used: the temperature_c column has one value (25 deg C)" in res.summary()
    none = simulate_tracker(robot, 60, noise_mm=0.02, seed=5, payloads=[0])
    c = calibrate(robot, none.data, nongeometric="payload").to_dict()["conditions"]
    assert c["not_used"] == [{"term": "payload", "reason": "the payload_kg column is 0 kg in every row"}]


# ----------------------------------------------------------------- one vocabulary
def _words(ident) -> dict[str, str]:
    return {nm: vocabulary.status(nm, ident) for nm in ident.names}


def test_calibrate_analyze_and_the_planner_say_the_same_of_a_simulated_arm(tmp_path, capsys):
    robot = rc.Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 60, noise_mm=0.02, seed=11, n_smr=2)
    res = calibrate(robot, sim.data, nongeometric=None)
    ident = rc.analyze(res.start, sim.data, noise_mm=res.space.noise * 1e3)
    assert _words(ident) == _words(res.identifiability)
    assert {nm for nm, w in _words(ident).items() if w == "not identifiable"} == \
        {"alpha1", "a1", "theta1", "d1", "d3", "theta6", "d6"}
    assert ident.confounded_with["d3"] == res.identifiability.confounded_with["d3"] == ["d2"]
    # the CLI: analyze of the measurement file and calibrate's summary name d1 alike
    sim.data.save(tmp_path / "m.csv")
    assert main(["analyze", str(tmp_path / "m.csv"), "--robot", "abb_irb2600"]) == 0
    analyzed = capsys.readouterr().out
    assert "  not identifiable: d3  (confounded with d2)" in analyzed and "not determined" not in \
        analyzed.split("\n", 2)[2]
    assert "not identifiable (exactly confounded" in res.summary() and "d3 (~d2)" in res.summary()
    # the planner on candidates: the same words in its summary and JSON
    plan = rc.plan_poses(robot, 15, candidates=sim.data.joints[::2], smr=[[0.03, 0.02, 0.08]], starts=1)
    words = {d["name"]: d["status"] for d in plan.to_dict()["dropped"]}
    assert words["d1"] == "not identifiable" and "d1 (~base.z)" in plan.summary()


@pytest.mark.parametrize("which", ["meca500", "irb120"])
def test_calibrate_and_analyze_say_the_same_on_the_real_data(which):
    from robocal.data import datasets

    cal, _ = getattr(datasets, which)(require_datasets())
    robot = rc.Robot.from_catalog({"meca500": "meca500", "irb120": "abb_irb120"}[which])
    res = calibrate(robot, cal, nongeometric=None)
    ident = rc.analyze(res.start, cal, noise_mm=res.space.noise * 1e3)
    assert _words(ident) == _words(res.identifiability)
    not_identifiable = {nm for nm, w in _words(ident).items() if w == "not identifiable"}
    assert not_identifiable == {"alpha1", "a1", "theta1", "d1", "d3", "theta6", "d6"}
    assert "d1" in res.summary().split("not identifiable (")[1].split("\n")[0]


def test_of_two_parameters_with_one_effect_the_earlier_is_kept_whatever_the_rounding():
    rng = np.random.default_rng(2)
    J = rng.normal(size=(30, 4))
    names = ["a2", "d2", "a3", "d3"]
    for eps in (1e-15, -1e-15, 0.0):
        J[:, 3] = J[:, 1] * (1.0 + eps)  # d3 has d2's effect; rounding may favour either
        ident = analyze_jacobian(J.copy(), names, 30)
        assert ident.dropped == ["d3"] and ident.confounded_with["d3"] == ["d2"]


def test_a_parameter_confounded_only_on_these_poses_is_not_determined_by_them():
    """q2 and q3 never move: on these poses the upper arm's parameters act like the base frame's,
    but other poses separate them (not determined by these data); d1 beside the base height stays
    not identifiable (no poses separate it)."""
    robot = rc.Robot.from_catalog("abb_irb2600")
    q = np.random.default_rng(0).uniform(robot.limits[:, 0], robot.limits[:, 1], (40, 6))
    q[:, 1], q[:, 2] = 0.3, -0.2
    sim = simulate_tracker(robot, joints=q, noise_mm=0.02, seed=1, n_smr=2)
    res = calibrate(robot, sim.data, nongeometric=None, force=True)  # it holds only near its poses
    ident = res.identifiability
    assert {"theta2", "a3", "d4"} <= set(ident.undetermined)
    assert all(ident.prior_ratio[nm] == 1.0 for nm in ("theta2", "a3", "d4"))
    assert {"d1", "d3", "theta6", "d6"} <= set(ident.dropped) and "theta2" not in ident.dropped
    assert _words(rc.analyze(res.start, sim.data, noise_mm=res.space.noise * 1e3)) == _words(ident)
    rows = {r["name"]: r for r in res.to_dict()["parameters"]}
    assert rows["theta2"]["identification"] == "not determined by these data"
    assert rows["theta2"]["status"] == "not determined" and rows["theta2"]["correction"] == 0.0
    # on poses spread over the limits, the same parameters: only the structural ones are dropped
    spread = calibrate(robot, simulate_tracker(robot, 40, noise_mm=0.02, seed=1, n_smr=2).data,
                       nongeometric=None)
    assert set(spread.identifiability.dropped) == {"alpha1", "a1", "theta1", "d1", "d3", "theta6", "d6"}
    assert "theta2" in spread.identifiability.kept


def test_the_words_of_one_identifiability():
    from robocal.identify.identifiability import Identifiability

    conf = {"d1": ["base.z"], "d3": ["d2"], "gear2_c1": ["theta2"], "comp4_5": [], "d5": ["alpha6"]}
    ident = Identifiability(names=["d1", "d3", "gear2_c1", "comp4_5", "d5", "a2"], kept=["a2"],
                            dropped=["d1", "d3", "gear2_c1", "comp4_5"], confounded_with=conf, rank=1,
                            condition_number=1.0, singular_values=np.ones(1), undetermined=["d5"],
                            prior_ratio={"d5": 0.83, "a2": 0.1})
    unused = {"comp4_5": "the calibration data have no payload_kg column"}
    rows = {r["name"]: r for r in vocabulary.entries(ident.dropped + ident.undetermined, ident, unused)}
    assert rows["d1"] == {"name": "d1", "status": "not identifiable", "confounded_with": ["base.z"],
                          "reason": "not identifiable: confounded with base.z; held at nominal, its "
                                    "confounders absorb it"}
    assert rows["gear2_c1"]["reason"].startswith("not identifiable: not separable from the geometry on "
                                                 "these data")
    assert rows["comp4_5"]["status"] == "not used"
    assert rows["d5"] == {"name": "d5", "status": "not determined by these data", "prior_ratio": 0.83,
                          "confounded_with": ["alpha6"],
                          "reason": "not determined by these data: posterior sigma 83% of its prior; "
                                    "confounded with alpha6; held near nominal by its prior"}
    assert vocabulary.status("a2", ident) == "estimated"
    assert vocabulary.counts(ident) == ("estimated: 1; not determined by these data (held near nominal by "
                                        "their priors): 1; not identifiable (held at nominal): 4")
    lines = vocabulary.lines(ident)
    assert lines[0].endswith("d1 (~base.z), d3 (~d2), gear2_c1 (~theta2), comp4_5 (no effect)")
    assert lines[1].endswith("d5 (83% of prior; ~alpha6)")
