"""``robocal poses --model CELL.yaml`` and ``campaign.plan_cell`` (issue 45): one planned file with
the body column and the positioner's columns, each body's plan as planned alone, the campaign
program carrying both the arm's joints and the positioner's values, and bad input refused with
nothing written."""

from __future__ import annotations

import csv
import json
import re

import numpy as np
import pytest

import robocal as rc
from robocal.campaign import Constraints, Tracker, plan_cell
from robocal.cli import main
from robocal.core.errors import DataError
from robocal.programs.registry import dialect_named

CELL = """units: {length: mm, angle: deg}
name: welding cell
robot: abb_irb2600
positioner:
  unit: STN1
  mount: {xyz: [1400, 0, 0], rpy: [0, 0, 0]}
  axes: [{type: revolute, axis: [1, 0, 0], origin: [0, 0, 900], limits: [-90, 90]},
         {type: revolute, axis: [0, 0, 1], origin: [0, 0, 250], limits: [-360, 360]}]
  plate: {xyz: [0, 0, 0], rpy: [0, 0, 0]}
%s  columns: [e1, e2]
  external_axes: [2, 3]
"""
NESTS = "  nests: [[200, 0, 0], [0, 200, 0], [-150, -150, 0]]\n"
TRACKER_MM = "1200,2800,2000"  # on the tilt side, above the plate


@pytest.fixture(scope="module")
def cell_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("cell") / "cell.yaml"
    path.write_text(CELL % NESTS)
    return path


@pytest.fixture(scope="module")
def planned(cell_file):
    d = cell_file.parent
    args = ["--quiet", "poses", "--model", str(cell_file), "-n", "20", "--table-poses", "18", "--smr-mm",
            "20,-30,80", "--tracker-mm", TRACKER_MM, "--acceptance-deg", "45", "--candidates", "1200",
            "--starts", "1", "-o", str(d / "poses.csv"), "--json", str(d / "c.json"),
            "--rapid", str(d / "Campaign.mod")]
    assert main(args) == 0
    return d


def read_rows(path) -> tuple[list[str], list[list[str]]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def test_one_file_holds_the_arm_rows_then_the_table_rows(planned):
    header, rows = read_rows(planned / "poses.csv")
    assert header[:9] == ["body", *(f"q{i}_deg" for i in range(1, 7)), "e1_deg", "e2_deg"]
    assert header[9:] == [f"visible_smr{k}" for k in range(4)]
    bodies = [r[0] for r in rows]
    assert bodies == ["arm"] * 20 + ["STN1"] * 18
    values = np.array([[float(v) for v in r[1:9]] for r in rows])
    seen = np.array([[int(v) for v in r[9:]] for r in rows], bool)
    np.testing.assert_array_equal(values[:20, 6:], 0.0)  # the table at rest while the arm is measured
    np.testing.assert_array_equal(values[20:, :6], np.tile(values[19, :6], (18, 1)))  # the arm stays put
    assert seen[:20, 0].all() and not seen[:20, 1:].any()  # the arm's one SMR
    assert not seen[20:, 0].any() and seen[20:, 1:].any(axis=1).all()  # nests 1..3, never the plate origin
    campaign = json.loads((planned / "c.json").read_text())
    table = campaign["positioners"]["STN1"]
    np.testing.assert_allclose(table["joints_deg"], values[20:, 6:], atol=1e-9)
    assert table["nests_known"] and table["predicted_rms_mm"] > 0
    assert campaign["arms"]["arm"]["n_poses"] == 20
    assert set(campaign["identifiability"]) == {"arm", "STN1"}


def test_the_program_moves_the_arm_and_the_table_through_the_file(planned):
    text = (planned / "Campaign.mod").read_text()
    _, rows = read_rows(planned / "poses.csv")
    targets = {m.group(1): (m.group(2).split(","), m.group(3).split(","))
               for m in re.finditer(r"CONST jointtarget (\w+) := \[\[([^\]]*)\],\[([^\]]*)\]\]", text)}
    order = re.findall(r"MoveAbsJ (\w+)\\NoEOffs", text)
    assert len(order) == len(rows)
    arm = np.array([[float(v) for v in targets[k][0]] for k in order])
    extax = np.array([targets[k][1] for k in order])
    np.testing.assert_allclose(arm, [[float(v) for v in r[1:7]] for r in rows], atol=1e-9)
    table = [[float(v) for v in r[7:9]] for r in rows]
    np.testing.assert_allclose(extax[:, 1:3].astype(float), table, atol=1e-9)
    assert "ActUnit STN1;" in text and "DeactUnit STN1;" in text


def test_the_plan_per_body_is_each_body_planned_alone(cell_file):
    cell = rc.load_cell(cell_file)
    tracker = Tracker(position=[1.2, 2.8, 2.0], acceptance_deg=45)
    plan = plan_cell(cell, {"flange": 15}, {"plate": 12}, constraints=Constraints(tracker=tracker),
                     smr={"arm": [[0.02, -0.03, 0.08]]}, n_candidates=600, table_candidates=600, starts=1)
    alone = rc.plan_poses(cell.arms["arm"], 15, constraints=Constraints(tracker=tracker),
                          smr=[[0.02, -0.03, 0.08]], n_candidates=600, starts=1)
    np.testing.assert_array_equal(plan.arms["arm"].joints, alone.joints)
    assert plan.tables["STN1"].n == 12 and "positioner STN1 (STN1):" in plan.summary()
    q, external = plan.program_joints()
    assert q.shape == (27, 6) and external.unit == "STN1" and external.external_axes == (2, 3)
    assert external.in_language(dialect_named("rapid")).axes == ("eax_b", "eax_c")
    np.testing.assert_allclose(np.deg2rad(external.values[15:]), plan.tables["STN1"].joints, atol=1e-12)


def test_a_positioner_without_nests_needs_their_approximate_places(tmp_path, capsys):
    path = tmp_path / "cell.yaml"
    path.write_text(CELL % "")
    out = tmp_path / "poses.csv"
    base = ["poses", "--model", str(path), "-n", "15", "--smr-mm", "20,-30,80", "--tracker-mm", TRACKER_MM,
            "--acceptance-deg", "45", "--candidates", "600", "--starts", "1", "-o", str(out)]
    assert main(base) == 2
    assert "declares no nests" in capsys.readouterr().err and not out.exists()
    nests = ["--nest-mm", "200,0,0", "--nest-mm", "0,200,0", "--nest-mm=-150,-150,0"]
    assert main(["--quiet", *base, *nests]) == 0
    printed = capsys.readouterr().out
    assert "nests at unknown plate positions" in printed and "theta2" in printed


@pytest.mark.parametrize("extra, message", [
    (["--html", "c.html"], "--model plans a cell"),
    (["--urscript", "c.script"], "do not drive a positioner"),
    (["--inform", "C.JBI"], "station ST1"),
])
def test_bad_cell_input_is_refused_and_nothing_is_written(cell_file, tmp_path, capsys, extra, message):
    out = tmp_path / "poses.csv"
    args = ["poses", "--model", str(cell_file), "-n", "15", "--smr-mm", "20,-30,80", "--tracker-mm",
            TRACKER_MM, "--acceptance-deg", "45", "--candidates", "600", "--starts", "1", "-o", str(out)]
    extra = [tmp_path / v if "." in v else v for v in extra]
    assert main([*args, *map(str, extra)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())


def test_a_body_planned_as_the_wrong_kind_is_refused(cell_file):
    cell = rc.load_cell(cell_file)
    with pytest.raises(DataError, match="is a positioner"):
        plan_cell(cell, {"STN1": 10}, {})
    with pytest.raises(DataError, match="is an arm"):
        plan_cell(cell, {}, {"arm": 10})


def test_the_planned_file_measured_on_a_true_cell_calibrates_as_predicted(cell_file):
    """The planned rows, read at a simulated true cell (the cell simulation's own truth draw; the
    tracker frame the world's) and written as the cell's measurement file (each visible SMR's
    reading appended), are read by the cell data layer to the planned joints and calibrated by
    ``rc.calibrate``: the positioner's model error at held-out table angles is what the plan
    predicted (ratio within sampling: one truth, 72 readings)."""
    from robocal.data.cell_measurements import CellMeasurements
    from robocal.data.cell_simulation import true_cell

    cell = rc.load_cell(cell_file)
    tracker = Tracker(position=[1.2, 2.8, 2.0], acceptance_deg=45)
    plan = plan_cell(cell, {"arm": 30}, {"STN1": 24}, constraints=Constraints(tracker=tracker),
                     smr={"arm": [[0.02, -0.03, 0.08]]}, n_candidates=1000, table_candidates=1000, starts=1)
    truth = true_cell(cell, 7)
    truth = truth.__class__(arms={"arm": truth.arms["arm"].with_frames(tool=plan.arms["arm"].robot.tool)},
                            positioners=truth.positioners, name=truth.name)
    rng = np.random.default_rng(8)
    text = plan.poses_csv().splitlines()
    header, rows = text[0].split(","), list(csv.reader(text[1:]))
    lines = [",".join([*header[:9], "smr", "x_mm", "y_mm", "z_mm"])]
    for r, (body, i) in zip(rows, plan.rows(), strict=True):
        for k in np.flatnonzero(np.array(r[9:], int)):
            q = (plan.arms if body == "arm" else plan.tables)[body].joints[i][None]
            p = truth.body(body).fk(q, smr=[k if body == "STN1" else 0])[0, :3, 3] + rng.normal(0.0, 2e-5, 3)
            lines.append(",".join([*r[:9], str(k), *(f"{v * 1e3:.6f}" for v in p)]))
    data = CellMeasurements.parse("\n".join(lines) + "\n", cell, "measured.csv")
    np.testing.assert_allclose(np.unique(data["STN1"].joints, axis=0),
                               np.unique(np.round(plan.tables["STN1"].joints, 12), axis=0), atol=1e-9)
    result = rc.calibrate(cell, data, nongeometric=None)
    model, real = result.in_tracker["STN1"], truth.positioners["STN1"].chain
    e = np.deg2rad(rng.uniform([-89, -179], [89, 179], (400, 2)))
    nests = cell.positioners["STN1"].nests
    smr = np.repeat(np.arange(1, len(nests) + 1), len(e))
    e = np.tile(e, (len(nests), 1))
    err = model.fk(e, smr=smr)[:, :3, 3] - real.fk(e, smr=smr)[:, :3, 3]
    rms_mm = float(np.sqrt(np.mean(np.sum(err**2, axis=1)))) * 1e3
    predicted = plan.tables["STN1"].predicted_rms_mm
    assert 0.4 < rms_mm / predicted < 2.5, (rms_mm, predicted)


def test_a_parked_arm_in_the_beam_hides_nests_from_the_table_plan(cell_file):
    """With the tracker's arm radius, the table's angles are planned with the parked arm's axis lines
    blocking the beam: every nest the plan counts as seen is clear of them, and some angles lose nests
    the tracker would otherwise see."""
    from robocal.campaign.cell import _axis_lines
    from robocal.campaign.positioner import nest_visibility

    cell = rc.load_cell(cell_file)
    tracker = Tracker(position=[1.2, 2.8, 2.0], acceptance_deg=45, arm_radius_m=0.15)
    park = np.deg2rad([35.0, 35.0, -40.0, 0.0, 0.0, 0.0])  # the forearm raised into the beam's way
    plan = plan_cell(cell, {}, {"STN1": 12}, constraints=Constraints(tracker=tracker), park={"arm": park},
                     table_candidates=500, starts=1)
    table = plan.tables["STN1"]
    nests, normals = cell.positioners["STN1"].nests, np.tile([0.0, 0.0, 1.0], (3, 1))
    obstacles = _axis_lines(cell.arms["arm"], park)
    blocked = nest_visibility(table.chain, table.joints, nests, normals, tracker, obstacles)
    np.testing.assert_array_equal(table.visible, blocked)
    assert "the beam clear of the parked arms" in table.funnel.text()
    q = np.deg2rad(np.c_[np.linspace(-89, 89, 60), np.zeros(60)])
    assert nest_visibility(table.chain, q, nests, normals, tracker, obstacles).sum() < \
        nest_visibility(table.chain, q, nests, normals, tracker).sum()
    np.testing.assert_array_equal(plan.park["arm"], park)


def test_each_language_names_the_table_axes_its_own_way(tmp_path):
    """One cell file (external_axes [2, 3]; unit GP2), three programs: RAPID's extax b and c, KRL's
    E2 and E3 (`Dialect.positioner_axes`), FANUC's motion group GP2 with its own J1 and J2."""
    path = tmp_path / "cell.yaml"
    path.write_text((CELL % NESTS).replace("unit: STN1", "unit: GP2"))
    cell = rc.load_cell(path)
    plan = plan_cell(cell, {"arm": 12}, {"GP2": 10}, constraints=Constraints(tracker=Tracker(
        position=[1.2, 2.8, 2.0], acceptance_deg=45)), smr={"arm": [[0.02, -0.03, 0.08]]},
        n_candidates=400, table_candidates=400, starts=1)
    files = {"rapid": tmp_path / "C.mod", "krl": tmp_path / "c.src", "fanuc": tmp_path / "c.ls"}
    texts = plan.programs(files)
    e = np.rad2deg(plan.tables["GP2"].joints[-1])
    last_krl = re.findall(r"DECL E6AXIS XP22=\{([^}]*)\}", texts[str(tmp_path / "c.dat")])[0]
    krl = dict(item.split() for item in last_krl.split(","))
    np.testing.assert_allclose([float(krl["E2"]), float(krl["E3"])], e, atol=1e-9)
    assert "E1" not in krl
    rapid = re.findall(r"jt22 := \[\[[^\]]*\],\[([^\]]*)\]\]", texts[str(files["rapid"])])[0].split(",")
    np.testing.assert_allclose([float(rapid[1]), float(rapid[2])], e, atol=1e-9)
    fanuc = texts[str(files["fanuc"])].split("P[22]{")[1]
    group = re.findall(r"GP2:\s*UF : 0, UT : 0,\s*J1= (\S+) deg,\s*J2= (\S+) deg", fanuc)[0]
    np.testing.assert_allclose([float(v) for v in group], e, atol=1e-4)


def test_the_cell_plan_and_the_table_plan_keep_the_result_protocol(cell_file, tmp_path):
    """summary(), warnings (a list), to_dict() (plain JSON) and write() as every result has them."""
    from pathlib import Path

    plan = plan_cell(rc.load_cell(cell_file), {}, {"STN1": 10}, constraints=Constraints(
        tracker=Tracker(position=[1.2, 2.8, 2.0], acceptance_deg=45)), table_candidates=300, starts=1)
    for result, write in ((plan, lambda r: r.write(tmp_path / "p.csv", tmp_path / "p.json")),
                          (plan.tables["STN1"], lambda r: r.write(tmp_path / "t.json"))):
        assert isinstance(result.summary(), str) and result.summary()
        assert isinstance(result.warnings, list)
        json.dumps(result.to_dict(), allow_nan=False)
        assert all(Path(p).is_file() for p in write(result))
