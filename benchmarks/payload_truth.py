"""An independent payload truth: joints that yield under the gravity moment of the load (and
optionally of the arm's own links), written without robocal's payload term.

Each joint i turns ``dq_i = c_i tau_i`` (``c_i`` rad per kg m, per unit of gravity) with
``tau_i = z_i . sum_b m_b ((r_b - o_i) x g_hat)`` summed over the bodies beyond joint i: the load
(mass ``m``, centre of mass ``com`` in the flange frame, the *true* one, which the rows need not
record) and, optionally, the links (``own``: mass and centre of mass in each link's frame). The
frames are those of the deflected arm: the moments are evaluated again at ``q + dq`` until the
turn settles (``ITERATIONS`` fixed-point passes), so the truth is not the first-order model the
fit uses. The links grow by ``1 + k (T - T_ref)`` (a, d) with the row's temperature. The points
are the true tool's positions plus the simulator's own noise draw.

Used by ``benchmarks/bench_payload_thermal.py`` (the independent-truth section) and
``tests/test_payload_thermal.py`` (recovery of known compliances and centre of mass).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal import Robot
from robocal.data.simulate import simulate_tracker
from robocal.kinematics.fk import LinkArrays, chain_fk, chain_frames

ITERATIONS = 3  # fixed-point passes of the deflection at the deflected frames
# each joint's turn at the reach for the heaviest load held there, mm (a KR 210's order)
DEFLECTION_MM = (1.0, 4.0)
THERMAL_K = 11.5e-6  # 1/K, steel
TRUE_COM_M = (0.06, -0.04, 0.32)  # the load's true centre of mass in the flange frame
RECORDED_COM_M = (0.0, 0.0, 0.25)  # what the rows record (the program's nominal load data)
# a KR 210's links 1..6, kg (link 1 turns about the vertical: no moment), and their centres of mass
# in their own frames, m (the "own weight" variant)
LINK_MASS_KG = (240.0, 310.0, 190.0, 60.0, 25.0, 5.0)
LINK_COM_M = ((0.0, 0.0, -0.2), (0.55, 0.0, 0.1), (0.1, 0.0, 0.15), (0.0, 0.0, -0.4), (0.0, 0.05, 0.0),
              (0.0, 0.0, 0.02))


def gravity_moments(robot: Robot, q: np.ndarray, load: np.ndarray, own=None) -> np.ndarray:
    """``(N, n)`` kg m: the gravity moment per unit g about each joint's axis of the load ``(N, 4)``
    (kg, centre of mass in the flange frame, m) and of the links ``own`` (``(masses (n,), centres
    (n, 3))``, each in its link's frame; None: weightless links) at joints ``q (N, n)``, with
    ``robot``'s geometry (its joint errors are not applied)."""
    _, F = chain_frames(robot.links, robot.base, np.eye(4), q, frames=True, prismatic=robot.prismatic)
    g_hat = -F[:, 0, :3, 2]
    n = q.shape[1]
    bodies = [(load[:, 0], F[:, n, :3, 3] + np.einsum("nij,nj->ni", F[:, n, :3, :3], load[:, 1:]), n)]
    if own is not None:
        for link, (m, c) in enumerate(zip(*own, strict=True), start=1):
            bodies.append((np.full(len(q), m), F[:, link, :3, 3] + F[:, link, :3, :3] @ np.asarray(c), link))
    tau = np.zeros(q.shape)
    for i in range(n):
        z, o = F[:, i + 1, :3, 2], F[:, i + 1, :3, 3]
        for m, r, link in bodies:
            if link >= i + 1:  # the body is carried by joint i
                tau[:, i] += m * np.einsum("nj,nj->n", z, np.cross(r - o, g_hat))
    return tau


def yielded_joints(robot: Robot, q: np.ndarray, load: np.ndarray, compliance: np.ndarray,
                   own=None) -> np.ndarray:
    """``(N, n)`` rad: the joints ``q`` reached when each joint turns ``compliance (n,)`` times the
    gravity moment at the deflected frames (fixed point, :data:`ITERATIONS` passes)."""
    reached = q
    for _ in range(ITERATIONS):
        reached = q + compliance * gravity_moments(robot, reached, load, own)
    return reached


def campaign(seed: int, n_cal: int = 300, n_held: int = 100, noise_mm: float = 0.02,
             payloads=(0.0, 75.0, 150.0), held_payload: float = 110.0, temperatures=(20.0, 35.0),
             held_temperature: float = 28.0, true_com=TRUE_COM_M, recorded_com=RECORDED_COM_M,
             own_weight: bool = False, robot_name: str = "kuka_kr210_r2700"):
    """``(nominal, calibration data, held-out data, held-out noise floor mm, truth dict)``: a
    campaign in blocks per payload warming through ``temperatures`` (as
    :func:`robocal.data.simulate.simulate_tracker` schedules it; its geometric truth, poses, SMRs and
    noise), the points replaced by this module's physics; the rows record ``recorded_com``. The
    truth dict: ``compliance (n,)`` rad per kg m, ``com (3,)`` m, ``thermal_k`` 1/K, ``robot``."""
    nominal = Robot.from_catalog(robot_name)
    sims = [simulate_tracker(nominal, n_cal, noise_mm=noise_mm, seed=seed, payloads=list(payloads),
                             temperatures=temperatures, payload_com=recorded_com)]
    truth = replace(sims[0].truth, joint_errors=None)
    sims.append(simulate_tracker(truth, n_held, noise_mm=noise_mm, seed=seed + 100, as_is=True,
                                 payloads=[held_payload], temperatures=(held_temperature, held_temperature),
                                 payload_com=recorded_com))
    rng = np.random.default_rng([seed, 44])
    n = nominal.n_joints
    reach = float(np.linalg.norm(nominal.fk(np.zeros((1, n)))[0, :3, 3] - nominal.base[:3, 3]))
    compliance = np.r_[0.0, rng.uniform(*DEFLECTION_MM, n - 1) * 1e-3 / reach / (max(payloads) * reach)]
    own = (np.asarray(LINK_MASS_KG), np.asarray(LINK_COM_M)) if own_weight else None
    t_ref = float(np.mean(sims[0].data.temperature))
    out = []
    for sim in sims:
        d = sim.data
        load = np.c_[d.payload[:, :1], np.tile(np.asarray(true_com, float), (len(d), 1))]
        reached = yielded_joints(truth, sim.true_joints, load, compliance, own)
        s = 1.0 + np.outer(d.temperature - t_ref, np.full(n, THERMAL_K))
        L = truth.links
        links = LinkArrays(L.alpha, L.a * s, L.beta, L.theta, L.d * s)
        T = chain_fk(links, truth.base, truth.tools_for(d.smr), reached, prismatic=truth.prismatic)
        out.append(replace(d, points=T[:, :3, 3] + sim.noise))
    return nominal, out[0], out[1], sims[1].noise_floor_mm, {
        "compliance": compliance, "com": np.asarray(true_com, float), "thermal_k": THERMAL_K, "robot": truth}
