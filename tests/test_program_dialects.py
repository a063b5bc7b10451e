"""The dialect framework: a language is one folder and one registry line (a toy language registered
here is recognised, filtered and marked like the six), the docs' format table and the command line
come from the registry, and the engine names no language."""

from __future__ import annotations

import io
import re
import sys
import tokenize
from contextlib import redirect_stdout
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robocal as rc
from robocal.cli import main
from robocal.data.simulate import perturbed
from robocal.programs import dialect_for, filter_program
from robocal.programs.dialects.base import Dialect
from robocal.programs.model import IDENTITY, Program
from robocal.programs.registry import DIALECTS, dialect_named, dialects, format_table, register
from robocal.programs.target import Target

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import docs_hooks  # noqa: E402

_POINT = re.compile(r"^P (\w+) (.+)$", re.M)


class ToyDialect(Dialect):
    """A toy language: ``P name x y z rx ry rz`` (mm, rotation vector in deg) moves there."""

    key = "toy"
    name = "Toy"
    suffixes = (".toy",)
    signature = r"^P \w+ "
    frame_help = "x,y,z (mm),rx,ry,rz (deg, rotation vector)"

    def parse(self, sources, frames, tools, references=()):
        prog = Program([], frames={IDENTITY: np.eye(4), **frames}, tools={IDENTITY: np.eye(4), **tools})
        for src in sources:
            for m in _POINT.finditer(src.text):
                numbers = src.numbers_in(m.start(2), m.end(2))
                target = Target(src, m.start(), m.group(1), numbers)
                here = f"{src.path.name}:{src.line_of(m.start())}"
                prog.use(target, IDENTITY, IDENTITY, here, m.group(1), "frame", (src.path, m.start()),
                         prog.motion(src, m.start(), "P"))
        return prog

    def to_pose(self, values):
        values = np.asarray(values, float)
        T = np.tile(np.eye(4), (len(values), 1, 1))
        T[:, :3, :3] = Rotation.from_rotvec(np.deg2rad(values[:, 3:6])).as_matrix()
        T[:, :3, 3] = values[:, :3] * 1e-3
        return T

    def from_pose(self, T, old):
        rotvec = Rotation.from_matrix(T[:, :3, :3]).as_rotvec()
        return np.column_stack([T[:, :3, 3] * 1e3, np.rad2deg(rotvec)])

    def resolutions(self):
        return np.array([1e-3] * 3 + [1e-4] * 3)

    def mark(self, text, body, note):
        return f"# {note}\n{text}"


@pytest.fixture
def toy():
    register(ToyDialect)
    yield ToyDialect
    del DIALECTS["toy"]


def _toy_program(path: Path, nominal: rc.Robot) -> Path:
    q = np.deg2rad([[10, -20, 30, 5, 40, 15], [15, -25, 35, 0, 45, 10], [20, -15, 25, -5, 35, 20]])
    T = nominal.fk(q)
    rows = ToyDialect().from_pose(T, np.zeros((len(q), 6)))
    lines = [f"P p{i} " + " ".join(f"{v:.4f}" for v in row) + "\n" for i, row in enumerate(rows)]
    path.write_text("".join(lines))
    return path


def test_a_registered_toy_language_is_recognised_filtered_and_marked(toy, tmp_path):
    nominal = rc.Robot.from_catalog("abb_irb2600")
    program = _toy_program(tmp_path / "cell.toy", nominal)
    assert dialect_for([program]).name == "Toy"  # by its suffix
    assert dialect_named("toy").key == "toy" and "toy" in [d.key for d in dialects()]
    res = filter_program(program, perturbed(nominal, 0), nominal)
    assert res.dialect == "Toy" and res.summary_dict()["filtered"] == 3
    assert max(r["correction_mm"] for r in res.rows) > 0.01
    out = tmp_path / "cell_cal.toy"
    res.write(out)
    text = out.read_text()
    assert text.startswith("# robocal ") and text.count("\nP p") == 3 and text != program.read_text()
    with pytest.raises(rc.DataError, match="already filtered"):
        filter_program(out, perturbed(nominal, 0), nominal)
    # a toy file named as RAPID, without a Cartesian target RAPID reads: told by its signature
    named = tmp_path / "cell.mod"
    named.write_text(program.read_text())
    with pytest.raises(rc.DataError, match="looks like Toy, not ABB RAPID as its name says: give --format"):
        filter_program(named, perturbed(nominal, 0), nominal)


def test_the_docs_format_table_is_the_registry():
    table = format_table()
    assert [line.split("|")[1].strip(" `") for line in table.splitlines()[2:]] == list(DIALECTS)
    page = (ROOT / "docs" / "programs.md").read_text()
    assert docs_hooks.FORMATS_MARK in page
    assert table in docs_hooks.on_page_markdown(page, None, None, None)
    rows = page[page.index("| format | files | targets"):].split("\n\n")[0].splitlines()[2:]
    assert len(rows) == len(DIALECTS)  # the hand-written table: one row per language, its suffixes
    for d in dialects():
        row = next(r for r in rows if r.startswith(f"| {d.name} |"))
        assert all(s in row.split("|")[2].lower() for s in d.suffixes)


def test_poses_program_option_and_the_old_options_write_the_same(tmp_path):
    def run(*options: str, folder: str) -> dict[str, bytes]:
        out = tmp_path / folder
        out.mkdir()
        args = ["--quiet", "poses", "--robot", "abb_irb2600", "-n", "12", "--candidates", "300",
                "--starts", "1", "-o", str(out / "poses.csv")]
        with redirect_stdout(io.StringIO()):
            assert main(args + [o.replace("OUT", str(out)) for o in options]) == 0
        return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}

    old = run("--rapid", "OUT/c.mod", "--krl", "OUT/c.src", "--urscript", "OUT/c.script", "--val3", "OUT/cc",
              folder="old")
    new = run("--program", "rapid", "OUT/c.mod", "--program", "krl", "OUT/c.src", "--program", "urscript",
              "OUT/c.script", "--program", "val3", "OUT/cc", folder="new")
    assert old == new and {"c.mod", "c.src", "c.dat", "c.script", "cc/start.pgx"} <= set(new)


def _code(path: Path) -> str:
    """The code of ``path`` without comments and docstrings, lower case."""
    out, previous = [], None
    for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
        if tok.type == tokenize.COMMENT or (tok.type == tokenize.STRING and previous in (
                tokenize.INDENT, tokenize.NEWLINE, tokenize.NL, tokenize.DEDENT, None)):
            previous = tok.type if tok.type == tokenize.STRING else previous
            continue
        out.append(tok.string)
        if tok.type != tokenize.NL:
            previous = tok.type
    return " ".join(out).lower()


def test_only_the_registry_and_the_language_help_name_several_languages():
    languages = {"rapid": "rapid", "krl": "krl|kuka", "fanuc": "fanuc", "urscript": "urscript",
                 "inform": r"inform\b|yaskawa|jbi", "val3": "val3|staubli"}
    src = ROOT / "src" / "robocal"
    several = sorted(str(p.relative_to(src)) for p in src.rglob("*.py")
                     if sum(bool(re.search(r, _code(p))) for r in languages.values()) >= 2)
    assert several == ["programs/language_help.py", "programs/registry.py"]
