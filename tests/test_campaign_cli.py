"""``robocal poses`` end to end: the files it writes, the robot programs parsed back, candidates
from a file copied exactly, the rehearsal with ``simulate --joints``, and bad input."""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest

from robocal import DataError, Robot
from robocal.campaign import read_planned
from robocal.cli import main
from robocal.core.io import write_all
from robocal.data.measurements import Measurements, read_joint_table, read_joints
from robocal.programs.dialects.krl.campaign import krl_program
from robocal.programs.dialects.rapid.campaign import rapid_module
from robocal.programs.dialects.urscript.campaign import urscript_program
from robocal.report.campaign import render_campaign


def parse_rapid(text: str) -> np.ndarray:
    targets = {m.group(1): [float(v) for v in m.group(2).split(",")]
               for m in re.finditer(r"CONST jointtarget (\w+) := \[\[([^\]]*)\]", text)}
    order = re.findall(r"MoveAbsJ (\w+)\\NoEOffs", text)
    calls = [int(k) for k in re.findall(r"^\s+MeasurePose (\d+);", text, flags=re.M)]
    assert calls == list(range(1, len(order) + 1))
    return np.array([targets[name] for name in order])


def parse_krl(src: str, dat: str) -> np.ndarray:
    declared = {}
    for m in re.finditer(r"DECL AXIS (\w+)=\{([^}]*)\}", dat):
        axes = dict(item.split() for item in m.group(2).split(","))
        declared[m.group(1)] = [float(axes[f"A{i}"]) for i in range(1, 7)]
    order = re.findall(r"^\s+PTP (\w+)", src, flags=re.M)
    return np.array([declared[name] for name in order])


def parse_urscript(text: str) -> np.ndarray:
    return np.array([[float(v) for v in m.split(",")] for m in re.findall(r"movej\(\[([^\]]*)\]", text)])


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    d = tmp_path_factory.mktemp("campaign")
    args = ["--quiet", "poses", "--robot", "abb_irb2600", "-n", "14", "--candidates", "1200", "--starts", "2",
            "--smr-mm", "20,-30,80", "--smr-mm=-50,50,60", "--smr-normal", "0,0,1", "--smr-normal=-1,1,1",
            "--tracker-mm", "2500,500,300", "--curve", "10:20", "-o", str(d / "poses.csv"),
            "--json", str(d / "c.json"), "--html", str(d / "c.html"), "--rapid", str(d / "Campaign.mod"),
            "--krl", str(d / "campaign.src"), "--urscript", str(d / "campaign.script"),
            "--speed-percent", "15", "--settle-s", "0.5"]
    assert main(args) == 0
    return d


def test_programs_recover_every_joint_in_the_planned_order(planned):
    q_deg = np.rad2deg(read_joints(planned / "poses.csv"))
    assert q_deg.shape == (14, 6)
    np.testing.assert_allclose(parse_rapid((planned / "Campaign.mod").read_text()), q_deg, atol=1e-9)
    np.testing.assert_allclose(parse_krl((planned / "campaign.src").read_text(),
                                         (planned / "campaign.dat").read_text()), q_deg, atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(parse_urscript((planned / "campaign.script").read_text())),
                               q_deg, atol=1e-9)
    rapid = (planned / "Campaign.mod").read_text()
    assert "MODULE Campaign" in rapid and "VelSet 15, 5000;" in rapid and "WaitTime 0.5;" in rapid
    assert "BAS (#VEL_PTP,15 )" in (planned / "campaign.src").read_text()
    assert "v=0.4712" in (planned / "campaign.script").read_text()  # 15 % of pi rad/s


def test_poses_csv_json_and_page(planned):
    table = read_joint_table(planned / "poses.csv")
    assert table.header[:6] == [f"q{i}_deg" for i in range(1, 7)]
    assert table.header[6:8] == ["visible_smr0", "visible_smr1"]
    planned_with = read_planned(planned / "poses.csv", Robot.from_catalog("abb_irb2600"))
    np.testing.assert_array_equal(planned_with.smr * 1e3, [[20, -30, 80], [-50, 50, 60]])
    np.testing.assert_array_equal(planned_with.tracker * 1e3, [2500, 500, 300])
    campaign = json.loads((planned / "c.json").read_text())
    np.testing.assert_array_equal(np.deg2rad(campaign["joints_deg"]), read_joints(planned / "poses.csv"))
    assert campaign["predicted_rms_mm"] > 0 and len(campaign["curve"]) >= 2
    page = (planned / "c.html").read_text()
    assert "Content-Security-Policy" in page and "<script" not in page and page.count("<svg") == 2
    campaign["robot"]["name"] = "<script>alert(1)</script>"
    assert "<script>alert" not in render_campaign(campaign)


def test_analyze_and_simulate_read_the_planned_file(planned, capsys):
    assert main(["analyze", str(planned / "poses.csv"), "--robot", "abb_irb2600",
                 "--tool-mm", "20,-30,80"]) == 0
    assert "14 poses" in capsys.readouterr().out
    out = planned / "data.csv"
    assert main(["--quiet", "simulate", "--robot", "abb_irb2600", "--joints", str(planned / "poses.csv"),
                 "--smr-mm", "20,-30,80", "--smr-mm=-50,50,60", "--tracker-mm", "2500,500,300",
                 "-o", str(out), "--truth", str(planned / "truth.yaml")]) == 0
    data = Measurements.load(out)
    table = read_joint_table(planned / "poses.csv")
    seen = np.array([table.column(f"visible_smr{k}") for k in range(2)]).T == "1"
    assert len(data) == seen.sum()
    planned_q = read_joints(planned / "poses.csv")
    np.testing.assert_array_equal(data.joints, planned_q[data.pose_id])
    np.testing.assert_array_equal(seen[data.pose_id, data.smr], True)


def test_candidates_from_a_file_are_copied_exactly(tmp_path, capsys):
    """A taught file's cells are copied exactly; its placeholder points (1, 2, 3 mm at every pose)
    cannot be calibrated: the plan is for the noise alone, with a warning."""
    rng = np.random.default_rng(1)
    robot = Robot.from_catalog("meca500")
    q = np.rad2deg(rng.uniform(robot.limits[:, 0] * 0.8, robot.limits[:, 1] * 0.8, (80, 6)))
    lines = ["# taught poses", "pose_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm"]
    for k, row in enumerate(q):  # every pose twice (repeated readings), odd spellings of numbers
        cells = [f"{v:.5f}0" for v in row]
        lines += [f"{k},{','.join(cells)},1,2,3"] * 2
    src = tmp_path / "taught.csv"
    src.write_text("\n".join(lines) + "\n")
    before = src.read_bytes()
    out = tmp_path / "poses.csv"
    assert main(["--quiet", "poses", "--robot", "meca500", "-n", "15", "--from", str(src), "--starts", "2",
                 "-o", str(out)]) == 0
    assert src.read_bytes() == before
    assert "the candidates' measurements do not show their unmodelled error" in capsys.readouterr().out
    chosen = read_joint_table(out)
    assert chosen.header[:7] == [f"q{i}_deg" for i in range(1, 7)] + ["source_row"]
    assert chosen.header[7:] == ["smr0_x_mm", "smr0_y_mm", "smr0_z_mm"]  # the planned SMR
    original = src.read_text().splitlines()
    for row in chosen.cells:
        line = original[int(row[6]) - 1].split(",")
        assert row[:6] == line[1:7]  # the cells exactly as read
    assert len({row[6] for row in chosen.cells}) == 15


def test_bad_input_is_refused_and_nothing_is_written(tmp_path, capsys):
    out = tmp_path / "poses.csv"
    out.write_text("keep me\n")
    cases = [
        (["-n", "5"], "plan at least 10 poses"),
        (["-n", "20", "--box", "5000", "5000", "5000", "6000", "6000", "6000"], "removed by the TCP box"),
        (["-n", "20", "--tracker-mm", "100,0,200"], "inside the robot"),
        (["-n", "20", "--margin-deg", "200"], "leaves no room"),
        (["-n", "20", "--krl", str(tmp_path / "x.txt")], "names the .src file"),
        (["-n", "20", "--rapid", str(tmp_path / "9bad.mod")], "not a valid identifier"),
    ]
    for extra, message in cases:
        rc = main(["poses", "--robot", "abb_irb2600", "--candidates", "300", "--starts", "1",
                   "--smr-mm", "20,-30,80", "-o", str(out), *extra])
        err = capsys.readouterr().err
        assert rc == 2 and message in err and "Traceback" not in err, (extra, err)
        assert out.read_text() == "keep me\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["poses.csv"]



@pytest.mark.parametrize("command", [
    ["poses", "--robot", "abb_irb2600", "-n", "20", "--smr-mm", "20,-30"],
    ["poses", "--robot", "abb_irb2600", "-n", "20", "--tracker-mm", "2500,x,300"],
    ["simulate", "--robot", "abb_irb2600", "--poses", "20", "--smr-mm", "20,-30", "--truth", "t.yaml"],
    ["simulate", "--robot", "abb_irb2600", "--poses", "20", "--tool-mm", "1,2,3,4", "--truth", "t.yaml"],
    ["simulate", "--robot", "abb_irb2600", "--poses", "20", "--tracker-mm", "2500,500", "--truth", "t.yaml"],
])
def test_coordinates_are_parsed_by_one_argument_type(command, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main([*command, "-o", str(tmp_path / "out.csv")])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2 and "expected 3 comma-separated numbers (X,Y,Z in mm)" in err
    assert not list(tmp_path.iterdir())


def test_simulate_takes_the_smr_count_from_the_planned_visibility(planned):
    out = planned / "data_visible.csv"
    assert main(["--quiet", "simulate", "--robot", "abb_irb2600", "--joints", str(planned / "poses.csv"),
                 "-o", str(out), "--truth", str(planned / "truth_visible.yaml")]) == 0
    data = Measurements.load(out)
    table = read_joint_table(planned / "poses.csv")
    seen = np.array([table.column(f"visible_smr{k}") for k in range(2)]).T == "1"
    assert len(data) == seen.sum() and set(np.unique(data.smr)) == {0, 1}

def test_write_all_rolls_back_when_a_later_file_fails(tmp_path, monkeypatch):
    first, second = tmp_path / "a.txt", tmp_path / "b.txt"
    first.write_text("old a")
    real = os.replace
    calls = []

    def failing(src, dst):
        calls.append(dst)
        if str(dst) == str(second):
            raise PermissionError(13, "Permission denied")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(DataError, match="Permission denied"):
        write_all({first: "new a", second: "new b"})
    monkeypatch.setattr(os, "replace", real)
    assert first.read_text() == "old a" and not second.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_program_writers_check_their_input():
    q = np.zeros((3, 5))
    with pytest.raises(DataError, match="6-axis"):
        rapid_module(q)
    with pytest.raises(DataError, match="percentage"):
        urscript_program(np.zeros((2, 6)), speed_percent=0)
    with pytest.raises(DataError, match="identifier"):
        krl_program(np.zeros((2, 6)), "a" * 30)
    src, dat = krl_program(np.array([[-0.0, 1e-11, 123.456789, -45, 0, 360]]))
    assert "DECL AXIS XP1={A1 0,A2 0,A3 123.456789,A4 -45,A5 0,A6 360}" in dat and "PTP XP1" in src


def test_plan_from_noise_free_candidates_predicts_with_the_instruments_noise(tmp_path):
    """Candidates whose points fit exactly (simulated without noise) show no noise; the held-out
    prediction still carries the noise model's (a check measurement has it): finite, not zero."""
    import json

    import numpy as np

    import robocal as rc
    from robocal.cli import main
    from robocal.data.simulate import sample_joints

    robot = rc.Robot.from_catalog("abb_irb2600")
    q = sample_joints(robot, 40, np.random.default_rng(3))
    rc.Measurements.from_arrays("point", q, points=robot.fk(q)[:, :3, 3]).save(tmp_path / "poses.csv")
    plan = tmp_path / "plan.json"
    assert main(["--quiet", "poses", "--robot", "abb_irb2600", "-n", "12",
                 "--from", str(tmp_path / "poses.csv"), "--smr-mm", "20,-30,80",
                 "-o", str(tmp_path / "out.csv"), "--json", str(plan), "--starts", "1"]) == 0
    campaign = json.loads(plan.read_text())
    assert 0 < campaign["predicted_rms_mm"] < campaign["predicted_heldout_mm"] < 1
