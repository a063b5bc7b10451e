"""Program files as controllers read them: LF, CRLF, CR-only and mixed line ends (line numbers
right, line ends written back as they were), and call chains of any depth (no recursion limit),
recursive calls named."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

import robocal as rc
from robocal.data.simulate import perturbed
from robocal.programs import filter_program

CORPUS = Path(__file__).parent / "data" / "programs" / "corpus"
FANUC = {"frames": {"1": "450,-150,100,0,0,-10"}, "tools": {"2": "0,0,120,0,0,0"}}
PROGRAMS = {"rapid": (["arc_station.mod"], "abb_irb2600", {}),
            "krl": (["deburr_cell.src", "deburr_cell.dat"], "kuka_kr16_2", {}),
            "fanuc": (["weld_bracket.ls"], "fanuc_lrmate200id", FANUC),
            "urscript": (["palletizing_ur5.script"], "ur5", {})}


def _line_ends(data: bytes, style: str) -> bytes:
    """``data`` with every line end made LF, CRLF, CR, or mixed (cycling LF, CR, CRLF: a CR end
    is never followed by an LF end alone, which would read as one CRLF)."""
    lines = re.split(rb"\r\n|\r|\n", data)
    if style != "mixed":
        return {"lf": b"\n", "crlf": b"\r\n", "cr": b"\r"}[style].join(lines)
    ends = [b"\n", b"\r", b"\r\n"]
    return b"".join(line + ends[k % 3] for k, line in enumerate(lines[:-1])) + lines[-1]


@pytest.mark.parametrize("style", ["crlf", "cr", "mixed"])
@pytest.mark.parametrize("dialect", list(PROGRAMS))
def test_line_ends_read_as_the_controller_reads_them(dialect, style, tmp_path):
    """The same program with other line ends: the same motions on the same lines, the same
    corrected numbers, and its own line ends written back."""
    names, robot, options = PROGRAMS[dialect]
    nominal = rc.Robot.from_catalog(robot)
    cal = perturbed(nominal, 7)
    runs = {}
    for kind in ("lf", style):
        folder = tmp_path / kind
        folder.mkdir()
        paths = []
        for n in names:
            (folder / n).write_bytes(_line_ends((CORPUS / n).read_bytes(), kind))
            paths.append(folder / n)
        refs = []
        if dialect == "krl":
            shutil.copy(CORPUS / "$config.dat", folder / "$config.dat")
            refs = [folder / "$config.dat"]
        runs[kind] = (filter_program(paths, cal, nominal, references=refs, **options), paths)
    (lf, lf_paths), (other, paths) = runs["lf"], runs[style]
    assert other.motions == lf.motions and other.motions
    assert [(r["line"], r["name"]) for r in other.rows] == [(r["line"], r["name"]) for r in lf.rows]
    for p, q in zip(paths, lf_paths, strict=True):
        out = other.outputs[p]
        assert _line_ends(out, "lf") == lf.outputs[q]  # the same numbers
        assert out.count(b"\r") == p.read_bytes().count(b"\r")  # its own line ends
        assert out.count(b"\n") == p.read_bytes().count(b"\n")


DEPTH = 1200


def _chain(dialect: str) -> tuple[str, bytes, str]:
    """A program whose one motion is reached through DEPTH routines each calling the next."""
    n = DEPTH
    if dialect == "rapid":
        lines = ["MODULE deep", "  CONST robtarget p:=[[800,0,900],[0,0,1,0],[0,0,0,0],"
                 "[9E9,9E9,9E9,9E9,9E9,9E9]];", "  PROC main()", "    r0;", "  ENDPROC"]
        for i in range(n):
            body = f"    r{i + 1};" if i < n - 1 else "    MoveL p, v100, fine, tool0;"
            lines += [f"  PROC r{i}()", body, "  ENDPROC"]
        return "deep.mod", "\n".join([*lines, "ENDMODULE", ""]).encode(), "abb_irb2600"
    if dialect == "krl":
        lines = ["DEF deep( )", "  $TOOL = $NULLFRAME", "  $BASE = $NULLFRAME", "  r0( )", "END"]
        for i in range(n):
            body = f"  r{i + 1}( )" if i < n - 1 else "  LIN {X 800, Y 0, Z 900, A 0, B 90, C 0}"
            lines += [f"DEF r{i}( )", body, "END"]
        return "deep.src", "\r\n".join([*lines, ""]).encode(), "kuka_kr16_2"
    lines = [f"def r{i}():\n  r{i + 1}()\nend" for i in range(n - 1)]
    lines += [f"def r{n - 1}():\n  movel(p[0.4, 0.1, 0.5, 0, 3.14, 0], a=1, v=0.1)\nend", "r0()", ""]
    return "deep.script", "\n".join(lines).encode(), "ur5"


@pytest.mark.parametrize("dialect", ["rapid", "krl", "urscript"])
def test_call_chains_of_any_depth(dialect, tmp_path):
    name, data, robot = _chain(dialect)
    path = tmp_path / name
    path.write_bytes(data)
    nominal = rc.Robot.from_catalog(robot)
    res = filter_program(path, perturbed(nominal, 7), nominal)
    assert res.summary_dict()["motions"] == {"total": 1, "corrected": 1, "named": 0}
    word = {"rapid": b"MoveL", "krl": b"LIN", "urscript": b"movel"}[dialect]
    assert res.motions[0].line == data.count(b"\n", 0, data.index(word)) + 1


def test_recursive_calls_are_named(tmp_path):
    path = tmp_path / "loop.mod"
    path.write_bytes(b"MODULE loop\n  CONST robtarget p:=[[800,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,"
                     b"9E9,9E9]];\n  PROC main()\n    a;\n  ENDPROC\n  PROC a()\n"
                     b"    MoveL p, v100, fine, tool0;\n    b;\n  ENDPROC\n  PROC b()\n    a;\n  ENDPROC\n"
                     b"ENDMODULE\n")
    nominal = rc.Robot.from_catalog("abb_irb2600")
    res = filter_program(path, perturbed(nominal, 7), nominal)
    assert "loop.mod:11: a recursive call (a -> b -> a): its motions are ordered from the first entry only" \
        in res.warnings
    assert res.summary_dict()["motions"] == {"total": 1, "corrected": 1, "named": 0}


def test_krl_partial_inline_position_is_named(tmp_path):
    """LIN {Z 950} takes its other components from where the robot is: named, never silent; an
    axis position is a joint motion (no record)."""
    path = tmp_path / "part.src"
    path.write_bytes(b"DEF part( )\r\n  $TOOL = $NULLFRAME\r\n  $BASE = $NULLFRAME\r\n"
                     b"  LIN {X 800, Y 0, Z 900, A 0, B 80, C 0}\r\n  LIN {Z 950}\r\n"
                     b"  PTP {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}\r\nEND\r\n")
    nominal = rc.Robot.from_catalog("kuka_kr16_2")
    res = filter_program(path, perturbed(nominal, 7), nominal)
    assert [(m.line, m.status) for m in res.motions] == [(4, "corrected"), (5, "named")]
    assert "a partial position" in res.motions[1].reason


def test_fanuc_motion_to_a_vision_register_is_named(tmp_path):
    path = tmp_path / "vis.ls"
    path.write_bytes(b"/PROG  VIS\n/ATTR\n/MN\n   1:  UFRAME_NUM=1 ;\n   2:  UTOOL_NUM=2 ;\n"
                     b"   3:L VR[1].FOUND_POS[1] 100mm/sec FINE    ;\n   4:L P[1] 100mm/sec FINE    ;\n/POS\n"
                     b"P[1]{\n   GP1:\n\tUF : 1, UT : 2,\t\tCONFIG : 'N U T, 0, 0, 0',\n"
                     b"\tX = -45.6 mm, Y = 128.8 mm, Z = 315.1 mm,\n"
                     b"\tW = 178.3 deg, P = -0.6 deg, R = 24.9 deg\n};\n/END\n")
    nominal = rc.Robot.from_catalog("fanuc_lrmate200id")
    res = filter_program(path, perturbed(nominal, 7), nominal, frames={"1": "450,-150,100,0,0,-10"},
                         tools={"2": "0,0,120,0,0,0"})
    assert [(m.line, m.status, m.target) for m in res.motions] == [(6, "named", "VR[1].FOUND_POS[1]"),
                                                                   (7, "corrected", "P[1]")]


def test_constant_expressions():
    from robocal.programs.expressions import constant_value

    k = {"k": 2.5, "nbead__1_2": 2.0}
    assert constant_value("(-1) * K * 4", k) == -10.0
    assert constant_value("nBead__1_2 * ((-1) * K)", k) == -5.0
    assert constant_value("+3 - -2 / 4", k) == 3.5
    for text in ("nRow * 2", "CRobT()", "2 ** 3", "a.b", "1 / 0", "[1, 2]", "", "1;2"):
        assert constant_value(text, k) is None, text


def test_chunked_filtering_gives_the_same_program(tmp_path, monkeypatch):
    """Large programs are solved CHUNK targets at a time: with chunks of 3 targets the filtered
    program and its table are those of one pass."""
    import robocal.programs.filter as flt

    names, robot, options = PROGRAMS["rapid"]
    paths = []
    for n in names:
        shutil.copy(CORPUS / n, tmp_path / n)
        paths.append(tmp_path / n)
    nominal = rc.Robot.from_catalog(robot)
    cal = perturbed(nominal, 7)
    one = filter_program(paths, cal, nominal, **options)
    monkeypatch.setattr(flt, "CHUNK", 3)
    chunked = filter_program(paths, cal, nominal, **options)
    assert chunked.outputs == one.outputs and chunked.motions == one.motions
    for a, b in zip(chunked.rows, one.rows, strict=True):
        assert a.keys() == b.keys()
        for k in a:
            assert a[k] == pytest.approx(b[k], abs=1e-9) if isinstance(a[k], float) else a[k] == b[k]
