"""Campaign programs that drive a positioner with the arm (issue 45): RAPID (jointtarget extax with
ActUnit/DeactUnit), KRL (E6AXIS E1/E2), FANUC TP (a second motion group GP2 in every P[k]) and
INFORM (a station group RB1,ST1 with EC positions in pulses), each read back with robocal's own
program readers to the planned joints and the positioner's values; the languages that drive no
positioner, and bad units, refused."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import robocal as rc
from robocal.campaign.programs import campaign_programs
from robocal.core.errors import DataError
from robocal.programs.dialects.fanuc.reader import _GROUP, _POS
from robocal.programs.dialects.inform.reader import _read_positions
from robocal.programs.dialects.writing import ExternalAxes
from robocal.programs.model import Program
from robocal.programs.registry import dialect_named
from robocal.programs.source import ProgramText

ROBOT = rc.Robot.from_catalog("abb_irb2600")


def planned(n: int = 7, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Arm joints ``(n, 6)`` rad inside the limits and a tilt-and-turn table's values ``(n, 2)`` deg."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(ROBOT.limits[:, 0] * 0.8, ROBOT.limits[:, 1] * 0.8, (n, 6))
    e = np.column_stack([rng.uniform(-90, 90, n), rng.uniform(-360, 360, n)]).round(4)
    return q, e


def parsed(language: str, path) -> Program:
    """The program as robocal's reader of ``language`` reads it (no error: the text is valid for it)."""
    d = dialect_named(language)
    return d.parse([ProgramText(path)], {}, {}, [])


def _written(path: Path, language: str, unit: str, axes: tuple[str, str]):
    """The planned campaign (arm joints q, rad, (n, 6); table e, (n, 2)) written as ``language`` at
    ``path`` (every file it makes), the table driven as ``unit``'s ``axes``, and read back without
    error: (q, e, path, {file name: text})."""
    q, e = planned()
    texts = campaign_programs(q, ROBOT, {language: path}, external=ExternalAxes(e, unit, axes))
    for name, text in texts.items():
        (path.parent / name).write_text(text)
    parsed(language, path)
    return q, e, path, texts


def test_rapid_moves_the_unit_in_each_jointtarget(tmp_path):
    q, e, path, texts = _written(tmp_path / "Campaign.mod", "rapid", "STN1", ("eax_b", "eax_c"))
    text = texts[str(path)]
    targets = {m.group(1): (np.array(m.group(2).split(","), float), m.group(3).split(","))
               for m in re.finditer(r"CONST jointtarget (\w+) := \[\[([^\]]*)\],\[([^\]]*)\]\]", text)}
    order = re.findall(r"MoveAbsJ (\w+)\\NoEOffs", text)
    np.testing.assert_allclose([targets[k][0] for k in order], np.rad2deg(q), atol=1e-9)
    extax = np.array([targets[k][1] for k in order])
    np.testing.assert_array_equal(extax[:, [0, 3, 4, 5]], "9E9")
    np.testing.assert_allclose(extax[:, 1:3].astype(float), e, atol=1e-9)
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if "MoveAbsJ" in line)
    last = max(i for i, line in enumerate(lines) if "MoveAbsJ" in line)
    assert lines.index("        ActUnit STN1;") < first and lines.index("        DeactUnit STN1;") > last


def test_krl_declares_e6axis_with_e1_e2(tmp_path):
    q, e, path, texts = _written(tmp_path / "campaign.src", "krl", "EASYS", ("E1", "E2"))
    dat = texts[str(path.with_suffix(".dat"))]
    declared = {}
    for m in re.finditer(r"DECL E6AXIS (\w+)=\{([^}]*)\}", dat):
        declared[m.group(1)] = dict(item.split() for item in m.group(2).split(","))
    order = re.findall(r"^\s+PTP (\w+)", texts[str(path)], flags=re.M)
    assert len(order) == len(q) and "DECL AXIS" not in dat
    np.testing.assert_allclose([[float(declared[k][f"A{i}"]) for i in range(1, 7)] for k in order],
                               np.rad2deg(q), atol=1e-9)
    np.testing.assert_allclose([[float(declared[k]["E1"]), float(declared[k]["E2"])] for k in order], e,
                               atol=1e-9)


def test_fanuc_positions_carry_group_two(tmp_path):
    q, e, path, texts = _written(tmp_path / "campaign.ls", "fanuc", "GP2", ("E1", "E2"))
    text = texts[str(path)]
    assert "DEFAULT_GROUP\t= 1,1,*,*,*;" in text
    arm, table = [], []
    for m in _POS.finditer(text):  # the reader's own position pattern, split by its group pattern
        groups = dict(zip(_GROUP.findall(m.group(3)), _GROUP.split(m.group(3))[2::2], strict=True))
        values = {g: [float(v) for v in re.findall(r"J\d= (-?[\d.]+) (?:deg|mm)", body)]
                  for g, body in groups.items()}
        arm.append(values["1"])
        table.append(values["2"])
    expected = np.rad2deg(q)
    expected[:, 2] += expected[:, 1]  # FANUC's J3
    np.testing.assert_allclose(arm, expected, atol=1e-4)
    np.testing.assert_allclose(table, e, atol=1e-4)


def test_inform_job_moves_the_station_in_pulses(tmp_path):
    q, e = planned()
    path = tmp_path / "CAMPAIGN.JBI"
    ratio = (1000.0, 800.0)  # pulses per degree
    text = campaign_programs(q, ROBOT, {"inform": path},
                             external=ExternalAxes(e, "ST1", ("E1", "E2"), pulses_per_unit=ratio))[str(path)]
    path.write_text(text, newline="")
    prog = parsed("inform", path)
    assert not [w for w in prog.warnings if "NPOS" in w]
    positions = _read_positions(ProgramText(path), Program([]))
    robot_pos = [p for p in positions if p.kind == "C"]
    station = np.array([[float(n.text) for n in p.numbers] for p in positions if p.kind == "EC"])
    d = dialect_named("inform")
    poses = d.to_pose(np.array([[float(n.text) for n in p.numbers] for p in robot_pos]))
    np.testing.assert_allclose(poses[:, :3, 3], ROBOT.fk(q)[:, :3, 3], atol=1e-6)  # 3 decimals of mm
    np.testing.assert_allclose(station / ratio, e, atol=0.5 / min(ratio))
    assert "///GROUP1 RB1,ST1" in text
    assert re.findall(r"MOVJ C(\d{5}) EC(\d{5})", text) == [(f"{k:05d}", f"{k:05d}") for k in range(len(q))]


@pytest.mark.parametrize("programs, external, message", [
    ({"urscript": "c.script"}, ExternalAxes(np.zeros((7, 2)), "STN1", ("E1", "E2")),
     "do not drive a positioner"),
    ({"inform": "C.JBI"}, ExternalAxes(np.zeros((7, 2)), "ST1", ("E1", "E2")), "pulses per degree"),
    ({"fanuc": "c.ls"}, ExternalAxes(np.zeros((7, 2)), "STN1", ("E1", "E2")), "motion group GP2"),
    ({"rapid": "C.mod"}, ExternalAxes(np.zeros((7, 2)), "STN1", ("E1", "E2")), "not a RAPID external axis"),
    ({"krl": "c.src"}, ExternalAxes(np.zeros((5, 2)), "EASYS", ("E1", "E2")), "5 rows"),
])
def test_programs_that_cannot_drive_the_positioner_are_refused(programs, external, message, tmp_path):
    q, _ = planned()
    with pytest.raises(DataError, match=message):
        campaign_programs(q, ROBOT, {k: tmp_path / v for k, v in programs.items()}, external=external)


def test_external_axes_are_checked():
    with pytest.raises(DataError, match="2 axes' values but 1 axis letters"):
        ExternalAxes(np.zeros((3, 2)), "STN1", ("eax_b",))
    with pytest.raises(DataError, match="not a valid identifier"):
        ExternalAxes(np.zeros((3, 1)), "STN 1", ("eax_b",))
    with pytest.raises(DataError, match="given twice"):
        campaign_programs(np.zeros((3, 6)), ROBOT, {"rapid": "C.mod"},
                          external=ExternalAxes(np.zeros((3, 2)), "STN1", ("eax_b", "EAX_B")))
