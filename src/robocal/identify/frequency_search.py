"""Find the frequencies of cyclic joint errors (term ``cyclic``) in a calibration's residuals.

A transmission repeats its error with every turn of its motor or of an intermediate shaft, so a
joint's error holds a sinusoid in ``f q_i`` with ``f`` the reduction ratio (or a multiple) in
cycles per joint revolution: dq_i = s sin(f q_i) + c cos(f q_i). The search is greedy, on the
linearised problem at a fitted model (a periodogram in the joint angle):

1. For each joint and each frequency on a grid from CYCLIC_MIN_FREQUENCY to MAX_FREQUENCY, or to
   the highest frequency the joint's angles resolve when lower (:func:`resolved_frequency`: angles
   on a grid of step h alias every frequency above pi / h onto a lower one, as a positioner's
   table turned in 22.5 deg steps does above 8 cycles per revolution)
   (step pi / (2 span_i), half the width of a peak over the joint's span in the data), the Wald
   statistic of adding the two columns ``d(TCP)/d(theta_i) * (sin f q_i, cos f q_i)`` to the
   fitted model, vectorised over frequencies. The variance is cluster-robust by pose (the
   residuals of the SMRs of one pose are one error of the flange, and the residuals are
   heavy-tailed), so the statistic is chi-square with 2 degrees of freedom when there is no
   such error, whatever the noise.
2. Each joint's highest peak is refined to the least-squares frequency within one grid step. In
   decreasing order of the peaks, each is tested exactly (columns made orthogonal to the model
   with the ones kept before it) and kept when
   its statistic exceeds ``2 ln(n_independent / alpha)`` — the level a pure-noise periodogram
   exceeds with probability ``alpha`` over the n_independent frequencies searched (Bonferroni)
   — and its column is not confounded with the model's (variance inflation below NG_MAX_VIF).
3. The kept columns join the model and the search repeats, until a round keeps nothing.
4. (:meth:`FrequencyScan.polish`, for the model delivered) each frequency is moved to its exact
   least-squares value with all the others in the model.

Whole-campaign cost: the sums over poses of step 1 at every grid frequency are a non-uniform
discrete Fourier transform, computed without a (poses x frequencies) table (which would cost
~170 kB per pose) by gridding with a Taylor expansion (:func:`trig_sums`): each pose's phase is
split into the nearest point of a regular grid plus a small remainder whose exponential is
expanded in powers, so the sums are a few FFTs of binned weights — memory linear in the poses and
in the grid, time nearly independent of the pose count, accurate to ``TRIG_SUM_RTOL`` of the
summed weights. The cross-validation folds search on their training poses only (``mask``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse

from robocal.identify.identifiability import NG_RTOL
from robocal.identify.normal import r_factor, row_chunks
from robocal.kinematics.joint_errors import CYCLIC_MIN_FREQUENCY

MAX_FREQUENCY = 400.0        # cycles per revolution: twice the largest common reducer ratio
FALSE_ALARM = 0.01           # probability that noise alone yields one frequency
MAX_PER_JOINT = 3            # frequencies kept per joint at most
MIN_SPAN = np.deg2rad(20.0)  # a joint that moves less is not searched
_SCREEN = 0.25               # peaks whose screening statistic is below this x threshold are not tested
_REFINE_POINTS = 21          # least-squares refinement grid over +-1 grid step around a peak
_POLISH_POINTS = 9           # exact refinement grid over +-1/2 grid step (polish)
TRIG_SUM_RTOL = 1e-13        # truncation of the gridded sums' Taylor series, relative to sum |w|
_OVERSAMPLING = 4            # FFT length / number of modes: the Taylor remainder's step is pi / 4
_LOWEST = CYCLIC_MIN_FREQUENCY + 0.01  # refinement never goes below this (names round to 0.01)
# Two frequencies D apart whose columns correlate this much at the poses' angles (the sampling's
# spectral window |mean exp(i D q)|) are not told apart: the higher one is an alias of the lower.
# A grid's aliases reach ~1 (0.99 with 0.5 deg of jitter at 16 cycles/rev); P angles spread at
# random exceed it at one of the ~3000 offsets scanned with probability ~3000 exp(-0.64 P): 1e-5
# for 30 poses
ALIAS_CORRELATION = 0.8


def trig_sums(w: np.ndarray, x: np.ndarray, n_modes: int) -> np.ndarray:
    """``G[k] = sum_p w[p] exp(i k x[p])`` for ``k = 0 .. n_modes - 1`` (complex ``(n_modes,)``);
    ``w (P,)`` real or complex weights, ``x (P,)`` phases in rad per mode.

    Gridding: ``x = v_j + delta`` with ``v_j = 2 pi j / L`` the nearest point of an L-point grid
    (``L >= _OVERSAMPLING n_modes``, so ``|k delta| <= pi / _OVERSAMPLING``) and
    ``exp(i k delta) = sum_m (i k delta)^m / m!`` truncated where the next term is below
    ``TRIG_SUM_RTOL``: then ``G[k] = sum_m (i k)^m / m! * L ifft(H_m)[k]`` with ``H_m[j]`` the sum
    of ``w delta^m`` binned on the grid. Memory O(P + L), time O(M (P + L log L))."""
    if n_modes <= 0:
        return np.zeros(0, complex)
    L = 1 << int(np.ceil(np.log2(max(_OVERSAMPLING * n_modes, 2))))
    bound = np.pi * n_modes / L  # |k delta| at most
    terms, size = 1, 1.0
    while size > TRIG_SUM_RTOL:
        size *= bound / terms
        terms += 1
    u = np.mod(x, 2.0 * np.pi) * (L / (2.0 * np.pi))
    j = np.rint(u)
    delta = (u - j) * (2.0 * np.pi / L)
    j = j.astype(np.int64) % L
    k = np.arange(n_modes)
    total = np.zeros(n_modes, complex)
    power = np.asarray(w, complex)
    factor = np.ones(n_modes, complex)  # (i k)^m / m!
    for m in range(terms):
        H = np.bincount(j, power.real, L) + 1j * np.bincount(j, power.imag, L)
        total += factor * (np.fft.ifft(H) * L)[:n_modes]
        power = power * delta
        factor = factor * (1j * k) / (m + 1)
    return total


def resolved_frequency(q: np.ndarray, step: float) -> float:
    """The highest frequency (cycles per revolution) whose cyclic error the joint angles ``q
    (poses,)`` rad tell apart from a lower one: half the first offset D (on a grid of ``step``)
    beyond the window's main lobe where the sampling's spectral window ``|mean exp(i D q)|``
    reaches ALIAS_CORRELATION, since f and D - f then give the same columns. A regular grid of
    step h has D = 2 pi / h: pi / h, its Nyquist frequency; angles spread irregularly (an arm's
    poses) have no such D up to 2 MAX_FREQUENCY: MAX_FREQUENCY."""
    n_modes = int(np.ceil(2.0 * MAX_FREQUENCY / step)) + 1
    window = np.abs(trig_sums(np.full(q.size, 1.0 / max(q.size, 1)), step * np.asarray(q, float), n_modes))
    below = np.flatnonzero(window < ALIAS_CORRELATION)
    if below.size == 0:
        return 0.0  # the angles never spread enough to leave the main lobe: nothing is resolved
    alias = np.flatnonzero(window[below[0]:] >= ALIAS_CORRELATION)
    return MAX_FREQUENCY if alias.size == 0 else min(0.5 * (below[0] + alias[0]) * step, MAX_FREQUENCY)


class FrequencyScan:
    """The poses' joint angles and each joint's frequency grid (step 1 of the module docstring).

    ``q (N, n)`` joints of the measurement items (rad), ``group (N,)`` their pose labels (items
    of one pose share the joints)."""

    def __init__(self, q: np.ndarray, group: np.ndarray) -> None:
        _, first, self.pose_of_item = np.unique(group, return_index=True, return_inverse=True)
        self.q_item = np.asarray(q, float)
        q_pose = self.q_item[first]
        self.n_poses = q_pose.shape[0]
        span = np.ptp(q_pose, axis=0)
        self.step = np.pi / (2.0 * np.maximum(span, 1e-12))
        # per joint, the top of its searched band (0: not searched): MAX_FREQUENCY or its aliasing limit
        self.top = np.array([resolved_frequency(q_pose[:, i], self.step[i]) if span[i] >= MIN_SPAN else 0.0
                             for i in range(q_pose.shape[1])])
        self.grids = [np.arange(CYCLIC_MIN_FREQUENCY + self.step[i], self.top[i], self.step[i])
                      for i in range(q_pose.shape[1])]
        self.n_independent = max(sum(g.size for g in self.grids) / 2.0, 1.0)
        self.q_pose = q_pose

    def columns(self, Jtheta: np.ndarray, rows: int, found, items: slice = slice(None)) -> np.ndarray:
        """``(M, 2k)`` columns ``Jtheta[:, i] * (sin f q_i, cos f q_i)`` of ``found`` [(i, f)];
        ``Jtheta`` the rows of the measurement ``items`` (default all)."""
        cols = []
        for i, f in found:
            qi = np.repeat(self.q_item[items, i], rows)
            cols += [Jtheta[:, i] * np.sin(f * qi), Jtheta[:, i] * np.cos(f * qi)]
        return np.stack(cols, axis=1) if cols else np.zeros((Jtheta.shape[0], 0))

    def search(self, J: np.ndarray, r: np.ndarray, Jtheta: np.ndarray, rows: int,
               mask: np.ndarray | None = None) -> list[tuple[int, float]]:
        """Significant cyclic errors ``[(joint 0-based, frequency)]`` of the model with weighted
        Jacobian ``J (M, p)`` and residuals ``r (M,)`` at its fit; ``Jtheta (M, n)`` are the
        weighted theta columns there, ``rows`` the residual rows per item, ``mask (N,)`` the items
        to use (default all)."""
        n = self.q_item.shape[1]
        if mask is not None:  # the left-out items' rows count as zero (copies of the arrays)
            row_keep = np.repeat(np.asarray(mask, bool), rows)[:, None]
            J, r, Jtheta = J * row_keep, r * row_keep[:, 0], Jtheta * row_keep
        pose_of_row = np.repeat(self.pose_of_item, rows)
        weight = np.zeros((self.n_poses, n))  # sum of squared theta columns per pose (refinement)
        np.add.at(weight, pose_of_row, Jtheta**2)
        rows_all = np.arange(pose_of_row.size)
        to_pose = scipy.sparse.csr_matrix((np.ones(rows_all.size), (pose_of_row, rows_all)),
                                          shape=(self.n_poses, rows_all.size))  # sums rows per pose
        U = _orthonormal(J)
        r = r - U @ (U.T @ r)
        threshold = 2.0 * np.log(self.n_independent / FALSE_ALARM)
        found: list[tuple[int, float]] = []
        while True:
            y = to_pose @ (Jtheta * r[:, None])  # (poses, n): residual along each joint's motion
            peaks = []
            for i, grid in enumerate(self.grids):
                if grid.size and sum(j == i for j, _ in found) < MAX_PER_JOINT:
                    w = _wald_scan(y[:, i], self.q_pose[:, i], grid[0], self.step[i], grid.size)
                    t = int(np.argmax(w))
                    peaks.append((float(w[t]), i, self._refine(i, float(grid[t]), y[:, i], weight[:, i])))
            added = 0
            for screen, i, f in sorted(peaks, reverse=True):  # each joint's best, re-tested after each
                if screen < _SCREEN * threshold:
                    break  # far below significance already in the screening statistic
                stat, cp = self._exact(i, f, Jtheta, rows, U, r, to_pose)
                if cp is None or stat < threshold:
                    continue
                found.append((i, f))
                added += 1
                Q = _orthonormal(cp - U @ (U.T @ cp))
                U = np.hstack([U, Q])
                r = r - Q @ (Q.T @ r)
            if not added:
                break
        return found

    def polish(self, found, J: np.ndarray, r: np.ndarray, Jtheta: np.ndarray,
               rows: int) -> list[tuple[int, float]]:
        """``found`` with each frequency moved to its exact least-squares value given the model and
        the other frequencies (one backfitting pass; the search refines each peak before the later
        ones join the model, which biases overlapping ones by a few hundredths)."""
        out = list(found)
        if not out:
            return out
        U0 = _orthonormal(J)  # the model's span once; each frequency adds the others' columns to it
        for k, (i, f0) in enumerate(out):
            others = self.columns(Jtheta, rows, out[:k] + out[k + 1 :])
            U = np.hstack([U0, _orthonormal(others - U0 @ (U0.T @ others))])
            rp = r - U @ (U.T @ r)
            grid = _in_band(f0 + np.linspace(-0.5, 0.5, _POLISH_POINTS) * self.step[i], self.top[i])
            qi = np.repeat(self.q_item[:, i], rows)[:, None] * grid[None]
            S, C = Jtheta[:, [i]] * np.sin(qi), Jtheta[:, [i]] * np.cos(qi)
            S, C = S - U @ (U.T @ S), C - U @ (U.T @ C)
            gain = _quadratic_form(S.T @ rp, C.T @ rp, (S * S).sum(0), (C * C).sum(0), (S * C).sum(0))
            out[k] = (i, _peak(grid, gain))
        return out

    def _refine(self, i: int, f0: float, y: np.ndarray, weight: np.ndarray) -> float:
        """The least-squares frequency near the peak ``f0`` (within one grid step), to 0.01.

        ``y (poses,)`` is the residual along joint i's motion per pose, ``weight (poses,)`` the
        squared norm of its column; the columns' small overlap with the model's is neglected
        here (the statistic of the refined frequency is then computed exactly)."""
        grid = _in_band(f0 + np.linspace(-1.0, 1.0, _REFINE_POINTS) * self.step[i], self.top[i])
        phase = np.outer(self.q_pose[:, i], grid)
        s, c = np.sin(phase), np.cos(phase)
        gain = _quadratic_form(y @ s, y @ c, weight @ (s * s), weight @ (c * c), weight @ (s * c))
        return _peak(grid, gain)

    def _exact(self, i: int, f: float, Jtheta, rows: int, U, r, to_pose):
        """Exact cluster-robust Wald statistic of joint ``i`` at ``f`` with the columns made
        orthogonal to the model's ``U``; (0, None) when they are confounded with it."""
        c = self.columns(Jtheta, rows, [(i, f)])
        cp = c - U @ (U.T @ c)
        if (np.linalg.norm(cp, axis=0) < NG_RTOL * np.maximum(np.linalg.norm(c, axis=0), 1e-300)).any():
            return 0.0, None
        g = to_pose @ (cp * r[:, None])
        b = cp.T @ r
        V = g.T @ g * self.n_poses / max(self.n_poses - 1, 1)
        if np.linalg.det(V) <= 0:
            return 0.0, None
        return float(b @ np.linalg.solve(V, b)), cp


def _in_band(grid: np.ndarray, top: float) -> np.ndarray:
    """The refinement ``grid``'s frequencies a cyclic error can have: above the gear term's
    harmonics (a peak at the bottom of the searched band must not refine into them) and up to
    the joint's ``top`` (MAX_FREQUENCY, or lower where its angles alias)."""
    return grid[(grid >= _LOWEST) & (grid <= top)]


def _peak(grid: np.ndarray, gain: np.ndarray) -> float:
    """The grid's best frequency, refined by a parabola through its neighbours, to 0.01."""
    t = int(np.argmax(gain))
    if 0 < t < grid.size - 1:
        a, b, c = gain[t - 1], gain[t], gain[t + 1]
        shift = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c < 0 else 0.0
        return round(float(grid[t] + shift * (grid[1] - grid[0])), 2)
    return round(float(grid[t]), 2)


def _orthonormal(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis ``(M, rank)`` of the column space of ``A (M, p)`` (columns scaled first),
    the only (M x p) array made: the singular values and right vectors from the R factor of the
    scaled columns (:func:`robocal.identify.normal.r_factor`, chunk by chunk), the basis as the
    scaled columns times V / s, made orthonormal to rounding by one more chunked QR pass."""
    M, p = A.shape
    if p == 0:
        return np.zeros((M, 0))
    norms = np.linalg.norm(A, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    _, s, Vt = np.linalg.svd(r_factor(lambda c: A[c] / scale, M, p))
    keep = s > 1e-10 * max(s[0], 1e-300)
    T = Vt[keep].T / s[keep] / scale[:, None]  # (p, rank): the scaled columns' left singular vectors
    U = np.empty((M, int(keep.sum())))
    for c in row_chunks(M):
        U[c] = A[c] @ T
    R = r_factor(lambda c: U[c], *U.shape)  # close to the identity: undo the rounding of A @ T
    for c in row_chunks(M):
        U[c] = scipy.linalg.solve_triangular(R, U[c].T, trans="T").T
    return U


def _wald_scan(y: np.ndarray, q: np.ndarray, f0: float, step: float, n_freq: int) -> np.ndarray:
    """Cluster-robust Wald statistic of (sin, cos) at the grid frequencies ``f0 + k step``
    (``k < n_freq``); ``y (poses,)`` the residual along the joint's motion, ``q (poses,)`` its
    angle. A screening statistic (the best peaks are checked exactly); the variance sums use
    sin^2 = (1 - cos 2x) / 2, cos^2 = (1 + cos 2x) / 2, sin cos = sin 2x / 2."""
    y2 = y * y
    # sum y exp(i f q) and sum y^2 exp(2 i f q), f = f0 + k step: the grid's offset as a phase
    first = trig_sums(y * np.exp(1j * f0 * q), step * q, n_freq)
    double = trig_sums(y2 * np.exp(2j * f0 * q), 2.0 * step * q, n_freq)
    bs, bc = first.imag, first.real
    s2, c2 = double.imag, double.real
    total = float(y2.sum())
    return _quadratic_form(bs, bc, (total - c2) / 2.0, (total + c2) / 2.0, s2 / 2.0)


def _quadratic_form(a, b, gaa, gbb, gab) -> np.ndarray:
    """``[a b] G^-1 [a b]^T`` for the 2x2 matrices ``G = [[gaa, gab], [gab, gbb]]`` (vectorised);
    0 where G is singular."""
    det = gaa * gbb - gab * gab
    ok = det > 1e-30 * np.maximum(gaa * gbb, 1e-300)
    return np.where(ok, (gbb * a * a - 2.0 * gab * a * b + gaa * b * b) / np.where(ok, det, 1.0), 0.0)
