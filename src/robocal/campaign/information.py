"""What each candidate pose would tell the identification: noise-weighted Jacobian blocks.

The parameters are those ``params='auto'`` identifies on the chosen kind of data: the robot's
default free set without what the kind can never see, reduced by the identifiability analysis
(pivoted QR) on the candidates together (at most ``IDENTIFIABILITY_ROWS`` residual rows from
measurements spread over all of them: what is identifiable is structural). A candidate's block
holds the identification-Jacobian rows of every measurement it gives (one per SMR the tracker
sees for points, a 6-DOF pose, a plane contact, a distance), each whitened by its noise model
(:class:`robocal.trust.posterior.Noise`) so that ``G^T G`` is the information in 1/unit^2.

The information matrix is the calibration's posterior one, ``M = P^-1 + sum G_j^T G_j``, with
``P`` the priors every fit carries (:func:`robocal.identify.priors.prior_sigma`, joint-error terms
included; frames and SMR offsets have none). The unknowns are those the rank test keeps on all
candidates together and those it drops that have a prior and an effect (d1 beside the base
height, a wrist twist beside the tool): the fit holds these at nominal, and their prior is what
remains of their error, so the plan neither ignores them nor spends poses on what the priors
already pin.

The region of interest enters through ``A = mean_region(J_r^T J_r)``
(:func:`robocal.trust.coverage.region_matrix`, the TCP Jacobian the predicted accuracy of a
calibration uses), so ``trace(M^-1 A)`` is the mean predicted variance (m^2) of the TCP position
over the region after calibration: the ``predicted_accuracy`` of ``calibrate`` before the
unmodelled error.

What a chosen set determines is judged as the calibration judges it
(:func:`robocal.trust.posterior.judge`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError
from robocal.data.kinds import OBSERVED
from robocal.data.measurements import Measurements
from robocal.identify.identifiability import Identifiability, analyze
from robocal.identify.priors import prior_sigma
from robocal.identify.problem import CalibrationProblem
from robocal.trust.coverage import region_matrix
from robocal.trust.posterior import Noise, judge, whitened_jacobian

IDENTIFIABILITY_ROWS = 12000         # residual rows (items spread over all candidates) analysed


@dataclass
class Information:
    """Candidate blocks ``G (C, r, p)`` (columns scaled by ``scale``) of the unknowns ``names``
    (``robot_names`` without the nuisance) and their prior precisions ``prior (p,)`` in the
    scaled unknowns (0: no prior), ``rows (C,)`` the residual rows each candidate gives, the
    candidates' measurement data ``data`` (``group`` the candidate of each data row,
    ``row_group`` of each residual row), the unweighted Jacobian ``J_raw`` of all rows over
    ``all_names`` and its whitened rows ``J_white``, with the priors ``sigma`` (SI, inf: none)
    of ``all_names`` (for :func:`judge` of a chosen set, as ``robocal analyze`` computes it);
    ``identifiable`` how many of ``names`` the rank test keeps (the rest only their priors pin),
    ``structure`` that test's result."""

    G: np.ndarray
    scale: np.ndarray
    prior: np.ndarray
    names: list[str]
    robot_names: list[str]
    rows: np.ndarray
    data: Measurements
    group: np.ndarray
    row_group: np.ndarray
    J_raw: np.ndarray
    J_white: np.ndarray
    sigma: np.ndarray
    all_names: list[str]
    identifiable: int
    structure: Identifiability

    def region_matrix(self, robot, q_region: np.ndarray) -> np.ndarray:
        """``A (p, p)`` in the scaled unknowns: :func:`robocal.trust.coverage.region_matrix` of
        the TCP position over the region joints ``q_region (R, n)``; zero on nuisance unknowns."""
        k = len(self.robot_names)
        A = np.zeros((len(self.names), len(self.names)))
        A[:k, :k] = region_matrix(robot, self.robot_names, q_region)
        return A / np.outer(self.scale, self.scale)

    def analyze_subset(self, candidates: np.ndarray) -> Identifiability:
        """:func:`judge` of the chosen candidates (as ``robocal analyze`` does it)."""
        rows = np.isin(self.row_group, candidates)
        n_poses = int(np.unique(self.data.pose_id[np.isin(self.group, candidates)]).size)
        return judge(self.J_raw[rows], self.J_white[rows], self.all_names, self.sigma, n_poses)


def candidate_data(robot, kind: str, q: np.ndarray, visible: np.ndarray) -> Measurements:
    """Measurements a campaign at joints ``q (C, n)`` would give, with the model's own
    predictions as the measured values: one row per candidate and SMR it sees (points), one per
    candidate (poses)."""
    spec = OBSERVED.get(kind)
    if spec is None or not spec.sees_position:  # only a tracker's candidates follow from the joints
        raise DataError(f"{kind} candidates come from a file of contacts or pairs (--from): robocal "
                        "cannot place them without the fixture")
    cand, smr = np.nonzero(visible) if spec.several_smrs else (np.arange(len(q)), np.zeros(len(q), int))
    T = robot.fk(q[cand], smr=smr)
    return Measurements.from_arrays(kind, q[cand], smr=smr, pose_id=cand, **spec.readings(T))


def candidate_blocks(obs, data: Measurements, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Residual rows ``(M, k)`` of the observation ``obs`` of ``data`` grouped into candidate blocks
    ``G (C, r_max, k)`` (zero rows where a candidate gives fewer), with the candidate of each item
    ``(items,)`` and the items per candidate ``(C,)``. A candidate is a pose (all its SMRs' rows), or
    one pair of a distance measurement."""
    r = obs.rows_per_item
    item_group = data.pose_id if data.spec.group == "pose_id" else np.arange(obs.n_items)  # a pair: one item
    labels, cand_of_item = np.unique(item_group, return_inverse=True)
    per = np.bincount(cand_of_item, minlength=labels.size)
    order = np.argsort(cand_of_item, kind="stable")
    slot = np.empty(obs.n_items, int)
    slot[order] = np.arange(obs.n_items) - np.repeat(np.cumsum(per) - per, per)
    G = np.zeros((labels.size, per.max() * r, rows.shape[1]))
    items = rows.reshape(obs.n_items, r, -1)
    for k in range(r):  # a loop over the rows of one item only
        G[cand_of_item, slot * r + k] = items[:, k]
    return G, cand_of_item, per


def candidate_information(robot, data: Measurements, noise: Noise, params="auto",
                          structure: Identifiability | None = None) -> Information:
    """The candidate blocks of ``data`` (rows grouped into candidates by ``pose_id``; distances by
    pair) for the unknowns ``params`` identifies (see the module docstring); ``structure``: the
    identifiability of the same unknowns on candidates of the same structure (e.g. another SMR off
    the flange axis), reused instead of analysed again."""
    problem = CalibrationProblem(robot, data)
    obs = problem.observation
    space = problem.space(robot, params)
    robot_names, all_names = list(space.robot), space.names
    state = problem.start(robot)
    J_raw = problem.jacobian(state, space)  # the data carry no sigma: unit weights
    Jw = whitened_jacobian(robot, problem, state, J_raw, noise)
    r = obs.rows_per_item
    # which parameters are identifiable is structural: items spread over all candidates suffice
    count = min(obs.n_items, IDENTIFIABILITY_ROWS // r)
    sample = np.unique(np.linspace(0, obs.n_items - 1, count).astype(int))
    rows = (sample[:, None] * r + np.arange(r)).reshape(-1)
    ident = analyze(Jw[rows], all_names, data.n_poses) if structure is None else structure
    sigma = np.r_[prior_sigma(robot, robot_names), np.full(len(all_names) - len(robot_names), np.inf)]
    pinned = {nm for nm in ident.dropped  # no data on them, but a prior: what remains of their error
              if np.isfinite(sigma[all_names.index(nm)]) and ident.confounded_with[nm]}
    keep = [j for j, nm in enumerate(all_names) if nm in ident.kept or nm in pinned]
    G, cand_of_item, per = candidate_blocks(obs, data, Jw[:, keep])
    scale = np.sqrt(np.sum(G**2, axis=(0, 1)) / len(G))
    scale = np.where(scale > 0, scale, 1.0)
    names = [all_names[j] for j in keep]
    prior = np.where(np.isfinite(sigma[keep]), 1.0 / (sigma[keep] * scale) ** 2, 0.0)
    return Information(G=G / scale, scale=scale, prior=prior, names=names,
                       robot_names=[nm for nm in names if nm in robot_names],
                       rows=per * r, data=data, group=cand_of_item[obs.item_of_rows()],
                       row_group=np.repeat(cand_of_item, r), J_raw=J_raw, J_white=Jw, sigma=sigma,
                       all_names=all_names, identifiable=len(ident.kept), structure=ident)


