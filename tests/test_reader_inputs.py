"""Program inputs read less trustingly (issue 47, cause 6): a byte-order mark wherever a reader
looks for a file's first line, a position number given twice (INFORM C and P variables, VAL3
values and attributes), a VAL3 value that is no finite number, an element left unclosed; and every
reader linear in the size of a comment block (the patterns that backtracked on a masked comment
timed at two sizes)."""

from __future__ import annotations

import contextlib
import shutil
import signal
import time
from pathlib import Path

import pytest
import test_inform_variables as iv
import test_val3_layouts as vl

import robocal as rc
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.programs import filter_program
from robocal.programs.registry import dialect_for, dialect_named, program_files
from robocal.programs.source import ProgramText

PROGRAMS = Path(__file__).parent / "data" / "programs"
CORPUS = PROGRAMS / "corpus"
VAL3_APP = PROGRAMS / "val3" / "pick_place"
BOM = b"\xef\xbb\xbf"


def _counts(res) -> tuple[int, int]:
    return len(res.motions), sum(m.status == "corrected" for m in res.motions)


# ----------------------------------------------------------------- byte-order marks
@pytest.mark.parametrize("given", ["program", "reference"])
def test_a_var_dat_saved_with_a_bom_is_inform_and_read_the_same(tmp_path, given):
    """A VAR.DAT saved by a Windows editor (UTF-8 BOM): it was taken for a KRL .dat (0 motions, exit
    0) alone, and with its job the format could not be told."""
    var = (CORPUS / "VAR.DAT").read_bytes()
    results = []
    for bom in (b"", BOM):
        folder = tmp_path / f"bom{len(bom)}"
        folder.mkdir()
        (folder / "VAR.DAT").write_bytes(bom + var)
        (folder / "PP.JBI").write_bytes((CORPUS / "PICK_PLACE.JBI").read_bytes())
        files = [folder / "PP.JBI", *([folder / "VAR.DAT"] if given == "program" else [])]
        refs = [folder / "VAR.DAT"] if given == "reference" else []
        assert dialect_for([folder / "VAR.DAT"]).key == "inform"
        results.append(_counts(filter_program(files, iv.CALIBRATED, iv.NOMINAL, tools=iv.TOOLS,
                                              references=refs)))
    assert results[0] == results[1] and results[0][1] > 0


def test_a_var_dat_whose_first_line_is_its_position_section_after_a_bom(tmp_path):
    """``//P`` on the BOM's line: the section was not seen (its variables not read)."""
    var = (CORPUS / "VAR.DAT").read_bytes()
    var = var[var.index(b"//P"):]
    results = []
    for bom in (b"", BOM):
        (tmp_path / "VAR.DAT").write_bytes(bom + var)
        (tmp_path / "PP.JBI").write_bytes((CORPUS / "PICK_PLACE.JBI").read_bytes())
        res = filter_program([tmp_path / "PP.JBI"], iv.CALIBRATED, iv.NOMINAL, tools=iv.TOOLS,
                             references=[tmp_path / "VAR.DAT"])
        results.append(_counts(res))
    assert results[0] == results[1] and results[0][1] > 0


def test_a_val3_application_without_its_bom_is_read_the_same(tmp_path):
    """The seed application's files start with a BOM; without it, the same motions."""
    results = []
    for strip in (False, True):
        folder = tmp_path / f"app{strip}"
        shutil.copytree(VAL3_APP, folder)
        for f in folder.iterdir():
            data = f.read_bytes()
            f.write_bytes(data.removeprefix(BOM) if strip else data)
        results.append(_counts(filter_program([folder], vl.CALIBRATED, vl.NOMINAL)))
    assert results[0] == results[1] and results[0][1] > 0


# ----------------------------------------------------------------- a number given twice
def _palletize_with(tmp_path, edit) -> Path:
    path = tmp_path / "J.JBI"
    lines = (CORPUS / "PALLETIZE.JBI").read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join(edit(lines)))
    return path


def test_an_inform_position_given_twice_is_refused_naming_both_lines(tmp_path):
    """C00002 on two lines of //POS: the motions reached one copy and the other stayed as it was.
    Which copy the controller keeps is not documented: refused, both lines named."""
    def twice(lines):
        i = next(k for k, ln in enumerate(lines) if ln.startswith(b"C00002="))
        return [*lines[:i + 1], lines[i].replace(b"=", b"=1", 1), *lines[i + 1:]]

    path = _palletize_with(tmp_path, twice)
    nominal = rc.Robot.from_catalog("yaskawa_gp180")
    with pytest.raises(DataError, match=r"J\.JBI:(\d+): C00002 is given twice \(first at line \d+\)"):
        filter_program([path], perturbed(nominal, 7), nominal, references=[CORPUS / "TOOL.CND"])
    before = path.read_bytes()
    out = tmp_path / "out.JBI"
    code = main(["--quiet", "filter", str(path), "--references", str(CORPUS / "TOOL.CND"), "--calibrated",
                 str(_saved(tmp_path, perturbed(nominal, 7))), "--nominal", "yaskawa_gp180", "-o", str(out)])
    assert code == 2 and not out.exists() and path.read_bytes() == before


def _saved(folder: Path, robot: rc.Robot) -> Path:
    path = folder / "cal.yaml"
    robot.save(path)
    return path


def test_a_var_dat_variable_given_twice_is_refused_naming_both_lines(tmp_path):
    var = (CORPUS / "VAR.DAT").read_bytes().replace(b"P0002=996.498", b"P0001=996.498")
    (tmp_path / "VAR.DAT").write_bytes(var)
    (tmp_path / "PP.JBI").write_bytes((CORPUS / "PICK_PLACE.JBI").read_bytes())
    with pytest.raises(DataError, match=r"VAR\.DAT:\d+: P0001 is given twice \(first at line \d+\)"):
        filter_program([tmp_path / "PP.JBI"], iv.CALIBRATED, iv.NOMINAL, tools=iv.TOOLS,
                       references=[tmp_path / "VAR.DAT"])


# ----------------------------------------------------------------- VAL3 values
def _val3(tmp_path, edit, name="pick_place.dtx") -> Path:
    folder = tmp_path / "app"
    shutil.copytree(VAL3_APP, folder)
    path = folder / name
    path.write_bytes(edit(path.read_bytes()))
    return folder


@pytest.mark.parametrize("edit, match", [
    (lambda b: b.replace(b'j2="-20"', b'j2="abc"'),
     r'pick_place\.dtx:\d+: jHome\[0\]: j2="abc" is not a number'),
    (lambda b: b.replace(b'j2="-20"', b'j2="1e999"'), r'jHome\[0\]: j2="1e999" is not a finite number'),
    (lambda b: b.replace(b'x="294.445"', b'x="1e999"'), r'pPick\[0\]: x="1e999" is not a finite number'),
    (lambda b: b.replace(b'x="294.445"', b'x="294.445" x="300"'), r"attribute x given twice in one element"),
    (lambda b: b.replace(b'<Value key="1"', b'<Value key="0"', 1),
     r"pick_place\.dtx:(\d+): pPick\[0\] is given twice \(first at line \d+\)"),
    (lambda b: b.replace(b'<Data name="pOld"', b'<Data name="pPick"', 1), r"pPick\[0\] is given twice"),
    (lambda b: (lambda i: b[:i] + b[i + 7:])(b.index(b"</Data>", b.index(b"jHome"))),
     r'pick_place\.dtx:\d+: <Data name="jHome"> is not closed: no </Data> before the next <Data>'),
])
def test_a_val3_value_the_controller_would_not_load_is_refused_with_its_place(tmp_path, edit, match):
    """A joint value that is no number or infinite, a key or attribute given twice (one copy was
    left uncorrected), a <Data> without </Data> (it took the next datum's close and values)."""
    folder = _val3(tmp_path, edit)
    before = {f.name: f.read_bytes() for f in folder.iterdir()}
    with pytest.raises(DataError, match=match):
        filter_program([folder], vl.CALIBRATED, vl.NOMINAL)
    assert {f.name: f.read_bytes() for f in folder.iterdir()} == before


@pytest.mark.parametrize("edit, match", [
    (lambda b: b.replace(b'<valuePoint index="1"', b'<valuePoint index="0"', 1), r"pArr\[0\] is given twice"),
    (lambda b: b.replace(b"</joint>", b"", 1), r'<joint name="jHome"> is not closed'),
])
def test_a_val3_s6_value_given_twice_or_unclosed_is_refused(tmp_path, edit, match):
    folder = vl._s6_application(tmp_path / "cell")
    dtx = folder / "cell.dtx"
    dtx.write_bytes(edit(dtx.read_bytes()))
    with pytest.raises(DataError, match=match):
        filter_program([folder / n for n in ("start.pgx", "place.pgx", "cell.dtx")], vl.CALIBRATED,
                       vl.NOMINAL)


# ----------------------------------------------------------------- linear in a comment's size
SCALE = 10  # the larger comment has this many times the lines
LINEAR = 40.0  # its read may take at most this many times as long (linear: 10x, quadratic: 100x)
SLACK_S = 0.05  # and this much more (timer noise on a shared machine)
LINES = 400


def _comment(mark: str, n: int) -> bytes:
    """``n`` comment lines, ``mark`` its start (``{i}``: the line's number)."""
    return "".join(f"{mark.format(i=i)} a comment of the kind editors leave, line {i}\n"
                   for i in range(n)).encode()


# dialect, its files (the first one gets the comment), the text after which it goes, comment mark:
# right after a statement's first word (KRL's DEF, a VAL3 program's first word, a RAPID
# instruction), where two quantifiers over the masked blanks met
PLACES = {
    "krl_def": ("krl", ["palletize.src", "palletize.dat"], b"DEF ", ";"),
    "krl_line": ("krl", ["palletize.src", "palletize.dat"], b"\n", ";"),
    "rapid_move": ("rapid", ["weld_cell.mod"], b"MoveL", "!"),
    "rapid_proc": ("rapid", ["weld_cell.mod"], b"PROC", "!"),
    "rapid_for": ("rapid", ["corpus/arc_station.mod"], b"FOR", "!"),
    "val3_code": ("val3", ["pickPart.pgx", "pick_place.dtx", "start.pgx", "stop.pgx", "pick_place.pjx"],
                  b"movel(x_pPart", "//"),
    "val3_begin": ("val3", ["pickPart.pgx", "pick_place.dtx", "start.pgx", "stop.pgx", "pick_place.pjx"],
                   b"begin", "//"),
    "urscript": ("urscript", ["pick_place.script"], b"movel(", "#"),
    "fanuc": ("fanuc", ["sealing.ls"], b"/MN", "{i:4d}:  !"),
    "inform": ("inform", ["PALLETIZE.JBI"], b"NOP", "'"),
}
SOURCES = {"val3": VAL3_APP, "inform": CORPUS}


class _SlowError(Exception):
    pass


def _parse_time(key: str, folder: Path, files: list[str], anchor: bytes, block: bytes) -> float:
    """The shortest of 3 reads (the dialect's parse) of ``files`` with ``block`` after ``anchor``."""
    source = SOURCES.get(key, PROGRAMS)
    first = (source / files[0]).read_bytes()
    k = first.index(anchor) + len(anchor)
    data = first[:k] + b"\n" + block + first[k:]
    sources = [ProgramText(folder / files[0], data)] + [ProgramText(source / f) for f in files[1:]]
    dialect = dialect_named(key)
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        with contextlib.suppress(DataError):  # refusing is fine here: the time to decide is measured
            dialect.parse(sources, {}, {})
        best = min(best, time.perf_counter() - t)
    return best


def _alarm(signum, frame):
    raise _SlowError


@pytest.mark.parametrize("place", list(PLACES))
def test_every_reader_is_linear_in_a_comments_size(place, tmp_path):
    """A comment block of LINES and SCALE x LINES lines at a place where a pattern backtracked: the
    larger read takes at most LINEAR times as long (a 40-line VAL3 comment took 30 s)."""
    key, files, anchor, mark = PLACES[place]
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(120)
    try:
        small = _parse_time(key, tmp_path, files, anchor, _comment(mark, LINES))
        large = _parse_time(key, tmp_path, files, anchor, _comment(mark, LINES * SCALE))
    except _SlowError:
        pytest.fail(f"{place}: a {LINES * SCALE}-line comment took more than 120 s to read")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert large <= LINEAR * small + SLACK_S, f"{place}: {small:.4f} s -> {large:.4f} s, {SCALE}x the lines"


def test_the_val3_application_files_are_found_for_the_scaling_check():
    names = {p.name for p in program_files([VAL3_APP])}
    assert set(PLACES["val3_code"][1]) >= names - {"pick_place.pjx"}


# ----------------------------------------------------------------- the same position declared twice
def _twice(data: bytes, first: bytes, last: bytes) -> bytes:
    """``data`` with its block from ``first`` to ``last`` (included) written twice in a row."""
    i = data.index(first)
    j = data.index(last, i) + len(last)
    return data[:j] + data[i:j] + data[j:]


@pytest.mark.parametrize("files, robot, edit, match, options", [
    (["weld_cell.mod"], "abb_irb2600", (b"CONST robtarget pApproach", b"\n"),
     r"weld_cell\.mod:\d+: robtarget pApproach is declared twice in the module \(first at line \d+\)", {}),
    (["palletize.src", "palletize.dat"], "kuka_kr16_2", (b"DECL E6POS XP1=", b"\n"),
     r"palletize\.dat:\d+: XP1 is declared twice in palletize\.dat \(first at line \d+\)", {}),
    (["sealing.ls"], "fanuc_lrmate200id", (b"P[2]{", b"};\r\n"),
     r"sealing\.ls:\d+: P\[2\] is given twice in /POS \(first at line \d+\)",
     {"frames": {"1": "450,-150,100,0,0,-10"}, "tools": {"2": "0,0,120,0,0,0"}}),
])
def test_a_position_declared_twice_in_one_file_is_refused(tmp_path, files, robot, edit, match, options):
    """The controllers refuse a module, data list or program declaring a name twice in one scope;
    the filter corrected one copy and left the other as it was (exit 0)."""
    paths = []
    for name in files:
        data = (PROGRAMS / name).read_bytes()
        (tmp_path / name).write_bytes(_twice(data, *edit) if edit[0] in data else data)
        paths.append(tmp_path / name)
    nominal = rc.Robot.from_catalog(robot)
    refs = [PROGRAMS / "config.dat"] if robot == "kuka_kr16_2" else []
    with pytest.raises(DataError, match=match):
        filter_program(paths, perturbed(nominal, 7), nominal, references=refs, **options)


def test_a_ur_calibration_conf_key_given_twice_is_refused_naming_both_lines(tmp_path):
    """delta_a twice in [mounting]: the last one was taken (the arm 10 mm longer, exit 0)."""
    from robocal.kinematics.manufacturer.ur import import_calibration

    text = (Path(__file__).parent / "data" / "ur5e_calibration.conf").read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("delta_a "))
    path = tmp_path / "calibration.conf"
    path.write_text(text + line.replace("0.321935209127972688", "0.331935209127972688") + "\n")
    with pytest.raises(rc.ModelError, match=r"delta_a is given twice in \[mounting\] \(first at line 3\)"):
        import_calibration(path, "ur5e")
