"""Writers escape what they embed (issue 47): a model name holding ``]]>``, a line end, quotes and
``-->`` goes through the command line into the campaign programs of every language, the URDF and
the ur_calibration YAML without breaking out of its comment, string or CDATA section."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from robocal.cli import main

EVIL = "m]]></Code></Program><Program name='evil'><Code><![CDATA[begin\nINJECTED: 1 --> \"q' <x>"
PROGRAMS = {"--rapid": "c.mod", "--krl": "c.src", "--fanuc": "c.ls", "--inform": "c.jbi",
            "--urscript": "c.script", "--val3": "app"}
VAL3 = "{http://www.staubli.com/robotics/VAL3/Program/2}Program"


def _evil_model(tmp_path, robot: str):
    assert main(["export", robot, "--yaml", str(tmp_path / "m.yaml")]) == 0
    text = (tmp_path / "m.yaml").read_text()
    quoted = '"' + EVIL.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'
    (tmp_path / "evil.yaml").write_text(re.sub(r"^name:.*$", lambda m: f"name: {quoted}", text, count=1,
                                               flags=re.M))
    return tmp_path / "evil.yaml"


def _no_line_injected(path) -> None:
    for line in path.read_text(encoding="latin-1").splitlines():
        assert not line.lstrip().startswith("INJECTED"), f"{path.name}: {line!r}"


def test_a_hostile_model_name_stays_in_its_comments(tmp_path):
    model = _evil_model(tmp_path, "staubli_tx2_140")
    args = ["poses", "--model", str(model), "-n", "12", "-o", str(tmp_path / "p.csv")]
    for option, name in PROGRAMS.items():
        args += [option, str(tmp_path / name)]
    assert main(args) == 0
    files = [p for p in tmp_path.rglob("*") if p.is_file() and p.name not in ("m.yaml", "evil.yaml")]
    assert len(files) >= 8
    for path in files:
        _no_line_injected(path)
    for pgx in (tmp_path / "app").glob("*.pgx"):  # each file one program: none injected
        programs = [p.get("name") for p in ET.parse(pgx).getroot().iter(VAL3)]
        assert programs == [pgx.stem], (pgx.name, programs)
    for other in (tmp_path / "app").glob("*.[dp][tj]x"):
        ET.parse(other)  # well-formed


def test_a_hostile_model_name_in_the_urdf_and_ur_calibration(tmp_path):
    model = _evil_model(tmp_path, "ur5e")
    assert main(["export", str(model), "--urdf", str(tmp_path / "r.urdf"),
                 "--ur-calibration", str(tmp_path / "cal.yaml"), "--nominal", "ur5e"]) == 0
    root = ET.parse(tmp_path / "r.urdf").getroot()
    assert root.tag == "robot" and root.get("name").replace("\n", " ") in (EVIL, EVIL.replace("\n", " "))
    _no_line_injected(tmp_path / "cal.yaml")
    import yaml

    assert set(yaml.safe_load((tmp_path / "cal.yaml").read_text())) == {"kinematics"}


def test_a_hostile_model_name_in_the_campaign_report(tmp_path):
    model = _evil_model(tmp_path, "staubli_tx2_140")
    assert main(["--quiet", "poses", "--robot", str(model), "-n", "12", "-o", str(tmp_path / "p.csv"),
                 "--html", str(tmp_path / "p.html")]) == 0
    page = (tmp_path / "p.html").read_text()
    assert "<Program" not in page and "<x>" not in page and "&lt;x&gt;" in page


def test_a_measurement_file_source_with_line_breaks_stays_one_comment(tmp_path):
    """A file name or label with a line break, in the ``# source`` comment of a measurement CSV,
    cannot start a line of its own (it would be read as a header or a row)."""
    from dataclasses import replace

    import robocal as rc
    from robocal.data.simulate import simulate_tracker

    robot = rc.Robot.from_catalog("abb_irb2600")
    data = replace(simulate_tracker(robot, 5, seed=1).data, source="run\nq1_rad,q2_rad\r\n1,2")
    path = tmp_path / "m.csv"
    data.save(path)
    lines = path.read_text().splitlines()
    assert lines[0] == "# run?q1_rad,q2_rad??1,2" and not lines[1].startswith("q1_rad,q2_rad")
    back = type(data).load(path, robot)
    assert len(back) == len(data)


def test_a_register_comment_cannot_break_the_setter_program(tmp_path):
    """A POSREG.VA register comment holding ``]`` and ``;`` (the end of the label and of the TP
    line) is written into PR_CAL.LS without them: every /MN line stays one assignment."""
    from test_fanuc_posreg import FRAME, PALLET, POSREG, TOOL, _write

    import robocal as rc
    from robocal.data.simulate import perturbed

    assert "'PICK' " in POSREG
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG.replace("'PICK' ", "'P]I;C\"K' "))
    perturbed(rc.Robot.from_catalog("fanuc_m20ia"), 7).save(tmp_path / "cal.yaml")
    out = tmp_path / "out"
    out.mkdir()
    assert main(["--quiet", "filter", str(program), "--references", str(posreg), "--calibrated",
                 str(tmp_path / "cal.yaml"), "--nominal", "fanuc_m20ia", "--frame", f"1={FRAME}", "--tool",
                 f"2={TOOL}", "-o", str(out / "PALLET.ls")]) == 0
    text = (out / "PR_CAL.LS").read_text()
    assert "PR[11:P I C K]=P[" in text  # the comment kept, its brackets and ';' and quote spaces
    for line in text[text.index("/MN") + 3:text.index("/POS")].strip().splitlines():
        assert re.fullmatch(r"\s*\d+:\s+(PR\[\d+(:[^\[\];]*)?\]=P\[\d+\]\s+;|!.*;)", line), line
