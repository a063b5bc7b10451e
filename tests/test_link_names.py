"""Markers name their link as a URDF does (``arm_left_4_link``) where the model knows its links'
names: the same calibration as with frame numbers, clear errors otherwise, and the names kept by
the model file and the measurement CSV."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import robocal as rc
from robocal.core.errors import DataError, ModelError
from robocal.data.measurements import parse_csv
from robocal.kinematics.urdf import from_urdf, to_urdf

ROBOT = from_urdf(to_urdf(rc.Robot.from_catalog("ur10")))  # links base_link, link_1 .. link_6, tool0


def _named(data, robot):
    """``data`` with each marker's link given by the name of its frame's link (the last name of
    each frame: link_j, tool0 on the flange)."""
    name_of = {frame: name for name, frame in robot.link_frames.items()}
    return replace(data, link=np.array([name_of[int(j)] for j in data.link]))


def test_named_links_calibrate_as_frame_numbers():
    sim = rc.simulate_markers(ROBOT, 40, links=[6, 6, 4, 3], noise_mm=0.05, seed=9)
    named = _named(sim.data, ROBOT)
    assert set(named.link.tolist()) == {"tool0", "link_4", "link_3"}
    np.testing.assert_array_equal(ROBOT.link_numbers(named.link), sim.data.link)
    by_number, by_name = (rc.calibrate(ROBOT, d, nongeometric="none") for d in (sim.data, named))
    np.testing.assert_allclose(by_name.robot.values, by_number.robot.values, atol=1e-12)
    assert by_name.summary() == by_number.summary()


def test_csv_with_link_names_round_trips_and_mixes_with_numbers(tmp_path):
    sim = rc.simulate_markers(ROBOT, 4, links=[6, 2], seed=2).data
    named = _named(sim, ROBOT)
    text = named.to_csv()
    assert ",tool0," in text and ",link_2," in text
    back = parse_csv(text)
    assert back.kind == "marker" and back.link.tolist() == named.link.tolist()
    path = tmp_path / "m.csv"
    named.save(path)
    assert rc.Measurements.load(path).link.tolist() == named.link.tolist()
    header = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm,smr,link\n"
    mixed = parse_csv(header + "0,0,0,0,0,0,1,2,3,0,6\n10,0,0,0,0,0,1,2,3,1, link_3 \n")
    assert mixed.link.tolist() == ["6", "link_3"]
    np.testing.assert_array_equal(ROBOT.link_numbers(mixed.link), [6, 3])
    numbers = parse_csv(header + "0,0,0,0,0,0,1,2,3,0,6\n10,0,0,0,0,0,1,2,3,1,3\n")
    assert numbers.link.dtype.kind == "i" and numbers.link.tolist() == [6, 3]  # numbers stay numbers


def test_unknown_link_names_are_refused_naming_the_known_ones():
    data = _named(rc.simulate_markers(ROBOT, 4, links=[6, 2], seed=2).data, ROBOT)
    wrong = replace(data, link=np.where(data.link == "link_2", "arm_left_4_link", data.link))
    with pytest.raises(DataError, match=r"'arm_left_4_link' is not a link of model .*: its links are "
                                        r"world, base_link, link_1, link_2"):
        rc.calibrate(ROBOT, wrong)
    catalog = rc.Robot.from_catalog("ur10")  # a catalog model names no links
    with pytest.raises(DataError, match="names no links .*give frame numbers"):
        rc.calibrate(catalog, data)
    with pytest.raises(DataError, match="link indices must be >= 0"):
        rc.Measurements.from_arrays("marker", np.zeros((2, 6)), points=np.zeros((2, 3)), link=["-1", "a"])
    with pytest.raises(DataError, match="link is empty"):
        rc.Measurements.from_arrays("marker", np.zeros((2, 6)), points=np.zeros((2, 3)), link=["", "a"])
    fraction = replace(data, link=np.where(data.link == "link_2", "2.5", data.link))
    for model in (ROBOT, catalog):  # a number that is no frame number is not taken for a name
        with pytest.raises(DataError, match=r"link '2.5' is not a frame number: give an integer"):
            rc.calibrate(model, fraction)


def test_model_file_keeps_link_names(tmp_path):
    path = tmp_path / "ur10.yaml"
    ROBOT.save(path)
    assert rc.Robot.load(path).link_frames == ROBOT.link_frames
    assert "link_frames" in path.read_text()
    assert ROBOT.with_values({"a2": ROBOT.get("a2") + 1e-3}).link_frames == ROBOT.link_frames
    with pytest.raises(ModelError, match="link_frames.link_9: 9 is not a frame number 0..6"):
        replace(ROBOT, link_frames={"link_9": 9})
    with pytest.raises(ModelError, match="'3' is not a link name"):
        replace(ROBOT, link_frames={"3": 3})


def test_calibrated_model_judged_on_held_out_markers_of_several_links():
    # a Panda-style campaign: three markers (one on a forearm link, two on the flange), named links,
    # the calibrated model judged on held-out poses: its one tool SMR does not refuse the 3 markers
    sim = rc.simulate_markers(ROBOT, 60, links=[4, 6, 6], noise_mm=0.1, seed=4)
    named = _named(sim.data, ROBOT)
    fit, held = named.subset(named.pose_id < 40), named.subset(named.pose_id >= 40)
    result = rc.calibrate(ROBOT, fit, nongeometric="none")
    stats = rc.evaluate(result.robot, held)
    assert stats["kind"] == "marker" and stats["n"] == len(held)
    assert stats["rms"] < 1.2 * sim.noise_floor_mm < rc.evaluate(ROBOT, held)["rms"]


def test_simulated_markers_name_their_links_as_the_csv_does(tmp_path, capsys):
    # `simulate --links panda_link4,panda_link8,7`: names of a URDF's links, as the CSV's link column
    # takes them, give the simulation of their frame numbers; an unknown name lists the known ones
    from robocal.cli import main

    by_name = rc.simulate_markers(ROBOT, 5, links=["link_4", "tool0", "6"], seed=3)
    by_number = rc.simulate_markers(ROBOT, 5, links=[4, 6, 6], seed=3)
    np.testing.assert_array_equal(by_name.data.points, by_number.data.points)
    urdf, out, truth = tmp_path / "arm.urdf", tmp_path / "m.csv", tmp_path / "t.yaml"
    urdf.write_text(to_urdf(rc.Robot.from_catalog("ur10")))
    args = ["simulate", "--robot", str(urdf), "--kind", "marker", "--poses", "5", "-o", str(out),
            "--truth", str(truth), "--links"]
    assert main(args + ["link_4,tool0"]) == 0
    assert rc.Measurements.load(out).link.tolist() == [4, 6] * 5
    capsys.readouterr()
    assert main(args + ["arm_left_4_link"]) != 0
    assert "'arm_left_4_link' is not a link of model" in capsys.readouterr().err
