"""SCARAs: the catalog entries against their published chains, structural freedoms named, closed-form
IK in 2 branches, a calibration recovering a simulated truth, a FANUC SR program's CONFIG
'L|R, t1, t2, t4' read and filtered, the quill in mm."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

import robocal as rc
from robocal.data.simulate import simulate_tracker
from robocal.ik import scara

SOURCES = yaml.safe_load((Path(__file__).parent / "data" / "scara_sources.yaml").read_text())


def _source_fk(src: dict, q: np.ndarray) -> np.ndarray:
    """The published chain's flange poses (m) of joints ``q`` (rad; m on the quill): Craig's
    modified DH product, theta_i + inv_i q_i on revolute joints, d_i + inv_i q_i on the quill."""
    alpha, a, d0, theta0 = (np.asarray(src[k], float) for k in ("alpha", "a", "d", "theta"))
    inv, k = np.asarray(src["inv"][:4], float), src["prismatic"] - 1
    N = len(q)
    T = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
    for i in range(4):
        th = theta0[i] + (np.zeros(N) if i == k else inv[i] * q[:, i])
        d = d0[i] * 1e-3 + (inv[i] * q[:, i] if i == k else np.zeros(N))
        ca, sa, ct, st = np.cos(alpha[i]), np.sin(alpha[i]), np.cos(th), np.sin(th)
        A = np.zeros((N, 4, 4))
        A[:, 0, :] = np.stack([ct, -st, np.zeros(N), np.full(N, a[i] * 1e-3)], axis=1)
        A[:, 1, :] = np.stack([st * ca, ct * ca, np.full(N, -sa), -sa * d], axis=1)
        A[:, 2, :] = np.stack([st * sa, ct * sa, np.full(N, ca), ca * d], axis=1)
        A[:, 3, 3] = 1.0
        T = T @ A
    return T


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_catalog_scara_equals_its_published_chain(name):
    robot = rc.Robot.from_catalog(name)
    q = np.random.default_rng(4).uniform(robot.limits[:, 0], robot.limits[:, 1], (200, 4))
    np.testing.assert_allclose(robot.fk(q), _source_fk(SOURCES[name], q), rtol=0, atol=1e-12)
    assert scara.is_scara(robot)
    assert [j.column for j in robot.joints] == ["q1_deg", "q2_deg", "q3_mm", "q4_deg"]


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_every_catalog_scara_round_trips_through_its_closed_form(name):
    robot = rc.Robot.from_catalog(name)
    q = np.random.default_rng(5).uniform(robot.limits[:, 0], robot.limits[:, 1], (300, 4))
    q[:, [0, 1, 3]] = (q[:, [0, 1, 3]] + np.pi) % (2 * np.pi) - np.pi
    sol = rc.ik.solve_all(robot, robot.fk(q))
    assert np.isclose(sol, q[:, None], atol=1e-8).all(axis=2).any(axis=1).all()


def test_scara_closed_form_round_trip_in_two_branches():
    robot = rc.Robot.from_catalog("epson_g6_651s")
    q = np.random.default_rng(0).uniform(robot.limits[:, 0], robot.limits[:, 1], (500, 4))
    q[:, 3] = (q[:, 3] + np.pi) % (2 * np.pi) - np.pi
    sol = rc.ik.solve_all(robot, robot.fk(q))
    assert sol.shape == (500, 2, 4)
    hit = np.isclose(sol, q[:, None], atol=1e-8).all(axis=2)
    assert hit.any(axis=1).all()
    np.testing.assert_array_equal(np.argmax(hit, axis=1), scara.branch_slot(robot, q))


def test_scara_calibration_recovers_truth_and_names_its_freedoms():
    robot = rc.Robot.from_catalog("epson_g6_651s")
    sim = simulate_tracker(robot, 60, seed=1, noise_mm=0.0)
    result = rc.calibrate(robot, sim.data, nongeometric="none")
    assert result.to_dict()["after"]["rms"] < 1e-4  # mm: noise-free data are fitted exactly
    q = np.random.default_rng(9).uniform(robot.limits[:, 0], robot.limits[:, 1], (200, 4))
    held_out = result.robot.fk(q)[:, :3, 3] - sim.truth.fk(q)[:, :3, 3]
    assert np.abs(held_out).max() < 1e-7  # m: the truth's TCP everywhere, whatever the freedoms held
    freedoms = {f["freedom"]: f for f in result.identifiability.freedoms}
    assert {"height", "turn", "tilt", "axis1", "quill", "forearm"} <= set(freedoms)
    assert "d3" in freedoms["height"]["held"] and "quill zero (d3)" in freedoms["height"]["words"]
    assert "structural freedoms of a SCARA" in result.summary()
    from robocal.report.html import render_report

    assert "Structural freedoms of a SCARA" in render_report(result.to_dict())


def _sr_program(robot, q, hands) -> str:
    """A FANUC SR TP program moving to the flange poses of joints ``q`` with CONFIG ``hands``."""
    from scipy.spatial.transform import Rotation

    T = robot.fk(q)
    rpw = Rotation.from_matrix(T[:, :3, :3]).as_euler("ZYX", degrees=True)  # R, P, W: Rz Ry Rx
    pos = []
    for k, (p, (r, pp, w), hand) in enumerate(zip(T[:, :3, 3] * 1e3, rpw, hands, strict=True), start=1):
        pos += [f"P[{k}]{{", "   GP1:", f"\tUF : 0, UT : 0,\t\tCONFIG : '{hand}, 0, 0, 0',",
                f"\tX = {p[0]:.3f}  mm,\tY = {p[1]:.3f}  mm,\tZ = {p[2]:.3f}  mm,",
                f"\tW = {w:.3f} deg,\tP = {pp:.3f} deg,\tR = {r:.3f} deg", "};"]
    moves = [f"   {k}:J P[{k}] 100% FINE    ;" for k in range(1, len(q) + 1)]
    return "\n".join(["/PROG  T", "/MN", *moves, "/POS", *pos, "/END", ""])


def test_fanuc_scara_config_is_read_kept_and_selects_the_hand(tmp_path):
    robot = rc.Robot.from_catalog("fanuc_sr6ia")
    q = np.deg2rad([[30.0, 40.0, 0.0, 10.0], [-50.0, -60.0, 0.0, 80.0]])
    q[:, 2] = [-0.05, -0.1]
    (tmp_path / "t.ls").write_text(_sr_program(robot, q, "RL"))  # elbow turning left about up: 'R'
    out = rc.filter_program(tmp_path / "t.ls", robot, robot)
    assert [r["configuration"] for r in out.rows] == ["kept", "kept"]
    assert max(r["correction_mm"] for r in out.rows) < 1e-6
    (tmp_path / "w.ls").write_text(_sr_program(robot, q, "LR"))  # the other hand: the same point
    out = rc.filter_program(tmp_path / "w.ls", robot, robot)
    assert max(r["correction_mm"] for r in out.rows) < 1e-6  # reached in the hand asked for


def test_filter_on_a_calibrated_scara_corrects_toward_the_truth(tmp_path):
    """A FANUC SR program filtered through the true robot (as the calibrated model): the corrected
    targets, driven through the nominal controller, put the true robot's flange on the program's."""
    nominal = rc.Robot.from_catalog("fanuc_sr6ia")
    truth = simulate_tracker(nominal, 10, seed=3, noise_mm=0.0).truth
    truth = replace(truth, tool=nominal.tool, smr=np.zeros((0, 3)))  # the flange, as the program's
    q = np.deg2rad([[20.0, 50.0, 0.0, 10.0], [-40.0, -70.0, 0.0, 60.0], [60.0, 30.0, 0.0, -90.0]])
    q[:, 2] = [-0.05, -0.1, -0.15]
    (tmp_path / "t.ls").write_text(_sr_program(nominal, q, "RLR"))
    out = rc.filter_program(tmp_path / "t.ls", truth, nominal)
    assert all(r["filtered"] for r in out.rows) and 0.01 < max(r["correction_mm"] for r in out.rows) < 5.0
    # the corrected targets, solved by the nominal controller in the hand asked for, move the true robot's
    # flange (in its base frame {0}) onto the program's targets
    text = next(iter(out.outputs.values())).decode()
    values = np.array([[float(v) for v in re.findall(r"[XYZWPR] = +([-\d.]+)", block)]
                       for block in text.split("/POS")[1].split("P[")[1:]])
    from scipy.spatial.transform import Rotation

    F = np.broadcast_to(np.eye(4), (len(values), 4, 4)).copy()
    F[:, :3, :3] = Rotation.from_euler("ZYX", values[:, [5, 4, 3]], degrees=True).as_matrix()
    F[:, :3, 3] = values[:, :3] * 1e-3
    sol = rc.ik.solve_all(nominal, F)[np.arange(3), [0, 1, 0]]  # 'R' = slot 0 (elbow positive, axis up)
    reached = np.linalg.inv(truth.base) @ truth.fk(sol)
    np.testing.assert_allclose(reached[:, :3, 3], nominal.fk(q)[:, :3, 3], atol=2e-6)  # the TP's 3 decimals


def test_a_scale_bar_calibrates_a_scara_without_naming_parameters():
    """Distances on a SCARA: the freedoms a bar cannot see (every height, the base) are named, not
    called a degenerate pose set (which needed --params before)."""
    robot = rc.Robot.from_catalog("epson_g6_651s")
    sim = simulate_tracker(robot, 60, seed=7, noise_mm=0.0, kind="distance", smr_offsets=np.zeros((1, 3)))
    result = rc.calibrate(robot, sim.data, nongeometric="none")
    assert result.to_dict()["after"]["rms"] < 1e-4
    held = {f["freedom"]: f["held"] for f in result.identifiability.freedoms}
    assert "d3" in held["height"] and "theta1" in held["turn"]
    true_a = sim.truth.values[[sim.truth.parameter_names.index(n) for n in ("a2", "a3")]]
    fit_a = result.robot.values[[result.robot.parameter_names.index(n) for n in ("a2", "a3")]]
    assert abs((fit_a.sum() + result.robot.values[result.robot.parameter_names.index("a4")])
               - (true_a.sum() + sim.truth.values[sim.truth.parameter_names.index("a4")])) < 1e-6


def test_compensate_a_calibrated_scara_reaches_the_targets():
    """Numeric IK on a calibrated SCARA solves its 4 tasks (position, turn): the true robot driven to
    the compensated joints puts its flange on the targets."""
    nominal = rc.Robot.from_catalog("epson_g6_651s")
    truth = replace(simulate_tracker(nominal, 10, seed=3, noise_mm=0.0).truth, tool=nominal.tool,
                    smr=np.zeros((0, 3)))
    q = np.deg2rad([[20.0, 50.0, 0.0, 10.0], [-40.0, -70.0, 0.0, 60.0]])
    q[:, 2] = [-0.05, -0.1]
    targets = truth.base @ nominal.fk(q)
    res = rc.ik.solve(truth, targets)
    assert res.converged.all()
    np.testing.assert_allclose(truth.fk(res.joints)[:, :3, 3], targets[:, :3, 3], atol=1e-9)


def test_a_scale_bar_scara_predicts_millimetres_not_metres():
    """The SMR height has no effect on distances on a SCARA (its column is round-off): held at
    nominal, it adds no variance to the predicted accuracy (it read 1.28 m RMS before)."""
    robot = rc.Robot.from_catalog("epson_g6_651s")
    sim = simulate_tracker(robot, 60, seed=7, noise_mm=0.01, kind="distance", smr_offsets=np.zeros((1, 3)))
    result = rc.calibrate(robot, sim.data, nongeometric="none")
    assert "tool.z" in result.identifiability.dropped
    assert result.to_dict()["predicted_accuracy"]["workspace"]["rms"] < 20.0  # mm: priors a bar cannot see


def test_a_scara_campaign_program_is_fanuc_tp_with_the_quill_in_mm(tmp_path):
    from robocal.campaign.programs import campaign_programs, refuse_tracks
    from robocal.core.errors import DataError

    robot = rc.Robot.from_catalog("fanuc_sr6ia")
    q = np.array([[0.1, -0.2, -0.05, 1.0], [0.3, 0.4, -0.15, -2.0]])
    text = campaign_programs(q, robot, {"fanuc": tmp_path / "c.ls"})[str(tmp_path / "c.ls")]
    assert "J3= -50 mm" in text and "J3= -150 mm" in text and "J5" not in text
    assert "J2= 22.9183 deg" in text  # 0.4 rad as it is: no J2/J3 coupling on a SCARA
    refuse_tracks({"fanuc": "c.ls"}, robot, "poses.csv")  # FANUC TP drives a SCARA
    with pytest.raises(DataError, match="is a SCARA: campaign programs are written for it in FANUC"):
        refuse_tracks({"rapid": "c.mod"}, robot, "poses.csv")


def test_plan_path_on_a_scara_chooses_among_its_hands():
    robot = rc.Robot.from_catalog("epson_g6_651s")
    q = np.deg2rad([[30.0, 40.0, 0.0, 10.0], [-50.0, -60.0, 0.0, 80.0], [10.0, 100.0, 0.0, -30.0]])
    q[:, 2] = [-0.05, -0.1, -0.02]
    path = rc.ik.plan_path(robot, robot.fk(q))
    assert path.joints.shape == (3, 4) and path.cost <= path.greedy_cost
    np.testing.assert_allclose(robot.fk(path.joints), robot.fk(q), atol=1e-9)
    calibrated = simulate_tracker(robot, 10, seed=3, noise_mm=0.0).truth
    path = rc.ik.plan_path(calibrated, calibrated.fk(q), nominal=robot)
    np.testing.assert_allclose(calibrated.fk(path.joints)[:, :3, 3], calibrated.fk(q)[:, :3, 3], atol=1e-9)


def test_a_six_axis_config_on_a_scara_is_named_not_called_impossible(tmp_path):
    from robocal.core.errors import DataError

    robot = rc.Robot.from_catalog("fanuc_sr6ia")
    q = np.deg2rad([[30.0, 40.0, 0.0, 10.0]])
    q[:, 2] = -0.05
    (tmp_path / "t.ls").write_text(_sr_program(robot, q, ["N U T"]))
    with pytest.raises(DataError, match="CONFIG 'N U T, 0, 0, 0' is a 6-axis arm's, but the nominal model "
                                        "fanuc_sr6ia is a SCARA"):
        rc.filter_program(tmp_path / "t.ls", robot, robot)


# A FANUC SR pick-and-place program as its pendant writes it (the style of a real SR-6iA program):
# named positions in user frame 1 and tool 1, six decimals, W = -180 (flange down), CONFIG 'L, 0, 0, 0',
# and motions to position registers (whose values live in the controller)
_PICK_PLACE = """/PROG  PICK_PLACE
/ATTR
OWNER\t\t= MNEDITOR;
COMMENT\t\t= "";
LINE_COUNT\t= 5;
PROTECT\t\t= READ_WRITE;
DEFAULT_GROUP\t= 1,*,*,*,*;
/APPL
/MN
   1:J P[1:HOME_PICK] 100% FINE    ;
   2:L P[2:PLACE_A] 100mm/sec FINE    ;
   3:  PR[2:TMP]=PR[5:TRAY]    ;
   4:L PR[2:TMP] 100mm/sec FINE    ;
   5:J P[3:CAM] 100% FINE    ;
/POS
{positions}/END
"""
_SR_TARGETS = [("HOME_PICK", 412.5, 176.25, 0.0, 0.0), ("PLACE_A", 355.125, -160.5, 0.0, 12.5),
               ("CAM", 215.75, 330.0, 80.125, -35.0)]  # name, X Y Z mm in UF 1, R deg


def test_a_pendant_written_sr_program_in_a_user_frame_is_filtered_onto_the_truth(tmp_path, capsys):
    from scipy.spatial.transform import Rotation

    from robocal.cli import main

    nominal = rc.Robot.from_catalog("fanuc_sr6ia")
    truth = replace(simulate_tracker(nominal, 10, seed=5, noise_mm=0.0).truth, tool=nominal.tool,
                    smr=np.zeros((0, 3)))
    truth.save(tmp_path / "cal.yaml")
    blocks = "".join(f'P[{k}:"{name}"]{{\n   GP1:\n\tUF : 1, UT : 1,\t\tCONFIG : \'L, 0, 0, 0\',\n'
                     f"\tX = {x:12.6f}  mm,\tY = {y:12.6f}  mm,\tZ = {z:12.6f}  mm,\n"
                     f"\tW =  -180.000000 deg,\tP =     0.000000 deg,\tR = {r:12.6f} deg\n}};\n"
                     for k, (name, x, y, z, r) in enumerate(_SR_TARGETS, start=1))
    program = tmp_path / "PICK_PLACE.ls"
    program.write_text(_PICK_PLACE.replace("{positions}", blocks))
    out = tmp_path / "out.ls"
    cal = str(tmp_path / "cal.yaml")
    assert main(["filter", str(program), "--calibrated", cal, "--nominal", "fanuc_sr6ia",
                 "--frame", "1=0,0,50,0,0,0", "--tool", "1=0,0,0,0,0,0", "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "3 of 3 Cartesian target(s) filtered" in said  # PR[2:TMP] is written on line 12: run time
    assert "PR[2:TMP] is written at PICK_PLACE.ls:12 (PR[2]=...): its value is computed at run time" in said
    # the quill's margin to its limits is in mm (it was its metres shown as radians in deg: 2.86 'deg')
    import csv

    with open(tmp_path / "out.ls.targets.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert all(r["limit_unit"] == ("mm" if r["limit_joint"] == "3" else "deg") for r in table)
    quill = [r for r in table if r["limit_joint"] == "3"]
    assert quill and all(float(r["limit_margin_deg"]) > 10.0 for r in quill)  # mm, not 0.05
    text = out.read_text()
    assert text.count("CONFIG : 'L, 0, 0, 0'") == 3 and 'P[2:"PLACE_A"]' in text
    values = np.array([[float(v) for v in re.findall(r"[XYZWPR] = +([-\d.]+)", block)]
                       for block in text.split("/POS")[1].split("P[")[1:]])
    meant = np.array([t[1:4] for t in _SR_TARGETS])
    assert 0.01 < np.abs(values[:, :3] - meant).max() < 5.0  # corrected, by a calibration's size
    F = np.broadcast_to(np.eye(4), (3, 4, 4)).copy()  # the corrected targets in the base frame (UF 1: z + 50)
    F[:, :3, :3] = Rotation.from_euler("ZYX", values[:, [5, 4, 3]], degrees=True).as_matrix()
    F[:, :3, 3] = (values[:, :3] + [0.0, 0.0, 50.0]) * 1e-3
    sol = rc.ik.solve_all(nominal, F)[:, 1]  # 'L': slot 1
    reached = np.linalg.inv(truth.base) @ truth.fk(sol)
    np.testing.assert_allclose(reached[:, :3, 3], (meant + [0.0, 0.0, 50.0]) * 1e-3, atol=2e-6)
def test_a_scara_program_in_a_language_without_scaras_is_refused_naming_those_with(tmp_path):
    """The languages whose programs drive a SCARA are the dialects that declare it
    (``scara_programs``): a URScript program on a SCARA is refused naming them."""
    from robocal.core.errors import DataError
    from robocal.programs.registry import capable

    assert [d.key for d in capable("scara_programs")] == ["fanuc"]
    robot = rc.Robot.from_catalog("fanuc_sr6ia")
    (tmp_path / "t.script").write_text("def t():\n  movel(p[0.3, 0.1, 0.1, 3.14159, 0, 0])\nend\n")
    with pytest.raises(DataError, match="a SCARA: its programs are read in FANUC TP only"):
        rc.filter_program(tmp_path / "t.script", robot, robot)
