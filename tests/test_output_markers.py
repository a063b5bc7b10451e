"""Every file the filter writes carries its provenance, data files included (issue 47: a filtered
VAR.DAT, a FANUC register file and a VAL3 .dtx without an XML declaration were corrected twice when
given back). Each is written through the command line, then given back where it is read: refused
with one line naming the earlier run (exit 2), never corrected a second time; ``--force`` lets it
through. (Programs in every language: tests/test_workflow_mistakes.py; compensated targets:
tests/test_compensate.py.)"""

from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from test_fanuc_posreg import FRAME, PALLET, POSREG, TOOL, _write

import robocal as rc
from robocal.cli import main
from robocal.data.simulate import perturbed
from robocal.trust.output_marker import find_marker, model_fingerprint

PROGRAMS = Path(__file__).parent / "data" / "programs"


def _calibrated(tmp_path, nominal: str) -> Path:
    path = tmp_path / "cal.yaml"
    perturbed(rc.Robot.from_catalog(nominal), 7).save(path)
    return path


def _refused(argv, capsys, *words) -> str:
    """``argv`` exits 2 with one error line holding ``words`` (after the warnings on the input)."""
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert len(errors) == 1 and err.endswith(errors[0] + "\n") and all(w in errors[0] for w in words), err
    return errors[0]


def test_the_fanuc_register_file_is_marked_and_refused_back(tmp_path, capsys):
    for name in ("sealing.ls", "weld_bracket.ls", "weld_registers.csv"):
        if (PROGRAMS / "corpus" / name).exists():
            shutil.copy(PROGRAMS / "corpus" / name, tmp_path / name)
    program, regs = tmp_path / "weld_bracket.ls", tmp_path / "weld_registers.csv"
    cal = _calibrated(tmp_path, "fanuc_lrmate200id")
    options = ["--calibrated", str(cal), "--nominal", "fanuc_lrmate200id", "--frame",
               "1=450,-150,100,0,0,-10", "--tool", "2=0,0,120,0,0,0"]
    assert main(["--quiet", "filter", str(program), "--position-registers", str(regs), "-o",
                 str(tmp_path / "o.ls"), *options]) == 0
    corrected = tmp_path / "o.ls.registers.csv"
    marker = find_marker(corrected.read_text())
    assert corrected.read_text().startswith("# robocal ") and marker is not None
    assert marker.model == model_fingerprint(rc.Robot.load(cal))
    # the original program with the corrected registers: refused, nothing written
    _refused(["filter", str(program), "--position-registers", str(corrected), "-o", str(tmp_path / "p.ls"),
              *options], capsys, "o.ls.registers.csv", "already filtered", "--force")
    assert not (tmp_path / "p.ls").exists()
    assert main(["filter", str(program), "--position-registers", str(corrected), "-o",
                 str(tmp_path / "p.ls"), "--force", *options]) == 0
    assert "o.ls.registers.csv was already filtered by robocal" in capsys.readouterr().out  # a warning


def test_the_fanuc_register_setter_program_is_refused_back(tmp_path, capsys):
    cal = _calibrated(tmp_path, "fanuc_m20ia")
    program = _write(tmp_path, "PALLET.ls", PALLET)
    posreg = _write(tmp_path, "POSREG.VA", POSREG)
    out = tmp_path / "out"
    out.mkdir()
    options = ["--calibrated", str(cal), "--nominal", "fanuc_m20ia", "--frame", f"1={FRAME}", "--tool",
               f"2={TOOL}"]
    assert main(["--quiet", "filter", str(program), "--references", str(posreg), "-o", str(out / "PALLET.ls"),
                 *options]) == 0
    setter = out / "PR_CAL.LS"
    assert find_marker(setter.read_text()) is not None
    _refused(["filter", str(setter), "-o", str(tmp_path / "again.ls"), *options], capsys, "already filtered")


def test_a_var_dat_is_marked_by_its_name_and_refused_back(tmp_path, capsys):
    """A VAR.DAT has no comment syntax: its corrected copy is named VAR_CAL.DAT (as a reference's
    and as a program file's), and a variables file so named is refused as input, as a reference or
    a program file."""
    job, var = tmp_path / "PICK_PLACE.JBI", tmp_path / "VAR.DAT"
    for p in (job, var):
        shutil.copy(PROGRAMS / "corpus" / p.name, p)
    cal = _calibrated(tmp_path, "yaskawa_gp25")
    options = ["--calibrated", str(cal), "--nominal", "yaskawa_gp25", "--tool", "3=0,0,180,0,0,0"]
    out = tmp_path / "out"
    out.mkdir()
    assert main(["--quiet", "filter", str(job), "-o", str(out / "PICK_CAL.JBI"), "--references", str(var),
                 *options]) == 0
    corrected = out / "VAR_CAL.DAT"
    assert corrected.read_bytes() != var.read_bytes()
    # given back with the original job: refused
    _refused(["filter", str(job), "-o", str(tmp_path / "J2.JBI"), "--references", str(corrected), *options],
             capsys, "VAR_CAL.DAT", "named as robocal's filtered copy", "--force")
    # VAR.DAT filtered as a program file with the job: written under its corrected name
    both = tmp_path / "both"
    both.mkdir()
    assert main(["--quiet", "filter", str(job), str(var), "-o", str(both), *options]) == 0
    written = sorted(p.name for p in both.glob("*.*") if "targets" not in p.name)
    assert written == ["PICK_PLACE.JBI", "VAR_CAL.DAT"]
    assert (both / "VAR_CAL.DAT").read_bytes() == corrected.read_bytes()  # the same corrections
    again = tmp_path / "again"
    again.mkdir()
    _refused(["filter", str(job), str(both / "VAR_CAL.DAT"), "-o", str(again), *options], capsys,
             "named as robocal's filtered copy")
    assert main(["--quiet", "filter", str(job), "-o", str(tmp_path / "J3.JBI"), "--references",
                 str(corrected), "--force", *options]) == 0


@pytest.mark.parametrize("declaration", [True, False], ids=["with an XML declaration", "without"])
def test_a_val3_dtx_is_marked_with_or_without_a_declaration(tmp_path, capsys, declaration):
    """The .dtx holds the targets: marked whether or not it starts with an XML declaration (the
    comment then comes first, before the root: still well-formed XML), and given back with the
    application's original programs it is refused."""
    app = tmp_path / "pick_place"
    shutil.copytree(PROGRAMS / "val3" / "pick_place", app)
    dtx = app / "pick_place.dtx"
    if not declaration:
        text = dtx.read_text(encoding="utf-8-sig")
        dtx.write_text(text[text.index("?>") + 2:].lstrip(), encoding="utf-8")
        assert dtx.read_text().startswith("<Database")
    cal = _calibrated(tmp_path, "staubli_tx2_140")
    out = tmp_path / "filtered"
    out.mkdir()
    assert main(["--quiet", "filter", str(app), "--calibrated", str(cal), "--nominal", "staubli_tx2_140",
                 "-o", str(out)]) == 0
    written = (out / "pick_place.dtx").read_text(encoding="utf-8-sig")
    assert find_marker(written) is not None and written != dtx.read_text(encoding="utf-8-sig")
    assert ET.fromstring(written.encode()).tag.endswith("Database")  # still well-formed
    if not declaration:
        assert written.startswith("<!-- robocal ")
    back = tmp_path / "back"
    shutil.copytree(app, back)
    shutil.copy(out / "pick_place.dtx", back / "pick_place.dtx")  # the corrected data, the old programs
    (tmp_path / "twice").mkdir()
    _refused(["filter", str(back), "--calibrated", str(cal), "--nominal", "staubli_tx2_140", "-o",
              str(tmp_path / "twice")], capsys, "pick_place.dtx", "already filtered")
