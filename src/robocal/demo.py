"""The whole pipeline on the campaign shipped with the package (``robocal demo``).

A simulated laser-tracker campaign on an ABB IRB 2600 (see scripts/make_demo_data.py):
identifiability -> lsq and robust calibration -> validation on held-out poses -> comparison
with the known truth -> compensated joint commands -> a globally optimal joint path -> the
calibrated model, the result JSON and the HTML report written to ``out_dir``.
"""

from __future__ import annotations

import functools
from importlib.resources import files
from pathlib import Path

import numpy as np

from robocal.calibration.pipeline import calibrate
from robocal.calibration.result import json_text
from robocal.core.errors import DataError
from robocal.core.io import write_all, write_atomic
from robocal.data.measurements import Measurements
from robocal.deploy.compensation import compensate
from robocal.ik import plan_path
from robocal.kinematics.model import Robot
from robocal.kinematics.model_file import dump_model
from robocal.report.html import render_report


def demo_files() -> dict[str, Path]:
    root = files("robocal") / "demo_data"
    return {name: Path(str(root / f"{name}.{ext}")) for name, ext in
            (("calibration", "csv"), ("validation", "csv"), ("truth", "yaml"))}


@functools.cache
def samples() -> dict[str, str]:
    """The small files the how-to pages start from (``robocal sample NAME``): name -> what it is
    (``demo_data/samples.tsv``, the list being data: it names programs of every language)."""
    text = (files("robocal") / "demo_data" / "samples.tsv").read_text(encoding="utf-8")
    rows = (line.split("\t", 1) for line in text.splitlines() if line and not line.startswith("#"))
    return {name: what for name, what in rows}


def sample_path(name: str) -> Path:
    """The path of a small sample file shipped with robocal, the files the how-to pages start from
    (``robocal sample NAME`` copies one into the current folder).

    Parameters
    ----------
    name : str
        One of `samples` (``robocal sample`` lists them): ``"weld_cell.mod"``,
        ``"calibration.conf"``, ``"tracker_export.txt"``...

    Returns
    -------
    pathlib.Path
        The file inside the installed package: read it or copy it, do not edit it.

    Raises
    ------
    DataError
        ``name`` is not a sample (the message lists them).

    See Also
    --------
    rc.filter_program : filter a sample program (``weld_cell.mod``) with a calibration
    rc.Measurements : read a sample measurement file

    Examples
    --------
    >>> import robocal as rc
    >>> rc.sample_path("weld_cell.mod").name
    'weld_cell.mod'
    """
    if name not in samples():
        raise DataError(f"no sample named {name!r}: the samples are {', '.join(samples())}")
    return Path(str(files("robocal") / "demo_data" / name))


def copy_sample(name: str, destination: Path) -> Path:
    """Copy the sample ``name`` to ``destination`` (a file, or a folder to copy it into under its
    name), atomically; an existing file is never overwritten. Returns the written path."""
    target = destination / name if destination.is_dir() else destination
    if target.exists():
        raise DataError(f"{target} exists: robocal does not overwrite it (remove it or name another file)")
    write_atomic(target, sample_path(name).read_bytes())
    return target


def _line(text: str = "") -> None:
    print(text)


def run_demo(out_dir: Path, quiet: bool = False) -> dict[str, Path]:
    """Run the pipeline, print what happens, write the outputs; returns their paths."""
    paths = demo_files()
    nominal = Robot.from_catalog("abb_irb2600")
    cal = Measurements.load(paths["calibration"], robot=nominal)
    val = Measurements.load(paths["validation"], robot=nominal)
    truth = Robot.load(paths["truth"])
    _line(f"robot: {nominal.description}")
    _line(f"data:  {cal.n_poses} calibration poses (with gross outliers), {val.n_poses} validation poses "
          f"— {cal.source}")

    results = {}
    for method in ("lsq", "robust"):
        results[method] = calibrate(nominal, cal, method=method, validation=val, progress=not quiet)
    robust = results["robust"]
    _line("\nidentifiability of this pose set")
    _line("  " + robust.identifiability.summary().replace("\n", "\n  "))
    _line("\nposition error, mm          calibration RMS  ->  after     validation RMS  ->  after")
    for method, res in results.items():
        after = res.after_inliers or res.after
        _line(f"  {method:<8} {res.before['rms']:>22.4f} {after['rms']:>10.4f} "
              f"{res.validation_before['rms']:>18.4f} {res.validation['rms']:>10.4f}"
              + (f"   ({len(res.rejected)} rejected observations left out)" if len(res.rejected) else ""))
    chosen = robust.model_selection
    if chosen is not None:
        terms = ", ".join(chosen["chosen_terms"]) or "geometric"
        _line(f"  joint-error model chosen by cross-validation on the calibration data: {terms} "
              f"(of {len(chosen['candidates'])} candidates)")
    q_val = val.joints
    model_vs_truth = np.linalg.norm(robust.robot.fk(q_val)[:, :3, 3] - truth.fk(q_val)[:, :3, 3], axis=1)
    _line(f"  robust model vs the true robot on the validation poses: RMS "
          f"{np.sqrt(np.mean(model_vs_truth**2)) * 1e3:.4f} mm (the rest of the validation RMS is "
          "tracker noise)")

    # compensation: the controller's model (nominal links, registered frames) vs the calibrated one
    controller = robust.start
    targets = controller.fk(q_val[:50])
    comp = compensate(robust.robot, controller, targets)
    reached = truth.fk(comp.joints)[:, :3, 3]
    uncompensated = truth.fk(q_val[:50])[:, :3, 3]

    def rms(a):
        return np.sqrt(np.mean(np.sum((a - targets[:, :3, 3]) ** 2, axis=1))) * 1e3

    _line(f"\ncompensation of {len(targets)} Cartesian targets (true robot's position error, RMS):")
    _line(f"  nominal joint commands     {rms(uncompensated):.4f} mm")
    _line(f"  compensated joint commands {rms(reached):.4f} mm")

    # seed 001: a joint-space sweep whose poses have up to 8 IK branches each; the greedy
    # nearest-branch choice from the start commits to a branch that costs far more travel later
    s = np.linspace(0, 1, 60)[:, None]
    q_from, q_to = np.array([-153, -21, -154, -165, 12, -114]), np.array([-145, 122, -134, -146, 108, 60])
    q_line = np.deg2rad(q_from * (1 - s) + q_to * s)
    path = plan_path(nominal, nominal.fk(q_line))
    _line(f"\njoint path over {len(q_line)} waypoints (Dijkstra over all IK branches): "
          f"weighted travel {path.cost:.2f}; the greedy nearest-branch choice: {path.greedy_cost:.2f} "
          f"({path.greedy_cost / path.cost:.1f}x)")

    out_dir.mkdir(parents=True, exist_ok=True)
    outputs = {"model": out_dir / "calibrated.yaml", "json": out_dir / "result.json",
               "report": out_dir / "report.html"}
    content = robust.to_dict()
    write_all({outputs["model"]: dump_model(robust.robot), outputs["json"]: json_text(content),
               outputs["report"]: render_report(content,
                                                title="robocal demo: ABB IRB 2600, robust calibration")})
    _line("")
    for label, path_ in outputs.items():
        _line(f"wrote {label:<6} {path_}")
    _line(f"open the report: {outputs['report'].resolve()}")
    return outputs
