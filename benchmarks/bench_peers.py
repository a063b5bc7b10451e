"""robocal's default calibration against FIGAROH (the open-source peer) on FIGAROH's own example
data (TALOS, TIAGo within a session and the next day, UR10 with a camera, MATE), both on the same
fixed split (``benchmarks/peer_sets.py``), held-out position error in mm, measured in one run.

``python benchmarks/bench_peers.py [--data DIR] [--only NAME] [--robocal-only] [--liao DIR]
[--splits K]``. The data folder holds FIGAROH's repositories (``--data``, else
``$ROBOCAL_FIGAROH_DATA``, else the download cache ``~/.cache/robocal/figaroh``, filled when
online); without it the benchmark says why and skips.
FIGAROH itself is the optional ``peers`` extra (``pip install robocal[peers]``); without it the
FIGAROH rows are skipped with the reason.

robocal runs what ``robocal calibrate CAL.csv --robot MODEL.urdf --validate HELD.csv`` runs:
``rc.calibrate(robot, cal, validation=held)`` with every default. FIGAROH runs its example's
calibration class (``TALOSCalibration``, ``TiagoCalibration``, ``UR10Calibration``; the generic
``BaseCalibration`` where the example's class does not import with FIGAROH 1.0: MATE, UR10) with
the example folder's configuration (its legacy file converted by FIGAROH's own
``figaroh.utils.config_migration``, the data file pointed at the split's calibration poses, one
marker entry per marker of the set) and the example's ``solve`` arguments. Both are judged alike:
the held-out markers predicted by each calibrated model in its fitted measurement frame, against
the measured ones (3-D distance per marker and pose: RMS, mean, max); for the next-day set the
frame is fitted again (rigid motion only) on the judging session for both.

With ``--splits K`` (default 1, or ``$ROBOCAL_PEER_SPLITS``: what ``benchmarks/run.py peers``
records) each set is also run on its first K fixed splits (``peer_sets.py``: split 0 the default,
then random thirds with fixed seeds; the next-day set has two, one per calibrating day), both tools
on each, and a second table gives per set the mean and spread (sample standard deviation) over
the splits of the held-out RMS of robocal's default, of FIGAROH and of the nominal model with
its frame registered on the calibration poses, and the number of splits robocal wins (its RMS at
or below FIGAROH's).

Without ``--only`` it also measures robocal's default on the IRB 120 campaign published with
Wu et al. 2015 (``benchmarks/liao_irb120.py``: ``--liao DIR`` or ``$ROBOCAL_LIAO_DATA``) on the
paper's 40 test points, beside the paper's own published figures.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import liao_irb120  # noqa: E402
import peer_sets as ps  # noqa: E402
from results import table  # noqa: E402

import robocal as rc  # noqa: E402
from robocal.data.registration import umeyama  # noqa: E402

DOWNLOADS = {  # FIGAROH's public repositories (Apache-2.0), as GitHub archives of their default branch
    "figaroh-examples": "https://github.com/thanhndv212/figaroh-examples/archive/refs/heads/main.tar.gz",
    "figaroh-plus": "https://github.com/thanhndv212/figaroh-plus/archive/refs/heads/main.tar.gz",
    "figaroh": "https://github.com/thanhndv212/figaroh/archive/refs/heads/main.tar.gz",
}
DOWNLOAD_TIMEOUT_S = 30
# FIGAROH's example per set: the module and class under figaroh-examples/examples (None: the
# generic BaseCalibration), the legacy config, and the example script's solve() arguments.
TIAGO_RUN = ("examples.tiago.utils.tiago_tools", "TiagoCalibration", "config/tiago_config.yaml", {})
FIGAROH_RUNS = {
    "talos": ("examples.talos.utils.talos_tools", "TALOSCalibration", "config/talos_config.yaml",
              dict(method="lm", max_iterations=3, outlier_threshold=3.0)),
    "tiago": TIAGO_RUN,
    "tiago_next_day": TIAGO_RUN,
    "ur10_pose": ("examples.ur10.utils.ur10_tools", "UR10Calibration", "config/ur10_config_new.yaml", {}),
    "ur10_point": ("examples.ur10.utils.ur10_tools", "UR10Calibration", "config/ur10_config_new.yaml", {}),
    "mate": (None, None, "config/mate.yaml", {}),
    "mate_q1_flipped": (None, None, "config/mate.yaml", {}),
}


def stats_mm(err: np.ndarray) -> dict:
    """RMS, mean and max (mm) of per-marker 3-D errors ``err (K, 3)`` in metres."""
    d = np.linalg.norm(err, axis=1) * 1e3
    return {"rms": float(np.sqrt(np.mean(d**2))), "mean": float(d.mean()), "max": float(d.max()), "n": len(d)}


def judged(pred: np.ndarray, meas: np.ndarray, refit: bool) -> dict:
    """Held-out statistics of predicted marker positions ``pred (K, 3)`` against ``meas``; with
    ``refit`` the measurement frame is fitted again first (the best rigid motion of pred onto meas)."""
    if refit:
        T = umeyama(pred, meas)
        pred = pred @ T[:3, :3].T + T[:3, 3]
    return stats_mm(pred - meas)


def run_nominal(s: ps.PeerSet, refit: bool) -> dict:
    """The nominal model, its measurement frame (and SMRs) registered on the calibration poses,
    judged like a calibrated one: the figure a calibration has to beat."""
    model = rc.register(s.robot, s.calibration)
    return judged(model.fk(s.held_out.joints, smr=s.held_out.smr)[:, :3, 3], s.held_out.points, refit)


def run_robocal(s: ps.PeerSet, refit: bool) -> dict:
    """robocal's default calibration (what ``robocal calibrate`` runs) judged on the held-out poses."""
    held = s.held_out
    try:
        res = rc.calibrate(s.robot, s.calibration, validation=None if refit else held)
        note = ""
    except rc.PlausibilityError as exc:  # the default refuses: say why, and judge the forced fit
        res = rc.calibrate(s.robot, s.calibration, validation=None if refit else held, force=True)
        note = "refused by default (" + str(exc).split(":")[0][:90] + "); figures with force=True"
    pred = res.robot.fk(held.joints, smr=held.smr)[:, :3, 3]
    out = judged(pred, held.points, refit)
    out.update(note=note, result=res)
    return out


def _figaroh_csv(path: Path, session_joints, markers, rotations, names) -> None:
    cols, data = [], []
    for k in range(markers.shape[1]):
        cols += [f"x{k + 1}", f"y{k + 1}", f"z{k + 1}"]
        data.append(markers[:, k])
        if rotations is not None:
            from scipy.spatial.transform import Rotation
            cols += [f"phix{k + 1}", f"phiy{k + 1}", f"phiz{k + 1}"]
            data.append(Rotation.from_matrix(rotations).as_euler("ZYX")[:, ::-1])
    cols += list(names)
    data.append(session_joints)
    np.savetxt(path, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.10g")


def _figaroh_robot(urdf: Path, models: Path):
    """FIGAROH's robot loader as the examples call it; when the meshes are absent (a copy of the
    data without them), the same kinematic model without its geometry."""
    from figaroh.tools.robot import load_robot

    try:
        return load_robot(str(urdf), package_dirs=str(models), load_by_urdf=True)
    except ValueError as exc:
        if "Mesh" not in str(exc):
            raise
    import pinocchio as pin

    return pin.RobotWrapper(pin.buildModelFromUrdf(str(urdf)))


def run_figaroh(name: str, root: Path, workdir: Path, split: int = 0) -> dict:
    """FIGAROH's example calibration of set ``name`` on the same calibration poses (split number
    ``split``), judged alike."""
    import yaml
    from figaroh.calibration.base_calibration import BaseCalibration
    from figaroh.calibration.calibration_tools import calc_updated_fkm
    from figaroh.utils.config_migration import convert_legacy_to_unified

    spec = ps.SPECS[name]
    robot_rc = ps.nominal(name, root)
    cal, held, _ = ps.sessions(name, root, robot_rc, split)
    ids = sorted(set(cal.ids) | set(held.ids))
    module, cls, config, solve_kw = FIGAROH_RUNS[name]
    example = root / spec.example
    legacy = yaml.safe_load((example / config).read_text())
    calib = legacy["calibration"]
    measure = [True] * 6 if spec.pose_6d else [True, True, True, False, False, False]
    calib["markers"] = [dict(ref_joint=calib["markers"][0]["ref_joint"], measure=measure) for _ in ids]
    cal_csv, held_csv = workdir / f"{name}_cal.csv", workdir / f"{name}_held.csv"

    def full(sess):  # every marker of ``ids`` (a missing one repeats a present one: masked below)
        cols = [sess.ids.index(i) if i in sess.ids else 0 for i in ids]
        return sess.markers[:, cols]

    _figaroh_csv(cal_csv, cal.joints, full(cal), cal.rotations, spec.joint_columns)  # rad, m
    _figaroh_csv(held_csv, held.joints, full(held), held.rotations, spec.joint_columns)
    calib["data_file"] = str(cal_csv)
    calib["nb_sample"] = len(cal.joints)
    unified = convert_legacy_to_unified({"calibration": calib})
    unified["extends"] = str(root / "figaroh-examples/examples/templates" / Path(unified["extends"]).name)
    cfg = workdir / f"{name}.yaml"
    cfg.write_text(yaml.safe_dump(unified))
    cwd = os.getcwd()
    os.chdir(example)
    try:
        robot = _figaroh_robot(root / spec.urdf, root / spec.example.split("/")[0] / "models")
        klass, how = BaseCalibration, "BaseCalibration"
        if module is not None:
            sys.path.insert(0, str(root / "figaroh-examples"))
            try:
                klass, how = getattr(importlib.import_module(module), cls), cls
            except ImportError as exc:  # the example's tools use an API FIGAROH 1.0 removed
                how = f"BaseCalibration ({cls}: {type(exc).__name__})"
        t0 = time.perf_counter()
        with contextlib.redirect_stdout(io.StringIO()):
            calibration = klass(robot, str(cfg))
            calibration.calib_config["known_baseframe"] = False
            calibration.calib_config["known_tipframe"] = False
            calibration.calib_config["validation_data_file"] = str(held_csv)
            calibration.initialize()
            result = calibration.solve(plotting=False, enable_logging=False, **solve_kw)
        seconds = time.perf_counter() - t0
    finally:
        os.chdir(cwd)
    cfgd = dict(calibration.calib_config, NbSample=len(calibration._q_val))
    pee = calc_updated_fkm(calibration.model, calibration.data, result.x, calibration._q_val, cfgd)
    n_dofs = cfgd["calibration_index"]
    pee = pee.reshape(len(ids), n_dofs, -1)[:, :3, :]  # (markers, xyz, poses)
    pred = np.concatenate([pee[ids.index(i)].T[:, None] for i in held.ids], axis=1).reshape(-1, 3)
    out = judged(pred, held.markers.reshape(-1, 3), name in ps.REFIT_FRAME)
    out.update(note=f"{how}, {len(result.x)} parameters, {calibration.STATUS.lower()}, {seconds:.1f} s",
               params=dict(zip(calibration.calib_config["param_name"], result.x, strict=True)))
    return out


def download(cache: Path) -> str | None:
    """Fetch FIGAROH's repositories into ``cache``; None when done, else why not."""
    import tarfile
    import urllib.request

    cache.mkdir(parents=True, exist_ok=True)
    for repo, url in DOWNLOADS.items():
        if (cache / repo).is_dir():
            continue
        try:
            with urllib.request.urlopen(url, timeout=DOWNLOAD_TIMEOUT_S) as resp:
                blob = resp.read()
        except OSError as exc:
            return f"could not download {repo} ({exc}): offline? give --data DIR or ${ps.DATA_ENV}"
        with tempfile.TemporaryDirectory(dir=cache) as tmp:
            with tarfile.open(fileobj=io.BytesIO(blob)) as tar:
                tar.extractall(tmp, filter="data")
            (next(Path(tmp).iterdir())).rename(cache / repo)
    return None


def find_data(folder: str | None) -> tuple[Path | None, str]:
    """The data root, or None and the reason (after trying the download when nothing was named)."""
    try:
        return ps.data_root(folder), ""
    except ps.DataUnavailableError as exc:
        if folder or os.environ.get(ps.DATA_ENV):
            return None, str(exc)
        why = download(ps.CACHE)
        if why:
            return None, f"{exc}; {why}"
        return ps.data_root(None), ""


def figaroh_missing() -> str:
    """Why FIGAROH cannot run here ('' when it can)."""
    try:
        importlib.import_module("figaroh.calibration.base_calibration")
    except ImportError as exc:
        return f"FIGAROH not installed ({exc}): pip install robocal[peers]"
    return ""


SPLITS_ENV = "ROBOCAL_PEER_SPLITS"  # --splits' default: how many splits benchmarks/run.py records
PAPER_IRB120_MM = {"mean": 0.266, "max": 0.525}  # Wu et al. 2015's own method on its 40 test points


def irb120_paper(folder: str | None) -> None:
    """robocal's default on the IRB 120 campaign of Wu et al. 2015, judged on its 40 test points
    (the paper's own figures beside it); skipped with the reason when the data are absent."""
    try:
        campaign = liao_irb120.load(folder)
    except liao_irb120.LiaoUnavailableError as exc:
        print(f"(IRB 120 paper comparison skipped: {exc})")
        return
    print(f"  {campaign.description}", flush=True)
    rows = []
    for label, model in (("nominal, frame registered", rc.register(campaign.robot, campaign.calibration)),
                         ("robocal default", rc.calibrate(campaign.robot, campaign.calibration).robot)):
        e = liao_irb120.test_errors_mm(model, campaign)
        rows.append([label, f"{np.sqrt(np.mean(e**2)):.3f}", f"{e.mean():.3f}", f"{e.max():.3f}"])
    rows.append(["the paper's method (published)", "", f"{PAPER_IRB120_MM['mean']:.3f}",
                 f"{PAPER_IRB120_MM['max']:.3f}"])
    table("IRB 120 (Wu et al. 2015, 36 poses x 3 SMRs): error on the 40 test points, mm",
          ["model", "RMS", "mean", "max"], rows, key="irb120_paper")


def _row(name: str, tool: str, r: dict) -> list:
    return [name, tool, f"{r['rms']:.3f}", f"{r['mean']:.3f}", f"{r['max']:.3f}", r["n"], r["note"]]


def run_split(name: str, root: Path, split: int, peer: bool, workdir: Path) -> dict:
    """Both tools (FIGAROH when ``peer``) and the registered nominal model on split ``split`` of
    set ``name``: {"robocal", "figaroh", "nominal"} -> statistics dict (FIGAROH's failure: a dict
    with ``failed``), and the set's ``description``."""
    s = ps.load(name, root, split)
    refit = name in ps.REFIT_FRAME
    out = {"description": s.description, "robocal": run_robocal(s, refit), "nominal": run_nominal(s, refit)}
    if peer:
        try:
            out["figaroh"] = run_figaroh(name, root, workdir, split)
        except Exception as exc:  # noqa: BLE001 - the peer's failure is a result to report
            out["figaroh"] = {"failed": f"failed: {type(exc).__name__}: {str(exc)[:120]}"}
    return out


def _spread(values: list[float]) -> str:
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not len(v):
        return ""
    return f"{v.mean():.3f} ± {v.std(ddof=1):.3f}" if len(v) > 1 else f"{v[0]:.3f}"


def split_summary(name: str, runs: list[dict]) -> list:
    """One row of the multi-split table: the set, its splits, mean ± sd of the held-out RMS (mm) of
    robocal's default, FIGAROH and the registered nominal model, and robocal's wins."""
    def rms(tool):
        return [r[tool]["rms"] if tool in r and "rms" in r[tool] else np.nan for r in runs]
    ours, peer, nominal = rms("robocal"), rms("figaroh"), rms("nominal")
    both = np.isfinite(peer)
    wins = f"{int(np.sum(np.asarray(ours)[both] <= np.asarray(peer)[both]))} of {int(both.sum())}"
    refused = sum(1 for r in runs if r["robocal"]["note"])
    failed = sum(1 for r in runs if "failed" in r.get("figaroh", {}))
    notes = ([f"robocal refused by default on {refused} (figures with force=True)"] if refused else []) + \
        ([f"FIGAROH failed on {failed}"] if failed else [])
    return [name, len(runs), _spread(ours), _spread(peer), _spread(nominal),
            wins if both.any() else "", "; ".join(notes)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", help=f"folder with FIGAROH's repositories (default ${ps.DATA_ENV})")
    parser.add_argument("--only", choices=sorted(ps.SETS), help="one set")
    parser.add_argument("--robocal-only", action="store_true", help="skip FIGAROH")
    parser.add_argument("--splits", type=int, default=int(os.environ.get(SPLITS_ENV, "1")),
                        help=f"run the first K fixed splits of each set (default ${SPLITS_ENV} or 1)")
    parser.add_argument("--liao", help="the IRB 120 campaign of Wu et al. 2015 (default "
                                       f"${liao_irb120.DATA_ENV}); absent: that table is skipped")
    args = parser.parse_args([] if argv is None and __name__ != "__main__" else argv)
    if args.splits < 1:
        parser.error(f"--splits must be at least 1, got {args.splits}")
    if not args.only:
        irb120_paper(args.liao)
    root, why = find_data(args.data)
    if root is None:
        print(f"(peer benchmark skipped: {why})")
        return 0
    peer_why = "--robocal-only" if args.robocal_only else figaroh_missing()
    if peer_why:
        print(f"(FIGAROH rows skipped: {peer_why})")
    rows, summary = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name in [args.only] if args.only else list(ps.SETS):
            runs = []
            for split in range(ps.n_splits(name, args.splits)):
                runs.append(run_split(name, root, split, not peer_why, Path(tmp)))
                print(f"  {runs[-1]['description']}" if split == 0 else f"    split {split}: "
                      + "; ".join(runs[-1]["description"].split("; ")[1:]), flush=True)
            rows.append(_row(name, "robocal default", runs[0]["robocal"]))
            if "figaroh" in runs[0]:
                fig = runs[0]["figaroh"]
                rows.append([name, "FIGAROH example", "", "", "", "", fig["failed"]] if "failed" in fig
                            else _row(name, "FIGAROH example", fig))
            summary.append(split_summary(name, runs))
    table("FIGAROH's example data: held-out marker position error, mm (same split, same run)",
          ["set", "tool", "RMS", "mean", "max", "points", "note"], rows, key="peers")
    if args.splits > 1:
        table(f"FIGAROH's example data over {args.splits} fixed splits (next day: 2): held-out RMS, mm, "
              "mean ± sd over the splits (same splits, same run)",
              ["set", "splits", "robocal default", "FIGAROH example", "nominal, frame registered",
               "robocal wins", "note"], summary, key="peers_splits")
    return 0


if __name__ == "__main__":
    sys.exit(main())
