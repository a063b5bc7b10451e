"""The interface every observation type implements (see ``point.py`` for the simplest)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.kinematics.fk import chain_frames
from robocal.kinematics.jacobian import identification_jacobian
from robocal.kinematics.joint_errors import joint_error_basis, scatter_offsets
from robocal.kinematics.thermal import link_coefficients as thermal_coefficients
from robocal.kinematics.thermal import scale as thermal_scale
from robocal.kinematics.thermal import scaled_links


class SixDWeights:
    """A 6-D observation's rows weighed in one norm: per item 3 position rows (m) and 3 rotation
    rows (rad) times ``length_scale`` (m per rad; estimated by
    :mod:`robocal.identify.variance_components`, which reads ``variance_groups``)."""

    variance_groups = ("position", "rotation")  # rows per item: 3 of each (variance components)
    kind: str

    def set_length_scale(self, length_scale: float) -> None:
        """Weigh a rad of orientation residual like ``length_scale`` m of position residual
        (> 0; IdentificationError otherwise)."""
        if not length_scale > 0:
            raise IdentificationError(f"the length scale of {self.kind} rows must be positive (m per rad), "
                                      f"got {length_scale}")
        self.length_scale = float(length_scale)
        self.scale = np.r_[np.ones(3), np.full(3, self.length_scale)]


class Observation:
    """Residuals ``measured - modelled`` (unweighted, SI) and their Jacobian rows.

    Subclasses set ``kind``, ``rows_per_item`` and implement :meth:`residuals`,
    :meth:`jacobian` and :meth:`residuals_batch`. Items are the measurement rows; each gives
    ``rows_per_item`` residuals. Observation types with nuisance parameters (plane
    coefficients) list them in :attr:`nuisance_names` and solve for them with the robot.
    """

    kind = "abstract"
    rows_per_item = 1
    nuisance_names: list[str] = []
    blind_spot = ""  # why :meth:`not_observable` is not empty, for the result's warnings
    # the data are measured in the robot's world (a tracker's, an instrument's frame): False for
    # contacts and distances, whose calibration holds up to a rigid motion (robocal.trust.gauge)
    world_frame = True

    def __init__(self, data, robot) -> None:
        self.data = data
        self.q = robot.check_joints(data.joints)
        self.smr = np.asarray(data.smr, dtype=int)
        self.conditions = data.conditions  # approach, travel, payload, temperature of each row
        self.item_sigma = None if data.sigma is None else np.asarray(data.sigma, dtype=float)
        self._basis = None  # (robot, B, joint): the joint-error basis batch_tcp last used

    @property
    def n_items(self) -> int:
        return self.q.shape[0]

    def not_observable(self, robot) -> list[str]:
        """Parameters this kind of data can never identify ('auto' leaves them out)."""
        return []

    def scale_reference(self, robot) -> str | None:
        """The length parameter held at nominal for the scale when the data carry no length
        reference (plane, flush contacts), else None."""
        return None

    def check_enough(self, n_unknowns: int) -> None:
        """Raise IdentificationError when the data are too few for ``n_unknowns`` (kinds with a
        sharper count than the general residuals-versus-rank check)."""

    def item_of_rows(self) -> np.ndarray:
        """``(N,)``: the measurement item each data row belongs to (each row is one item here)."""
        return np.arange(self.q.shape[0])

    def nuisance_start(self, robot) -> np.ndarray:
        """Starting values of the nuisance parameters ``(m,)``."""
        return np.zeros(len(self.nuisance_names))

    def export_nuisance(self, nuisance: np.ndarray) -> dict[str, np.ndarray]:
        """The nuisance parameters as physical entities independent of this data set's
        parametrisation (e.g. ``{"plane3": [nx, ny, nz, c]}``), to judge other data with them."""
        return {}

    def import_nuisance(self, robot, entities: dict[str, np.ndarray]) -> np.ndarray:
        """Nuisance values ``(m,)`` taking the ``entities`` this data set shares (see
        :meth:`export_nuisance`) and fitting the others to ``robot``."""
        return self.nuisance_start(robot)

    def residual_scale(self, default_sigma: float = 1.0) -> np.ndarray:
        """Per-residual standard deviation ``(N * rows_per_item,)`` used for weighting."""
        sigma = np.full(self.n_items, default_sigma) if self.item_sigma is None else self.item_sigma
        return np.repeat(sigma, self.rows_per_item)

    def residuals(self, robot, nuisance: np.ndarray) -> np.ndarray:
        """``(N * rows_per_item,)`` residuals."""
        raise NotImplementedError

    def jacobian(self, robot, names: Sequence[str], nuisance: np.ndarray) -> np.ndarray:
        """``(N * rows_per_item, len(names) + len(nuisance))`` d(modelled)/d(parameters)."""
        raise NotImplementedError

    def residuals_batch(self, robot, names: Sequence[str], X: np.ndarray,
                        nuisance: np.ndarray | None = None) -> np.ndarray:
        """Residuals ``(P, N * rows_per_item)`` for P displacement vectors ``X (P, k)`` of
        ``names`` around ``robot`` — one vectorised evaluation for a whole population."""
        raise NotImplementedError

    def profiled_residuals_batch(self, robot, names: Sequence[str], X: np.ndarray
                                 ) -> tuple[np.ndarray, np.ndarray]:
        """Residuals ``(P, N * rows_per_item)`` of P displacements ``X (P, k)`` with the nuisance
        parameters fitted per displacement, and those ``(P, m)``: here there are none (kinds with
        nuisance override this)."""
        return self.residuals_batch(robot, names, X), np.zeros((X.shape[0], 0))

    def modelled_points(self, robot, nuisance: np.ndarray | None = None) -> np.ndarray:
        """``(N, 3)`` modelled positions (TCP / SMR / probe tip) in the world frame, m."""
        return self._fk(robot)[:, :3, 3]

    def position_errors(self, robot, nuisance: np.ndarray) -> np.ndarray:
        """``(N,)`` position error of each item in m (what the statistics report)."""
        r = self.residuals(robot, nuisance).reshape(self.n_items, self.rows_per_item)
        return np.linalg.norm(r[:, :3], axis=1)

    # shared by point-like observations ------------------------------------------------
    def _fk(self, robot) -> np.ndarray:
        """TCP poses ``(N, 4, 4)`` of the data rows: each with its SMR, joint-error terms from
        the rows' approach directions and moves."""
        return robot.fk(self.q, smr=self.smr, conditions=self.conditions)

    def _tcp_jacobian(self, robot, names: Sequence[str], kind: str = "point") -> np.ndarray:
        """d(TCP of each row)/d(``names``) ``(N, 3|6, k)`` (:func:`identification_jacobian`,
        ``kind`` 'point' or 'pose'), with the rows' SMRs, approach directions and moves."""
        return identification_jacobian(robot, self.q, names, kind, self.smr, self.conditions)

    def batch_tcp(self, robot, names, X, frames: bool = False):
        """TCP poses ``(P, N, 4, 4)`` of the displaced robots (each row with its SMR, joint-error
        terms applied with their basis at the undisplaced robot: exact at X = 0); with ``frames``
        (kinds whose rows are not the robot's SMRs) the tool's for every row and the world poses
        of frames {0}..{n} ``(P, N, n + 1, 4, 4)`` (as `Robot.fk`)."""
        moved = robot.displaced_arrays(names, X)
        P, (N, n) = X.shape[0], self.q.shape
        smr = np.zeros_like(self.smr) if frames else self.smr
        offsets = np.concatenate([moved.tool[:, None, :3, 3], moved.smr], axis=1)[:, smr]  # (P, N, 3)
        tools = np.broadcast_to(moved.tool[:, None], (P, N, 4, 4)).copy()
        tools[..., :3, 3] = offsets
        links = type(moved.links)(*(v[:, None, :] for v in moved.links))
        q = np.broadcast_to(self.q, (P, N, n))
        if moved.joint_errors is not None:
            if self._basis is None or self._basis[0] is not robot:  # once per robot, not per call
                self._basis = (robot, *joint_error_basis(robot, self.q, robot.joint_errors.names,
                                                         self.conditions))
            q = q + scatter_offsets(*self._basis[1:], moved.joint_errors, n)
            k = thermal_coefficients(robot.joint_errors.names, moved.joint_errors, robot.prismatic)  # (P, n)
            temperature = self.conditions.temperature
            if k is not None and temperature is not None:  # (P, N, n) scale of each displaced robot
                links = scaled_links(links, thermal_scale(k, temperature,
                                                          robot.joint_errors.reference_temperature_c))
        return chain_frames(links, moved.base[:, None], tools, q, frames=frames, prismatic=robot.prismatic)
