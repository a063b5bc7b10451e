"""`UrdfLikeExport.write` checks what `robocal export --urdf-like -o` checks (the API knows what
the command line knows): the output named for a URDF, never one of the vendor's files."""

from __future__ import annotations

from pathlib import Path

import pytest

import robocal as rc
from robocal.kinematics.urdf import to_urdf


def test_write_refuses_another_format_and_the_vendor_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    nominal = rc.Robot.from_catalog("kuka_kr16_2")
    Path("kr16_2.urdf").write_text(to_urdf(nominal, frames="robot"))
    before = Path("kr16_2.urdf").read_bytes()
    out = rc.export_urdf_like(nominal.with_values({"a2": nominal.get("a2") + 5e-4}), "kr16_2.urdf")
    with pytest.raises(rc.DataError, match="writes URDF, but the name says YAML"):
        out.write("kr16_2_cal.yaml")
    with pytest.raises(rc.DataError, match="one of this command's input files"):
        out.write("kr16_2.urdf")
    assert Path("kr16_2.urdf").read_bytes() == before and not Path("kr16_2_cal.yaml").exists()
    assert out.write("kr16_2_cal.urdf") == ["kr16_2_cal.urdf"]


def test_the_api_refuses_writing_over_the_model_file(tmp_path, monkeypatch):
    """What `robocal export --urdf-like` refused, the API refuses too: the output is the calibrated
    model's own file (a YAML model saved without a suffix, which the format check lets through), at
    export (before any work) and at write."""
    monkeypatch.chdir(tmp_path)
    nominal = rc.Robot.from_catalog("kuka_kr16_2")
    Path("kr16_2.urdf").write_text(to_urdf(nominal, frames="robot"))
    nominal.with_values({"a2": nominal.get("a2") + 5e-4}).save("calibrated")
    before = Path("calibrated").read_bytes()
    with pytest.raises(rc.DataError, match="one of this command's input files"):
        rc.export_urdf_like("calibrated", "kr16_2.urdf", output="calibrated")
    out = rc.export_urdf_like("calibrated", "kr16_2.urdf")
    with pytest.raises(rc.DataError, match="one of this command's input files"):
        out.write("calibrated")
    assert Path("calibrated").read_bytes() == before
