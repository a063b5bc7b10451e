"""Random serial URDF chains (revolute, continuous, prismatic and fixed joints) against an
independent composition of their joints (shared by tests/test_fuzz_urdf.py and a long run:
``python tests/fuzz_urdf.py 3000``).

A chain has 1 to 8 moving joints with fixed joints between some; its origins are drawn at a random
scale (a 1 mm wrist to a 60 m gantry), its rotations random or multiples of 90 deg, its axes random,
along a frame axis, not unit length, or the previous axis again (parallel, coincident, nearly
parallel around the import's 5 deg threshold). The truth is the URDF's own definition composed
here with plain numpy: ``T = prod(origin_i @ motion_i(q_i))`` (Rodrigues for a turn, a shift along
the axis for a slide). A valid chain must import (API and ``robocal export X.urdf --yaml``) with
the same FK within a tolerance scaled to the chain's size; an invalid one (:data:`BREAKS`) must be
refused in one line (exit 2) with no output written.
"""

from __future__ import annotations

import contextlib
import io
import random
from dataclasses import dataclass
from pathlib import Path

import numpy as np

REL_TOL = 1e-9  # FK agreement: this times the chain's size (sum of its offsets and travels, m)
ROT_TOL = 1e-9  # rad
BREAKS = ("zero axis", "nan origin", "inf axis", "huge origin", "planar joint", "prismatic without limit",
          "limit reversed", "loop", "two parents", "no moving joint", "mimic", "text in rpy", "two tips")


@dataclass
class Joint:
    name: str
    kind: str  # revolute, continuous, prismatic, fixed
    xyz: np.ndarray
    rpy: np.ndarray
    axis: np.ndarray
    lower: float = -3.0
    upper: float = 3.0


def _rpy_matrix(rpy) -> np.ndarray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def truth_fk(joints: list[Joint], q: np.ndarray) -> np.ndarray:
    """The tip pose (4, 4) of the chain at the moving joints' values ``q`` (rad, m)."""
    T = np.eye(4)
    k = 0
    for j in joints:
        O = np.eye(4)
        O[:3, :3], O[:3, 3] = _rpy_matrix(j.rpy), j.xyz
        M = np.eye(4)
        if j.kind in ("revolute", "continuous"):
            M[:3, :3] = _rodrigues(j.axis, q[k])
        elif j.kind == "prismatic":
            M[:3, 3] = j.axis / np.linalg.norm(j.axis) * q[k]
        T = T @ O @ M
        k += j.kind != "fixed"
    return T


def _axis(rng: random.Random, previous: np.ndarray | None) -> np.ndarray:
    pick = rng.random()
    if previous is not None and pick < 0.25:  # the previous axis again, or nearly (around 5 deg)
        tilt = rng.choice([0.0, 0.0, 1e-9, 1e-4, np.deg2rad(4.99), np.deg2rad(5.01), np.deg2rad(30)])
        other = np.cross(previous, [0.3, 0.5, 0.7])
        return previous * rng.choice([1, -1]) + np.tan(tilt) * other / np.linalg.norm(other) * \
            np.linalg.norm(previous)
    if pick < 0.6:
        v = np.zeros(3)
        v[rng.randrange(3)] = rng.choice([1.0, -1.0])
        return v * rng.choice([1.0, 1.0, 2.5, 1e-3])
    return np.array([rng.gauss(0, 1) for _ in range(3)])


def random_chain(rng: random.Random) -> list[Joint]:
    """A random valid serial chain."""
    scale = rng.choice([1e-3, 0.05, 0.3, 1.0, 3.0])  # a model file holds reaches up to 50 m
    joints: list[Joint] = []
    moving = rng.randint(1, 8)
    previous = None
    k = 0
    while sum(j.kind != "fixed" for j in joints) < moving:
        kind = rng.choices(["revolute", "continuous", "prismatic", "fixed"], [5, 1, 3, 1])[0]
        xyz = np.array([rng.gauss(0, scale) if rng.random() < 0.7 else 0.0 for _ in range(3)])
        rpy = np.array([rng.choice([0, np.pi / 2, -np.pi / 2, np.pi]) if rng.random() < 0.5 else
                        rng.uniform(-np.pi, np.pi) if rng.random() < 0.5 else 0.0 for _ in range(3)])
        axis = _axis(rng, previous if not np.allclose(rpy, 0) or rng.random() < 0.5 else None)
        if kind == "prismatic":
            travel = scale * rng.choice([0.1, 1, 5])
            lower, upper = -travel * rng.random(), travel * (0.1 + rng.random())
        else:
            lower, upper = -rng.uniform(0.5, 3.1), rng.uniform(0.5, 3.1)
        joints.append(Joint(f"j{k}", kind, xyz, rpy, axis, lower, upper))
        previous = axis if kind != "fixed" else previous
        k += 1
    if rng.random() < 0.5:
        tip = np.array([0, 0, scale * rng.random()])
        joints.append(Joint(f"j{k}", "fixed", tip, np.zeros(3), np.zeros(3)))
    return joints


def _num(v: float) -> str:
    return repr(float(v))


def to_urdf(joints: list[Joint], name: str = "fuzz", extra: str = "") -> str:
    """The URDF text of a chain (links l0..ln; joint i from l(i) to l(i+1))."""
    lines = [f'<robot name="{name}">'] + [f'  <link name="l{i}"/>' for i in range(len(joints) + 1)]
    for i, j in enumerate(joints):
        body = [f'    <parent link="l{i}"/>', f'    <child link="l{i + 1}"/>',
                f'    <origin xyz="{" ".join(map(_num, j.xyz))}" rpy="{" ".join(map(_num, j.rpy))}"/>']
        if j.kind != "fixed":
            body.append(f'    <axis xyz="{" ".join(map(_num, j.axis))}"/>')
            if j.kind != "continuous":
                body.append(f'    <limit lower="{_num(j.lower)}" upper="{_num(j.upper)}" effort="1" '
                            'velocity="1"/>')
        lines += [f'  <joint name="{j.name}" type="{j.kind}">', *body, "  </joint>"]
    return "\n".join(lines + [extra, "</robot>", ""])


def broken(rng: random.Random) -> tuple[str, str]:
    """(what, URDF text) of a chain broken by one of :data:`BREAKS`."""
    joints = random_chain(rng)
    while all(j.kind == "fixed" for j in joints[:1]):
        joints = random_chain(rng)
    what = rng.choice(BREAKS)
    moving = [j for j in joints if j.kind != "fixed"]
    j = rng.choice(moving)
    extra = ""
    if what == "zero axis":
        j.axis = np.zeros(3)
    elif what == "nan origin":
        j.xyz = np.array([np.nan, 0, 0])
    elif what == "inf axis":
        j.axis = np.array([np.inf, 0, 0])
    elif what == "huge origin":
        j.xyz = np.array([1e300, 0, 0])
    elif what == "planar joint":
        j.kind = "planar"
    elif what == "prismatic without limit":
        j.kind = "prismatic"
        text = to_urdf(joints)
        import re
        return what, re.sub(rf'(<joint name="{j.name}" type="prismatic">(?:(?!</joint>).)*?)<limit[^>]*/>',
                            r"\1", text, flags=re.S)
    elif what == "limit reversed":
        j.kind = "prismatic" if j.kind == "continuous" else j.kind
        j.lower, j.upper = 1.0, -1.0
    elif what == "loop":
        extra = f'  <joint name="back" type="fixed"><parent link="l{len(joints)}"/><child link="l0"/></joint>'
    elif what == "two parents":
        extra = f'  <joint name="twin" type="fixed"><parent link="l0"/><child link="l{len(joints)}"/></joint>'
    elif what == "no moving joint":
        for m in joints:
            m.kind = "fixed"
    elif what == "mimic":
        text = to_urdf(joints)
        return what, text.replace(f'<joint name="{j.name}" type="{j.kind}">',
                                  f'<joint name="{j.name}" type="{j.kind}"><mimic joint="x"/>', 1)
    elif what == "text in rpy":
        return what, to_urdf(joints).replace('rpy="', 'rpy="pi ', 1)
    elif what == "two tips":
        extra = ('  <link name="side"/><joint name="side_j" type="revolute"><parent link="l0"/>'
                 '<child link="side"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>')
        for m in joints[1:]:
            m.kind = "fixed"
    return what, to_urdf(joints, extra=extra)


def size(joints: list[Joint]) -> float:
    """The chain's size in m: its offsets and its slides' travels."""
    return 1.0 + sum(float(np.linalg.norm(j.xyz)) + (max(abs(j.lower), abs(j.upper)) if j.kind == "prismatic"
                                                    else 0.0) for j in joints)


def samples(joints: list[Joint], rng: random.Random, count: int = 8) -> np.ndarray:
    """``count`` joint vectors within the moving joints' limits (rad, m)."""
    moving = [j for j in joints if j.kind != "fixed"]
    return np.array([[rng.uniform(j.lower, j.upper) for j in moving] for _ in range(count)])


def fk_gap(robot, joints: list[Joint], q: np.ndarray) -> tuple[float, float]:
    """Largest position (m) and rotation (rad) gaps between ``robot.fk`` and the truth."""
    got = robot.fk(q)
    pos, rot = 0.0, 0.0
    for k in range(len(q)):
        T = truth_fk(joints, q[k])
        pos = max(pos, float(np.linalg.norm(got[k, :3, 3] - T[:3, 3])))
        rot = max(rot, float(np.linalg.norm(got[k, :3, :3] - T[:3, :3]) / np.sqrt(2)))  # ~ the angle
    return pos, rot


def cli(argv: list[str]) -> tuple[int, str]:
    from robocal.cli import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        try:
            code = main(["--quiet", *argv])
        except BaseException as exc:  # noqa: BLE001 - anything escaping main breaks the contract
            return -2, f"{type(exc).__name__}: {exc}"
    return code, err.getvalue()


def one_error_line(code: int, stderr: str) -> bool:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    return code == 2 and len(lines) >= 1 and lines[-1].startswith("robocal ") and \
        all(ln.lower().startswith(("warning", "robocal")) for ln in lines)


def fuzz_one(rng: random.Random, folder: Path, through_cli: bool) -> list[str]:
    """One valid chain (API, and CLI when asked) and one broken one; the contract breaks."""
    from robocal.core.errors import RobocalError
    from robocal.kinematics.model import load_model
    from robocal.kinematics.urdf import from_urdf

    problems = []
    joints = random_chain(rng)
    text = to_urdf(joints)
    tol = REL_TOL * size(joints)
    q = samples(joints, rng)
    try:
        robot = from_urdf(text)
    except RobocalError as exc:
        return [f"valid chain refused: {exc}\n{text}"]
    except Exception as exc:  # noqa: BLE001
        return [f"valid chain: internal {type(exc).__name__}: {exc}\n{text}"]
    pos, rot = fk_gap(robot, joints, q)
    if pos > tol or rot > ROT_TOL * size(joints):
        problems.append(f"FK off by {pos:.3g} m, {rot:.3g} rad (tolerance {tol:.3g} m)\n{text}")
    if through_cli:
        src, out = folder / "chain.urdf", folder / "chain.yaml"
        out.unlink(missing_ok=True)
        src.write_text(text)
        code, err = cli(["export", str(src), "--yaml", str(out)])
        if code == 2 and one_error_line(code, err) and "would not read back" in err and not out.exists():
            pass  # a chain beyond what a model file holds (a reach over 50 m): refused, nothing written
        elif code != 0:
            problems.append(f"export --yaml exit {code}: {err.strip()[:200]}\n{text}")
        else:
            try:
                reread = load_model(str(out))
            except RobocalError as exc:
                return [*problems, f"export --yaml wrote a model it refuses to read: {exc}"]
            pos, rot = fk_gap(reread, joints, q)
            if pos > tol * 10 or rot > ROT_TOL * 10 * size(joints):
                problems.append(f"via the YAML, FK off by {pos:.3g} m, {rot:.3g} rad\n{text}")
        if src.read_text() != text:
            problems.append("the URDF changed")
    what, text = broken(rng)
    try:
        from_urdf(text)
        problems.append(f"broken chain ({what}) imported\n{text}")
    except RobocalError:
        pass
    except Exception as exc:  # noqa: BLE001
        problems.append(f"broken chain ({what}): internal {type(exc).__name__}: {exc}")
    if through_cli:
        src, out = folder / "bad.urdf", folder / "bad.yaml"
        out.unlink(missing_ok=True)
        src.write_text(text)
        code, err = cli(["export", str(src), "--yaml", str(out)])
        if not one_error_line(code, err) or out.exists():
            problems.append(f"broken chain ({what}) through the CLI: exit {code}, output "
                            f"{'written' if out.exists() else 'absent'}: {err.strip()[:200]}")
    return problems


if __name__ == "__main__":  # pragma: no cover - the long run
    import sys
    import tempfile

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    r = random.Random(seed)
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(n):
            for p in fuzz_one(r, Path(tmp), k % 10 == 0):
                print(f"chain {k}: {p}", flush=True)
