"""A SCARA (Epson G6-651S from the catalog): structural freedoms named, closed-form IK in 2 branches,
a FANUC SR program's CONFIG 'L|R, t1, t2, t4' read and filtered, the quill in mm."""

from __future__ import annotations

import numpy as np

import robocal as rc
from robocal.data.simulate import simulate_tracker
from robocal.ik import scara


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
    freedoms = {f["freedom"]: f for f in result.identifiability.freedoms}
    assert {"height", "turn", "tilt", "axis1", "quill", "forearm"} <= set(freedoms)
    assert "d3" in freedoms["height"]["held"] and "quill zero (d3)" in freedoms["height"]["words"]
    assert "structural freedoms of a SCARA" in result.summary()


def test_fanuc_scara_config_is_read_and_kept(tmp_path):
    robot = rc.Robot.from_catalog("epson_g6_651s")
    q = np.deg2rad([[30.0, 40.0, 0.0, 10.0], [-50.0, -60.0, 0.0, 80.0]])
    q[:, 2] = [-0.05, -0.1]
    T = robot.fk(q)
    rz = np.rad2deg(np.arctan2(T[:, 1, 0], T[:, 0, 0]))
    pos = []
    for k, (p, r, hand) in enumerate(zip(T[:, :3, 3] * 1e3, rz, "RL", strict=True), start=1):
        pos += [f"P[{k}]{{", "   GP1:", f"\tUF : 0, UT : 0,\t\tCONFIG : '{hand}, 0, 0, 0',",
                f"\tX = {p[0]:.3f}  mm,\tY = {p[1]:.3f}  mm,\tZ = {p[2]:.3f}  mm,",
                f"\tW = 0.000 deg,\tP = 0.000 deg,\tR = {r:.3f} deg", "};"]
    text = "\n".join(["/PROG  T", "/MN", "   1:J P[1] 100% FINE    ;", "   2:L P[2] 100mm/sec FINE    ;",
                      "/POS", *pos, "/END", ""])
    (tmp_path / "t.ls").write_text(text)
    out = rc.filter_program(tmp_path / "t.ls", robot, robot)
    assert [r["configuration"] for r in out.rows] == ["kept", "kept"]
    assert max(r["correction_mm"] for r in out.rows) < 1e-6
