"""Workflow mistakes of a third round (arms from users' DH files, outputs fed back in, magnitudes
typed in the wrong unit, messages that must name the cause): each is refused with one line naming
the cause (exit 2, no traceback), warned naming the problem, or handled right."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.compensate import format_csv

# A user's DH file for a 7-axis arm: Franka Emika Panda, Craig's modified DH as Franka publishes it
PANDA_YAML = """\
# Franka Emika Panda (Franka's published kinematics, Craig's modified DH), flange 107 mm past joint 7
name: my_panda
units: {length: mm, angle: deg}
mdh:
  alpha: [0, -90, 90, 90, -90, 90, 90]
  a: [0, 0, 0, 82.5, -82.5, 0, 88]
  theta: [0, 0, 0, 0, 0, 0, 0]
  d: [333, 0, 316, 0, 384, 0, 0]
limits: [[-166, 166], [-101, 101], [-166, 166], [-176, -4], [-166, 166], [-1, 215], [-166, 166]]
tool: {xyz: [0, 0, 107]}
"""
# A 5-axis arm (a palletiser-like wrist without roll), standard DH
ARM5_YAML = """\
name: my_5axis
units: {length: mm, angle: deg}
dh:
  theta: [0, 0, 0, 0, 0]
  d: [300, 0, 0, 0, 100]
  a: [50, 400, 350, 0, 0]
  alpha: [90, 0, 0, 90, 0]
limits: [[-170, 170], [-100, 100], [-150, 150], [-120, 120], [-350, 350]]
"""


def _digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.iterdir()) if p.is_file()}


def _waypoints(robot: rc.Robot, path: Path) -> None:
    """Six reachable TCP poses of ``robot`` as a poses CSV (mm, scalar-first quaternions)."""
    q = robot.limits.mean(axis=1) + np.linspace(0.0, 0.3, 6)[:, None]
    T = robot.fk(q)
    quat = Rotation.from_matrix(T[:, :3, :3]).as_quat(scalar_first=True)
    cols = ["x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"]
    path.write_text(format_csv(cols, np.hstack([T[:, :3, 3] * 1e3, quat])))


@pytest.fixture(scope="module")
def arms(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("arms")
    for name, text in (("panda", PANDA_YAML), ("arm5", ARM5_YAML)):
        (d / f"{name}.yaml").write_text(text)
        _waypoints(rc.Robot.load(d / f"{name}.yaml"), d / f"{name}_way.csv")
    return d


def _run(argv: list[str], capsys) -> tuple[int, str, str]:
    try:
        code = main(["--quiet", *argv])
    except SystemExit as exc:  # argparse
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def _refused(argv: list[str], capsys, *words: str) -> str:
    """The run exits 2 with one error line holding every word, no traceback."""
    code, _, err = _run(argv, capsys)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, err
    assert len(lines) == 1 and "Traceback" not in err and "internal error" not in err, err
    for w in words:
        assert w.lower() in lines[0].lower(), lines[0]
    return lines[0]


# ------------------------------------------------------------------ chains other than 6R
@pytest.mark.parametrize("arm, joints", [("panda", 7), ("arm5", 5)])
def test_poses_plans_a_campaign_for_a_chain_of_any_length(arms, tmp_path, capsys, arm, joints):
    code, out, err = _run(["poses", "--robot", str(arms / f"{arm}.yaml"), "-n", "20", "--candidates", "800",
                           "--starts", "1", "-o", str(tmp_path / "p.csv")], capsys)
    assert code == 0, err
    header = (tmp_path / "p.csv").read_text().splitlines()[0].split(",")
    assert [h for h in header if h.startswith("q")] == [f"q{i + 1}_deg" for i in range(joints)]
    assert len((tmp_path / "p.csv").read_text().splitlines()) == 21


def test_default_weights_cover_every_joint(arms):
    from robocal.ik.path import default_weights
    for arm, n in (("panda", 7), ("arm5", 5)):
        w = default_weights(rc.Robot.load(arms / f"{arm}.yaml"))
        assert w.shape == (n,) and (w[:3] > 1).all() and (w[3:] == 1).all()


@pytest.mark.parametrize("arm, words", [("panda", ("7 joints", "redundant")),
                                        ("arm5", ("5 joints", "fewer than 6"))])
def test_plan_refuses_a_chain_without_branches_in_one_line(arms, tmp_path, capsys, arm, words):
    before = _digest(arms)
    _refused(["plan", "--robot", str(arms / f"{arm}.yaml"), str(arms / f"{arm}_way.csv"),
              "-o", str(tmp_path / "j.csv")], capsys, *words)
    assert not (tmp_path / "j.csv").exists() and _digest(arms) == before
