"""Exact conversions of other kinematic conventions to modified DH + beta.

Every convention here is first written as a product of constant transforms and joint rotations;
from it we take the joint axes (lines in space, directed so that a positive joint value turns
right-handedly) and the flange pose at zero joints. :func:`mdh_from_axes` then places the MDH
frames on those axes (common normals; on parallel axes the foot of the previous common normal,
so d = 0 there) and lets the base and tool frames absorb what the chain cannot express. This is
exact by the product-of-exponentials argument: a joint turning about a line acts the same in
every frame whose z axis is that line.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from robocal.core.errors import ModelError
from robocal.core.io import ANGLE_UNITS, length_scale
from robocal.kinematics.opw import OPWParameters

PARALLEL_TOL = 1e-9  # |sin| of the angle between two axes below which they count as parallel
_DIST_TOL = 1e-12  # m: axes closer than this intersect


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    T = np.eye(4)
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def _trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def _joint(axis: str, sign: float) -> list:
    """Chain elements of a joint turning by ``sign * q`` about the local ``axis``: constant
    frames around the marker ``None`` (the marker stands for Rz(q))."""
    pre, post = np.eye(4), np.eye(4)
    if axis == "y":
        pre, post = _rot("x", -np.pi / 2), _rot("x", np.pi / 2)
    if sign < 0:
        pre, post = pre @ _rot("x", np.pi), _rot("x", np.pi) @ post
    return [pre, None, post]


def _zero_pose(elements: list) -> tuple[np.ndarray, np.ndarray]:
    """Joint frames ``(n, 4, 4)`` (z = positive joint axis) and flange pose at zero joints."""
    T = np.eye(4)
    frames = []
    for el in elements:
        if el is None:
            frames.append(T.copy())
        else:
            T = T @ el
    return np.array(frames), T


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _perp(v: np.ndarray, z: np.ndarray) -> np.ndarray:
    return v - (v @ z) * z


def _frame(x: np.ndarray, z: np.ndarray, o: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, o
    return T


def default_parallel(alpha) -> np.ndarray:
    """``(n,)`` bool: axis i is nominally parallel to axis i-1 (so beta_i is a parameter) where
    ``|sin alpha_i| < PARALLEL_TOL``; never the first axis (rad)."""
    parallel = np.abs(np.sin(np.asarray(alpha, dtype=float))) < PARALLEL_TOL
    parallel[:1] = False
    return parallel


def _normal_feet(p0: np.ndarray, z: np.ndarray, p1: np.ndarray, u1: np.ndarray,
                 w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The feet ``(3,), (3,)`` of the common normal of the line through ``p0`` along unit ``z`` and
    the one through ``p1`` along unit ``u1`` (m), ``w = z x u1`` (not near zero: not parallel)."""
    r = p1 - p0
    ww = w @ w
    return p0 + (np.cross(r, u1) @ w) / ww * z, p1 + (np.cross(r, z) @ w) / ww * u1


def _last_frame(p: np.ndarray, z: np.ndarray, flange: np.ndarray, x_prev: np.ndarray) -> np.ndarray:
    """The last joint's MDH frame ``(4, 4)`` on the line through ``p`` along unit ``z``: its origin
    level with the flange, its x the flange's x (else y, else ``x_prev``) made normal to ``z``."""
    o = p + ((flange[:3, 3] - p) @ z) * z
    x = next(_unit(_perp(v, z)) for v in (flange[:3, 0], flange[:3, 1], x_prev)
             if np.linalg.norm(_perp(v, z)) > 1e-6)
    return _frame(x, z, o)


def _snap(values: np.ndarray, grid: float, tol: float) -> np.ndarray:
    """Round values within ``tol`` of a multiple of ``grid`` onto it (cleans 1e-17 residue)."""
    k = np.round(values / grid)
    return np.where(np.abs(values - k * grid) < tol, k * grid, values) + 0.0  # + 0.0: no -0.0


def first_frame(axis: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The MDH frame {0} ``(4, 4)`` of a chain whose first joint turns about the unit ``axis (3,)``
    through ``point (3,)`` (world, m): the world frame when that line is the world z axis, else a
    frame on the line (its x the world x, or y, made normal to it)."""
    ez = np.array([0.0, 0.0, 1.0])
    if np.linalg.norm(np.cross(axis, ez)) < PARALLEL_TOL and np.linalg.norm(point[:2]) < _DIST_TOL:
        return np.eye(4)
    x0 = _perp(np.array([1.0, 0, 0]), axis)
    x0 = _unit(x0 if np.linalg.norm(x0) > 1e-6 else _perp(np.array([0, 1.0, 0]), axis))
    return _frame(x0, axis, point - (point @ axis) * axis)


def mdh_from_axes(joint_frames: np.ndarray, flange: np.ndarray) -> dict:
    """MDH + beta parameters of the chain whose joint i turns about the z axis of
    ``joint_frames[i]`` (world, zero joints), with flange pose ``flange`` at zero joints.

    Returns ``alpha, a, beta, theta, d`` ``(n,)`` (m, rad), ``base``, ``tool`` (4x4) and
    ``parallel`` ``(n,)`` so that ``base * T_1(q_1) ... T_n(q_n) * tool`` equals the chain.
    """
    u = joint_frames[:, :3, 2]
    p = joint_frames[:, :3, 3]
    n = len(u)
    F = [first_frame(u[0], p[0])]
    for i in range(n - 1):
        x_prev, o_prev = F[-1][:3, 0], F[-1][:3, 3]
        # where the previous x axis meets axis i (the MDH intermediate origin, d_i = 0 there)
        hit = o_prev + ((p[i] - o_prev) @ x_prev) * x_prev
        z = u[i]
        w = np.cross(z, u[i + 1])
        if np.linalg.norm(w) < PARALLEL_TOL:  # parallel: normal from the hit point
            o = hit
            v = _perp(p[i + 1] - o, z)
            x = _unit(v) if np.linalg.norm(v) > _DIST_TOL else _unit(_perp(x_prev, z))
        else:
            o, foot = _normal_feet(p[i], z, p[i + 1], u[i + 1], w)
            v = foot - o
            x = _unit(v) if np.linalg.norm(v) > _DIST_TOL else _unit(w)
        if x @ x_prev < -1e-9:  # prefer theta near 0: a may then be negative
            x = -x
        F.append(_frame(x, z, o))
    F.append(_last_frame(p[-1], u[-1], flange, F[-1][:3, 0]))
    alpha, a, theta, d = (np.zeros(n) for _ in range(4))
    for i in range(n):
        x0, z0, o0 = F[i][:3, 0], F[i][:3, 2], F[i][:3, 3]
        x1, z1, o1 = F[i + 1][:3, 0], F[i + 1][:3, 2], F[i + 1][:3, 3]
        alpha[i] = np.arctan2(np.cross(z0, z1) @ x0, z0 @ z1)
        a[i] = (o1 - o0) @ x0
        theta[i] = np.arctan2(np.cross(x0, x1) @ z1, x0 @ x1)
        d[i] = (o1 - o0 - a[i] * x0) @ z1
    alpha = _snap(alpha, np.pi / 2, 1e-13)
    theta = _snap(theta, np.pi / 2, 1e-13)
    a, d = _snap(a, 1.0, 1e-15), _snap(d, 1.0, 1e-15)
    tool = np.linalg.solve(F[-1], flange)
    tool[:3] = _snap(tool[:3], 1.0, 1e-15)
    return {"alpha": alpha, "a": a, "beta": np.zeros(n), "theta": theta, "d": d,
            "base": F[0], "tool": tool, "parallel": default_parallel(alpha)}


def _table(values, n: int | None, what: str) -> np.ndarray:
    arr = np.asarray(values, dtype=float).reshape(-1)
    if n is not None and arr.size != n:
        raise ModelError(f"{what} must have {n} values (one per joint), got {arr.size}")
    if arr.size == 0:
        raise ModelError(f"{what} is empty: a robot needs at least one joint")
    if not np.isfinite(arr).all():
        raise ModelError(f"{what} contains NaN or infinite values: {arr.tolist()}")
    return arr


def _finish(mdh: dict, degrees: bool, kw: dict) -> dict:
    """Robot keyword arguments: user base/tool wrap the converted ones, limits converted from deg."""
    base = mdh["base"] if kw.get("base") is None else np.asarray(kw["base"], float) @ mdh["base"]
    tool = mdh["tool"] if kw.get("tool") is None else mdh["tool"] @ np.asarray(kw["tool"], float)
    kw = {**kw, "base": base, "tool": tool}
    kw.setdefault("parallel", mdh["parallel"])
    _limits(kw, degrees)
    return {"alpha": mdh["alpha"], "a": mdh["a"], "beta": mdh["beta"], "theta": mdh["theta"],
            "d": mdh["d"], **kw}


def _limits(kw: dict, degrees: bool) -> None:
    """``kw["limits"]`` (when given) from degrees to rad when ``degrees``."""
    if kw.get("limits") is not None:
        limits = np.asarray(kw["limits"], dtype=float)
        kw["limits"] = limits * ANGLE_UNITS["deg"] if degrees else limits


def mdh_kwargs(alpha: Sequence[float], a: Sequence[float], theta: Sequence[float], d: Sequence[float],
               beta: Sequence[float] | None = None, *, degrees: bool = False, length_unit: str = "m",
               **kw) -> dict:
    """Robot keyword arguments from Craig's modified DH rows (alpha_{i-1}, a_{i-1}, theta offset,
    d_i) and Hayati's beta (default 0), in ``length_unit`` and deg or rad.

    ``parallel`` defaults to :func:`default_parallel`; ``base`` / ``tool`` in ``kw`` (4x4, m) are
    the model's own frames; ``limits`` ``(n, 2)`` are in degrees when ``degrees``.
    """
    scale = length_scale(length_unit, ModelError)
    ang = ANGLE_UNITS["deg"] if degrees else 1.0
    al = _table(alpha, None, "MDH alpha") * ang
    n = al.size
    kw = {"alpha": al, "a": _table(a, n, "MDH a") * scale, "theta": _table(theta, n, "MDH theta") * ang,
          "d": _table(d, n, "MDH d") * scale,
          "beta": np.zeros(n) if beta is None else _table(beta, n, "MDH beta") * ang, **kw}
    kw.setdefault("parallel", default_parallel(al))
    _limits(kw, degrees)
    return kw


def dh_kwargs(theta_offsets: Sequence[float], d: Sequence[float], a: Sequence[float],
              alpha: Sequence[float], *, degrees: bool = False, length_unit: str = "m", **kw) -> dict:
    """Robot keyword arguments from a standard DH table (A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i)
    Rx(alpha_i)).

    The DH base frame is the world frame and the DH frame n is the flange; ``base`` / ``tool`` in
    ``kw`` (4x4, m) are world -> DH base and DH flange -> TCP. ``limits`` ``(n, 2)`` are in degrees
    when ``degrees``.
    """
    scale = length_scale(length_unit, ModelError)
    ang = ANGLE_UNITS["deg"] if degrees else 1.0
    th = _table(theta_offsets, None, "DH theta offsets") * ang
    n = th.size
    dd = _table(d, n, "DH d") * scale
    aa = _table(a, n, "DH a") * scale
    al = _table(alpha, n, "DH alpha") * ang
    elements = []
    for i in range(n):
        elements += [_rot("z", th[i]), None, _trans(z=dd[i]) @ _trans(x=aa[i]) @ _rot("x", al[i])]
    return _finish(mdh_from_axes(*_zero_pose(elements)), degrees, kw)


def opw_elements(params: OPWParameters) -> list:
    """The OPW arm as a chain: Rz(t1) T(a1, b, c1) Ry(t2) Tz(c2) Ry(t3) T(a2, 0, c3) Rz(t4) Ry(t5)
    Rz(t6) Tz(c4) with t_i = sign_i q_i - offset_i."""
    axes = ("z", "y", "y", "z", "y", "z")
    after = (_trans(params.a1, params.b, params.c1), _trans(z=params.c2),
             _trans(params.a2, 0.0, params.c3), np.eye(4), np.eye(4), _trans(z=params.c4))
    elements = []
    for axis, sign, offset, post in zip(axes, params.signs, params.offsets, after, strict=True):
        elements += [_rot(axis, -offset), *_joint(axis, sign), post]
    return elements


def opw_parameters(a1: float, a2: float, b: float, c1: float, c2: float, c3: float, c4: float,
                   offsets: Sequence[float] = (0.0,) * 6, signs: Sequence[int] = (1,) * 6, *,
                   degrees: bool = False, length_unit: str = "m") -> OPWParameters:
    """An OPW parameter set in SI from values in ``length_unit`` and (offsets) deg or rad."""
    scale = length_scale(length_unit, ModelError)
    lengths = _table([a1, a2, b, c1, c2, c3, c4], 7, "OPW lengths (a1, a2, b, c1, c2, c3, c4)") * scale
    off = _table(offsets, 6, "OPW offsets") * (ANGLE_UNITS["deg"] if degrees else 1.0)
    return OPWParameters(*lengths, offsets=tuple(off), signs=tuple(_table(signs, 6, "OPW signs")))


@functools.cache
def opw_chain(params: OPWParameters) -> dict:
    """The exact MDH + beta chain (alpha, a, beta, theta, d, base, tool, parallel) of an OPW set
    (cached: its arrays are read-only)."""
    chain = mdh_from_axes(*_zero_pose(opw_elements(params)))
    for value in chain.values():
        value.flags.writeable = False
    return chain


def opw_kwargs(params: OPWParameters, *, degrees: bool = False, **kw) -> dict:
    """Robot keyword arguments from an OPW parameter set (opw_kinematics convention, theta =
    q * sign - offset); ``limits`` in ``kw`` are in degrees when ``degrees``. The robot keeps the
    set as ``robot.opw`` for closed-form inverse kinematics."""
    kw.setdefault("opw", params)
    return _finish(opw_chain(params), degrees, kw)
