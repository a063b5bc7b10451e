"""Fuzzing every reader of the command line (bounded to about a minute): mutated measurement CSVs
of the four kinds, both import layouts, model YAML (three catalog forms and a saved model),
result JSON, URDF and five robot-program formats (INFORM with its TOOL.CND) must end with exit 0
and every output written, or exit 2 and one line; never an internal error (exit 3), a traceback,
a stray warning line or a modified input. The mutations and the contract are in tests/fuzzing.py;
the long run (10,000 mutants per reader) is scripts/fuzz_readers.py. A program reader's output may
differ from its input only in numbers (and added lines: the provenance marker). Below: reproducers
of the defects the fuzzing found, and the same program given with other line ends, a BOM, another
encoding, trailing blanks or tabs must be accounted the same and edited the same (issue 46)."""

from __future__ import annotations

import random
import re
from pathlib import Path

import pytest
from fuzzing import PROGRAMS, build_readers, check, mutate, run_case
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robocal.cli import main
from robocal.core.errors import DataError
from robocal.data.simulate import perturbed
from robocal.kinematics.model import Robot
from robocal.programs import filter_program

READERS = ["csv_point", "csv_pose", "csv_plane", "csv_distance", "import_rows", "import_files",
           "model_abb_irb2600", "model_ur5", "model_puma560", "model_saved", "urdf", "result_json",
           "rapid", "krl", "fanuc", "urscript", "inform", "fanuc_posreg", "inform_var", "inform_var_backup",
           "val3_s6", "rapid_rt", "krl_rt", "inform_cell"]
SLOWER = ["urscript", "fanuc", "inform", "fanuc_posreg", "inform_var", "inform_var_backup", "val3_s6",
          "rapid_rt", "krl_rt", "inform_cell"]
EXAMPLES = {"result_json": 15, **dict.fromkeys(SLOWER, 20)}  # the slower readers (default 30)


@pytest.fixture(scope="module")
def readers(tmp_path_factory):
    return build_readers(tmp_path_factory.mktemp("fuzz_seeds"))


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
def test_reader_keeps_the_contract_on_mutants(readers, tmp_path_factory, name):
    reader = readers[name]
    folder = tmp_path_factory.mktemp(f"fuzz_{name}")

    @settings(max_examples=EXAMPLES.get(name, 30), deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.integers(0, 2**32 - 1))
    def one(seed):
        target, data = mutate(reader, random.Random(seed))
        code, stderr = run_case(reader, target, data, folder / "case")
        problem = check(reader, target, data, folder / "case", code, stderr)
        assert problem is None, f"{name} mutant (seed {seed}, file {target}): {problem}"

    one()


# ----------------------------------------------------------------- reproducers of defects the fuzzing found
def test_val3_joint_value_that_is_no_number_is_a_clear_error(tmp_path):
    """<jointValue j1="" ...> (or "--1", "null") in an s6 .dtx: exit 2 with the place (was an
    internal ValueError)."""
    import test_val3_layouts as vl

    folder = vl._s6_application(tmp_path / "cell")
    dtx = folder / "cell.dtx"
    dtx.write_bytes(dtx.read_bytes().replace(b'<jointValue j1="0"', b'<jointValue j1="--1"', 1))
    with pytest.raises(DataError, match=r'cell.dtx:\d+: .*j1="--1" is not a number'):
        filter_program([folder / n for n in ("start.pgx", "place.pgx", "cell.dtx")], vl.CALIBRATED,
                       vl.NOMINAL)


def test_val3_s6_point_without_its_coordinates_element_is_refused_not_written_elsewhere(tmp_path):
    """<valuePoint> whose <tpValue> line is garbled (swapped case, as the fuzzing made it): the
    corrected coordinates were written as attributes of <valuePoint>, which the controller does not
    read (an unsafe edit): refused."""
    import test_val3_layouts as vl

    folder = vl._s6_application(tmp_path / "cell")
    dtx = folder / "cell.dtx"
    data = dtx.read_bytes()
    k = data.index(b"<tpValue")
    dtx.write_bytes(data[:k] + data[k:data.index(b"/>", k)].swapcase() + data[data.index(b"/>", k):])
    with pytest.raises(DataError, match=r"<valuePoint> of p1\[0\] holds no coordinates element"):
        filter_program([folder / n for n in ("start.pgx", "place.pgx", "cell.dtx")], vl.CALIBRATED,
                       vl.NOMINAL)


def test_fanuc_line_number_of_thousands_of_digits_is_no_internal_error(tmp_path):
    """A TP line number of 5,000 digits: the provenance marker's int() raised ValueError (exit 3)."""
    path = tmp_path / "S.ls"
    text = (PROGRAMS / "sealing.ls").read_bytes()
    path.write_bytes(text.replace(b"\n   1:", b"\n" + b"1" * 5000 + b":", 1))
    out = tmp_path / "out.ls"
    code = main(["--quiet", "filter", str(path), "--calibrated", str(_cal(tmp_path, "fanuc_lrmate200id")),
                 "--nominal", "fanuc_lrmate200id", "--frame", "1=450,-150,100,0,0,-10", "--tool",
                 "2=0,0,120,0,0,0", "-o", str(out)])
    assert code in (0, 2)


# ----------------------------------------------------------------- the same program whatever its bytes
def _cal(folder: Path, robot: str) -> Path:
    path = folder / f"cal_{robot}.yaml"
    if not path.exists():
        perturbed(Robot.from_catalog(robot), 7).save(path)
    return path


def _lf(b: bytes) -> bytes:
    return b.replace(b"\r\n", b"\n").replace(b"\r", b"\n")


# program files, references, robot, options, the comment mark after which an accented word goes
SEEDS = {"rapid": (["weld_cell.mod"], [], "abb_irb2600", {}, b"!"),
         "krl": (["palletize.src", "palletize.dat"], ["config.dat"], "kuka_kr16_2", {}, b";"),
         "fanuc": (["sealing.ls"], [], "fanuc_lrmate200id",
                   {"frames": {"1": "450,-150,100,0,0,-10"}, "tools": {"2": "0,0,120,0,0,0"}}, b"!"),
         "urscript": (["pick_place.script"], [], "ur5", {}, b"#"),
         "inform": (["corpus/PALLETIZE.JBI"], ["corpus/TOOL.CND"], "yaskawa_gp180", {}, b"'")}


def _variant(data: bytes, mark: bytes, end: bytes, bom: bool, encoding: str, blanks: bool,
             tabs: bool) -> bytes:
    """``data`` with line ends ``end``, a UTF-8 BOM, an accented word in its first comment written in
    ``encoding``, trailing blanks and tab indentation: what editors and controllers make of a file."""
    out = _lf(data)
    if tabs:
        out = re.sub(rb"(?m)^ {2,}", lambda m: b"\t" * (len(m.group()) // 2), out)
    if blanks:
        out = re.sub(rb"(?m)(\S)$", rb"\1 \t ", out)
    k = out.find(mark)
    if encoding and k >= 0:
        out = out[:k + 1] + "Schweißnaht é ".encode(encoding) + out[k + 1:]
    out = out.replace(b"\n", end)
    return (b"\xef\xbb\xbf" if bom else b"") + out


def _filter_seed(folder: Path, seed: str, transform):
    """The seed's programs and references, each file's bytes passed through ``transform``, written
    to ``folder`` and filtered against the nominal robot perturbed with seed 7: (result, paths)."""
    files, refs, robot, options, _ = SEEDS[seed]
    for f in files + refs:
        (folder / Path(f).name).write_bytes(transform((PROGRAMS / f).read_bytes()))
    nominal = Robot.from_catalog(robot)
    paths = [folder / Path(f).name for f in files]
    res = filter_program(paths, perturbed(nominal, 7), nominal,
                         references=[folder / Path(f).name for f in refs], **options)
    return res, paths


def _filter_and_write(seed: str, folder: Path, transform) -> tuple[list[Path], Path]:
    """`_filter_seed`, its outputs written to ``folder``/out: (the input paths, the out folder)."""
    res, paths = _filter_seed(folder, seed, transform)
    out = folder / "out"
    out.mkdir()
    res.write({p: out / p.name for p in paths})
    return paths, out


def _filtered(folder: Path, seed: str, transform) -> tuple[tuple, dict[str, bytes]]:
    folder.mkdir()
    res, _ = _filter_seed(folder, seed, transform)
    account = (res.summary_dict()["motions"], [w.replace(str(folder), "") for w in res.warnings],
               [(m.file, m.line, m.instruction, m.status, m.reason) for m in res.motions],
               [(r["name"], r["filtered"]) for r in res.rows])
    return account, {Path(p).name: b for p, b in res.outputs.items()}


@pytest.mark.parametrize("seed", list(SEEDS))
def test_every_motion_accounted_the_same_whatever_the_bytes(seed, tmp_path_factory):
    """Line ends (LF, CRLF, lone CR), a UTF-8 BOM, an accented comment in UTF-8 / cp1252, trailing
    blanks, tab indentation: the same motions, corrected and named with the same reasons, and the
    output is the input's bytes with the same edits (its line ends and encoding kept)."""
    base, outputs = _filtered(tmp_path_factory.mktemp("base") / "p", seed, _lf)
    mark = SEEDS[seed][4]

    @settings(max_examples=6, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.sampled_from([b"\n", b"\r\n", b"\r"]), st.booleans(), st.sampled_from(["", "utf-8", "cp1252"]),
           st.booleans(), st.booleans())
    def one(end, bom, encoding, blanks, tabs):
        def variant(b):
            return _variant(b, mark, end, bom, encoding, blanks, tabs)

        account, got = _filtered(tmp_path_factory.mktemp("v") / "p", seed, variant)
        assert account == base
        assert got == {n: variant(b) for n, b in outputs.items()}

    one()


@pytest.mark.parametrize("end", [b"\r", b"\r\n", b"\n"])
@pytest.mark.parametrize("files", [["arc_station.mod"], ["deburr_cell.src", "deburr_cell.dat"]])
def test_added_routine_and_marker_keep_the_files_line_ends(files, end, tmp_path):
    """--runtime-correction's routine and the provenance marker are written with the program's own
    line ends: a CR-only RAPID module had them with LF (the routine was written for the text the
    readers see, where a lone CR is LF; the marker's anchor knew only CRLF and LF)."""
    robot = "abb_irb2600" if files[0].endswith(".mod") else "kuka_kr16_2"
    paths = []
    for f in files:
        paths.append(tmp_path / f)
        paths[-1].write_bytes(_lf((PROGRAMS / "corpus" / f).read_bytes()).replace(b"\n", end))
    nominal = Robot.from_catalog(robot)
    refs = [] if robot == "abb_irb2600" else [PROGRAMS / "corpus" / "$config.dat"]
    res = filter_program(paths, perturbed(nominal, 7), nominal, references=refs, runtime_correction=True)
    out = tmp_path / "out"
    out.mkdir()
    res.write({p: out / p.name for p in paths})
    for p in paths:
        data = (out / p.name).read_bytes()
        assert data.count(end) == len(re.findall(rb"\r\n|\r|\n", data)), p.name
        assert data.count(end) > p.read_bytes().count(end)  # the marker (and the routine) added


@pytest.mark.parametrize("end", [b"\n", b"\r\n", b"\r"])
def test_a_backups_var_dat_saved_with_a_bom_is_read_the_same(end, tmp_path):
    """A controller backup's VAR.DAT saved by a Windows editor (UTF-8 BOM before //VAR): it was
    refused ("not a UFRAME.CND nor a TOOL.CND nor a VAR.DAT"); now read as without the BOM."""
    import test_inform_variables as iv

    forms = ["".join(map(str, iv.InformDialect().scheme.encode(iv.NOMINAL, iv.Q[k]).clip(0, 1))) + "0" * 18
             for k in range(2)]
    var = iv._backup_var(tmp_path, forms)
    job = tmp_path / "B.JBI"
    job.write_bytes(iv._job(["///NPOS 0,0,0,0,0,0"], [f"MOVL P{k:03d} V=100.0" for k in range(1, 6)]))
    plain = filter_program([job], iv.CALIBRATED, iv.NOMINAL, references=[var])
    var.write_bytes(b"\xef\xbb\xbf" + _lf(var.read_bytes()).replace(b"\n", end))
    res = filter_program([job], iv.CALIBRATED, iv.NOMINAL, references=[var])
    assert [m.as_dict() for m in res.motions] == [m.as_dict() for m in plain.motions]
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 2, "named": 2}


def test_a_var_dat_line_with_a_type_of_thousands_of_digits_is_named(tmp_path):
    """A backup VAR.DAT line whose coordinate type has 5,000 digits: int() raised ValueError
    (internal error); now the line is not a variable's and its motion is named."""
    import test_inform_variables as iv

    var = iv._backup_var(tmp_path, ["0" * 24, "0" * 24])
    data = var.read_bytes()
    var.write_bytes(data.replace(b"0,0,2,-76037", b"0," + b"1" * 5000 + b",2,-76037", 1))
    job = tmp_path / "B.JBI"
    job.write_bytes(iv._job(["///NPOS 0,0,0,0,0,0"], [f"MOVL P{k:03d} V=100.0" for k in range(1, 6)]))
    with pytest.raises(DataError, match=r"VAR.DAT:11: a number of 5000 digits"):  # refused when read
        filter_program([job], iv.CALIBRATED, iv.NOMINAL, references=[var], keep_unreached=True)
    var.write_bytes(data.replace(b"0,0,2,-76037", b"0," + b"1" * 40 + b",2,-76037", 1))  # read, not a type
    res = filter_program([job], iv.CALIBRATED, iv.NOMINAL, references=[var], keep_unreached=True)
    assert any(m.reason.startswith("P001's line in VAR.DAT is not") for m in res.motions)


def test_fanuc_marker_of_a_program_cut_short_is_a_line_of_its_own(tmp_path):
    """A .ls cut inside /MN (no /POS, no line end at its end) moving to PR[] of the POSREG.VA given:
    the provenance remark was glued to the last instruction (`L PR[17:DROP] 100mm/sec FI  19:  !robocal
    ...`), changing it; now on its own line."""
    import test_fanuc_posreg as fp

    backup = PROGRAMS.parent / "fanuc_backup"
    text = fp.PALLET.replace("\n", "\r\n").encode()
    path = tmp_path / "PALLET.ls"
    path.write_bytes(text[:text.index(b"/POS")].rstrip(b"\r\n ;"))
    out = tmp_path / "out.ls"
    code = main(["--quiet", "filter", str(path), "--references", str(backup / "POSREG.VA"),
                 str(backup / "SYSFRAME.VA"), "--calibrated", str(_cal(tmp_path, "fanuc_m20ia")),
                 "--nominal", "fanuc_m20ia", "-o", str(out)])
    assert code == 0
    lines = out.read_bytes().splitlines()
    marks = [ln for ln in lines if b"robocal" in ln]
    assert len(marks) == 1 and re.match(rb" *\d+:  !robocal", marks[0]), marks
    def masked(rows):
        return [re.sub(rb"\d+", b"#", ln) for ln in rows]

    assert masked(lines[:-1]) == masked(path.read_bytes().splitlines())  # only numbers (LINE_COUNT) changed


@pytest.mark.parametrize("seed", list(SEEDS))
def test_the_marker_leaves_a_bom_first_and_is_found_again(seed, tmp_path):
    """A file saved with a UTF-8 BOM: the provenance marker went before the BOM in RAPID (MODULE on
    the BOM's line was not found) and URScript (marker as first line), moving the BOM into the text;
    now the BOM stays first, and filtering the output again is refused as before."""
    _, refs, robot, options, _ = SEEDS[seed]
    paths, out = _filter_and_write(seed, tmp_path, lambda data: b"\xef\xbb\xbf" + data)
    nominal = Robot.from_catalog(robot)
    for p in paths:
        data = (out / p.name).read_bytes()
        assert data.startswith(b"\xef\xbb\xbf") and data.count(b"\xef\xbb\xbf") == 1, p.name
    with pytest.raises(DataError, match="already filtered"):
        filter_program([out / p.name for p in paths], perturbed(nominal, 7), nominal,
                       references=[tmp_path / Path(f).name for f in refs], **options)


@pytest.mark.parametrize("end", [b"\r", b"\r\n", b"\n"])
@pytest.mark.parametrize("seed", list(SEEDS))
def test_the_written_program_keeps_its_line_ends(seed, end, tmp_path):
    """The filtered file as written (with its provenance marker) has the input's line ends only."""
    paths, out = _filter_and_write(seed, tmp_path, lambda data: _lf(data).replace(b"\n", end))
    for p in paths:
        data = (out / p.name).read_bytes()
        assert data.count(end) == len(re.findall(rb"\r\n|\r|\n", data)) > p.read_bytes().count(end), p.name


def test_a_fanuc_remark_naming_a_section_is_no_section(tmp_path):
    """`! see /POS` in a remark of /MN: the reader took it for the /POS section and refused the valid
    program ("malformed position block"); the marker would have gone into that remark. A section
    header starts a line."""
    files, refs, robot, options, _ = SEEDS["fanuc"]
    data = (PROGRAMS / "sealing.ls").read_bytes()
    path = tmp_path / "sealing.ls"
    path.write_bytes(data.replace(b"!Sealing of the lid", b"!Sealing of the lid, see /POS and /END", 1))
    nominal = Robot.from_catalog(robot)
    res = filter_program([path], perturbed(nominal, 7), nominal, **options)
    assert res.summary_dict()["motions"] == {"total": 4, "corrected": 4, "named": 0}
    out = tmp_path / "out.ls"
    res.write(out)
    assert re.search(rb"\n *\d+:  !robocal[^\n]*\n/POS", out.read_bytes())


def test_a_posreg_index_of_thousands_of_digits_is_no_internal_error(tmp_path):
    """`[1,1111...1] = ''` (5,000 digits) in POSREG.VA: int() raised ValueError (internal error); the
    line is no register's now, and the motions to registers it does not hold are named."""
    import test_fanuc_posreg as fp

    backup = PROGRAMS.parent / "fanuc_backup"
    posreg = tmp_path / "POSREG.VA"
    data = (backup / "POSREG.VA").read_bytes()
    posreg.write_bytes(re.sub(rb"\[1,10\]", b"[1," + b"1" * 5000 + b"]", data, count=1))
    program = tmp_path / "PALLET.ls"
    program.write_bytes(fp.PALLET.replace("\n", "\r\n").encode())
    nominal = Robot.from_catalog("fanuc_m20ia")
    with pytest.raises(DataError, match=r"POSREG.VA:7: a number of 5000 digits"):  # refused when read
        filter_program([program], perturbed(nominal, 7), nominal,
                       references=[posreg, backup / "SYSFRAME.VA"], keep_unreached=True)
    posreg.write_bytes(re.sub(rb"\[1,10\]", b"[1," + b"1" * 40 + b"]", data, count=1))  # read: no register
    res = filter_program([program], perturbed(nominal, 7), nominal,
                         references=[posreg, backup / "SYSFRAME.VA"], keep_unreached=True)
    assert any("PR[10" in m.reason for m in res.motions if m.reason)


@pytest.mark.parametrize("seed", list(SEEDS))
def test_a_number_of_thousands_of_digits_is_refused_with_its_place(seed, tmp_path):
    """Any file holding a run of 5,000 digits (the fuzzing's huge number) is refused when read, with
    file:line, before a reader's int() fails on it (Python's 4300-digit limit: internal errors in
    FANUC POSREG.VA, TP line numbers, INFORM VAR.DAT)."""
    files, refs, robot, options, _ = SEEDS[seed]
    for f in files + refs:
        (tmp_path / Path(f).name).write_bytes((PROGRAMS / f).read_bytes())
    first = tmp_path / Path(files[0]).name
    data = first.read_bytes()
    k = data.index(b"\n", len(data) // 2) + 1
    first.write_bytes(data[:k] + b"1" * 5000 + data[k:])
    nominal = Robot.from_catalog(robot)
    line = data[:k].count(b"\n") + 1
    with pytest.raises(DataError, match=rf"{re.escape(first.name)}:{line}: a number of 5000 digits"):
        filter_program([tmp_path / Path(f).name for f in files], perturbed(nominal, 7), nominal,
                       references=[tmp_path / Path(f).name for f in refs], **options)
