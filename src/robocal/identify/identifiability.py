"""Which parameters the data can identify (seed 003): column scaling, pivoted QR, rank.

Columns are scaled to unit norm (lengths and angles on one scale), then QR with column
pivoting orders them by independent information. A parameter whose pivot |R_jj| falls below
``rtol * |R_00|`` is not identifiable from these data: it is fixed and reported with the
parameters whose columns explain it (the confounders). The selection runs in stages (see
:data:`STAGES`): frame, SMR and nuisance parameters first, then the link parameters, then the
joint-error terms, each stage on what the kept columns of the earlier stages leave unexplained,
so that of a confounded pair the earlier stage's parameter is kept (d1 is dropped rather than
base.z, gear1_c1 rather than theta1). A joint-error parameter that refines another for a part of
the arm (a link group's thermal deviation from the shared k:
:func:`robocal.kinematics.joint_errors.is_refinement`) is selected after the other joint-error
terms, so of the redundant set (the shared k and every group's deviation) a deviation is set
aside, not the shared k. A joint-error parameter must be more clearly independent:
at least 1/sqrt(NG_MAX_VIF) of its (unit) column beyond what the columns kept before it explain
(the earlier stages' and the terms the greedy pivoting picked ahead of it), i.e. a variance
inflation factor below NG_MAX_VIF against those columns — not against the final set, where
terms picked after it can raise its VIF further — because a nearly confounded term (the
harmonics of a joint that moves over a narrow range, pinned down by a few extreme poses) fits
those poses and predicts new ones badly. Condition number of the scaled normal matrix with the
seed-003 classes, and the observability indices O1 (Borm & Menq) .. O4 over the identifiable set.

Rank is not the whole story: a parameter can pass the rank test and still be nearly confounded
(the UR wrist d5, a6, theta5, alpha6 beside the SMR offset). :func:`hold` moves such parameters,
those the data do not determine beyond their prior (:mod:`robocal.identify.priors`), from
``kept`` to ``undetermined``, each with its confounders; the condition number and the
observability indices then describe the set that is estimated.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from robocal.core.io import write_atomic
from robocal.identify import vocabulary
from robocal.identify.freedoms import freedom_lines
from robocal.identify.normal import r_factor
from robocal.identify.space import block_of
from robocal.kinematics.joint_errors import is_refinement

DEFAULT_RTOL = 1e-7
NG_MAX_VIF = 1000.0  # largest VIF of a kept joint-error term against the columns picked before it
NG_RTOL = float(1.0 / np.sqrt(NG_MAX_VIF))  # the smallest relative pivot a joint-error term keeps
# the order in which blocks are selected (robocal.identify.space.BLOCKS), each with the smallest
# relative pivot it keeps whatever the rtol asked for
STAGES = ((("base", "tool", "smr", "nuisance"), 0.0), (("links",), 0.0), (("joint_errors",), NG_RTOL))
TWIN_COS = 1.0 - 1e-9  # |cos| between two unit Jacobian columns beyond which they are one effect
NO_EFFECT = 1e-9  # column norm, relative to the largest, below which a parameter has no effect


def condition_class(cond: float) -> str:
    """Seed-003 classes of the normal matrix's condition number."""
    if cond < 100:
        return "weak"
    if cond <= 1000:
        return "moderate"
    return "strong"


@dataclass
class Identifiability:
    """Result of the analysis; ``kept`` and ``dropped`` are parameter names.

    Returned by `robocal.analyze` and held by ``CalibrationResult.identifiability``: which
    parameters a pose set determines (QR with column pivoting on the scaled Jacobian).

    Attributes
    ----------
    names : list of str
        The candidate parameters.
    kept : list of str
        The identifiable ones, estimated.
    dropped : list of str
        Not identifiable from these poses (held at nominal).
    confounded_with : dict of str to list of str
        For each dropped (or undetermined) parameter, the kept ones it is confounded with.
    rank : int
        Numerical rank of the scaled Jacobian.
    condition_number : float
        Condition number of the scaled normal matrix (``condition_class`` names its class).
    singular_values : numpy.ndarray, shape (k,)
        Singular values of the scaled Jacobian of the kept parameters, largest first.
    n_poses : int
        The number of poses.
    undetermined : list of str
        Parameters the data barely determine (held at nominal with their prior).
    prior_ratio : dict of str to float
        Posterior / prior sigma of each parameter with a prior.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> q = np.random.default_rng(1).uniform(robot.limits[:, 0], robot.limits[:, 1], (30, 6))
    >>> ident = rc.analyze(robot, q)
    >>> len(ident.kept) + len(ident.dropped) == len(ident.names), ident.rank == len(ident.kept)
    (True, True)
    >>> sorted(ident.observability)  # observability indices of the pose set
    ['O1', 'O2', 'O3', 'O4']
    """

    names: list[str]
    kept: list[str]
    dropped: list[str]
    confounded_with: dict[str, list[str]]
    rank: int
    condition_number: float
    singular_values: np.ndarray = field(repr=False)
    n_poses: int = 0
    undetermined: list[str] = field(default_factory=list)
    prior_ratio: dict[str, float] = field(default_factory=dict)  # posterior / prior sigma
    warnings: list[str] = field(default_factory=list)  # the summary names what is not estimated: none
    freedoms: list[dict] = field(default_factory=list)  # a SCARA's structural freedoms (identify.freedoms)

    @property
    def condition_class(self) -> str:
        """The class of ``condition_number`` (see `condition_class`)."""
        return condition_class(self.condition_number)

    @property
    def observability(self) -> dict[str, float]:
        """The observability indices O1-O4 of the pose set (from the singular values)."""
        s = self.singular_values
        if s.size == 0 or s[-1] <= 0:
            return {"O1": 0.0, "O2": 0.0, "O3": 0.0, "O4": 0.0}
        return {
            "O1": float(np.exp(np.mean(np.log(s))) / np.sqrt(max(self.n_poses, 1))),
            "O2": float(s[-1] / s[0]),
            "O3": float(s[-1]),
            "O4": float(s[-1] ** 2 / s[0]),
        }

    def to_dict(self) -> dict:
        """Plain data for the result JSON (condition number None where infinite: no parameter kept,
        or their columns dependent)."""
        return {"n_params": len(self.names), "rank": self.rank,
                "condition_number": self.condition_number if np.isfinite(self.condition_number) else None,
                "condition_class": self.condition_class, **self.observability,
                "kept": self.kept, "dropped": self.dropped, "undetermined": self.undetermined,
                "confounded_with": self.confounded_with, "structural_freedoms": self.freedoms}

    def write(self, json_path=None) -> list[str]:
        """Write `to_dict` as JSON to ``json_path`` (atomically); the paths written."""
        if json_path is None:
            return []
        write_atomic(json_path, json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n")
        return [str(json_path)]

    def summary(self) -> str:
        """A short human summary: rank, condition number, observability, then each parameter not
        estimated in the words of :mod:`robocal.identify.vocabulary`."""
        o = self.observability
        lines = [f"rank {self.rank} of {len(self.names)} parameters; condition number of the "
                 f"scaled normal matrix {self.condition_number:.3g} ({self.condition_class})",
                 "observability O1 {O1:.3g}  O2 {O2:.3g}  O3 {O3:.3g}  O4 {O4:.3g}".format(**o)]
        for name in self.dropped + self.undetermined:  # the words of robocal.identify.vocabulary
            lines.append(f"  {vocabulary.status(name, self)}: {name}  ({vocabulary.detail(name, self)})")
        return "\n".join(lines + freedom_lines(self.freedoms, "  "))


def _pivoted_rank(A: np.ndarray, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """Column indices of ``A`` (unit-scale columns; overwritten) kept by pivoted QR, and an
    orthonormal basis of their span."""
    if A.shape[1] == 0:
        return np.zeros(0, int), np.zeros((A.shape[0], 0))
    Q, R, piv = scipy.linalg.qr(A, mode="economic", pivoting=True, overwrite_a=True)
    rank = int(np.sum(np.abs(np.diag(R)) > rtol))
    return piv[:rank], Q[:, :rank]


def _unit_columns(J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``J`` with unit-norm columns, and the mask of columns with no effect. A column of rounding
    noise (a parameter these data cannot see at all, e.g. alpha1 for distances) must not be
    scaled up to a unit column that looks independent."""
    norms = np.linalg.norm(J, axis=0)
    zero = norms <= NO_EFFECT * norms.max(initial=0.0)
    return J / np.where(zero, 1.0, norms), zero


def _select(Js: np.ndarray, groups: Sequence[tuple[np.ndarray, float]], rtol: float) -> np.ndarray:
    """Sorted indices of the columns of ``Js`` (unit columns) kept stage by stage: each group of
    column indices on what the kept columns of the earlier groups leave unexplained, with its
    own smallest relative pivot."""
    kept, basis = [], np.zeros((Js.shape[0], 0))
    for stage, (group, floor) in enumerate(groups):
        cols = Js[:, group]
        cols -= basis @ (basis.T @ cols)  # in place: one (M, group) array per stage
        picked, Q = _pivoted_rank(cols, max(rtol, floor))
        kept.append(group[picked])
        if stage < len(groups) - 1:  # the last stage's basis serves no later one
            basis = np.hstack([basis, Q])
    return np.sort(np.concatenate(kept))


def independent_columns(J: np.ndarray, k0: int, rtol: float = DEFAULT_RTOL,
                        later: np.ndarray | None = None) -> np.ndarray:
    """Sorted indices (0-based among the columns ``k0:``) of the joint-error columns of ``J (M, k)``
    that the joint-error stage keeps after the geometric columns ``J[:, :k0]`` (all kept);
    ``later`` ``(k - k0,)`` bool: the refinements, selected after the others."""
    Js, zero = _unit_columns(J)
    geometric, terms = np.arange(k0), np.arange(k0, J.shape[1])
    later = np.zeros(terms.size, bool) if later is None else np.asarray(later, bool)
    stages = [(geometric[~zero[:k0]], 0.0), (terms[~zero[k0:] & ~later], NG_RTOL),
              (terms[~zero[k0:] & later], NG_RTOL)]
    kept = _select(Js, stages, rtol)
    return kept[kept >= k0] - k0


def analyze(J: np.ndarray, names: Sequence[str], n_poses: int,
            rtol: float = DEFAULT_RTOL) -> Identifiability:
    """Identifiability of ``names`` from the Jacobian ``J (M, k)`` (weighted rows), selected in
    the :data:`STAGES` of the module docstring."""
    names = list(names)
    Js, zero = _unit_columns(J)
    blocks = np.array([block_of(nm) for nm in names])
    later = np.array([block == "joint_errors" and is_refinement(nm) for nm, block in zip(names, blocks,
                                                                                          strict=True)], bool)
    stages = [(np.flatnonzero(np.isin(blocks, stage) & ~zero & (later if refine else ~later)), floor)
              for stage, floor in STAGES for refine in (False, True)]  # a stage's refinements after it
    kept_idx = _earlier_twins(Js, blocks, zero, _select(Js, [s for s in stages if s[0].size], rtol))
    rank = kept_idx.size
    drop_idx = sorted(set(range(len(names))) - set(kept_idx.tolist()))
    s, cond = _spectrum(Js, kept_idx)
    return Identifiability(names=names, kept=[names[j] for j in kept_idx],
                           dropped=[names[j] for j in drop_idx],
                           confounded_with=_confounders(Js, zero, names, kept_idx, drop_idx),
                           rank=rank, condition_number=cond, singular_values=s, n_poses=n_poses)


def _earlier_twins(Js: np.ndarray, blocks: np.ndarray, zero: np.ndarray, kept_idx: np.ndarray) -> np.ndarray:
    """``kept_idx`` with, of two link parameters that have one effect (unit columns parallel beyond
    :data:`TWIN_COS`: d2 and d3 of two parallel axes), the earlier in the chain kept: which of them
    the pivoting keeps depends on rounding, and every analysis of the same poses must name the same."""
    kept = set(kept_idx.tolist())
    links = [j for j in range(Js.shape[1]) if blocks[j] == "links" and not zero[j]]
    for j in links:
        later = [k for k in links if k > j and k in kept]
        if j in kept or not later:
            continue
        twins = np.flatnonzero(np.abs(Js[:, j] @ Js[:, later]) > TWIN_COS)
        if twins.size:
            kept.discard(later[twins[0]])
            kept.add(j)
    return np.array(sorted(kept), dtype=kept_idx.dtype)


def _spectrum(Js: np.ndarray, kept_idx: np.ndarray) -> tuple[np.ndarray, float]:
    """Singular values of the unit columns ``Js[:, kept_idx]`` (those of their R factor, made
    chunk by chunk: no copy of the columns) and the condition number of their normal matrix."""
    if not kept_idx.size:
        return np.zeros(0), float("inf")
    s = np.linalg.svd(r_factor(lambda c: Js[c][:, kept_idx], Js.shape[0], kept_idx.size), compute_uv=False)
    return s, float((s[0] / s[-1]) ** 2) if s[-1] > 0 else float("inf")


def _confounders(Js: np.ndarray, zero: np.ndarray, names: Sequence[str], kept_idx: np.ndarray,
                 targets: Sequence[int]) -> dict[str, list[str]]:
    """For each target column: the (up to 4) kept parameters whose columns explain it most."""
    out: dict[str, list[str]] = {}
    if not len(targets):
        return out
    # least squares of the targets on the kept columns, from the R factor of [kept | targets]:
    # [[R11 R12] [0 R22]] gives the same coefficients as the columns themselves (R11 x = R12)
    cols, k = np.r_[kept_idx, list(targets)].astype(np.int64), len(kept_idx)
    R = r_factor(lambda c: Js[c][:, cols], Js.shape[0], cols.size)
    coef = np.linalg.lstsq(R[:k, :k], R[:k, k:], rcond=None)[0] if k else np.zeros((0, cols.size))
    for c, j in enumerate(targets):
        weights = np.abs(coef[:, c])
        if zero[j] or weights.max(initial=0) == 0:
            out[names[j]] = []
            continue
        order = np.argsort(-weights)
        out[names[j]] = [names[kept_idx[i]] for i in order if weights[i] > 0.1 * weights[order[0]]][:4]
    return out


def hold(ident: Identifiability, J: np.ndarray, undetermined: list[str],
         ratio: dict[str, float]) -> Identifiability:
    """``ident`` (of the columns ``J (M, len(ident.names))``) with the kept parameters
    ``undetermined`` (by the data beyond their prior; ``ratio``: posterior / prior sigma of the
    kept ones) moved to ``undetermined``, with their confounders among the parameters still kept;
    spectrum of the rest."""
    Js, zero = _unit_columns(J)
    kept = [nm for nm in ident.kept if nm not in undetermined]
    kept_idx = np.array([ident.names.index(nm) for nm in kept], dtype=np.int64)
    targets = [ident.names.index(nm) for nm in undetermined]
    confounded = {**ident.confounded_with, **_confounders(Js, zero, ident.names, kept_idx, targets)}
    s, cond = _spectrum(Js, kept_idx)
    return Identifiability(names=ident.names, kept=kept, dropped=ident.dropped, confounded_with=confounded,
                           rank=ident.rank, condition_number=cond, singular_values=s,
                           n_poses=ident.n_poses, undetermined=undetermined,
                           prior_ratio={nm: float(ratio[nm]) for nm in ident.kept if nm in ratio})
