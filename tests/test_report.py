"""HTML report: sections, plots, escaping, graceful degradation, CLI; on synthetic and real results."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest

from robocal import Robot

pytest.importorskip("matplotlib", reason="the report needs matplotlib (report/test extra)")

from robocal.report.html import render_report, write_report  # noqa: E402

HOSTILE = '<script>alert("x")</script>&'


def _stats(e: np.ndarray) -> dict:
    return {"n": int(e.size), "rms": float(np.sqrt(np.mean(e**2))), "mean": float(e.mean()),
            "max": float(e.max()), "p95": float(np.percentile(e, 95))}


def _observations(nominal: Robot, true: Robot, after: Robot, q: np.ndarray, pose_id: np.ndarray,
                  rng: np.random.Generator, noise_mm: float) -> dict:
    meas = true.fk(q)[:, :3, 3] * 1e3 + rng.normal(scale=noise_mm, size=(len(q), 3))
    return {"pose_id": pose_id.tolist(), "source_row": (np.arange(len(q)) + 2).tolist(),
            "smr": [0] * len(q), "joints_deg": np.rad2deg(q).tolist(), "measured": meas.tolist(),
            "model_before": (nominal.fk(q)[:, :3, 3] * 1e3).tolist(),
            "model_after": (after.fk(q)[:, :3, 3] * 1e3).tolist(), "weight": [1.0] * len(q)}


def synthetic_result(seed: int = 0, n_poses: int = 60, repeats: int = 5, validation: bool = True,
                     rejected: int = 2, name: str = "abb_irb2600") -> dict:
    """A realistic result dict: nominal IRB 2600-like arm, a 'true' robot with mm-level errors,
    measurements with 20 um noise, a calibrated model close to the truth."""
    rng = np.random.default_rng(seed)
    nominal = replace(Robot.from_catalog("abb_irb2600"), name=name)
    free = nominal.default_free()
    true = nominal.displaced(free, rng.normal(scale=4e-4, size=len(free)))
    after = true.displaced(free, rng.normal(scale=5e-6, size=len(free)))
    lo, hi = np.deg2rad([-150, -60, -150, -180, -110, -180]), np.deg2rad([150, 120, 60, 180, 110, 180])
    q = rng.uniform(lo, hi, (n_poses, 6))
    pose_id = np.arange(n_poses)
    if repeats:  # poses 0..2 measured `repeats` times each (ISO 9283)
        q = np.vstack([q, np.repeat(q[:3], repeats - 1, axis=0)])
        pose_id = np.concatenate([pose_id, np.repeat(np.arange(3), repeats - 1)])
    obs = _observations(nominal, true, after, q, pose_id, rng, 0.02)
    e0 = np.linalg.norm(np.subtract(obs["measured"], obs["model_before"]), axis=1)
    e1 = np.linalg.norm(np.subtract(obs["measured"], obs["model_after"]), axis=1)
    worst = np.argsort(-e1)[:rejected]
    for i in worst:
        obs["weight"][i] = 0.0
    names = [n for n in free if n not in ("d2", "d3")]
    k = len(names)
    A = rng.normal(size=(k, k + 5))
    cov = A @ A.T
    corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    params = []
    for nm, v0, v1, unit in zip(nominal.parameter_names, nominal.values, after.values,
                                nominal.parameter_units(), strict=True):
        f = 1e3 if unit == "m" else np.rad2deg(1.0)
        status = "dropped" if nm in ("d2", "d3") else "estimated" if nm in names else "fixed"
        params.append({"name": nm, "unit": "mm" if unit == "m" else "deg", "nominal": v0 * f,
                       "estimate": (v1 if status == "estimated" else v0) * f,
                       "correction": ((v1 - v0) if status == "estimated" else 0.0) * f,
                       "sigma": float(rng.uniform(1e-4, 5e-3)) if status == "estimated" else None,
                       "status": status})
    result = {
        "format": "robocal-result/1", "robocal_version": "0.1.0",
        "robot": {"name": name, "description": "ABB IRB 2600-12/1.65 (synthetic test)", "n_joints": 6},
        "data": {"file": "tracker.csv", "kind": "point", "n_poses": n_poses, "n_observations": len(q)},
        "method": "robust", "settings": {"params": "auto", "seed": seed},
        "converged": True, "message": "converged: step below tolerance",
        "before": _stats(e0), "after": _stats(e1),
        "parameters": params,
        "dropped": [{"name": "d2", "reason": "not identifiable from these data", "confounded_with": ["d3"]},
                    {"name": "d3", "reason": "not identifiable from these data", "confounded_with": ["d2"]}],
        "identifiability": {"n_params": k + 2, "rank": k, "condition_number": 412.3,
                            "condition_class": "moderate", "O1": 0.11, "O2": 0.0024, "O3": 0.013, "O4": 3e-5},
        "correlation": {"names": names, "matrix": np.round(corr, 6).tolist()},
        "rejected": [{"source_row": obs["source_row"][i], "pose_id": obs["pose_id"][i],
                      "residual": float(e1[i]), "weight": 0.0} for i in worst],
        "observations": obs,
        "history": [{"iteration": i, "rms": float((_stats(e0)["rms"] * 0.3**i + 0.02) / 1e3), "damping": 1e-3}
                    for i in range(6)],  # m, from the error before calibration
        "warnings": [],
    }
    if validation:
        qv = rng.uniform(lo, hi, (40, 6))
        vobs = _observations(nominal, true, after, qv, np.arange(40), rng, 0.02)
        ev0 = np.linalg.norm(np.subtract(vobs["measured"], vobs["model_before"]), axis=1)
        ev1 = np.linalg.norm(np.subtract(vobs["measured"], vobs["model_after"]), axis=1)
        result["data"]["validation_file"] = "validation.csv"
        result.update(validation_before=_stats(ev0), validation=_stats(ev1), validation_observations=vobs)
    return result


def svg_count(text: str) -> int:
    return len(re.findall(r"<svg[\s>]", text))


def section_ids(text: str) -> list[str]:
    return re.findall(r'<section id="([^"]+)"', text)


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    result = synthetic_result()
    path = write_report(result, tmp_path_factory.mktemp("full") / "report.html")
    return result, path.read_text(encoding="utf-8")


def test_full_report_has_every_section_and_plot(full):
    result, text = full
    assert section_ids(text) == ["summary", "errors", "parameters", "identifiability", "correlation",
                                 "rejected", "iso9283", "history"]
    # sorted errors, distribution, error vs joints, 3-D points, worst vectors, correlation, history
    assert svg_count(text) == 7
    for figure in ("3.1", "0.0024", "412.3", "moderate", "confounded with d3", "validation set, after"):
        assert figure in text
    # the summary shows the statistics it was given, to 4 decimals
    assert f"{result['after']['rms']:.4f}" in text and f"{result['validation']['p95']:.4f}" in text
    # ISO 9283 table: three repeated poses, each measured 5 times
    iso = text[text.index('id="iso9283"'):]
    assert "3 repeated pose(s)" in iso
    assert len(re.findall(r"<tr><td>[0-2]</td><td>5</td>", iso)) == 3
    # log axes are labelled with plain numbers (mathtext is off for users' strings)
    assert "\\mathdefault" not in text and "10^{" not in text


def test_self_contained_no_network_no_script(full):
    text = full[1]
    assert not re.search(r"""(src|href)\s*=\s*["'](https?:|//)""", text)
    assert "<script" not in text.lower() and "@import" not in text
    assert "default-src 'none'" in text  # CSP: the page may not load anything


def test_user_strings_are_escaped():
    result = synthetic_result(2, n_poses=20, repeats=0, validation=False)
    result["robot"]["description"] = HOSTILE
    result["data"]["file"] = HOSTILE
    result["warnings"] = [HOSTILE]
    result["settings"]["note"] = HOSTILE
    result["parameters"][0]["name"] = HOSTILE
    for key in ("observations", "correlation", "history"):  # no figures needed here
        result.pop(key)
    text = render_report(result, title=HOSTILE)
    assert HOSTILE not in text and "<script>" not in text
    assert "&lt;script&gt;alert(&quot;x&quot;)&lt;/script&gt;&amp;" in text


def test_degrades_without_optional_fields():
    result = synthetic_result(3, n_poses=25, repeats=0, validation=False)
    for key in ("rejected", "history", "warnings", "correlation", "dropped", "converged", "message"):
        result.pop(key)
    text = render_report(result)
    assert section_ids(text) == ["summary", "errors", "parameters", "identifiability"]
    assert svg_count(text) == 5
    minimal = {"robot": {"name": "r"}, "before": {"n": 3, "rms": 1.0}, "after": {"n": 3, "rms": 0.5}}
    text = render_report(minimal)
    assert section_ids(text) == ["summary", "parameters", "identifiability"] and svg_count(text) == 0


def test_plane_data_without_measured_points():
    result = synthetic_result(4, n_poses=40, repeats=0, validation=False)
    obs = result["observations"]
    rng = np.random.default_rng(0)
    # probe tips near the plane z = 300 mm (before: tilted and bumpy, after: flat to 5 um)
    xy = rng.uniform(-200, 200, (40, 2))
    before = np.column_stack([xy, 300 + 0.002 * xy[:, 0] + rng.normal(scale=0.2, size=40)])
    after = np.column_stack([xy, 300 + rng.normal(scale=0.005, size=40)])
    obs.update(measured=None, model_before=before.tolist(), model_after=after.tolist(), kind="plane",
               error_before=np.abs(before[:, 2] - 300).tolist(),
               error_after=np.abs(after[:, 2] - 300).tolist())
    text = render_report(result)
    assert "distance to fitted plane (mm)" in text and "no measured points" in text
    assert "iso9283" not in section_ids(text)
    assert svg_count(text) == 6  # no residual-vector plot without measured points


def test_rejects_non_dict():
    from robocal.core.errors import DataError

    with pytest.raises(DataError):
        render_report([1, 2])


def test_cli_report(tmp_path):
    from robocal.cli import main

    src = tmp_path / "result.json"
    result = synthetic_result(5, n_poses=20)
    for key in ("observations", "validation_observations", "correlation", "history"):
        result.pop(key)
    src.write_text(json.dumps(result))
    before = src.read_bytes()
    out = tmp_path / "r.html"
    assert main(["--quiet", "report", str(src), "-o", str(out), "--title", "Cell 4"]) == 0
    assert "<h1>Cell 4</h1>" in out.read_text()
    assert src.read_bytes() == before
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main(["report", str(bad), "-o", str(tmp_path / "x.html")]) == 2
    assert not (tmp_path / "x.html").exists()


def test_report_of_a_real_robust_calibration(tmp_path):
    """End to end: simulate a tracker data set with outliers, calibrate (robust), report."""
    from robocal.calibration.pipeline import calibrate
    from robocal.calibration.result import load_result
    from robocal.data.simulate import simulate_tracker

    robot = Robot.from_catalog("abb_irb2600")
    sim = simulate_tracker(robot, 40, seed=1, outliers=0.05)
    result = calibrate(robot, sim.data, method="robust")
    json_path = tmp_path / "result.json"
    result.save_json(json_path)
    data = load_result(json_path)
    text = write_report(data, tmp_path / "report.html").read_text(encoding="utf-8")
    ids = section_ids(text)
    for sid in ("summary", "errors", "parameters", "identifiability", "correlation", "rejected"):
        assert sid in ids
    assert svg_count(text) >= 6
    assert f"{data['after']['rms']:.4f}" in text
    assert len(data["rejected"]) >= 1
    for r in data["rejected"]:
        assert f"<td>{r['source_row']}</td><td>{r['pose_id']}</td>" in text
    for d in data["dropped"]:
        assert f"<td class=\"l\">{d['name']}</td>" in text


def test_nongeometric_terms_are_tabled():
    result = synthetic_result(5, n_poses=20, repeats=0, validation=False)
    result["nongeometric"] = {"terms": ["gear", "backlash"], "kept": ["gear2_s1", "backlash1"],
                              "dropped": ["gear1_c1"],
                              "parameters": [{"name": "gear2_s1", "estimate": 1e-4, "sigma": 1e-5},
                                             {"name": "backlash1", "estimate": 2e-4, "sigma": 2e-5}]}
    result["parameters"] += [  # the parameter table holds every estimated term in display units
        {"name": name, "unit": "deg", "nominal": 0.0, "estimate": float(np.rad2deg(v)),
         "correction": float(np.rad2deg(v)), "sigma": float(np.rad2deg(v / 10)), "status": "estimated"}
        for name, v in (("gear2_s1", 1e-4), ("backlash1", 2e-4))]
    result["parameters"].append({"name": "gear1_c1", "unit": "deg", "nominal": 0.0, "estimate": 0.0,
                                 "correction": 0.0, "sigma": None, "status": "dropped"})
    result["dropped"].append({"name": "gear1_c1", "reason": "not identifiable from these data",
                              "confounded_with": ["theta1"]})
    text = render_report(result)
    assert "Joint errors: gear, backlash" in text
    assert "0.01146" in text  # 2e-4 rad in deg
    params = text[text.index('id="parameters"'):text.index("</section>", text.index('id="parameters"'))]
    for name in ("gear2_s1", "backlash1", "gear1_c1"):  # in the joint-error table only, not twice
        assert params.count(f">{name}</td>") == 1, name
    joint = params[params.index("Joint errors"):]
    assert "confounded with theta1" in joint and ">alpha1</td>" not in joint


def test_summary_leads_with_error_model_accuracy_and_warnings():
    result = synthetic_result(3, n_poses=30, repeats=0)
    result["warnings"] = ["the normal matrix is strongly ill-conditioned"]
    result["nongeometric"] = {"terms": ["compliance", "travel"], "kept": [], "dropped": []}
    summary = render_report(result)
    summary = summary[summary.index('id="summary"'):summary.index("</section>")]
    model, accuracy = summary.index("Error model:"), summary.index("Accuracy held out")
    warning, table = summary.index("strongly ill-conditioned"), summary.index("<table")
    assert model < accuracy < warning < table
    assert "joint errors: compliance, travel" in summary[model:accuracy]
    assert f"{result['validation']['rms']:.4f} mm RMS" in summary[accuracy:warning]
    assert summary.index("Where these numbers come from") > table


def test_summary_without_validation_says_the_accuracy_is_the_fits_own():
    result = synthetic_result(4, n_poses=30, repeats=0, validation=False)
    summary = render_report(result)
    summary = summary[summary.index('id="summary"'):summary.index("</section>")]
    assert "Accuracy on the calibration set" in summary and "optimistic" in summary
    assert "geometric (MDH + beta)" in summary
    if result.get("dropped"):  # a parameter held at nominal is a warning, never "No warnings."
        assert "held at nominal" in summary and "No warnings." not in summary
    else:
        assert "No warnings." in summary


def test_every_figure_says_what_to_look_for(full):
    text = full[1]
    assert text.count("<figure") == svg_count(text) == text.count("<b>Look for:</b>")


def test_figures_state_scale_and_density_in_words(full):
    from robocal.report import plots

    assert plots.magnification(7290.4) == "7290x" and plots.magnification(12.54) == "12.5x"
    text = full[1]
    assert re.search(r"arrows magnified [0-9.]+x", text)
    assert "residual vectors x" not in text
    # 72 calibration observations against 40 validation ones: histogram as shares
    assert "share of the set (%)" in text and "as the share of each set per bin" in text


def test_binned_mean_matches_a_loop():
    from robocal.report.plots import _binned_mean

    rng = np.random.default_rng(0)
    x, y = rng.uniform(-90, 90, 600), rng.uniform(0, 1, 600)
    centres, mean = _binned_mean(x, y, 12)
    order = np.argsort(x)
    groups = np.array_split(order, 12)  # 600 distinct angles: 12 bins of 50
    np.testing.assert_allclose(mean, [y[g].mean() for g in groups])
    np.testing.assert_allclose(centres, [x[g].mean() for g in groups])


def test_history_that_starts_below_before_is_explained():
    result = synthetic_result(6, n_poses=30, repeats=0)
    before_m = result["before"]["rms"] / 1e3
    result["method"] = "lsq"
    result["model_selection"] = {"candidates": []}
    result["history"] = [{"iteration": k, "rms": before_m / 50 / (k + 1)} for k in range(4)]
    text = render_report(result)
    history = text[text.index('id="history"'):]
    assert "not at the error before calibration" in history and "largest candidate" in history
    assert "before calibration" in history  # the dashed line's legend


def test_an_unknown_parameter_status_is_shown_as_it_is():
    result = synthetic_result(7, n_poses=20, repeats=0, validation=False)
    result["parameters"][0]["status"] = "undetermined <x>"
    text = render_report(result)
    assert ">undetermined &lt;x&gt;</td>" in text


def test_distance_data_report_the_pairs_length_errors(tmp_path):
    """A ball-bar (distance-only) calibration: the report's per-row errors are the pairs' length
    errors the result states, not distances to a plane through the modelled tips."""
    from test_distance import _truth, ballbar

    from robocal import calibrate

    nominal, truth = _truth()
    res = calibrate(nominal, ballbar(truth, 60, 0.005, seed=3))
    result = res.to_dict()
    obs = result["observations"]
    assert obs["kind"] == "distance"
    after = np.asarray(obs["error_after"])
    assert np.sqrt(np.mean(after**2)) == pytest.approx(result["after"]["rms"], rel=1e-9)
    text = render_report(result)
    assert "the pair&#x27;s distance (mm)" in text and "distance to fitted plane" not in text


def test_priors_section_gives_the_asked_scales_their_units():
    from robocal.report.priors import section

    zeros = {"scale": 0.5, "default": 0.5, "unit": "deg", "source": "fixed"}
    result = {"priors": {"class": "industrial", "class_chosen_by": "model ur5", "groups": {"zeros": zeros},
                         "asked": {"zeros": 3.2}, "asked_gain_nats": 12.0}}
    assert "wider priors than were used: zeros 3.200 deg (evidence +12" in section(result)
