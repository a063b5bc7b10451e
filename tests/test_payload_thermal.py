"""Payload and temperature: the measurement columns, the payload and thermal error terms against
independent physics (gravity torque as the derivative of the payload's potential energy, scaled
link lengths), their Jacobian columns against finite differences, the model file round trip."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from jacobian_check import assert_columns_match, joint_error_jacobian

from robocal import Robot
from robocal.calibration.pipeline import calibrate
from robocal.cli import main
from robocal.core.errors import DataError, UnitError
from robocal.data.measurements import Measurements, parse_csv
from robocal.data.simulate import simulate_tracker
from robocal.kinematics.conditions import Conditions
from robocal.kinematics.joint_errors import parse_terms, term_names

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))  # the independent payload truth

HEADER = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm"
ROW = "0,-90,90,0,30,0,1500.0,20.0,1200.0"


def _conditions(rng, n):
    payload = np.c_[rng.choice([0.0, 75.0, 150.0], n), rng.uniform(-0.1, 0.1, (n, 2)), rng.uniform(0, 0.3, n)]
    return payload, rng.uniform(20.0, 35.0, n)


def test_condition_columns_round_trip_and_units(rng):
    payload, temperature = _conditions(rng, 6)
    data = Measurements.from_arrays("point", rng.uniform(-1, 1, (6, 6)), points=rng.uniform(0, 2, (6, 3)),
                                    conditions=Conditions(payload=payload, temperature=temperature))
    back = parse_csv(data.to_csv())
    np.testing.assert_array_equal(back.payload, payload)
    np.testing.assert_array_equal(back.temperature, temperature)
    columns = "payload_kg,payload_x_mm,payload_y_mm,payload_z_mm,temperature_c"
    text = f"{HEADER},{columns}\n{ROW},110,0,10,300,28.5\n"
    got = parse_csv(text)
    np.testing.assert_allclose(got.payload, [[110.0, 0.0, 0.01, 0.3]])
    np.testing.assert_allclose(got.temperature, [28.5])
    mass_only = parse_csv(f"{HEADER},payload_kg\n{ROW},20\n")  # the centre of mass defaults to the flange
    np.testing.assert_array_equal(mass_only.payload, [[20.0, 0.0, 0.0, 0.0]])
    assert parse_csv(f"{HEADER}\n{ROW}\n").payload is None
    assert parse_csv(f"{HEADER}\n{ROW}\n").temperature is None
    assert back.subset([1, 3]).temperature.tolist() == temperature[[1, 3]].tolist()


@pytest.mark.parametrize("extra, values, error, match", [
    ("payload_kg,payload_x_mm", "10,5", DataError, "needs all of payload_x"),
    ("payload_x_mm,payload_y_mm,payload_z_mm", "1,2,3", DataError, "need the payload_kg"),
    ("temperature_c", "301.2", DataError, "degrees Celsius"),
    ("payload_kg", "-3", DataError, "outside"),
    ("payload_lb", "3", DataError, "unknown column 'payload_lb'"),
    ("payload_kg,payload_x_in,payload_y_in,payload_z_in", "3,1,1,1", UnitError, "unknown length unit"),
])
def test_condition_column_errors_are_one_line(extra, values, error, match):
    with pytest.raises(error, match=match):
        parse_csv(f"{HEADER},{extra}\n{ROW},{values}\n", "f.csv")


def test_a_model_without_the_terms_says_it_did_not_use_the_columns(rng):
    payload, temperature = _conditions(rng, 3)
    data = Measurements.from_arrays("point", rng.uniform(-1, 1, (3, 6)), points=rng.uniform(0, 2, (3, 3)),
                                    conditions=Conditions(payload=payload, temperature=temperature),
                                    source="cell")
    robot = Robot.from_catalog("kuka_kr210_r2700")
    note = data.unused_conditions(robot)
    assert "payload and temperature" in note and "no payload or thermal term" in note
    assert "temperature" in data.unused_conditions(robot.with_joint_errors(["payload2"]))
    assert data.unused_conditions(robot.with_joint_errors(["payload2", "thermal"])) is None
    assert replace(data, payload=None, temperature=None).unused_conditions(robot) is None


def test_payload_moment_is_the_derivative_of_the_payloads_potential_energy(rng):
    """tau_i / |g| = -dV/dq_i / |g| with V = m |g| height of the centre of mass: finite differences of
    the FK of a tool at the centre of mass, independent of the basis's cross products."""
    robot = Robot.from_catalog("kuka_kr210_r2700")
    names = term_names(6, "payload")[:5]
    assert names == ["payload2", "payload3", "payload4", "payload5", "payload6"]
    model = robot.with_joint_errors(names)
    q = rng.uniform(-1.0, 1.0, (8, 6))
    payload, _ = _conditions(rng, 8)
    from robocal.kinematics.joint_errors import joint_error_basis
    B, joint = joint_error_basis(model, q, names, Conditions(payload=payload))
    com = replace(robot, tool=np.eye(4))
    h = 1e-6
    for p, i in enumerate(joint):
        e = np.zeros(6)
        e[i] = h
        heights = []  # the centre of mass as the tool, one row at a time
        for sign in (1, -1):
            z = []
            for c, qq in zip(payload[:, 1:], q + sign * e, strict=True):
                tool = np.eye(4)
                tool[:3, 3] = c
                z.append(replace(com, tool=tool).fk(qq[None])[0, 2, 3])
            heights.append(np.array(z))
        dV = payload[:, 0] * (heights[0] - heights[1]) / (2 * h)  # m * d(height)/dq_i, per unit g
        np.testing.assert_allclose(B[:, p], -dV, rtol=1e-6, atol=1e-6)


def test_lever_columns_are_the_moments_change_with_the_centre_of_mass(rng):
    """payload{i}_a: the payload moment's derivative along flange axis a of the centre of mass, by
    central differences of the moment (itself checked against the potential energy above)."""
    from robocal.kinematics.joint_errors import joint_error_basis

    robot = Robot.from_catalog("kuka_kr210_r2700")
    names = term_names(6, "payload")
    levers = [nm for nm in names if "_" in nm]
    assert levers == [f"payload{i}_{a}" for i in (2, 3) for a in "xyz"]  # not the wrist's by default
    levers += ["payload4_x", "payload5_z", "payload6_y"]  # named explicitly
    q = rng.uniform(-1.0, 1.0, (8, 6))
    payload, _ = _conditions(rng, 8)
    B, joint = joint_error_basis(robot, q, levers, Conditions(payload=payload))
    h = 1e-4
    for p, nm in enumerate(levers):
        axis = "xyz".index(nm[-1])
        moved = [payload.copy(), payload.copy()]
        moved[0][:, 1 + axis] += h
        moved[1][:, 1 + axis] -= h
        m = [joint_error_basis(robot, q, [nm[:-2]], Conditions(payload=x))[0][:, 0] for x in moved]
        np.testing.assert_allclose(B[:, p], (m[0] - m[1]) / (2 * h), rtol=1e-7, atol=1e-9)


def test_payload_term_recovers_known_compliances_and_the_loads_centre_of_mass():
    """On the independent truth of benchmarks/payload_truth.py (joints yielding 1-4 mm at the
    reach, moments at the deflected frames, the load's true centre of mass 60, -40, 70 mm off the
    recorded one): the held-out error at an unseen payload reaches the noise floor, the shoulder's
    and elbow's compliances come back within 2 %, the centre of mass's error within 15 mm."""
    import payload_truth

    from robocal.kinematics.load import lever_correction

    robot, data, held, floor, truth = payload_truth.campaign(2, n_cal=200, n_held=60)
    result = calibrate(robot, data, validation=held, nongeometric="payload,thermal")
    assert result.validation["rms"] <= 1.2 * floor
    values = dict(zip(result.robot.joint_errors.names, result.robot.joint_errors.values, strict=True))
    for i in (2, 3):
        assert values[f"payload{i}"] == pytest.approx(truth["compliance"][i - 1], rel=0.02)
    delta = lever_correction(values, (2, 3))
    true_delta = truth["com"] - np.asarray(payload_truth.RECORDED_COM_M)
    np.testing.assert_allclose(delta, true_delta, atol=0.015)
    said = result.to_dict()["conditions"]["payload_com_correction_mm"]  # what the summary says too
    assert said["joints"] == [2, 3] and np.allclose(said["xyz"], delta * 1e3)
    assert "the load's centre of mass, as the payload term sees it (joints 2, 3)" in result.summary()
    assert result.robot.joint_errors.thermal_k() == pytest.approx(payload_truth.THERMAL_K, rel=0.05)


def test_thermal_term_scales_the_arms_link_lengths_base_height_included(rng):
    k, t_ref = 11.5e-6, 22.0
    robot = Robot.from_catalog("kuka_kr210_r2700")
    warm = robot.with_joint_errors(["thermal"]).with_values({"thermal": k}).with_reference_temperature(t_ref)
    q = rng.uniform(-1.0, 1.0, (5, 6))
    for t in (12.0, 22.0, 37.0):
        s = 1 + k * (t - t_ref)
        scaled = replace(robot, a=robot.a * s, d=robot.d * s)  # d1 is the base height
        hot = Conditions(temperature=np.full(5, t))
        np.testing.assert_allclose(warm.fk(q, conditions=hot), scaled.fk(q), atol=1e-13)
    np.testing.assert_allclose(warm.fk(q), robot.fk(q), atol=1e-15)  # no temperature: the arm at T_ref


@pytest.mark.parametrize("kind", ["point", "pose"])
def test_payload_and_thermal_columns_match_finite_differences(kind, rng):
    robot = Robot.from_catalog("kuka_kr210_r2700")
    sim = simulate_tracker(robot, 15, kind=kind, noise_mm=0.0, seed=3)
    payload, temperature = _conditions(rng, len(sim.data))
    data = replace(sim.data, payload=payload, temperature=temperature)
    names = [*term_names(6, "payload")[:5], "payload2_x", "payload3_z", "payload5_y", "thermal", "comp2_3"]
    values = (np.array([3e-7, 2e-7, 1e-6, 5e-7, 1e-6, 3e-8, 2e-8, 5e-8, 11.5e-6, 4e-4])
              * (1 if kind == "point" else 1e-3))
    problem, state, space, J = joint_error_jacobian(sim.truth, data, names, values, ("a2", "d1"), 26.0)
    assert np.abs(J[:, 2:]).max(axis=0).min() > 1e-3  # every column moves the TCP
    assert_columns_match(problem, state, space, J, n_geometric=2)


def test_terms_parse_and_reference_temperature_round_trips(tmp_path):
    assert parse_terms("payload,thermal") == ["payload", "thermal"]
    robot = Robot.from_catalog("kuka_kr210_r2700").with_joint_errors(["payload3", "thermal"])
    robot = robot.with_values({"thermal": 1.2e-5, "payload3": 4e-7}).with_reference_temperature(27.25)
    robot.save(tmp_path / "m.yaml")
    back = Robot.load(tmp_path / "m.yaml")
    assert back.joint_errors.reference_temperature_c == 27.25
    assert back.joint_errors.names == ("payload3", "thermal")
    np.testing.assert_array_equal(back.joint_errors.values, robot.joint_errors.values)
    assert back.displaced(["a2"], [1e-4]).joint_errors.reference_temperature_c == 27.25


def test_simulated_conditions_physics_agrees_with_the_fitted_terms():
    """The simulator's own physics (energy derivative, scaled links) and the truth it writes, read
    through the payload and thermal terms, give the same points."""
    robot = Robot.from_catalog("kuka_kr210_r2700")
    sim = simulate_tracker(robot, 40, noise_mm=0.0, seed=5, payloads=[0, 75, 150], temperatures=(20, 35),
                           payload_com=[0.05, -0.02, 0.3])
    d = sim.data
    assert sorted(set(d.payload[:, 0])) == [0.0, 75.0, 150.0] and d.temperature.min() == 20.0
    assert sim.truth.joint_errors.reference_temperature_c == pytest.approx(d.temperature.mean())
    p = sim.truth.fk(d.joints, smr=d.smr, conditions=d.conditions)[:, :3, 3]
    np.testing.assert_allclose(p, d.points, rtol=0, atol=1e-9)
    plain = sim.truth.with_joint_errors([]).fk(d.joints, smr=d.smr)[:, :3, 3]
    assert np.linalg.norm(plain - d.points, axis=1).max() > 1e-4  # the conditions move the TCP


def test_payload_and_thermal_terms_reach_the_noise_floor_at_an_unseen_payload_and_temperature():
    robot = Robot.from_catalog("kuka_kr210_r2700")
    cal = simulate_tracker(robot, 150, noise_mm=0.02, seed=2, payloads=[0, 75, 150], temperatures=(20, 35))
    held = simulate_tracker(cal.truth, 60, noise_mm=0.02, seed=9, as_is=True, payloads=[110],
                            temperatures=(28, 28))
    geometric = calibrate(robot, cal.data, validation=held.data, nongeometric="none")
    result = calibrate(robot, cal.data, validation=held.data, nongeometric="payload,thermal")
    assert result.validation["rms"] <= 1.3 * held.noise_floor_mm < geometric.validation["rms"]
    assert result.robot.joint_errors.thermal_k() == pytest.approx(11.5e-6, rel=0.1)


def test_simulate_cli_writes_the_condition_columns_and_refuses_a_bad_range(tmp_path, capsys):
    out, truth = tmp_path / "cell.csv", tmp_path / "truth.yaml"
    assert main(["--quiet", "simulate", "--robot", "kuka_kr210_r2700", "--poses", "12", "--payloads", "0,150",
                 "--payload-com-mm", "0,0,300", "--temperatures", "20:30", "-o", str(out),
                 "--truth", str(truth)]) == 0
    data = Measurements.load(out)
    np.testing.assert_allclose(data.payload[-1], [150.0, 0.0, 0.0, 0.3])
    assert data.temperature.max() == 30.0
    assert Robot.load(truth).joint_errors.reference_temperature_c == pytest.approx(data.temperature.mean())
    capsys.readouterr()
    assert main(["evaluate", "kuka_kr210_r2700", str(out), "--fit-frame"]) == 0
    assert "no payload or thermal term: not used" in capsys.readouterr().out
    assert main(["evaluate", str(truth), str(out)]) == 0  # the truth has both terms: no note
    assert "not used" not in capsys.readouterr().out
    assert main(["simulate", "--robot", "kuka_kr210_r2700", "--poses", "12", "--temperatures", "35:20",
                 "-o", str(out), "--truth", str(truth)]) == 2
    assert "LO:HI" in capsys.readouterr().err


def _palletize(tmp_path, load2: str | None = None):
    """The palletize program (its inline forms use tool 2) and a $config.dat; ``load2``: the
    LOAD_DATA[2] aggregate the $config.dat declares (None: none)."""
    import shutil
    from pathlib import Path

    data = Path(__file__).parent / "data" / "programs"
    for f in ("palletize.src", "palletize.dat", "config.dat"):
        shutil.copy(data / f, tmp_path / f)
    if load2 is not None:
        config = tmp_path / "config.dat"
        config.write_text(config.read_text().replace("ENDDAT", f"LOAD_DATA[2]={load2}\nENDDAT"))
    return [tmp_path / "palletize.src", tmp_path / "palletize.dat"], [tmp_path / "config.dat"]


def test_filter_and_compensate_use_the_given_conditions_and_warn_of_the_assumed_ones(tmp_path):
    from robocal.data.simulate import perturbed
    from robocal.deploy.compensation import compensate
    from robocal.programs import filter_program

    nominal = Robot.from_catalog("kuka_kr16_2")
    true = perturbed(nominal, 3)
    k, t_ref, t = 11.5e-6, 24.0, 34.0
    warm = true.with_joint_errors(["payload2", "payload3", "thermal"]).with_values(
        {"payload2": 2e-5, "payload3": 3e-5, "thermal": k}).with_reference_temperature(t_ref)
    files, refs = _palletize(tmp_path)
    with pytest.raises(DataError, match=r"FDAT_ACT=FP1: LOAD_DATA\[2\] is declared in no file given"):
        filter_program(files, warm, nominal, references=refs)  # the inline forms load LOAD_DATA[2]
    files, refs = _palletize(tmp_path, "{M 0.0,CM {X 0,Y 0,Z 0,A 0,B 0,C 0},J {X 0,Y 0,Z 0}}")
    plain = filter_program(files, warm, nominal, references=refs)
    assumed = [w for w in plain.warnings if "assumed" in w]
    assert len(assumed) == 1 and "24 deg C" in assumed[0]
    assert plain.loads[0].startswith("0 kg, centre of mass [0, 0, 0] mm (palletize.src:27 (FDAT_ACT=FP1))")
    # the thermal term at t: the same as the true links scaled by 1 + k (t - t_ref), no thermal term
    s = 1 + k * (t - t_ref)
    scaled = replace(true, a=true.a * s, d=true.d * s).with_joint_errors(["payload2", "payload3"])
    scaled = scaled.with_values({"payload2": 2e-5, "payload3": 3e-5})
    hot = filter_program(files, warm, nominal, references=refs, temperature=t, payload=[12.0, 0, 0, 0.1])
    same = filter_program(files, scaled, nominal, references=refs, payload=[12.0, 0, 0, 0.1])
    assert not [w for w in hot.warnings if "assumed" in w]
    assert hot.outputs == same.outputs != plain.outputs
    # compensate: the corrected joints reach the targets on the model at those conditions
    q = np.deg2rad([[10, -80, 90, 5, 40, 0], [-20, -60, 70, 0, 60, 30]])
    targets = nominal.fk(q)
    res = compensate(warm, nominal, targets, payload=[12.0, 0, 0, 0.1], temperature=t, targets_frame="robot")
    reached = warm.with_frames(base=nominal.base).fk(res.joints, conditions=Conditions(
        payload=np.tile([12.0, 0, 0, 0.1], (2, 1)), temperature=np.full(2, t)))
    np.testing.assert_allclose(reached[:, :3, 3], targets[:, :3, 3], atol=1e-9)
    assert res.assumed == () and len(compensate(warm, nominal, targets, targets_frame="robot").assumed) == 2


def test_compensate_cli_takes_payload_and_temperature(tmp_path, capsys):
    model = tmp_path / "warm.yaml"
    Robot.from_catalog("kuka_kr210_r2700").with_joint_errors(["payload2", "thermal"]).with_values(
        {"payload2": 3e-7, "thermal": 11.5e-6}).with_reference_temperature(25.0).save(model)
    targets = tmp_path / "t.csv"
    targets.write_text("x_mm,y_mm,z_mm,rx_deg,ry_deg,rz_deg\n1800,200,1400,180,0,180\n")
    out = tmp_path / "c.csv"
    args = ["compensate", str(model), str(targets), "--nominal", "kuka_kr210_r2700", "-o", str(out)]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "assumed no payload (0 kg)" in text and "assumed its reference temperature 25 deg C" in text
    cold = out.read_text()
    assert main([*args, "--payload", "150,0,0,300", "--temperature", "35"]) == 0
    assert "assumed" not in capsys.readouterr().out and out.read_text() != cold
    assert main([*args, "--payload", "150,0"]) == 2
    assert "KG or KG,X,Y,Z" in capsys.readouterr().err
    plain = tmp_path / "plain.yaml"
    Robot.from_catalog("kuka_kr210_r2700").save(plain)
    capsys.readouterr()
    assert main(["compensate", str(plain), str(targets), "--nominal", "kuka_kr210_r2700", "-o", str(out),
                 "--temperature", "30"]) == 0
    assert "--temperature is not used" in capsys.readouterr().out


def test_auto_considers_payload_and_thermal_only_when_the_data_vary_them():
    from robocal.calibration.model_selection import _term_has_data

    robot = Robot.from_catalog("kuka_kr210_r2700")
    cal = simulate_tracker(robot, 80, noise_mm=0.02, seed=4, payloads=[0, 75, 150], temperatures=(20, 35))
    assert _term_has_data("payload", cal.data) and _term_has_data("thermal", cal.data)
    still = replace(cal.data, payload=np.tile([75.0, 0, 0, 0.25], (len(cal.data), 1)),
                    temperature=np.full(len(cal.data), 25.0))  # constant: indistinguishable from the geometry
    assert not _term_has_data("payload", still) and not _term_has_data("thermal", still)
    assert not _term_has_data("payload", replace(cal.data, payload=None))
    ms = calibrate(robot, cal.data, nongeometric="auto").model_selection
    assert {"payload", "thermal"} <= set(ms["chosen_terms"]) and not ms["terms_without_data"]


def test_evaluate_warns_when_the_data_lack_the_columns_the_model_uses(tmp_path, capsys):
    robot = Robot.from_catalog("kuka_kr210_r2700")
    sim = simulate_tracker(robot, 20, noise_mm=0.0, seed=6, payloads=[0, 150], temperatures=(20, 30))
    sim.truth.save(tmp_path / "truth.yaml")
    replace(sim.data, payload=None, temperature=None).save(tmp_path / "plain.csv")
    assert main(["evaluate", str(tmp_path / "truth.yaml"), str(tmp_path / "plain.csv")]) == 0
    out = capsys.readouterr().out
    assert "(the payload_kg column): assumed no payload (0 kg)" in out
    assert "(the temperature_c column): assumed its reference temperature 25 deg C" in out


def test_filter_reads_the_load_a_krl_program_sets(tmp_path):
    from robocal.data.simulate import perturbed
    from robocal.programs import filter_program

    nominal = Robot.from_catalog("kuka_kr16_2")
    warm = perturbed(nominal, 3).with_joint_errors(["payload2", "payload3"]).with_values(
        {"payload2": 2e-5, "payload3": 3e-5})
    load2 = "{M 12.0,CM {X 0,Y 0,Z 300,A 0,B 0,C 0},J {X 0,Y 0,Z 0}}"
    files, refs = _palletize(tmp_path, load2)
    src = files[0].read_text()
    given = filter_program(files, warm, nominal, references=refs, payload=[12.0, 0.0, 0.0, 0.3])
    own = filter_program(files, warm, nominal, references=refs)  # FDAT_ACT=FP1 loads LOAD_DATA[2]
    assert own.loads == ["12 kg, centre of mass [0, 0, 300] mm (palletize.src:27 (FDAT_ACT=FP1)): "
                         "4 motion(s), palletize.src lines 29, 36, 45-46"]
    assert not any("assumed" in w for w in own.warnings)

    def corrections(res):
        return [(r["name"].split("@")[0], r["correction_mm"], r["correction_deg"]) for r in res.rows]

    assert corrections(own) == corrections(given)
    tool2 = "$TOOL = TOOL_DATA[2]\n"
    files[0].write_text(src.replace(tool2, tool2 + "  $LOAD = LOAD_DATA[7]\n"))
    with pytest.raises(DataError, match=r"palletize.src:44: \$LOAD = LOAD_DATA\[7\]: LOAD_DATA\[7\] is "
                                        "declared in no file given .*--references.*--payload"):
        filter_program(files, warm, nominal, references=refs)
    files[0].write_text(src.replace("$TOOL = TOOL_DATA[2]\n", "$TOOL = TOOL_DATA[2]\n  $LOAD.M = 3.0\n"))
    with pytest.raises(DataError, match="a component of"):
        filter_program(files, warm, nominal, references=refs)
    model_without = filter_program(files, perturbed(nominal, 3), nominal, references=refs)  # reads no load
    assert model_without.loads == [] and not any("load" in w.lower() for w in model_without.warnings)


def test_filter_reads_urscript_set_payload(tmp_path):
    import shutil
    from pathlib import Path

    from robocal.data.simulate import perturbed
    from robocal.programs import filter_program

    path = tmp_path / "pick_place.script"
    shutil.copy(Path(__file__).parent / "data" / "programs" / "pick_place.script", path)
    nominal = Robot.from_catalog("ur5")
    warm = perturbed(nominal, 2).with_joint_errors(["payload2", "payload3"]).with_values(
        {"payload2": 1e-4, "payload3": 1e-4})
    res = filter_program([path], warm, nominal)
    assert res.loads[0].startswith("1.2 kg, centre of mass [0, 0, 80] mm (pick_place.script:4 "
                                   "(set_payload(1.2, [0.0, 0.0, 0.08])))")
    given = filter_program([path], warm, nominal, payload=[1.2, 0.0, 0.0, 0.08])
    assert [r["correction_mm"] for r in res.rows] == [r["correction_mm"] for r in given.rows]
