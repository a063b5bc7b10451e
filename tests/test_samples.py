"""The sample files the how-to pages start from (``robocal sample``, ``rc.sample_path``): each one
shipped, small, copied as it is, never over an existing file."""

from __future__ import annotations

import pytest

import robocal as rc
from robocal.cli import main
from robocal.demo import samples

MAX_SAMPLE_BYTES = 50_000  # small sample data, not data sets


def test_every_sample_is_shipped_and_small():
    for name in samples():
        path = rc.sample_path(name)
        assert path.is_file() and 0 < path.stat().st_size <= MAX_SAMPLE_BYTES, name
    with pytest.raises(rc.DataError, match="no sample named 'nope'.*weld_cell.mod"):
        rc.sample_path("nope")


def test_the_command_lists_copies_and_never_overwrites(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["sample"]) == 0
    listing = capsys.readouterr().out
    assert all(name in listing for name in samples())
    assert main(["sample", "weld_cell.mod", "TOOL.CND"]) == 0
    assert (tmp_path / "weld_cell.mod").read_bytes() == rc.sample_path("weld_cell.mod").read_bytes()
    assert main(["sample", "calibration.conf", "-o", "ur5e.conf"]) == 0
    assert (tmp_path / "ur5e.conf").read_bytes() == rc.sample_path("calibration.conf").read_bytes()
    (tmp_path / "weld_cell.mod").write_text("the user's own file")
    assert main(["sample", "weld_cell.mod"]) == 2
    assert "exists" in capsys.readouterr().err
    assert (tmp_path / "weld_cell.mod").read_text() == "the user's own file"
    assert main(["sample", "weld_cell.mod", "TOOL.CND", "-o", "x"]) == 2
    assert main(["sample", "nope"]) == 2
