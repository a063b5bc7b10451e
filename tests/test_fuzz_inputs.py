"""Mutation fuzzing of the program readers (every dialect, their reference files) and the cell
files, with the byte-level changes editors and transfers make besides tests/fuzzing.py's text
mutations: a UTF-8 BOM, CRLF or lone-CR line ends, NUL bytes, bytes that are no UTF-8, huge
numbers, a line copied many times, a cell naming itself (tests/fuzzing.py `_encoding_op`). Each
mutant must end with exit 0 and every output written, or exit 2 and one line; never an internal
error, a traceback, a hang, a modified input or, refused, an output left behind (`fuzzing.check`).
The default run is seeded and small (a few hundred mutants); the slow one has thousands
(scripts/fuzz_readers.py --encodings runs any number)."""

from __future__ import annotations

import random

import pytest
from fuzzing import cell_file_readers, check, mutate, program_readers, run_case, same_whatever_the_bytes

READERS = ["rapid", "krl", "fanuc", "urscript", "inform", "fanuc_posreg", "inform_var", "inform_var_backup",
           "inform_var_program", "val3_s6", "rapid_rt", "krl_rt", "inform_cell", "cell_work", "cell_track"]
FAST = 24  # mutants per reader in the default suite (15 readers: 360)
SLOW = 400  # per reader in the slow run (6,000)
TIMEOUT_S = 30  # a mutant read longer than this is a hang
# Not a reader's: the FANUC provenance marker of a CR-only program is numbered 1 and LINE_COUNT is
# not raised (its line patterns anchor on LF: programs/dialects/fanuc/marker.py, the writers' part)
WRITER_CR = dict.fromkeys(["fanuc", "fanuc_posreg"], "FANUC marker in a CR-only file: numbered 1, LINE_COUNT "
                          "not raised (fanuc/marker.py anchors on LF)")


@pytest.fixture(scope="module")
def readers(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz_input_seeds")
    return {**program_readers(folder), **cell_file_readers(folder)}


def _fuzz(readers, folder, name: str, count: int, seed: int) -> list[str]:
    """The contract breaks of ``count`` seeded mutants of reader ``name`` (one line each)."""
    reader = readers[name]
    rng = random.Random(f"{seed}-{name}")
    problems = []
    for k in range(count):
        target, data = mutate(reader, rng, encodings=True)
        code, stderr = run_case(reader, target, data, folder / "case", timeout_s=TIMEOUT_S)
        problem = check(reader, target, data, folder / "case", code, stderr, no_partial=True)
        if problem:
            problems.append(f"{name} mutant {k} (seed {seed}, file {target}): {problem}")
    return problems


@pytest.mark.parametrize("name", READERS)
def test_reader_keeps_the_contract_on_byte_level_mutants(readers, tmp_path, name):
    problems = _fuzz(readers, tmp_path, name, FAST, seed=0)
    assert not problems, "\n".join(problems[:5])


@pytest.mark.parametrize("name", READERS)
def test_reader_reads_its_files_the_same_with_a_bom_or_other_line_ends(readers, tmp_path, name):
    """The metamorphic half of the fuzzing: a mutant that must read as its seed does (a VAR.DAT
    with a BOM was read as KRL: 0 motions, exit 0, which the contract alone passes)."""
    problems = same_whatever_the_bytes(readers[name], tmp_path)
    known = [p for p in problems if name in WRITER_CR and " with cr:" in p]
    assert not [p for p in problems if p not in known], "\n".join(problems[:5])
    if known:
        pytest.xfail(WRITER_CR[name])


@pytest.mark.slow
@pytest.mark.parametrize("name", READERS)
def test_reader_keeps_the_contract_on_many_byte_level_mutants(readers, tmp_path, name):
    problems = _fuzz(readers, tmp_path, name, SLOW, seed=1)
    assert not problems, "\n".join(problems[:5])


def test_the_mutations_make_what_they_say():
    """Every byte-level operator is drawn and does its change (a fuzzer that never made a BOM or a
    CR-only file would pass vacuously)."""
    from fuzzing import BOM, _encoding_op

    seed = b"units: {length: mm}\nrobot: a.yaml\nx: 12.5\n"
    made = [_encoding_op(seed, random.Random(k), [b"a.yaml", b"b.yaml"]) for k in range(400)]
    assert any(m.startswith(BOM) for m in made)
    assert any(BOM in m[1:] for m in made)
    assert any(b"\r\n" in m for m in made) and any(b"\r" in m and b"\r\n" not in m for m in made)
    assert any(b"\x00" in m for m in made) and any(b"\xff" in m or b"\xc3(" in m for m in made)
    assert any(b"9" * 400 in m or b"1e999" in m for m in made)
    assert any(b"b.yaml" in m for m in made) and any(m.count(b"\n") > 20 for m in made)
