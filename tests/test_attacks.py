"""Injection into outputs through a model's name (tests/attacks.py): every writer's output keeps
the structure it has with a harmless name, or the command refuses in one line. A seeded sample in
the default suite, every hostile name in the slow run (``python tests/attacks.py``)."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import pytest
from attacks import HOSTILE, attack, cli, model_with_name

import robocal as rc
from robocal.kinematics.urdf import to_urdf

FAST = ["a\x00b", "a\nb", "a]]>b", "<script>alert(1)</script>"]


@pytest.mark.parametrize("name", ["a\x00b", "a\x1b[31mb", "a\x0bb\x0cc"])
def test_a_control_character_in_a_name_leaves_the_urdf_well_formed(tmp_path, name):
    """``export --urdf`` of a model named with a control character wrote, exit 0, a URDF no XML
    parser reads (XML 1.0 holds no such character, not even as a reference)."""
    model = model_with_name(tmp_path, name)
    code, _, err = cli(["--quiet", "export", model, "--urdf", tmp_path / "m.urdf"])
    assert code == 0, err
    assert "?" in ET.parse(tmp_path / "m.urdf").getroot().get("name")


def test_a_name_with_a_line_end_reads_back_from_the_urdf():
    robot = dataclasses.replace(rc.Robot.from_catalog("ur5e"), name="line one\nline two\tand a tab")
    assert ET.fromstring(to_urdf(robot)).get("name") == robot.name


@pytest.mark.parametrize("name", FAST)
def test_hostile_names_keep_every_output_whole(tmp_path, name):
    assert not attack(tmp_path, name)


@pytest.mark.slow
@pytest.mark.parametrize("name", [h for h in HOSTILE if h not in FAST])
def test_every_hostile_name_keeps_every_output_whole(tmp_path, name):
    assert not attack(tmp_path, name)
