"""The table angles of a positioner's calibration campaign: SMR nests on the plate measured at angle
sets chosen so that the axes are found (issue 45).

A positioner is a `Robot` (its ``base`` the mount in the world, its ``tool`` the plate frame,
its joints its axes: ``Positioner.chain``). The laser tracker measures SMRs sitting in nests on the
plate, each at a plate position ``n_k`` (m), so a nest's world position at table angles ``e`` is
``p_k(e) = F(e) @ n_k`` with ``F`` the plate frame's world pose. Its identification Jacobian
follows from the chain's 6-row pose Jacobian of the plate frame (`Robot.jacobian` with
``kind='pose'``: position rows ``Jp``, world-frame rotation rows ``Jr``):

    dp_k = Jp - [R_F n_k]x Jr

(``[v]x`` the cross-product matrix), so:

- **known nests** (declared in the cell file at known plate positions): the unknowns are the
  axes (the chain's MDH rows), the mount (``base.*``) and the plate frame (three or more nests not
  on a line fix it, the turn axis' zero with it); as the cell's calibration does it
  (`robocal.calibration.cell.PLATE_HELD`), the plate's turn about the last axis and its offset
  along it are carried by that axis' zero and offset (``theta_n``, ``d_n``), ``tool.rz`` and
  ``tool.z`` held;
- **unknown nests**: each nest's plate position is estimated (``smr{k}.x/y/z``, dp_k/dn_k =
  R_F) and the plate frame is not: the last axis' zero is then confounded with the nests'
  rotation about it, and the rank test of the identifiability analysis says so.

A nest's SMR faces along the plate's z axis (``normals``): it is seen when the tracker lies within
the reflector's acceptance half-angle of that direction (a nest facing away from the tracker, or
a tracker below the plate, sees nothing) and inside its range (`robocal.campaign.Tracker`).

The design is chosen as the arm's (`robocal.campaign.exchange`): candidate angle sets drawn in
the limits (each a block of whitened rows, zero rows for nests the tracker does not see), the
posterior information ``M = P^-1 + sum G_j^T G_j`` (priors of `robocal.identify.priors`; frames
and nests have none), and the I criterion ``trace(M^-1 A)`` with ``A`` the mean ``J^T J`` of the
nests' positions over a region of table angles: its square root is the predicted RMS error of the
calibrated positioner at a nest seen at any angle (m), before the noise of a check measurement
(`TablePlan.predicted_heldout_mm` adds it). The same figures for a naive grid of as many angle
sets (`table_grid`) are the baseline the plan is compared with.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

import numpy as np

from robocal.calibration.cell import PLATE_HELD
from robocal.campaign.constraints import Funnel, Tracker, limits_with_margin, segment_segment_distance
from robocal.campaign.exchange import CRITERIA, averaged_search, criterion_value
from robocal.campaign.order import measuring_order
from robocal.campaign.programs import DEGREE_DECIMALS, fixed_point
from robocal.core.errors import DataError
from robocal.core.io import write_all
from robocal.core.version import __version__
from robocal.identify import vocabulary
from robocal.identify.identifiability import Identifiability, analyze
from robocal.identify.priors import prior_sigma
from robocal.ik.path import default_weights, travel
from robocal.kinematics.model import Robot
from robocal.kinematics.positioner import ZERO_AXIS, with_positioner_priors
from robocal.trust.posterior import Noise, judge

DEFAULT_TABLE_CANDIDATES = 2000     # angle sets drawn in the limits
DEFAULT_TABLE_REGION = 400          # angle sets of the region the predicted accuracy is over
DEFAULT_TABLE_MARGIN_DEG = 1.0      # generated angles stay this far inside the limits
NEST_NORMAL = (0.0, 0.0, 1.0)       # a nest's SMR faces along the plate z axis
ROUND_DECIMALS_DEG = 4              # generated angles are rounded to 1e-4 deg (1e-4 mm)
MAX_TABLE_DRAWS = 20                # candidate batches drawn before the tracker is declared blind
FULL_TURN_TOL = 1e-9                # rad: a revolute range this close to 2 pi is a whole turn
GRID_MIN_SPAN = 1e-9                # deg (mm): an axis' range counted no narrower in the grid's levels
FORMAT = "robocal-table-campaign/1"


@dataclass
class TablePlan:
    """The positioner's part of a cell campaign: table angles chosen by `plan_table`.

    Attributes
    ----------
    chain : Robot
        The positioner's nominal chain (base: the mount in the world; tool: the plate frame).
    name : str
        The positioner's name in the cell (its ``body`` in the measurements).
    joints : numpy.ndarray, shape (N, m)
        The chosen table angles, rad (m on a prismatic axis), in measuring order.
    visible : numpy.ndarray of bool, shape (N, K)
        Which nests the tracker sees at each angle set.
    nests : numpy.ndarray, shape (K, 3)
        The nests' plate positions, m; ``nests_known``: declared (the plate frame is identified)
        or only approximate (each nest's position is estimated).
    predicted_rms_mm : float
        Predicted RMS error of the calibrated positioner at a nest over the region of table
        angles, mm (3-D, from the noise and the priors).
    predicted_heldout_mm : float
        The same with a check measurement's own noise: the predicted RMS of held-out nest
        measurements, mm.
    grid_rms_mm, grid_heldout_mm : float
        The same figures for a naive grid of as many angle sets (`table_grid`; inf: it does not
        determine the positioner, even with the priors).
    grid_not_determined : list of str
        The parameters the plan estimates that the grid leaves to their priors (or cannot see): its
        figures then rest on the priors' spread, not on the data.
    sigma : dict
        Each identified parameter's predicted 1-sigma (SI: m, rad) after the campaign.
    identifiability : Identifiability
        What the chosen angles determine (rank test and priors, as `robocal.analyze`).
    parameters : list of str
        The unknowns the design is for.
    criterion, criterion_value
        The design criterion (``'I'`` or ``'D'``) and its value.
    funnel : Funnel
        How many candidates the limits and the tracker removed.
    noise : Noise
        The measurement noise of the prediction.
    settings : dict
        The planning settings.
    warnings : list of str
        What limits the plan.

    Examples
    --------
    >>> plan = plan_table(chain, 24, nests=nests, tracker=tracker)  # doctest: +SKIP
    >>> plan.predicted_rms_mm < plan.grid_rms_mm  # doctest: +SKIP
    True
    """

    chain: Robot
    name: str
    joints: np.ndarray
    visible: np.ndarray
    nests: np.ndarray
    nests_known: bool
    predicted_rms_mm: float
    predicted_heldout_mm: float
    grid_rms_mm: float
    grid_heldout_mm: float
    grid_not_determined: list[str]
    sigma: dict
    identifiability: Identifiability
    parameters: list[str]
    criterion: str
    criterion_value: float
    funnel: Funnel
    noise: Noise
    settings: dict
    warnings: list[str] = field(default_factory=list)

    @property
    def n(self) -> int:
        """The number of angle sets."""
        return len(self.joints)

    def summary(self) -> str:
        """What the plan measures and how well it determines the positioner."""
        ident = self.identifiability
        nests = "known nests (plate frame identified)" if self.nests_known else \
            "nests at unknown plate positions (each estimated)"
        lines = [f"{self.n} table angle sets of {self.name} ({self.chain.n_joints} axes), "
                 f"{int(self.visible.sum())} nest measurements, {len(self.nests)} {nests}, chosen from "
                 f"{self.funnel.left} candidates ({self.criterion}-optimal)",
                 f"predicted accuracy at a nest over the table's range: {self.predicted_rms_mm:.4f} mm RMS "
                 f"(held-out nest measurements {self.predicted_heldout_mm:.4f} mm); a grid of "
                 f"{self.n} angle sets: " + self._grid_text(),
                 f"{vocabulary.counts(ident)}; condition number {ident.condition_number:.3g} "
                 f"({ident.condition_class})",
                 "predicted 1-sigma after calibration: " + axis_sigma_text(self.sigma, self._units()),
                 f"candidates: {self.funnel.text()}"]
        lines += vocabulary.lines(ident, indent="  ")
        return "\n".join(lines + [f"WARNING: {w}" for w in self.warnings])

    def _units(self) -> dict[str, str]:
        """Each parameter's SI unit (`Robot.parameter_units`; the nests as the chain's SMRs)."""
        model = replace(self.chain, smr=self.nests, nominal=None)
        return dict(zip(model.parameter_names, model.parameter_units(), strict=True))

    def _grid_text(self) -> str:
        if not np.isfinite(self.grid_rms_mm):
            return "does not determine the positioner"
        text = f"{self.grid_rms_mm:.4f} mm ({self.grid_heldout_mm:.4f} mm)"
        if self.grid_not_determined:
            text += f", leaving {', '.join(self.grid_not_determined)} to their priors"
        return text

    def to_dict(self) -> dict:
        """Plain data (mm, deg) for JSON."""
        ident = self.identifiability
        return {
            "format": FORMAT, "robocal_version": __version__, "body": self.name,
            "positioner": self.chain.section(), "criterion": self.criterion, "n_poses": self.n,
            "nests_mm": (self.nests * 1e3).tolist(), "nests_known": self.nests_known,
            "predicted_rms_mm": self.predicted_rms_mm, "predicted_heldout_mm": self.predicted_heldout_mm,
            **{key: (value if np.isfinite(value) else None)  # None: the grid does not determine it
               for key, value in (("grid_rms_mm", self.grid_rms_mm),
                                  ("grid_heldout_mm", self.grid_heldout_mm))},
            "grid_not_determined": self.grid_not_determined,
            "joints_deg": [[float(fixed_point(v, DEGREE_DECIMALS)) for v in row]
                           for row in self.chain.joints_shown(self.joints)],
            "visible": self.visible.astype(int).tolist(),
            "sigma": {k: float(v) for k, v in self.sigma.items()},
            "identifiability": {key: v for key, v in ident.to_dict().items()
                                if key not in ("kept", "dropped", "undetermined", "confounded_with")},
            "parameters": self.parameters,
            "dropped": vocabulary.entries(ident.dropped + ident.undetermined, ident),
            "candidates": self.funnel.to_dict(), "settings": self.settings, "warnings": self.warnings,
        }

    def write(self, json_path) -> list[str]:
        """Write the JSON of `to_dict` to ``json_path``; the paths written."""
        write_all({json_path: json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"})
        return [str(json_path)]


def axis_sigma_text(sigma: dict[str, float], units: dict[str, str]) -> str:
    """The predicted 1-sigma of the parameters (SI: ``units`` their 'm' or 'rad', as
    `Robot.parameter_units` gives them) as 'name value unit' in mm and mdeg."""
    return ", ".join(f"{k} {v * 1e3:.3g} mm" if units[k] == "m" else f"{k} {np.rad2deg(v) * 1e3:.3g} mdeg"
                     for k, v in sigma.items())


def nest_geometry(chain: Robot, q: np.ndarray, nests: np.ndarray,
                  normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World positions and facing directions ``(N, K, 3)`` of nests ``(K, 3)`` (m, plate frame)
    facing ``normals (K, 3)`` (plate frame) at table angles ``q (N, m)``."""
    F = chain.fk(q)
    R = F[:, :3, :3]
    return (np.einsum("nij,kj->nki", R, nests) + F[:, None, :3, 3],
            np.einsum("nij,kj->nki", R, normals))


def nest_visibility(chain: Robot, q: np.ndarray, nests: np.ndarray, normals: np.ndarray,
                    tracker: Tracker | None, obstacles: np.ndarray | None = None) -> np.ndarray:
    """``(N, K)`` bool: the tracker sees nest k at angles ``q[i]`` (its SMR faces the tracker within
    the acceptance half-angle, inside the range, and, with ``obstacles`` ``(S, 2, 3)`` (segments, m:
    a parked arm's axis lines) and the tracker's arm radius, the beam clears them by that radius);
    all True without a tracker."""
    if tracker is None:
        return np.ones((len(q), len(nests)), bool)
    pos, nrm = nest_geometry(chain, q, nests, normals)
    d = tracker.position - pos
    dist = np.linalg.norm(d, axis=2)
    cos = np.sum(d * nrm, axis=2) / np.maximum(dist, 1e-300)
    lo, hi = tracker.range_m
    seen = (cos >= np.cos(np.deg2rad(tracker.acceptance_deg))) & (dist >= lo) & (dist <= hi)
    if obstacles is not None and len(obstacles) and tracker.arm_radius_m is not None:
        gap = segment_segment_distance(obstacles[:, 0], obstacles[:, 1], pos[..., None, :],
                                        tracker.position)       # (N, K, S)
        seen &= gap.min(axis=2) > tracker.arm_radius_m
    return seen


def table_unknowns(chain: Robot, n_nests: int, known: bool) -> list[str]:
    """The positioner's unknowns as its calibration frees them: the axes (the chain's link rows,
    beta on parallel axes), the mount, and the plate frame but its turn and offset along the last
    axis (known nests: `PLATE_HELD`) or each nest's plate position (unknown nests)."""
    names = [nm for nm in chain.default_free(orientation=True) if not nm.startswith(("tool.", "smr"))]
    if known:
        plate = [f"tool.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
        return names + [nm for nm in plate if nm not in PLATE_HELD]
    return names + [f"smr{k + 1}.{c}" for k in range(n_nests) for c in "xyz"]


def nest_jacobian(chain: Robot, q: np.ndarray, nests: np.ndarray, names: list[str]) -> np.ndarray:
    """``(N, K, 3, p)``: d(world position of nest k at angles ``q[i]``)/d(unknowns ``names``)
    (`table_unknowns`; see the module docstring), m per m or per rad."""
    chain_names = [nm for nm in names if not nm.startswith("smr")]
    J = chain.jacobian(q, chain_names, kind="pose")                # (N, 6, c)
    R = chain.fk(q)[:, :3, :3]
    r = np.einsum("nij,kj->nki", R, nests)                         # R_F n_k (N, K, 3)
    cross = np.cross(r[:, :, None, :], J[:, None, 3:, :].swapaxes(2, 3)).swapaxes(2, 3)  # r x Jr: (N,K,3,c)
    out = np.zeros((len(q), len(nests), 3, len(names)))
    cols = [names.index(nm) for nm in chain_names]
    out[..., cols] = J[:, None, :3, :] - cross                      # Jp - [r]x Jr = Jp - r x Jr
    for k in range(len(nests)):  # a loop over the nests only: each one's own position columns
        own = [j for j, nm in enumerate(names) if nm.startswith(f"smr{k + 1}.")]
        if own:
            out[:, k, :, own] = R.transpose(2, 0, 1)
    return out


@dataclass
class _Blocks:
    """The candidates' whitened blocks ``G (C, 3K, p)`` scaled by ``scale``, the priors' precisions in
    the scaled unknowns ``prior (p,)``, the unknowns ``names`` kept, the raw and whitened Jacobian
    rows over ``all_names`` with their prior ``sigma`` (for `judge`)."""

    G: np.ndarray
    scale: np.ndarray
    prior: np.ndarray
    names: list[str]
    keep: np.ndarray
    all_names: list[str]
    sigma: np.ndarray
    structure: Identifiability


def _blocks(chain: Robot, q: np.ndarray, visible: np.ndarray, nests: np.ndarray, names: list[str],
            noise: Noise, structure: Identifiability | None = None) -> tuple[_Blocks, np.ndarray, np.ndarray]:
    """The candidate blocks of angles ``q (C, m)`` (rows of unseen nests zero) and the raw / whitened
    Jacobian ``(C, K, 3, p)``."""
    J = nest_jacobian(chain, q, nests, names)
    pos, _ = nest_geometry(chain, q, nests, np.zeros_like(nests))
    W = noise.whitener(pos.reshape(-1, 3)).reshape(len(q), len(nests), 3, 3)
    Jw = np.einsum("nkij,nkjp->nkip", W, J) * visible[:, :, None, None]
    sigma = prior_sigma(with_positioner_priors(chain), names)  # the priors its calibration carries
    if structure is None:  # what is identifiable is structural: all candidates together
        rows = Jw[visible].reshape(-1, len(names))
        structure = analyze(rows, names, len(q))
    pinned = {nm for nm in structure.dropped if np.isfinite(sigma[names.index(nm)])
              and structure.confounded_with[nm]}
    keep = np.array([j for j, nm in enumerate(names) if nm in structure.kept or nm in pinned], int)
    G = Jw[..., keep].reshape(len(q), -1, len(keep))
    scale = np.sqrt(np.sum(G**2, axis=(0, 1)) / len(G))
    scale = np.where(scale > 0, scale, 1.0)
    prior = np.where(np.isfinite(sigma[keep]), 1.0 / (sigma[keep] * scale) ** 2, 0.0)
    return _Blocks(G=G / scale, scale=scale, prior=prior, names=[names[j] for j in keep], keep=keep,
                   all_names=names, sigma=sigma, structure=structure), J, Jw


def region_matrix(chain: Robot, q_region: np.ndarray, nests: np.ndarray, b: _Blocks) -> np.ndarray:
    """``A (p, p)`` in the scaled unknowns: the mean ``J^T J`` of the nests' positions over the region
    angles ``q_region (R, m)`` (every nest, seen or not: the accuracy of the plate everywhere)."""
    J = nest_jacobian(chain, q_region, nests, b.all_names)[..., b.keep].reshape(-1, len(b.keep))
    return (J.T @ J) / (len(q_region) * len(nests)) / np.outer(b.scale, b.scale)


def _draw(chain: Robot, count: int, limits: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    q = rng.uniform(limits[:, 0], limits[:, 1], (count, chain.n_joints))
    return np.where(chain.prismatic, np.round(q * 1e3, ROUND_DECIMALS_DEG) / 1e3,
                    np.deg2rad(np.round(np.rad2deg(q), ROUND_DECIMALS_DEG)))


def table_grid(chain: Robot, n: int, margin_deg: float = DEFAULT_TABLE_MARGIN_DEG) -> np.ndarray:
    """A naive design: ``n`` angle sets ``(n, m)`` on a regular grid over the limits less the margin,
    ``n`` factored into per-axis level counts in proportion to the axes' ranges (a revolute range
    counts at most one turn; over a whole turn the levels stop one step short of it, so no set
    repeats another)."""
    lim = limits_with_margin(chain, margin_deg)
    span = np.where(chain.prismatic, (lim[:, 1] - lim[:, 0]) * 1e3,   # mm counts as deg, as elsewhere
                    np.rad2deg(np.minimum(lim[:, 1] - lim[:, 0], 2 * np.pi)))
    log_span = np.log(np.maximum(span, GRID_MIN_SPAN))
    counts = min(_factorings(n, chain.n_joints),
                 key=lambda c: float(np.ptp(np.log(np.array(c, float)) - log_span)))
    axes = []
    for i, c in enumerate(counts):
        lo, hi = lim[i]
        if not chain.prismatic[i] and hi - lo >= 2 * np.pi - FULL_TURN_TOL:
            hi = lo + 2 * np.pi * (1 - 1 / c)
        axes.append(np.linspace(lo, hi, c) if c > 1 else np.array([(lo + hi) / 2]))
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.column_stack([g.reshape(-1) for g in mesh])


def _factorings(n: int, parts: int) -> list[tuple[int, ...]]:
    """Every ordered way of writing ``n`` as a product of ``parts`` positive integers."""
    if parts == 1:
        return [(n,)]
    return [(a, *rest) for a in range(1, n + 1) if n % a == 0 for rest in _factorings(n // a, parts - 1)]


def plan_table(chain: Robot, n: int, *, nests, nests_known: bool = True, normals=None,
               tracker: Tracker | None = None, noise_mm: float = 0.02, noise_model: str = "isotropic",
               criterion: str = "I", n_candidates: int = DEFAULT_TABLE_CANDIDATES,
               region_size: int = DEFAULT_TABLE_REGION, margin_deg: float = DEFAULT_TABLE_MARGIN_DEG,
               starts: int = 4, seed: int = 0, name: str | None = None,
               obstacles: np.ndarray | None = None) -> TablePlan:
    """Choose ``n`` table angle sets at which the tracker measures the plate's nests.

    Parameters
    ----------
    chain : Robot
        The positioner's nominal chain (``Positioner.chain``: base = mount in the world, tool =
        the plate frame), 1-3 axes.
    n : int
        The number of angle sets.
    nests : array_like, shape (K, 3)
        The nests' positions in the plate frame, m (known, or approximate: ``nests_known``).
    nests_known : bool, default True
        The nests are at known plate positions (the plate frame is identified, see the module
        docstring); False: each is estimated.
    normals : array_like, shape (K, 3), optional
        Each nest's facing direction in the plate frame (default: the plate's z axis).
    tracker : Tracker, optional
        The laser tracker (world frame): its line of sight and range decide which nests are seen.
    noise_mm, noise_model
        The tracker's noise (1 sigma per axis, mm) and model (``'isotropic'`` or ``'tracker'``).
    criterion : {'I', 'D'}
        I-optimal (the predicted accuracy at the nests over the table's range, default) or
        D-optimal.
    n_candidates, region_size, margin_deg, starts, seed
        Candidate angle sets drawn in the limits less ``margin_deg`` (deg; mm on a prismatic
        axis), region angle sets, random starts of the exchange search, the seed.
    name : str, optional
        The positioner's name (default the chain's).
    obstacles : array_like, shape (S, 2, 3), optional
        Segments (m, world) that block the beam within the tracker's ``arm_radius_m`` (an arm
        parked while the table turns: `robocal.campaign.cell`).

    Returns
    -------
    TablePlan

    Raises
    ------
    DataError
        Bad counts or nests (not a finite (K, 3) array), a criterion other than I or D, or no angle
        at which the tracker sees a nest.
    """
    nests, normals = _table_settings(n, criterion, nests, normals, n_candidates, region_size, starts)
    noise = Noise(sigma_m=float(noise_mm) * 1e-3, model=noise_model,
                  tracker_position=None if tracker is None else tracker.position)
    rng = np.random.default_rng(seed)
    limits = limits_with_margin(chain, margin_deg)
    funnel = Funnel()
    obstacles = None if obstacles is None else np.asarray(obstacles, float).reshape(-1, 2, 3)
    q, visible = _candidates(chain, int(n_candidates), limits, nests, normals, tracker, rng, funnel,
                             obstacles)
    names = table_unknowns(chain, len(nests), nests_known)
    b, J, Jw = _blocks(chain, q, visible, nests, names, noise)
    p_data = len(b.structure.kept)
    rows_min = 3 * int(visible.sum(axis=1).min())
    if n * 3 * len(nests) <= p_data or n < -(-p_data // max(rows_min, 1)):
        raise DataError(f"{n} angle sets cannot identify the {p_data} positioner parameters the nests "
                        f"determine: plan at least {p_data // max(rows_min, 1) + 1}")
    if len(q) < n:
        raise DataError(f"only {len(q)} candidate angle sets show a nest to the tracker, fewer than the {n} "
                        f"asked for: {funnel.text()}")
    q_region = _draw(chain, int(region_size), limits, np.random.default_rng([seed, 3]))
    A = region_matrix(chain, q_region, nests, b)
    found = averaged_search([(b.G, A, b.prior)], n, criterion=criterion, starts=int(starts), seed=seed)
    weights = default_weights(chain)
    chosen = found.indices[measuring_order(chain, q[found.indices], weights)]
    ms_grid, grid_missing = _grid_baseline(chain, n, margin_deg, nests, normals, tracker, obstacles, names,
                                           noise, b, A)
    heldout_noise = _noise_ms(noise, nest_geometry(chain, q_region, nests, normals)[0].reshape(-1, 3))
    ms = criterion_value(b.G, A, chosen, "I", b.prior)
    sigma = _kept_sigma(b, chosen)
    rows = visible[chosen].reshape(-1)
    ident = judge(J[chosen].reshape(-1, len(names))[np.repeat(rows, 3)],
                  Jw[chosen].reshape(-1, len(names))[np.repeat(rows, 3)], names, b.sigma, n)
    warnings = _table_warnings(n, nests_known, ms_grid, grid_missing)
    return TablePlan(
        chain=chain, name=name or chain.name, joints=q[chosen], visible=visible[chosen], nests=nests,
        nests_known=nests_known, predicted_rms_mm=float(np.sqrt(ms) * 1e3),
        predicted_heldout_mm=float(np.sqrt(ms + heldout_noise) * 1e3),
        grid_rms_mm=float(np.sqrt(ms_grid) * 1e3),
        grid_heldout_mm=float(np.sqrt(ms_grid + heldout_noise) * 1e3), grid_not_determined=grid_missing,
        sigma=sigma, identifiability=ident, parameters=list(b.names), criterion=criterion,
        criterion_value=found.value, funnel=funnel, noise=noise,
        settings={"seed": int(seed), "starts": int(starts), "criterion": criterion, "margin_deg": margin_deg,
                  "region_size": int(region_size), "noise_mm": float(noise_mm), "noise_model": noise_model,
                  "travel": travel(q[chosen], weights), "normals": normals.tolist(),
                  "tracker_mm": None if tracker is None else (tracker.position * 1e3).tolist()},
        warnings=warnings)


def _table_settings(n: int, criterion: str, nests, normals, n_candidates: int, region_size: int,
                    starts: int) -> tuple[np.ndarray, np.ndarray]:
    """`plan_table`'s arguments checked: the nests ``(K, 3)`` (m, plate frame) and their unit facing
    directions ``(K, 3)`` (default the plate's z axis); DataError naming the bad one."""
    if not isinstance(n, int | np.integer) or n < 1:
        raise DataError(f"the number of table angle sets must be a positive integer, got {n!r}")
    if criterion not in CRITERIA[:2]:
        raise DataError(f"the table's criterion is I or D, got {criterion!r}")
    nests = _check_nests(nests)
    normals = np.tile(NEST_NORMAL, (len(nests), 1)) if normals is None else np.asarray(normals, float)
    if normals.shape != nests.shape or (np.linalg.norm(normals, axis=1) < ZERO_AXIS).any():
        raise DataError(f"give one non-zero facing direction per nest ({len(nests)} nests)")
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    if int(n_candidates) < n or int(region_size) < 1 or int(starts) < 1:
        raise DataError("n_candidates must be >= the angle sets asked for; region_size and starts >= 1")
    return nests, normals


def _grid_baseline(chain: Robot, n: int, margin_deg: float, nests: np.ndarray, normals: np.ndarray,
                   tracker: Tracker | None, obstacles: np.ndarray | None, names: list[str], noise: Noise,
                   b: _Blocks, A: np.ndarray) -> tuple[float, list[str]]:
    """The naive grid of as many angle sets (`table_grid`), with what the tracker sees there, judged
    as the plan is: its mean squared error at the nests over the region (m^2, the I criterion in the
    plan's scaling ``b`` and region matrix ``A``; inf when it does not determine the positioner) and
    the parameters the plan estimates that it leaves to their priors (or cannot see)."""
    q_grid = table_grid(chain, n, margin_deg)
    v_grid = nest_visibility(chain, q_grid, nests, normals, tracker, obstacles)
    g, Jg, Jgw = _blocks(chain, q_grid, v_grid, nests, names, noise, b.structure)
    ms_grid = criterion_value(g.G / b.scale * g.scale, A, np.arange(len(q_grid)), "I", b.prior)
    grid_rows = np.repeat(v_grid.reshape(-1), 3)
    grid_ident = judge(Jg.reshape(-1, len(names))[grid_rows], Jgw.reshape(-1, len(names))[grid_rows], names,
                       b.sigma, len(q_grid)) if v_grid.any() else None
    missing = [nm for nm in b.structure.kept if grid_ident is None or nm not in grid_ident.kept
               or nm in grid_ident.undetermined]
    return ms_grid, missing


def _table_warnings(n: int, nests_known: bool, ms_grid: float, grid_missing: list[str]) -> list[str]:
    """What limits a table plan: estimated nests (the last axis' zero held), a grid that does not
    determine the positioner."""
    warnings = []
    if not nests_known:
        warnings.append("the nests' plate positions are estimated: the last axis' zero is confounded with "
                        "their rotation about it and is held at nominal; declare the nests (their known "
                        "plate positions) to identify it with the plate frame")
    if not np.isfinite(ms_grid) or grid_missing:
        warnings.append(f"a grid of {n} angle sets does not determine the positioner (the tracker sees too "
                        "few nests there): the plan's angles matter here")
    return warnings


def _kept_sigma(b: _Blocks, chosen: np.ndarray) -> dict[str, float]:
    """The predicted 1-sigma (SI) of the parameters the calibration estimates (those the rank test
    keeps; the others are held at nominal, their error absorbed by their confounders) with the
    design ``chosen``: ``sqrt(diag(M_kk^-1))`` of their posterior information."""
    k = np.array([j for j, nm in enumerate(b.names) if nm in b.structure.kept], int)
    H = b.G[chosen][..., k].reshape(-1, len(k))
    cov = np.linalg.pinv(H.T @ H + np.diag(b.prior[k])) / np.outer(b.scale[k], b.scale[k])
    return {b.names[j]: float(np.sqrt(max(cov[i, i], 0.0))) for i, j in enumerate(k)}


def _noise_ms(noise: Noise, points: np.ndarray) -> float:
    """The mean 3-D squared noise (m^2) of a measurement at ``points (R, 3)`` m."""
    W = noise.whitener(points)
    return float(np.mean(np.trace(np.linalg.inv(np.swapaxes(W, 1, 2) @ W), axis1=1, axis2=2)))


def _check_nests(nests) -> np.ndarray:
    """Nests as a finite ``(K, 3)`` array (m). Known nests on one line leave the plate's turn about
    it undetermined: the identifiability analysis names it."""
    arr = np.asarray(nests, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3 or not len(arr) or not np.isfinite(arr).all():
        raise DataError("nests must be finite (K, 3) plate positions in m")
    return arr


def _candidates(chain, count, limits, nests, normals, tracker, rng, funnel, obstacles):
    """Angle sets drawn in the limits until ``count`` show at least one nest to the tracker."""
    kept_q, kept_v, total = [], [], 0
    for _ in range(MAX_TABLE_DRAWS):
        q = _draw(chain, count, limits, rng)
        funnel.start += len(q)
        visible = nest_visibility(chain, q, nests, normals, tracker, obstacles)
        seen = visible.any(axis=1)
        blocked = "" if obstacles is None or tracker is None or tracker.arm_radius_m is None else \
            ", the beam clear of the parked arms"
        funnel.record(f"the tracker line of sight and range{blocked} (no nest seen)", int((~seen).sum()))
        kept_q.append(q[seen])
        kept_v.append(visible[seen])
        total += int(seen.sum())
        if total >= count:
            break
    if total == 0:
        raise DataError(f"the tracker sees no nest at any table angle: {funnel.text()}; move the tracker "
                        "above the plate, within its range, or widen the acceptance angle")
    if total > count:
        funnel.record(f"keeping the {count} asked for", total - count)
    return np.concatenate(kept_q)[:count], np.concatenate(kept_v)[:count]
