"""Workflow mistakes (arms from users' DH files, outputs fed back in, magnitudes
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
from robocal.deploy.compensation import format_csv

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


# ------------------------------------------------------------------ provenance of outputs
PROGRAMS = Path(__file__).parent / "data" / "programs"
FILTER_CASES = {  # format: (nominal, program files, references, extra options)
    "rapid": ("abb_irb2600", ["weld_cell.mod"], [], []),
    "krl": ("kuka_kr16_2", ["palletize.src", "palletize.dat"], ["config.dat"], []),
    "fanuc": ("fanuc_lrmate200id", ["sealing.ls"], [],
              ["--frame", "1=450,-150,100,0,0,-10", "--tool", "2=0,0,120,0,0,0"]),
    "urscript": ("ur5", ["pick_place.script"], [], []),
}
COMMENT = {"rapid": "!", "krl": ";", "fanuc": "!", "urscript": "#"}


def _filter_argv(fmt: str, folder: Path, cal: Path, files: list[str], out: Path) -> list[str]:
    nominal, _, refs, extra = FILTER_CASES[fmt]
    argv = ["filter", *[str(folder / f) for f in files], "--calibrated", str(cal), "--nominal", nominal,
            "-o", str(out), *extra]
    return argv + (["--references", *[str(PROGRAMS / r) for r in refs]] if refs else [])


@pytest.mark.parametrize("fmt", list(FILTER_CASES))
def test_a_filtered_program_is_marked_and_filtering_it_again_is_refused(fmt, tmp_path, capsys):
    from robocal.data.simulate import perturbed
    from robocal.programs.source import NUMBER_RE
    from robocal.trust.output_marker import find_marker, model_fingerprint

    nominal, files, _, _ = FILTER_CASES[fmt]
    cal = perturbed(rc.Robot.from_catalog(nominal), 7)
    cal.save(tmp_path / "cal.yaml")
    fp = model_fingerprint(rc.Robot.load(tmp_path / "cal.yaml"))
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir(), second.mkdir()
    out = first if len(files) > 1 else first / files[0]
    code, _, err = _run(_filter_argv(fmt, PROGRAMS, tmp_path / "cal.yaml", files, out), capsys)
    assert code == 0, err
    marker_fp = fp[:10] if fmt == "fanuc" else fp  # a TP remark line holds 30 characters
    for f in files:
        before, after = (PROGRAMS / f).read_bytes(), (first / f).read_bytes()
        lines = after.decode("latin-1").splitlines(keepends=True)
        added = [i for i, ln in enumerate(lines) if "robocal " in ln]
        assert len(added) == 1 and f"model {marker_fp}" in lines[added[0]], lines
        marker = find_marker(after.decode("latin-1"))
        assert marker is not None and fp.startswith(marker.model) and marker.version == rc.__version__
        line = lines.pop(added[0])
        assert line.split(":")[-1 if fmt == "fanuc" else 0].lstrip().startswith(COMMENT[fmt])
        assert line.endswith("\r\n") == (b"\r\n" in before)  # the file's own line ends
        # byte for byte outside numbers: the marker line is the only added text
        assert NUMBER_RE.sub("#", "".join(lines)) == NUMBER_RE.sub("#", before.decode("latin-1"))
    if fmt == "fanuc":  # the remark is the last /MN line, numbered after it; LINE_COUNT counts it
        text = (first / files[0]).read_text()
        assert "LINE_COUNT\t= 15;" in text and "LINE_COUNT\t= 14;" in (PROGRAMS / files[0]).read_text()
        mn = text[text.index("/MN"):text.index("/POS")].splitlines()
        assert mn[-1] == f"  13:  !robocal {rc.__version__} model {marker_fp} ;"
        assert len(mn[-1].split("!")[1][:-2]) <= 30  # a TP remark's length
    # fed back in: refused naming the earlier run, nothing written
    out2 = second if len(files) > 1 else second / files[0]
    line = _refused(_filter_argv(fmt, first, tmp_path / "cal.yaml", files, out2), capsys,
                    "already filtered", f"robocal {rc.__version__}", marker_fp, "--force")
    assert "twice" in line and not list(second.iterdir())
    code, _, err = _run([*_filter_argv(fmt, first, tmp_path / "cal.yaml", files, out2), "--force"], capsys)
    assert code == 0 and (second / files[0]).exists(), err


def test_the_fingerprint_names_the_parameters_not_the_file(tmp_path):
    from robocal.trust.output_marker import model_fingerprint

    irb = rc.Robot.from_catalog("abb_irb2600")
    irb.save(tmp_path / "irb.yaml")
    assert model_fingerprint(rc.Robot.load(tmp_path / "irb.yaml")) == model_fingerprint(irb)
    moved = irb.with_values({"a2": irb.get("a2") + 1e-6})  # one micrometre
    assert model_fingerprint(moved) != model_fingerprint(irb)
    assert len(model_fingerprint(irb)) == 12 and int(model_fingerprint(irb), 16) >= 0


def test_compensated_targets_are_marked_and_compensating_them_again_is_refused(tmp_path, capsys):
    from robocal.data.simulate import perturbed
    from robocal.deploy.compensation import pose_columns, read_poses_csv
    from robocal.trust.output_marker import model_fingerprint

    irb = rc.Robot.from_catalog("abb_irb2600")
    cal = perturbed(irb, 3)
    cal.save(tmp_path / "cal.yaml")
    q = np.deg2rad([[10, 20, 10, 30, 40, 20], [-20, 10, 20, -30, 50, 10], [30, 0, 30, 10, 60, -20]])
    layout = {"length": "mm", "orientation": "deg"}
    (tmp_path / "t.csv").write_text(format_csv(*pose_columns(irb.fk(q), layout)))
    base = ["compensate", str(tmp_path / "cal.yaml"), "--nominal", "abb_irb2600"]
    code, _, err = _run([*base, str(tmp_path / "t.csv"), "-o", str(tmp_path / "c.csv")], capsys)
    assert code == 0, err
    fp = model_fingerprint(rc.Robot.load(tmp_path / "cal.yaml"))
    first = (tmp_path / "c.csv").read_text().splitlines()[0]
    assert first == f"# robocal {rc.__version__} model {fp}: targets compensated, do not compensate again"
    T, layout = read_poses_csv(tmp_path / "c.csv")  # robocal's reader skips the marker
    assert T.shape == (3, 4, 4) and layout == {"length": "mm", "orientation": "deg"}
    _refused([*base, str(tmp_path / "c.csv"), "-o", str(tmp_path / "c2.csv")], capsys,
             "already compensated", fp, "--force")
    assert not (tmp_path / "c2.csv").exists()
    code, _, err = _run([*base, str(tmp_path / "c.csv"), "-o", str(tmp_path / "c2.csv"), "--force"], capsys)
    assert code == 0 and (tmp_path / "c2.csv").exists(), err


# ------------------------------------------------------------------ magnitudes everywhere
@pytest.fixture(scope="module")
def cell(tmp_path_factory) -> Path:
    """A calibrated ABB model, flange targets in mm/deg and the same in the wrong units."""
    from robocal.data.simulate import perturbed
    from robocal.deploy.compensation import pose_columns

    d = tmp_path_factory.mktemp("cell")
    irb = rc.Robot.from_catalog("abb_irb2600")
    perturbed(irb, 3).save(d / "cal.yaml")
    q = np.deg2rad([[10, 20, 10, 30, 40, 20], [-20, 10, 20, -30, 50, 10], [30, 0, 30, 10, 60, -20]])
    names, vals = pose_columns(irb.fk(q), {"length": "mm", "orientation": "deg"})
    for name, scale, angle in (("mm", 1.0, 1.0), ("m_as_mm", 1e-3, 1.0), ("inch_as_mm", 1 / 25.4, 1.0),
                               ("rad_as_deg", 1.0, np.pi / 180)):
        table = np.hstack([vals[:, :3] * scale, vals[:, 3:] * angle])
        (d / f"{name}.csv").write_text(format_csv(names, table))
    cal = (d / "cal.yaml").read_text()
    assert "angle: rad" in cal
    (d / "cal_deg.yaml").write_text(cal.replace("angle: rad", "angle: deg"))  # a hand edit
    (d / "panda_m.yaml").write_text(PANDA_YAML.replace("length: mm", "length: m"))
    (d / "panda_rad.yaml").write_text(PANDA_YAML.replace("angle: deg", "angle: rad"))
    sim = rc.simulate_tracker(irb, 30, noise_mm=0.01, seed=4)
    sim.data.save(d / "irb.csv")
    return d


FANUC = ["filter", str(PROGRAMS / "sealing.ls"), "--calibrated", "{d}/fcal.yaml", "--nominal",
         "fanuc_lrmate200id"]
UR = ["filter", str(PROGRAMS / "pick_place.script"), "--calibrated", "{d}/ucal.yaml", "--nominal", "ur5"]
COMP = ["compensate", "{c}/cal.yaml", "--nominal", "abb_irb2600"]


@pytest.mark.parametrize("case, argv, words", [
    ("filter-frame-in-metres", [*FANUC, "--frame", "1=0.45,-0.15,0.1,0,0,-10", "--tool", "2=0,0,120,0,0,0"],
     ("--frame 1=", "look like metres", "give millimetres")),
    ("filter-frame-rotation-in-radians", [*FANUC, "--frame", "1=450,-150,100,0,0,-0.7854",
                                          "--tool", "2=0,0,120,0,0,0"], ("--frame 1=", "radians")),
    ("filter-tool-in-metres", [*FANUC, "--frame", "1=450,-150,100,0,0,-10", "--tool", "2=0,0,0.12,0,0,0"],
     ("--tool 2=", "look like metres")),
    ("filter-urscript-tool-in-mm", [*UR, "--tool", "0,20,150,0,0,0.5"],
     ("--tool", "look like millimetres", "give metres")),
    ("filter-urscript-tool-rotation-in-degrees", [*UR, "--tool", "0,0.02,0.15,0,0,30"],
     ("--tool", "look like degrees")),
    ("filter-robot-base-in-metres", ["filter", str(PROGRAMS / "weld_cell.mod"), "--calibrated",
                                     "{c}/cal.yaml", "--nominal", "abb_irb2600",
                                     "--robot-base", "1.2,0.3,0,0,0,0"],
     ("--robot-base", "look like metres")),
    ("compensate-targets-in-metres", [*COMP, "{c}/m_as_mm.csv"],
     ("m_as_mm.csv", "look like metres", "give millimetres")),
    ("compensate-targets-in-inches", [*COMP, "{c}/inch_as_mm.csv"], ("inch_as_mm.csv", "look like inches")),
    ("compensate-target-angles-in-radians", [*COMP, "{c}/rad_as_deg.csv"],
     ("rx, ry, rz", "look like radians")),
    ("plan-targets-in-metres", ["plan", "--robot", "abb_irb2600", "{c}/m_as_mm.csv"], ("look like metres",)),
    ("model-angle-rad-edited-to-deg", ["evaluate", "{c}/cal_deg.yaml", "{c}/irb.csv"],
     ("cal_deg.yaml", "model file's units look wrong", "look like radians", "angle: rad")),
    ("model-lengths-mm-declared-m", ["evaluate", "{c}/panda_m.yaml", "{c}/irb.csv"],
     ("panda_m.yaml", "model file's units look wrong", "look like millimetres", "length: mm")),
    ("model-angles-deg-declared-rad", ["evaluate", "{c}/panda_rad.yaml", "{c}/irb.csv"],
     ("panda_rad.yaml", "model file's units look wrong", "look like degrees", "angle: deg")),
])
def test_a_magnitude_in_another_unit_is_refused_naming_the_unit(case, argv, words, cell, tmp_path, capsys):
    from robocal.data.simulate import perturbed

    for name, robot in (("fcal", "fanuc_lrmate200id"), ("ucal", "ur5")):
        perturbed(rc.Robot.from_catalog(robot), 7).save(tmp_path / f"{name}.yaml")
    before = _digest(cell)
    argv = [a.format(d=tmp_path, c=cell) for a in argv]
    out = "--json" if argv[0] == "evaluate" else "-o"
    _refused([*argv, out, str(tmp_path / "out.x")], capsys, *words)
    assert not (tmp_path / "out.x").exists() and _digest(cell) == before


def test_magnitudes_in_the_right_units_pass(cell, tmp_path, capsys):
    from robocal.core.magnitudes import check_frame, check_length, check_targets, check_tool

    check_tool([0.0, 0.0, 0.12], "mm", "t")
    check_frame([0.0, 0.0, 0.0], "mm", 1.0, "f")  # the identity frame
    check_frame([0.45, -0.15, 0.1], "mm", 1.0, "f")
    check_targets(np.array([[0.8, 0.1, 0.5]]), "m", 1.5, "t")
    check_length(1.0, "mm", 2.0, 3.0, "far", "a thing", strict=False)  # fits no unit: left to others
    argv = [a.format(c=cell) for a in COMP]
    code, _, err = _run([*argv, str(cell / "mm.csv"), "-o", str(tmp_path / "c.csv")], capsys)
    assert code == 0, err
    code, _, err = _run(["evaluate", str(PROGRAMS.parent.parent.parent / "src" / "robocal" / "catalog" /
                                         "puma560.yaml"), str(cell / "irb.csv")], capsys)
    assert "units look wrong" not in err


# ------------------------------------------------------------------ messages that name the cause
@pytest.fixture(scope="module")
def fanuc(tmp_path_factory) -> Path:
    """A FANUC M-20iA measured: as it should be, in inches under _mm, and as the controller logs
    its joints (J3 from the horizontal), the latter only on poses where both conventions are inside
    the limits (so no joint-limit check can tell, only the fit)."""
    from dataclasses import replace

    from robocal.data.joint_conventions import fanuc_coupled

    d = tmp_path_factory.mktemp("fanuc")
    robot = rc.Robot.from_catalog("fanuc_m20ia")
    sim = rc.simulate_tracker(robot, 120, noise_mm=0.02, seed=5)
    sim.truth.save(d / "truth.yaml")
    sim.data.save(d / "good.csv")
    replace(sim.data, points=sim.data.points / 25.4 * 1e3 * 1e-3).save(d / "inches.csv")
    q = fanuc_coupled(sim.data.joints)
    inside = robot.within_limits(q) & robot.within_limits(sim.data.joints)
    assert inside.sum() >= 30
    replace(sim.data, joints=q).subset(np.flatnonzero(inside)).save(d / "coupled.csv")
    return d


@pytest.mark.parametrize("command", ["calibrate", "evaluate"])
def test_a_tracker_export_in_inches_is_named(fanuc, tmp_path, capsys, command):
    argv = (["calibrate", str(fanuc / "inches.csv"), "--robot", "fanuc_m20ia", "-o", str(tmp_path / "c.yaml")]
            if command == "calibrate" else ["evaluate", str(fanuc / "truth.yaml"), str(fanuc / "inches.csv")])
    line = _refused(argv, capsys, "inch")
    assert "another robot" not in line.split("(the check")[0]


@pytest.mark.parametrize("command", ["calibrate", "evaluate"])
def test_a_fanuc_joint_log_with_j3_coupled_to_j2_names_the_option(fanuc, tmp_path, capsys, command):
    data = str(fanuc / "coupled.csv")
    argv = (["calibrate", data, "--robot", "fanuc_m20ia", "-o", str(tmp_path / "c.yaml")]
            if command == "calibrate" else ["evaluate", str(fanuc / "truth.yaml"), data])
    _refused(argv, capsys, "J3 looks coupled to J2", "--fanuc-j2j3-coupled")
    fast = ["--nongeometric", "none"] if command == "calibrate" else []  # the geometric model: quick
    code, out, err = _run([*argv, "--fanuc-j2j3-coupled", *fast], capsys)
    assert code == 0, err
    if command == "evaluate":  # read right, the truth fits to the noise (0.02 mm per axis)
        from robocal.data.joint_conventions import fanuc_decoupled_data

        data = fanuc_decoupled_data(rc.Measurements.load(fanuc / "coupled.csv"))
        assert rc.evaluate(rc.Robot.load(fanuc / "truth.yaml"), data)["rms"] < 0.06


def test_the_fanuc_conventions_are_inverse(rng):
    from robocal.data.joint_conventions import J23_FACTOR, fanuc_coupled, fanuc_decoupled
    from robocal.programs.dialects.fanuc.campaign import J23_FACTOR as CAMPAIGN_FACTOR

    q = rng.uniform(-3, 3, (20, 6))
    assert np.allclose(fanuc_decoupled(fanuc_coupled(q)), q)
    assert np.allclose(fanuc_coupled(q)[:, 2], q[:, 2] + q[:, 1]) and CAMPAIGN_FACTOR == J23_FACTOR


@pytest.mark.parametrize("command", ["filter", "compensate"])
def test_calibrated_and_nominal_swapped_are_named(cell, tmp_path, capsys, command):
    from robocal.data.simulate import perturbed

    perturbed(rc.Robot.from_catalog("fanuc_lrmate200id"), 7).save(tmp_path / "fcal.yaml")
    rc.Robot.from_catalog("fanuc_lrmate200id").save(tmp_path / "fnom.yaml")
    frames = ["--frame", "1=450,-150,100,0,0,-10", "--tool", "2=0,0,120,0,0,0"]
    for cal, nom in (("fanuc_lrmate200id", tmp_path / "fcal.yaml"),
                     (tmp_path / "fnom.yaml", tmp_path / "fcal.yaml")):
        if command == "filter":
            argv = ["filter", str(PROGRAMS / "sealing.ls"), "--calibrated", str(cal), "--nominal", str(nom),
                    *frames]
        else:
            argv = ["compensate", str(cal), str(cell / "mm.csv"), "--nominal", str(nom)]
        _refused([*argv, "-o", str(tmp_path / "o.x")], capsys, "look swapped", f"--nominal {cal}")
        assert not (tmp_path / "o.x").exists()


def test_a_tool_that_disagrees_with_the_programs_own_tool_data_is_warned(cell, tmp_path, capsys):
    weld = ["filter", str(PROGRAMS / "weld_cell.mod"), "--calibrated", str(cell / "cal.yaml"), "--nominal",
            "abb_irb2600"]
    turn = "0.96592583,0,0.25881905,0"
    code, _, err = _run([*weld, "--tool", f"tGun=60,0,200,{turn}", "-o", str(tmp_path / "a.mod")], capsys)
    warned = [ln for ln in err.splitlines() if "warning" in ln and "own tool data tGun" in ln]
    assert code == 0 and len(warned) == 1, err
    assert "tGun=60,0,200" in warned[0] and "50, 0, 200 mm" in warned[0] and "10 mm" in warned[0]
    code, _, err = _run([*weld, "--tool", f"tGun=50,0,200,{turn}", "-o", str(tmp_path / "b.mod")], capsys)
    assert code == 0 and "own tool data" not in err, err
