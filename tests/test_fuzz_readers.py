"""Fuzzing every reader of the command line (bounded to about a minute): mutated measurement CSVs
of the four kinds, both import layouts, model YAML (three catalog forms and a saved model),
result JSON, URDF and five robot-program formats (INFORM with its TOOL.CND) must end with exit 0
and every output written, or exit 2 and one line; never an internal error (exit 3), a traceback,
a stray warning line or a modified input. The mutations and the contract are in tests/fuzzing.py;
the long run (10,000 mutants per reader) is scripts/fuzz_readers.py."""

from __future__ import annotations

import random

import pytest
from fuzzing import build_readers, check, mutate, run_case
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

READERS = ["csv_point", "csv_pose", "csv_plane", "csv_distance", "import_rows", "import_files",
           "model_abb_irb2600", "model_ur5", "model_puma560", "model_saved", "urdf", "result_json",
           "rapid", "krl", "fanuc", "urscript", "inform"]
EXAMPLES = {"result_json": 15, "urscript": 20, "fanuc": 20, "inform": 20}  # the slower readers (default 30)


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
