"""Diagnoses that test what the structure allows (issue 47, cause 2): a moved SMR or tracker named by
a check instead of a parameter confounded with them, several joints counted the other way, a track
counted the other way, an arm mounted turned on its carriage, targets in the tracker frame. Cases of
our own making on other families than the ABB arm the module was developed on (Yaskawa GP25, KUKA
KR 6 R700, a FANUC M-20iA on a track, a UR10e)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import yaml

import robocal as rc
from robocal.cli import main
from robocal.data.registration import register, rigid_fit_rms
from robocal.data.simulate import sample_joints, simulate_tracker
from robocal.history.check import FRAME_NAMES, Uncertainty, candidates, check_calibration, confounded
from robocal.history.record import calibration_uncertainty
from robocal.kinematics.model import cell_from_data
from robocal.kinematics.transforms import make_transform
from robocal.trust.diagnosis import diagnose

CELL = {"units": {"length": "mm", "angle": "deg"}, "robot": "fanuc_m20ia",
        "track": {"direction": [1, 0, 0], "limits": [0, 4000]}}


@pytest.fixture(scope="module")
def gp25():
    """A calibrated Yaskawa GP25 (60 poses), its truth, its uncertainty and 25 check poses."""
    nominal = rc.Robot.from_catalog("yaskawa_gp25")
    sim = simulate_tracker(nominal, 60, seed=5)
    result = rc.calibrate(nominal, sim.data, nongeometric="none", progress=False)
    q = sample_joints(sim.truth, 25, np.random.default_rng(9))
    return sim.truth, result, Uncertainty.from_dict(calibration_uncertainty(result)), q


def _check_data(robot, q):
    return simulate_tracker(robot, joints=q, as_is=True, seed=3).data


def test_a_reseated_smr_and_a_bumped_tracker_are_named_never_a_confounded_link(gp25):
    truth, result, unc, q = gp25
    seated = replace(truth, tool=truth.tool @ make_transform(np.eye(3), [0.002, -0.001, 0.0017]))  # 2.81 mm
    bumped = replace(truth, base=make_transform(np.eye(3), [0.0004, 0.0003, -0.0003]) @ truth.base)  # 0.58 mm
    for robot, moved, size in ((seated, "smr", np.sqrt(0.002**2 + 0.001**2 + 0.0017**2)),
                               (bumped, "tracker", np.sqrt(0.34e-6))):
        data = _check_data(robot, q)
        check = check_calibration(result.robot, data, unc, fit_frame=False)  # the model's own frame
        assert check.verdict == "changed" and check.frame_change["moved"] == [moved]
        assert not check.changed_parameters  # d6, a1, alpha1, d1 are never named
        shown = check.frame_change["smr_shift_norm_mm" if moved == "smr" else "points_moved_rms_mm"]
        assert np.linalg.norm(shown) == pytest.approx(size * 1e3, rel=0.05)
        assert "--fit-frame" in check.summary() and "d6" not in check.summary()
        assert check.explained_p_value >= 0.01
        assert check_calibration(result.robot, data, unc, fit_frame=True).verdict == "holds"
    # the SMR's shift in the flange frame: the tool is turned 180 deg about x, so y and z change sign
    data = _check_data(seated, q)
    shift = check_calibration(result.robot, data, unc, fit_frame=False).frame_change["smr_shift_mm"]
    np.testing.assert_allclose(shift, [2.0, 1.0, -1.7], atol=0.05)
    # a moved SMR and a changed joint zero together: the SMR first, then theta3 (still named)
    both = _check_data(seated.with_values({"theta3": truth.get("theta3") + np.deg2rad(0.02)}), q)
    check = check_calibration(result.robot, both, unc, fit_frame=False)
    assert check.frame_change["moved"] == ["smr"] and check.changed_parameters[0]["name"] == "theta3"


def test_the_confounded_parameters_are_found_by_their_columns():
    """Every parameter the structure confounds with the frames is matched exactly by a refitted
    frame (brute force: shift it by 1 mm / 0.1 deg, refit the frame, nothing is left); the others not."""
    for name in ("ur10e", "kuka_kr6_r700"):
        nominal = rc.Robot.from_catalog(name)
        sim = simulate_tracker(nominal, 25, seed=5, noise_mm=0.0)
        zeros, others = candidates(sim.truth)
        names = [*zeros, *others]
        J = sim.truth.jacobian(sim.data.joints, names).reshape(-1, len(names))
        frame = sim.truth.jacobian(sim.data.joints, list(FRAME_NAMES)).reshape(-1, len(FRAME_NAMES))
        hidden = confounded(names, J, frame, np.eye(len(J)))
        assert set(hidden) == {"alpha1", "a1", "theta1", "d1", "theta6", "d6"}
        for p in ("alpha1", "a1", "theta1", "d1", "theta6", "d6", "theta3", "a2", "alpha6"):
            step = 1e-3 if sim.truth.parameter_units()[sim.truth.parameter_names.index(p)] == "m" else 2e-3
            moved = simulate_tracker(sim.truth.with_values({p: sim.truth.get(p) + step}),
                                         joints=sim.data.joints, as_is=True, noise_mm=0.0).data
            fitted = register(sim.truth, moved)
            left = np.sqrt(np.mean(np.sum((fitted.fk(moved.joints)[:, :3, 3] - moved.points) ** 2, axis=1)))
            assert (left < 1e-6) == (p in hidden), (name, p, left)  # m


def test_a_reseated_smr_through_the_check_command(gp25, tmp_path, capsys):
    truth, result, _, q = gp25
    model, res_json = tmp_path / "cal.yaml", tmp_path / "result.json"
    result.problem.datasets[0].save(tmp_path / "cal.csv")
    assert main(["--quiet", "calibrate", str(tmp_path / "cal.csv"), "--robot", "yaskawa_gp25",
                 "--nongeometric", "none", "-o", str(model), "--json", str(res_json)]) == 0
    seated = replace(truth, tool=truth.tool @ make_transform(np.eye(3), [0.0, 0.0, 0.003]))
    _check_data(seated, q).save(tmp_path / "check.csv")
    capsys.readouterr()
    out = tmp_path / "check.json"
    assert main(["check", str(model), str(tmp_path / "check.csv"), "--result", str(res_json), "--json",
                 str(out)]) == 0
    said = capsys.readouterr().out
    assert "the SMR on the tool" in said and "--fit-frame" in said and "d6" not in said
    verdict = json.loads(out.read_text())
    assert verdict["frame_change"]["smr_shift_norm_mm"] == pytest.approx(3.0, rel=0.03)
    assert verdict["changed_parameters"] == []


@pytest.mark.parametrize("flipped", [(1,), (1, 2), (1, 2, 4), (0, 3, 5)])
def test_several_joints_counted_the_other_way_are_named(flipped):
    nominal = rc.Robot.from_catalog("kuka_kr6_r700")
    sim = simulate_tracker(nominal, 40, seed=2)
    q = sim.data.joints.copy()
    q[:, list(flipped)] *= -1
    why = diagnose(nominal, [replace(sim.data, joints=q)])
    names = ", ".join(f"q{i + 1}" for i in flipped)
    assert why is not None and (f"joints {names} look counted" in why if len(flipped) > 1
                                else f"joint {names}'s sign looks flipped" in why)
    assert diagnose(nominal, [sim.data]) is None  # clean: nothing to say


def test_the_rigid_screen_is_the_kabsch_fit():
    """rigid_fit_rms against an independent fit (scipy's Rotation.align_vectors)."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(4)
    Y = rng.normal(size=(30, 3))
    P = np.stack([Rotation.random(random_state=k).apply(Y) + rng.normal(scale=s, size=(30, 3)) + 1.0
                  for k, s in enumerate((0.0, 0.01, 0.3))])
    got = rigid_fit_rms(P, Y)
    for k in range(3):
        Pc, Yc = P[k] - P[k].mean(axis=0), Y - Y.mean(axis=0)
        R, _ = Rotation.align_vectors(Yc, Pc)
        assert got[k] == pytest.approx(np.sqrt(np.mean(np.sum((R.apply(Pc) - Yc) ** 2, axis=1))), abs=1e-9)


def test_a_track_counted_the_other_way_and_a_turned_mount_are_named():
    cell = cell_from_data(CELL)
    sim = simulate_tracker(cell, 40, seed=4)
    reversed_track = replace(sim.data, joints=sim.data.joints * np.r_[-1.0, np.ones(6)])
    why = diagnose(cell, [reversed_track])
    assert "prismatic axis e1's direction looks reversed" in why and "q1" not in why.split(":")[0]
    for turn in (90, -90, 35):
        real = cell_from_data(dict(CELL, mount={"xyz": [0, 0, 0], "rpy": [0, 0, turn]}))
        why = diagnose(cell, [_check_data(real, sim.data.joints)])
        assert f"mounted turned by {turn:+d} deg about the z axis of its base" in why, why
    assert diagnose(cell, [sim.data]) is None
    # a KUKA's joint 1 turns about its base's -z: the turn is still said as the mount's rpy z
    kuka = {**CELL, "robot": "kuka_kr16_2", "track": {"direction": [0, 1, 0], "limits": [0, 5000]}}
    real = cell_from_data(dict(kuka, mount={"xyz": [0, 0, 0], "rpy": [0, 0, 90]}))
    why = diagnose(cell_from_data(kuka), [_check_data(real, sim.data.joints)])
    assert "mounted turned by +90 deg" in why, why


def test_a_reversed_track_a_turned_mount_and_flipped_joints_through_the_calibrate_command(tmp_path, capsys):
    cell = cell_from_data(CELL)
    (tmp_path / "track.yaml").write_text(yaml.safe_dump(CELL))
    sim = simulate_tracker(cell, 40, seed=4)
    replace(sim.data, joints=sim.data.joints * np.r_[-1.0, np.ones(6)]).save(tmp_path / "reversed.csv")
    real = cell_from_data(dict(CELL, mount={"xyz": [0, 0, 0], "rpy": [0, 0, 90]}))
    _check_data(real, sim.data.joints).save(tmp_path / "turned.csv")
    kr6 = simulate_tracker(rc.Robot.from_catalog("kuka_kr6_r700"), 40, seed=2).data
    replace(kr6, joints=kr6.joints * np.array([1, -1, -1, 1, -1, 1])).save(tmp_path / "flipped.csv")
    track = str(tmp_path / "track.yaml")
    for data, robot, said in (("reversed", track, "prismatic axis e1's direction looks"),
                              ("turned", track, "mounted turned by +90 deg"),
                              ("flipped", "kuka_kr6_r700", "joints q2, q3, q5 look counted the other way")):
        capsys.readouterr()
        assert main(["calibrate", str(tmp_path / f"{data}.csv"), "--robot", robot,
                     "-o", str(tmp_path / "cal.yaml")]) == 2
        err = capsys.readouterr().err
        assert said in err and not (tmp_path / "cal.yaml").exists(), err


def test_targets_in_the_tracker_frame_name_targets_in(tmp_path, capsys):
    nominal = rc.Robot.from_catalog("kuka_kr6_r700")
    sim = simulate_tracker(nominal, 40, seed=2)  # the tracker 3 m away from the base
    calibrated = rc.calibrate(nominal, sim.data, nongeometric="none", progress=False).robot
    q = sample_joints(nominal, 6, np.random.default_rng(1))
    targets = calibrated.fk(q)  # poses of its measured tool in the tracker frame
    comp = rc.compensate(calibrated, nominal, targets, targets_frame="robot")
    assert not comp.converged.any() and "--targets-in model" in comp.warnings[0]
    right = rc.compensate(calibrated, nominal, targets, targets_frame="model")
    assert right.converged.all() and not any("--targets-in" in w for w in right.warnings)
    # targets reached where they are given: nothing is tried
    assert not any("--targets-in" in w for w in rc.compensate(
        calibrated, nominal, nominal.fk(q), targets_frame="robot").warnings)
    # through the command (flange targets): the default frame is the robot's, the warning names the option
    targets = calibrated.with_frames(tool=nominal.tool).fk(q)
    calibrated.save(tmp_path / "cal.yaml")
    rows = ["x_mm,y_mm,z_mm,qw,qx,qy,qz"]
    from scipy.spatial.transform import Rotation

    for T in targets:
        x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
        rows.append(",".join(repr(float(v)) for v in (*T[:3, 3] * 1e3, w, x, y, z)))
    (tmp_path / "targets.csv").write_text("\n".join(rows) + "\n")
    capsys.readouterr()
    assert main(["compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "targets.csv"), "--nominal",
                 "kuka_kr6_r700", "-o", str(tmp_path / "out.csv")]) == 1
    assert "compensate them with --targets-in model" in capsys.readouterr().out
    assert main(["--quiet", "compensate", str(tmp_path / "cal.yaml"), str(tmp_path / "targets.csv"),
                 "--nominal", "kuka_kr6_r700", "--targets-in", "model", "-o", str(tmp_path / "out.csv")]) == 0


def test_a_check_whose_joints_are_counted_the_other_way_is_diagnosed(gp25):
    from robocal.core.errors import PlausibilityError

    truth, result, unc, q = gp25
    data = _check_data(truth, q)
    flipped = replace(data, joints=data.joints * np.array([1, -1, -1, 1, -1, 1]))
    for fit_frame in (True, False):
        with pytest.raises(PlausibilityError, match="joints q2, q3, q5 look counted the other way"):
            check_calibration(result.robot, flipped, unc, fit_frame=fit_frame)


def test_the_smr_that_moved_is_named_among_several():
    nominal = rc.Robot.from_catalog("kuka_kr6_r700")
    sim = simulate_tracker(nominal, 60, seed=8, n_smr=2)
    result = rc.calibrate(nominal, sim.data, nongeometric="none", progress=False)
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    truth = sim.truth
    smr = truth.smr.copy()
    smr[0] += [0.0, 0.002, 0.0]  # the second SMR (smr index 1) moved 2 mm
    q = sample_joints(truth, 16, np.random.default_rng(2))
    data = simulate_tracker(replace(truth, smr=smr), joints=q, as_is=True, seed=2, n_smr=2).data
    check = check_calibration(result.robot, data, unc, fit_frame=False)
    assert check.frame_change["moved"] == ["smr"] and check.frame_change["smr"] == 1
    assert check.frame_change["smr_shift_norm_mm"] == pytest.approx(2.0, rel=0.05)
    assert "(smr index 1)" in check.summary() and not check.changed_parameters


def test_real_meca500_points_moved_as_a_bumped_tracker_or_a_reseated_smr():
    """The real Meca500 tracker data (a FARO tracker, ../shared/datasets): calibrated on six files,
    checked on 25 poses of the seventh with every point shifted 0.58 mm (a bumped tracker) or each
    shifted 2.81 mm along the pose's flange axes (a re-seated SMR): the frame is named, never a1,
    d1 or d6 (measured: the check's points moved 0.541 mm by the tracker frame, 2.806 mm by the
    SMR; the seventh file itself already differs by theta5 -0.02 deg, named after the tracker);
    joints counted the other way are named on the real joints."""
    from robots import require_datasets

    from robocal.data.importer import import_tracker

    folder = require_datasets() / "meca500-faro"
    spec = {"joints": "cols=0-5:deg", "points": "cols=6-8:m"}
    files = sorted(folder.glob("cal_data__*_Output.csv"))
    cal = import_tracker(files[:6], **spec).data
    check = import_tracker(files[6:], **spec).data.first_poses(25)
    nominal = rc.Robot.from_catalog("meca500")
    result = rc.calibrate(nominal, cal, nongeometric="none", progress=False)
    unc = Uncertainty.from_dict(calibration_uncertainty(result))
    R = result.robot.fk(check.joints)[:, :3, :3]
    bumped = replace(check, points=check.points + [0.0004, 0.0003, -0.0003])
    seated = replace(check, points=check.points + np.einsum("nij,j->ni", R, [0.002, -0.001, 0.0017]))
    for data, moved, size in ((bumped, "tracker", 0.58), (seated, "smr", 2.81)):
        verdict = check_calibration(result.robot, data, unc, fit_frame=False)
        assert verdict.frame_change["moved"] == [moved], verdict.summary()
        named = {c["name"] for c in verdict.changed_parameters}
        assert not {"a1", "alpha1", "d1", "theta1", "d6", "theta6"} & named
        shown = verdict.frame_change["smr_shift_norm_mm" if moved == "smr" else "points_moved_rms_mm"]
        assert shown == pytest.approx(size, rel=0.1)
    q = cal.joints * np.array([1, -1, -1, 1, -1, 1])
    assert "joints q2, q3, q5 look counted the other way" in diagnose(nominal, [replace(cal, joints=q)])
