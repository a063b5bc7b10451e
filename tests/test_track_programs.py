"""Programs of an arm on a track (RAPID robtargets with eax_a): the pose numbers are corrected so
that the true cell reaches the intended poses with the program's own e1; eax_a, confdata and every
other byte stay as they are."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robocal.data.simulate import simulate_tracker
from robocal.deploy.compensation import controller_model
from robocal.ik import track
from robocal.kinematics.cell import arm_model
from robocal.kinematics.model import cell_from_data
from robocal.programs.dialects.rapid.configuration import ABBConfig
from robocal.programs.filter import filter_program

CELL = {"units": {"length": "mm", "angle": "deg"}, "name": "irb2600 on a 6 m track",
        "robot": "abb_irb2600", "track": {"direction": [1, 0, 0], "limits": [0, 6000]},
        "mount": {"xyz": [0, 0, 0], "rpy": [0, 0, 0]}}
TOOL = np.eye(4)
TOOL[:3, 3] = [0, 0, 0.3]
_POSE = re.compile(r"\[\[([^\]]*)\],\[([^\]]*)\],(\[[^\]]*\]),(\[[^\]]*\])\]")


def _module(cell, n: int, seed: int) -> tuple[str, np.ndarray, np.ndarray, np.ndarray]:
    """A RAPID module of ``n`` robtargets along the track (mm, 4 / 6 decimals), their poses, e1 and the
    arm's joints (their confdata's branch)."""
    arm = arm_model(cell)
    rng = np.random.default_rng(seed)
    lo, hi = arm.limits[:, 0], arm.limits[:, 1]
    q = rng.uniform(-0.3, 0.3, (n, 6))
    # axes 1, 4, 6 mid-quadrant and axis 5 away from 0: no correction crosses a confdata boundary
    middle = rng.choice([-135.0, -45.0, 45.0, 135.0], (n, 3))
    q[:, [0, 3, 5]] = np.deg2rad(middle + rng.uniform(-20, 20, (n, 3)))
    q[:, 4] = np.deg2rad(rng.choice([-1.0, 1.0], n) * rng.uniform(30, 80, n))
    q = np.clip(q, lo, hi)
    e1 = np.round(np.linspace(0.2, 5.8, n), 3)
    X = cell.fk(track.with_track(e1, q)) @ TOOL
    conf = ABBConfig().encode(arm, q)  # rows [cfx, cf1, cf4, cf6]
    quat = Rotation.from_matrix(X[:, :3, :3]).as_quat(scalar_first=True)
    lines = ["MODULE TrackWeld",
             "  PERS tooldata tGun:=[TRUE,[[0,0,300],[1,0,0,0]],[5,[0,0,100],[1,0,0,0],0,0,0]];"]
    for k in range(n):
        p, qq, c = X[k, :3, 3] * 1e3, quat[k], conf[k]
        lines.append(f"  CONST robtarget p{k}:=[[{p[0]:.4f},{p[1]:.4f},{p[2]:.4f}],"
                     f"[{qq[0]:.6f},{qq[1]:.6f},{qq[2]:.6f},{qq[3]:.6f}],[{c[1]},{c[2]},{c[3]},{c[0]}],"
                     f"[{e1[k] * 1e3:g},9E+09,9E+09,9E+09,9E+09,9E+09]];")
    lines += ["", "  PROC main()"] + [f"    MoveL p{k}, v100, fine, tGun;" for k in range(n)]
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines), X, e1, q


def _poses(text: str) -> tuple[np.ndarray, list[str]]:
    """The robtargets' poses (m) and each line with its pose numbers blanked."""
    poses, rest = [], []
    for line in text.splitlines():
        m = _POSE.search(line)
        if m is None:
            rest.append(line)
            continue
        p = np.array(m.group(1).split(","), float) * 1e-3
        R = Rotation.from_quat(np.array(m.group(2).split(","), float), scalar_first=True).as_matrix()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, p
        poses.append(T)
        rest.append(line[:m.start()] + "POSE" + m.group(3) + m.group(4) + line[m.end():])
    return np.array(poses), rest


def test_rapid_targets_along_the_track_are_corrected(tmp_path):
    cell = cell_from_data(CELL)
    truth = simulate_tracker(cell, 5, seed=11).truth  # track tilt, scale, mount and arm errors
    text, X, e1, q = _module(cell, 30, seed=4)
    path = tmp_path / "track_weld.mod"
    path.write_text(text)
    res = filter_program(path, truth, cell)
    assert res.summary_dict()["motions"] == {"total": 30, "corrected": 30, "named": 0}
    out = res.outputs[path].decode()
    Xc, rest = _poses(out)
    X0, rest0 = _poses(text)
    assert rest == rest0  # eax_a, confdata and every other byte unchanged
    # the nominal controller at the program's e1 (its closed form, the branch of the original joints)
    # drives the true cell: where does the tool end up?
    real = controller_model(truth, cell)
    sols = track.solve_all(cell, Xc @ np.linalg.inv(TOOL), e1)
    before = track.solve_all(cell, X0 @ np.linalg.inv(TOOL), e1)
    reached, unfiltered = [], []
    for k in range(30):
        ok = np.isfinite(sols[k]).all(axis=1)
        ref = before[k, np.nanargmin(np.abs(before[k] - q[k]).max(axis=1))]  # the confdata's solution
        b = np.flatnonzero(ok)[np.argmin(np.abs(sols[k, ok] - ref).max(axis=1))]
        reached.append(real.fk(track.with_track(e1[k:k + 1], sols[k, b][None]))[0] @ TOOL)
        unfiltered.append(real.fk(track.with_track(e1[k:k + 1], ref[None]))[0] @ TOOL)
    err = np.linalg.norm(np.array(reached)[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    before_mm = np.linalg.norm(np.array(unfiltered)[:, :3, 3] - X[:, :3, 3], axis=1) * 1e3
    assert err.max() < 0.002  # the true cell lands on the intended poses (numbers written to 0.1 um)
    assert before_mm.max() > 0.5  # the track errors are large without the correction


def test_targets_without_a_track_value_are_named(tmp_path):
    cell = cell_from_data(CELL)
    text, *_ = _module(cell, 3, seed=5)
    text = text.replace("[200,9E+09", "[9E+09,9E+09", 1)
    path = tmp_path / "m.mod"
    path.write_text(text)
    res = filter_program(path, simulate_tracker(cell, 5, seed=1).truth, cell)
    assert res.summary_dict()["motions"] == {"total": 3, "corrected": 2, "named": 1}
    assert "no track position" in res.motions[0].reason


def test_a_six_axis_nominal_takes_track_targets_as_arm_targets_and_says_so(tmp_path):
    """eax_a values in wobj0 with a plain arm: no work object follows them; two targets at two
    values are too few to tell a track carrying the arm from a positioner: named (the safe side);
    declared fixed (``fixed_base``) they are corrected as arm targets (issue 45's rule), and one
    warning says so."""
    from robocal import Robot
    from robocal.core.errors import DataError

    text, *_ = _module(cell_from_data(CELL), 2, seed=6)
    path = tmp_path / "m.mod"
    path.write_text(text)
    robot = Robot.from_catalog("abb_irb2600")
    res = filter_program(path, robot, robot, keep_unreached=True)
    assert res.summary_dict()["motions"] == {"total": 2, "corrected": 0, "named": 2}
    assert all("too few to tell a track or gantry" in m.reason for m in res.motions)
    res = filter_program(path, robot, robot, keep_unreached=True, fixed_base=True)  # one out of reach alone
    assert res.summary_dict()["motions"]["total"] == 2
    assert not any("external axes" in m.reason or "if those axes" in m.reason for m in res.motions)
    assert sum("no external axis carries the arm (--fixed-base)" in w for w in res.warnings) == 1
    seven = Robot(alpha=[0.0] * 7, a=[0.0] * 7, beta=[0.0] * 7, theta=[0.0] * 7, d=[0.1] * 7)
    with pytest.raises(DataError, match="on a track: give its cell model"):
        filter_program(path, seven, seven)


def _corpus(names, tmp_path):
    import shutil
    from pathlib import Path

    src = Path(__file__).parent / "data" / "programs" / "corpus"
    out = []
    for name in names:
        shutil.copy(src / name, tmp_path / name)
        out.append(tmp_path / name)
    return out


@pytest.mark.parametrize("robot, files, mount_x, corrected", [
    ("fanuc_lrmate200id", ["track_pick.ls"], -1650, 2),  # E1 1500 and 2000 mm: the base near the targets
    ("kuka_kr16_2", ["deburr_cell.src", "deburr_cell.dat"], 0, 1),
])
def test_fanuc_and_krl_track_positions_are_corrected(tmp_path, robot, files, mount_x, corrected):
    """FANUC E1 = 1500.000 mm and KRL E1 0.0: the track's value is read (a zero too) and kept."""
    from test_program_corpus import FANUC_FRAMES

    cell = cell_from_data({**CELL, "robot": robot, "track": {"direction": [1, 0, 0], "limits": [0, 3000]},
                           "mount": {"xyz": [mount_x, 0, 0], "rpy": [0, 0, 0]}})
    paths = _corpus(files, tmp_path)
    kw = FANUC_FRAMES if robot.startswith("fanuc") else {"references": _corpus(["$config.dat"], tmp_path)}
    res = filter_program(paths, simulate_tracker(cell, 5, seed=2).truth, cell, keep_unreached=True, **kw)
    assert res.summary_dict()["motions"]["corrected"] >= corrected
    assert not any("external axes E1" in m.reason for m in res.motions if m.reason)
    old = b"".join(p.read_bytes() for p in paths)
    new = b"".join(res.outputs[p] for p in paths)
    e1 = re.compile(rb"E1\s*=?\s*[-+.\d]+")
    assert e1.findall(old) == e1.findall(new)  # the track values as written


def test_a_track_cell_names_targets_with_another_external_value(tmp_path):
    """A track cell: a target with eax_a and an eax_b value is not the track's alone (the arm's place
    may depend on it): named, not taken as an arm target."""
    from robocal.data.simulate import perturbed

    cell = cell_from_data(CELL)
    text, *_ = _module(cell, 2, seed=6)
    path = tmp_path / "m.mod"
    path.write_text(text.replace(",9E+09,9E+09,9E+09,9E+09,9E+09]]", ",12.5,9E+09,9E+09,9E+09,9E+09]]", 1))
    res = filter_program(path, perturbed(cell, 3), cell)
    assert res.summary_dict()["motions"] == {"total": 2, "corrected": 1, "named": 1}
    assert "external axes eax_a = " in next(m for m in res.motions if m.status == "named").reason
