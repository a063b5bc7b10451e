"""The robot model: modified DH + parallel-axis beta, base and tool frames, limits, nominal values.

Parameter vector (the view every solver uses), in this order with these stable names::

    alpha1 a1 beta1 theta1 d1 ... alphan an betan thetan dn
    base.x base.y base.z base.rx base.ry base.rz  tool.x tool.y tool.z tool.rx tool.ry tool.rz
    smr1.x smr1.y smr1.z ...   (only when the tool carries extra SMRs)
    comp2_3 gear1_s1 backlash2 ...   (only the joint-error terms the model declares)

The first three groups are the geometry; the joint-error terms (compliance, gear, backlash: see
`robocal.kinematics.joint_errors`) are parameters like any other, nominally zero (the
controller's model has none). Values are SI (m, rad). ``base.r*``/``tool.r*`` hold the rotation
vector of the frame's rotation for reading and writing; solvers never add to them:
`Robot.displaced` applies rotation increments multiplicatively (base: about world axes
through the world origin, tool: about flange axes through the TCP), which is what the
identification Jacobian differentiates.

A model is immutable: its arrays are read-only, and every change (`displaced`,
`with_values`, `with_frames`, ...) returns a new robot.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from robocal.core.errors import DataError, ModelError, UnitError
from robocal.core.io import as_number, write_atomic
from robocal.core.magnitudes import check_cell_offset
from robocal.kinematics.catalog import catalog_kwargs
from robocal.kinematics.cell_file import (
    TRACK_SCALE,
    ArmEntry,
    chain_arrays,
    count_positioners,
    is_workcell,
    read_arms,
    read_cell,
)
from robocal.kinematics.conditions import UNKNOWN, Conditions
from robocal.kinematics.convert import dh_kwargs, mdh_kwargs, opw_chain, opw_kwargs, opw_parameters
from robocal.kinematics.fk import LinkArrays, chain_fk, chain_frames
from robocal.kinematics.jacobian import identification_jacobian
from robocal.kinematics.joint_errors import JointErrorModel
from robocal.kinematics.link_names import check_link_frames, link_numbers
from robocal.kinematics.model_file import (
    LINK_FIELDS,
    MAX_NAME,
    _text,
    dump_model,
    is_cell,
    on_disk,
    read_model_data,
    reading_model,
    robot_kwargs,
)
from robocal.kinematics.opw import OPWParameters
from robocal.kinematics.opw_geometry import opw_model
from robocal.kinematics.prior_spec import PriorSpec
from robocal.kinematics.thermal import link_coefficients as thermal_coefficients
from robocal.kinematics.thermal import scale as thermal_scale
from robocal.kinematics.thermal import scaled_links
from robocal.kinematics.transforms import make_transform, matrix_to_rotvec, rotation_fault, rotvec_to_matrix
from robocal.kinematics.ur import URForm, ur_form
from robocal.kinematics.urdf_read import urdf_kwargs

FRAME_FIELDS = ("x", "y", "z", "rx", "ry", "rz")
REVOLUTE, PRISMATIC = "revolute", "prismatic"  # the joint types (JointSpec.kind)
_LINK_IS_LENGTH = {"alpha": False, "a": True, "beta": False, "theta": False, "d": True}
OPW_MATCH_TOL = 1e-12  # m / rad: links this close to their OPW form's chain still have that form

# Default search half-widths around nominal (bounds for metaheuristics and sanity checks).
DEFAULT_SPAN = {"length": 0.005, "angle": np.deg2rad(1.0), "frame_length": 0.05,
                "frame_angle": np.deg2rad(5.0)}


# Magnitudes no real robot model has (a unit or typing error, or a corrupted file): refused.
# rad for a revolute joint, m for a prismatic one: a value written at its limit (in degrees, mm)
# converts to SI a rounding away from it, and is still at the limit (Robot.outside_limits).
LIMIT_TOL = 1e-9
MAX_LINK_M = 100.0  # a_i, d_i, SMR offsets
MAX_FRAME_M = 10_000.0  # base and tool translations (a tracker can stand far away, not 10 km)
MAX_ANGLE_RAD = 100.0  # alpha, beta, theta, finite joint limits (16 turns)


def _check_magnitude(arr: np.ndarray, bound: float, what: str, unit: str) -> None:
    big = np.flatnonzero(np.abs(arr) > bound)
    if big.size:
        k = big[0]
        raise ModelError(f"{what}[{k}] = {arr.flat[k]:.6g} {unit} is beyond +-{bound:g} {unit}: no real "
                         "robot model has it (a unit or typing error?)")


def _as_vector(values, n: int, what: str) -> np.ndarray:
    try:
        arr = np.array(values, dtype=float).reshape(-1)  # a copy: the robot never aliases user arrays
    except (TypeError, ValueError):
        raise ModelError(f"{what} must be {n} numbers") from None
    if arr.shape != (n,):
        raise ModelError(f"{what} must have {n} values, got {arr.size}")
    if not np.isfinite(arr).all():
        raise ModelError(f"{what} contains NaN or infinite values: {arr.tolist()}")
    return arr


def _as_frame(T, what: str) -> np.ndarray:
    if T is None:
        return np.eye(4)
    T = np.array(T, dtype=float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise ModelError(f"{what} must be a finite 4x4 transform")
    fault = rotation_fault(T[:3, :3])
    if fault:
        raise ModelError(f"{what} rotation is {fault}: not orthonormal with det +1")
    return T


def joints_in_units(q, prismatic) -> np.ndarray:
    """Joints ``q (..., n)`` (rad; m on a joint flagged in ``prismatic (n,)``) in each joint's unit
    (deg; mm on a prismatic joint): what joints files and messages show (`JointSpec.shown`)."""
    q = np.asarray(q, float)
    return np.where(prismatic, q * 1e3, np.rad2deg(q))


class JointSpec(NamedTuple):
    """One joint as messages, range checks and joints files name it (`Robot.joints`).

    Values are SI inside robocal (rad for a revolute joint, m for a prismatic one); files and
    messages show them in the joint's `unit` (deg or mm) under its `column` (``q3_deg``,
    ``q3_mm``, a track's ``e1_mm``).
    """

    name: str  # "q3", or "e1" for an external axis (a track's carriage)
    kind: str  # REVOLUTE or PRISMATIC
    limits: tuple[float, float]  # (lower, upper), rad or m

    @property
    def prismatic(self) -> bool:
        """Whether the joint slides (its value in m adds to its d) rather than turns."""
        return self.kind == PRISMATIC

    @property
    def unit(self) -> str:
        """What the joint is shown in: 'mm' (prismatic) or 'deg' (revolute)."""
        return "mm" if self.prismatic else "deg"

    @property
    def column(self) -> str:
        """The joint's CSV column, e.g. ``q3_deg``, ``q3_mm``, ``e1_mm``."""
        return f"{self.name}_{self.unit}"

    def shown(self, value: float | np.ndarray) -> float | np.ndarray:
        """``value`` (SI: rad or m; a number or an array) in the joint's `unit` (deg or mm)."""
        return np.multiply(value, 1e3) if self.prismatic else np.rad2deg(value)

    def describe(self, value: float) -> str:
        """``value`` (SI) with the joint's name, unit and limits, e.g. ``q2 = 95.2 deg (limits -95 ..
        155)``, ``e1 = 6343 mm (limits 0 .. 6000)``."""
        lo, hi = self.shown(np.array(self.limits))
        return f"{self.name} = {self.shown(value):.6g} {self.unit} (limits {lo:.6g} .. {hi:.6g})"


class DisplacedArrays(NamedTuple):
    """What `Robot.displaced_arrays` returns for displacements ``(..., k)``: link arrays
    ``(..., n)``, base and tool ``(..., 4, 4)``, SMR offsets ``(..., s, 3)`` and the joint-error
    values ``(..., m)`` (None when the robot declares no joint-error terms)."""

    links: LinkArrays
    base: np.ndarray
    tool: np.ndarray
    smr: np.ndarray
    joint_errors: np.ndarray | None


@dataclass(frozen=True, eq=False)
class Robot:
    """A serial robot in modified DH + beta. Lengths in m, angles in rad.

    The model is immutable: every change (`with_values`, `with_frames`, `displaced`) returns a
    copy. Build one with `from_catalog`, `from_mdh`, `from_dh`, `from_opw` or `load`; a
    calibration returns the calibrated one. Parameters are addressed by name (`parameter_names`:
    ``alpha1``, ``a1``, ``beta1``, ``theta1``, ``d1``, ... ``base.x`` ... ``tool.rz``, then the
    joint-error terms).

    Attributes
    ----------
    alpha, a, beta, theta, d : numpy.ndarray, shape (n,)
        Modified DH rows (Craig: alpha_{i-1}, a_{i-1}, theta offset, d_i) and Hayati's beta;
        metres and radians.
    base : numpy.ndarray, shape (4, 4)
        The world -> frame {0} transform, metres.
    tool : numpy.ndarray, shape (4, 4)
        The flange -> TCP (or SMR) transform, metres.
    limits : numpy.ndarray, shape (n, 2)
        Joint limits (lower, upper), radians.
    parallel : numpy.ndarray of bool, shape (n,)
        ``parallel[i]``: axis i is nominally parallel to axis i-1, so ``beta_(i+1)`` is a
        parameter there.
    nominal : numpy.ndarray, shape (p,)
        The nominal model's geometry vector (the controller's model, which has no joint-error
        terms: their nominal is zero, see `nominal_values`).
    name, description : str
        The model's name and a free description.
    opw : OPWParameters or None
        The OPW form of the nominal model (catalog robots), which travels with the model like
        ``nominal``; `has_opw_form` says whether this robot's own chain still follows it
        (closed-form IK needs that).
    smr : numpy.ndarray, shape (S, 3), optional
        Extra SMR offsets on the flange, metres (SMR 0 is the tool).
    joint_errors : JointErrorModel or None
        The non-geometric terms that `fk` applies (compliance, backlash, cyclic errors...).
    link_frames : dict or None
        The model's link names (a URDF's) and the frame {0..n} each moves with
        (`robocal.kinematics.link_names`): markers may name their link; None: the model names none.
    priors : PriorSpec or None
        What the model file (or `with_priors`) says about the parameter priors: the robot's class
        and group scales (`robocal.kinematics.prior_spec`, docs/priors.md); None: the class is
        chosen from the model and every group scale estimated from the data.
    payload_kg : float or None
        The vendor's rated payload, kg (a model file's ``payload_kg``: the catalog's), which the
        payloads a user gives are checked against (`robocal.core.magnitudes.check_payload`);
        None: not known.
    prismatic : numpy.ndarray of bool, shape (n,)
        ``prismatic[i]`` makes joint i prismatic: its value (m) adds to ``d_i`` (``theta_i`` stays
        a constant angle); ``d_i`` is its zero and a ``scale{i}`` joint-error term its encoder
        scale.

    See Also
    --------
    rc.load_model : A robot from a model YAML, a URDF or a catalog name.
    rc.Cell : Arms and positioners placed in one world.
    rc.Conditions : The payload and temperature of each row, for `fk` and `jacobian`.
    rc.calibrate : Identify the robot's parameters from measurements.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> robot = rc.Robot.from_catalog("abb_irb2600")
    >>> robot
    Robot('abb_irb2600', 6 joints)
    >>> q = np.zeros((1, 6))  # joints, rad
    >>> robot.fk(q)[0, :3, 3].round(3)  # TCP position, m
    array([1.03, 0.  , 1.26])
    >>> robot.jacobian(q, ["d1", "a2"]).shape  # (poses, x y z, parameters)
    (1, 3, 2)
    >>> longer = robot.with_values({"d1": robot.get("d1") + 0.001})  # 1 mm taller
    >>> round(float(longer.fk(q)[0, 2, 3] - robot.fk(q)[0, 2, 3]), 6)
    0.001
    >>> longer.save("irb2600_longer.yaml")
    >>> bool(np.array_equal(rc.Robot.load("irb2600_longer.yaml").values, longer.values))
    True
    """

    alpha: np.ndarray
    a: np.ndarray
    beta: np.ndarray
    theta: np.ndarray
    d: np.ndarray
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    limits: np.ndarray | None = None
    parallel: np.ndarray | None = None
    nominal: np.ndarray | None = None
    name: str = "robot"
    description: str = ""
    opw: OPWParameters | None = None
    smr: np.ndarray | None = None
    joint_errors: JointErrorModel | None = None
    prismatic: np.ndarray | None = None
    priors: PriorSpec | None = None
    link_frames: dict[str, int] | None = None
    payload_kg: float | None = None

    def __post_init__(self) -> None:
        n = np.asarray(self.alpha).size
        if n < 1:
            raise ModelError("a robot needs at least one joint")
        set_ = object.__setattr__
        for f in LINK_FIELDS:
            set_(self, f, _as_vector(getattr(self, f), n, f))
            length = f in ("a", "d")
            _check_magnitude(getattr(self, f), MAX_LINK_M if length else MAX_ANGLE_RAD, f,
                             "m" if length else "rad")
        set_(self, "base", _as_frame(self.base, "base"))
        set_(self, "tool", _as_frame(self.tool, "tool"))
        for f in ("base", "tool"):
            _check_magnitude(getattr(self, f)[:3, 3], MAX_FRAME_M, f"{f} translation", "m")
        prismatic = np.zeros(n, bool) if self.prismatic is None else np.array(self.prismatic, bool)
        if prismatic.shape != (n,):
            raise ModelError(f"joint types (prismatic flags) must have {n} values")
        set_(self, "prismatic", prismatic)
        if self.limits is None:
            limits = np.tile([-np.pi, np.pi], (n, 1))
            limits[prismatic] = (-np.inf, np.inf)
        else:
            limits = np.array(self.limits, dtype=float)
            if limits.shape != (n, 2) or np.isnan(limits).any():
                raise ModelError(f"joint limits must be {n} (lower, upper) pairs without NaN")
            if (limits[:, 0] > limits[:, 1]).any():
                raise ModelError("a joint's lower limit is above its upper limit")
            _check_magnitude(np.where(np.isfinite(limits), limits, 0.0), MAX_ANGLE_RAD, "joint limits", "rad")
        set_(self, "limits", limits)
        parallel = np.zeros(n, bool) if self.parallel is None else np.array(self.parallel, bool)
        if parallel.shape != (n,):
            raise ModelError(f"parallel flags must have {n} values")
        set_(self, "parallel", parallel)
        smr = np.zeros((0, 3)) if self.smr is None else np.array(self.smr, dtype=float)
        if smr.ndim != 2 or smr.shape[1] != 3 or not np.isfinite(smr).all():
            raise ModelError("extra SMR offsets must be a finite (k, 3) array")
        _check_magnitude(smr, MAX_LINK_M, "SMR offsets", "m")
        set_(self, "smr", smr)
        if self.opw is not None and not isinstance(self.opw, OPWParameters):
            raise ModelError("opw must be an OPWParameters (robocal.kinematics.opw)")
        if self.joint_errors is not None and not isinstance(self.joint_errors, JointErrorModel):
            raise ModelError("joint_errors must be a JointErrorModel (robocal.kinematics.joint_errors)")
        if self.priors is not None and not isinstance(self.priors, PriorSpec):
            raise ModelError("priors must be a PriorSpec (robocal.kinematics.prior_spec)")
        if self.link_frames is not None:
            set_(self, "link_frames", check_link_frames(self.link_frames, n))
        if self.payload_kg is not None:
            payload = float(self.payload_kg)
            if not (np.isfinite(payload) and payload > 0):
                raise ModelError(f"payload_kg (the rated payload) must be a positive number of kg, got "
                                 f"{self.payload_kg!r}")
            set_(self, "payload_kg", payload)
        set_(self, "nominal", self._nominal_vector(self.nominal))
        for f in (*LINK_FIELDS, "base", "tool", "limits", "parallel", "smr", "nominal", "prismatic"):
            getattr(self, f).flags.writeable = False

    def _nominal_vector(self, nominal) -> np.ndarray:
        """The nominal geometry vector: the current values when None; a mapping name -> value
        (SI) must name every geometry parameter."""
        names = self.geometry_names
        if nominal is None:
            return self._values()[: len(names)]
        if isinstance(nominal, Mapping):
            if set(nominal) != set(names):
                missing = sorted(set(names) - set(nominal))
                unknown = sorted(set(nominal) - set(names))
                raise ModelError(f"nominal must give every geometry parameter (SI): missing {missing}, "
                                 f"unknown {unknown}")
            nominal = [as_number(nominal[name], f"nominal.{name}", ModelError) for name in names]
        return _as_vector(nominal, len(names), "nominal parameters")

    @functools.cached_property
    def has_opw_form(self) -> bool:
        """Whether this robot's chain is exactly its OPW form (closed-form IK applies): true for a
        nominal catalog robot with any base and tool, false once a link parameter is displaced
        or joint-error terms are declared (computed on first use: the model is immutable)."""
        if self.opw is None or self.n_joints != 6 or self.joint_errors is not None or self.has_prismatic:
            return False
        chain = opw_chain(self.opw)
        return all(np.allclose(getattr(self, f), chain[f], rtol=0.0, atol=OPW_MATCH_TOL)
                   for f in LINK_FIELDS)

    @functools.cached_property
    def opw_model(self) -> Robot | None:
        """This arm as an OPW-form model (closed-form IK applies): itself when `has_opw_form`, else
        the OPW form its chain's geometry has (`robocal.kinematics.opw_geometry.opw_model`: an OPW
        arm read from a URDF, a DH or MDH table, a cell), None without one (computed on first use)."""
        return self if self.has_opw_form else opw_model(self)

    @functools.cached_property
    def ur_form(self) -> URForm | None:
        """The UR form of this robot's own chain (three parallel axes, offset wrist:
        `robocal.kinematics.ur`), detected from its links; None without it (a calibrated
        model, joint-error terms, another geometry)."""
        if self.n_joints != 6 or self.joint_errors is not None or self.has_prismatic:
            return None
        return ur_form(*self.links)

    @property
    def has_prismatic(self) -> bool:
        """Whether a joint of the chain is prismatic (its value, in m, adds to its d)."""
        return bool(self.prismatic.any())

    @property
    def joint_params(self) -> list[str]:
        """The parameter each joint's value adds to, in joint order: ``theta<i>`` for a revolute
        joint, ``d<i>`` for a prismatic one; their `jacobian` columns are the joint Jacobian."""
        return [f"{'d' if slides else 'theta'}{i + 1}" for i, slides in enumerate(self.prismatic)]

    @property
    def external_axes(self) -> int:
        """How many leading joints are external axes (written ``e1..``): 1 for an arm on a track (a
        prismatic joint 1 carrying revolute joints, `robocal.kinematics.cell_file`), else 0."""
        return int(self.n_joints >= 2 and bool(self.prismatic[0]) and not self.prismatic[1:].any())

    @property
    def joints(self) -> tuple[JointSpec, ...]:
        """Each joint's name, type, unit, CSV column and limits (`JointSpec`): what every message,
        range check and joints file says of a joint. External axes are ``e1..``, the arm's joints
        ``q1..`` counted after them; revolute joints are shown in deg, prismatic ones in mm.

        Examples
        --------
        >>> import robocal as rc
        >>> [j.column for j in rc.Robot.from_catalog("abb_irb2600").joints][:2]
        ['q1_deg', 'q2_deg']
        """
        k = self.external_axes
        return tuple(JointSpec(f"e{i + 1}" if i < k else f"q{i - k + 1}",
                               PRISMATIC if slides else REVOLUTE,
                               (float(lo), float(hi)))
                     for i, (slides, (lo, hi)) in enumerate(zip(self.prismatic, self.limits, strict=True)))

    def joints_shown(self, q) -> np.ndarray:
        """Joints ``q`` ``(N, n)`` (rad; m for a prismatic joint) in each joint's unit (deg; mm):
        what joints files and messages show (`joints`).

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joint values (rad; m for a prismatic joint).

        Returns
        -------
        numpy.ndarray, shape (N, n)
            The values in deg (mm for a prismatic joint).

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> robot.joints_shown(np.array([[np.pi / 2, 0, 0, 0, 0, 0]]))  # deg
        array([[90.,  0.,  0.,  0.,  0.,  0.]])
        """
        return joints_in_units(q, self.prismatic)

    def section(self) -> dict:
        """The ``robot`` section of the result and campaign JSON: ``name``, ``description``,
        ``n_joints`` and, when a joint is prismatic, ``joints``: each joint's CSV column (``['e1_mm',
        'q1_deg', ...]``, ``['q1_deg', 'q2_deg', 'q3_mm', 'q4_deg']``), which says the unit of its
        values in the JSON (absent: every joint revolute, in deg).

        Returns
        -------
        dict
            The ``robot`` section (JSON-ready).
        """
        out = {"name": self.name, "description": self.description, "n_joints": self.n_joints}
        return {**out, "joints": [j.column for j in self.joints]} if self.has_prismatic else out

    @property
    def has_ur_form(self) -> bool:
        """Whether closed-form UR inverse kinematics applies to this robot's chain (see `ur_form`)."""
        return self.ur_form is not None

    # ----------------------------------------------------------------- construction
    @classmethod
    def from_mdh(cls, alpha: Sequence[float], a: Sequence[float], theta: Sequence[float],
                 d: Sequence[float], beta: Sequence[float] | None = None, *,
                 degrees: bool = False, length_unit: str = "m", **kwargs) -> Robot:
        """Robot from Craig's modified DH rows (alpha_{i-1}, a_{i-1}, theta offset, d_i).

        Axes i-1, i are flagged parallel where alpha_i = 0 (then beta_i is a parameter); see
        `robocal.kinematics.convert.mdh_kwargs`.

        Parameters
        ----------
        alpha, a, theta, d : sequence of float, length n
            The modified DH rows, in ``length_unit`` and degrees or radians.
        beta : sequence of float, length n, optional
            Hayati's beta about the y axis of parallel axes (default 0), degrees or radians.
        degrees : bool, default False
            The angles (and ``limits``) are in degrees.
        length_unit : {'m', 'mm'}
            The unit of ``a`` and ``d``.
        **kwargs
            Other attributes of the model: ``base``, ``tool`` (4x4, m), ``limits`` ``(n, 2)``,
            ``name``, ``description``...

        Returns
        -------
        Robot

        Raises
        ------
        ModelError
            Rows of different lengths, an unknown unit or an implausible value.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> arm = rc.Robot.from_mdh(alpha=[0, 0], a=[0, 500], theta=[0, 0], d=[0, 0],
        ...                         length_unit="mm")  # a planar arm, one 0.5 m link
        >>> arm.fk(np.array([[np.pi / 2, 0.0]]))[0, :3, 3].round(3)
        array([0. , 0.5, 0. ])
        """
        return cls(**mdh_kwargs(alpha, a, theta, d, beta, degrees=degrees, length_unit=length_unit,
                                **kwargs))

    @classmethod
    def from_dh(cls, theta_offsets: Sequence[float], d: Sequence[float], a: Sequence[float],
                alpha: Sequence[float], *, degrees: bool = False, length_unit: str = "m",
                **kwargs) -> Robot:
        """Robot from a standard DH table, converted exactly (see
        `robocal.kinematics.convert.dh_kwargs`).

        Row i is A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i); the DH base frame is the world
        frame and DH frame n the flange.

        Parameters
        ----------
        theta_offsets, d, a, alpha : sequence of float, length n
            The DH table, in ``length_unit`` and degrees or radians.
        degrees : bool, default False
            The angles (and ``limits``) are in degrees.
        length_unit : {'m', 'mm'}
            The unit of ``d`` and ``a``.
        **kwargs
            Other attributes of the model: ``base`` (world -> DH base), ``tool`` (DH flange ->
            TCP), 4x4, m; ``limits`` ``(n, 2)``; ``name``...

        Returns
        -------
        Robot

        Raises
        ------
        ModelError
            Rows of different lengths, an unknown unit or an implausible value.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> arm = rc.Robot.from_dh(theta_offsets=[0, 0], d=[0.3, 0], a=[0.5, 0.4], alpha=[0, 0])
        >>> arm.fk(np.zeros((1, 2)))[0, :3, 3].round(3)  # both links stretched along x, m
        array([0.9, 0. , 0.3])
        """
        return cls(**dh_kwargs(theta_offsets, d, a, alpha, degrees=degrees, length_unit=length_unit,
                               **kwargs))

    @classmethod
    def from_opw(cls, a1: float, a2: float, b: float, c1: float, c2: float, c3: float, c4: float,
                 offsets: Sequence[float] = (0.0,) * 6, signs: Sequence[int] = (1,) * 6, *,
                 degrees: bool = False, length_unit: str = "m", **kwargs) -> Robot:
        """Robot from an OPW parameter set, converted exactly (see
        `robocal.kinematics.convert.opw_kwargs`).

        The robot keeps the set as ``robot.opw``, so closed-form inverse kinematics
        (`robocal.ik.solve_all`) applies.

        Parameters
        ----------
        a1, a2, b, c1, c2, c3, c4 : float
            The OPW lengths (opw_kinematics convention), in ``length_unit``.
        offsets : sequence of float, length 6
            Joint zero offsets (theta = q * sign - offset), degrees or radians.
        signs : sequence of int, length 6
            Joint direction signs, +1 or -1.
        degrees : bool, default False
            ``offsets`` (and ``limits``) are in degrees.
        length_unit : {'m', 'mm'}
            The unit of the lengths.
        **kwargs
            Other attributes of the model: ``base``, ``tool`` (4x4, m), ``limits`` ``(6, 2)``,
            ``name``...

        Returns
        -------
        Robot

        Raises
        ------
        ModelError
            A wrong count of offsets or signs, an unknown unit or an implausible value.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_opw(a1=150, a2=-115, b=0, c1=445, c2=700, c3=795, c4=85,
        ...                           length_unit="mm")
        >>> robot.has_opw_form
        True
        >>> robot.fk(np.zeros((1, 6)))[0, :3, 3].round(3)  # arm upright at zero, m
        array([0.035, 0.   , 2.025])
        """
        params = opw_parameters(a1, a2, b, c1, c2, c3, c4, offsets, signs, degrees=degrees,
                                length_unit=length_unit)
        return cls(**opw_kwargs(params, degrees=degrees, **kwargs))

    @classmethod
    def from_catalog(cls, name: str) -> Robot:
        """A catalog robot by name (``robocal robots`` lists them).

        Parameters
        ----------
        name : str
            The catalog name, e.g. ``"abb_irb2600"``, ``"ur10e"``.

        Returns
        -------
        Robot
            The nominal model, with its joint limits and (where it has one) its OPW form.

        Raises
        ------
        ModelError
            The name is not in the catalog (the message lists the names).

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> robot.n_joints, robot.has_opw_form
        (6, True)
        """
        return cls(**catalog_kwargs(name))

    # ----------------------------------------------------------------- parameter view
    @property
    def n_joints(self) -> int:
        """The number of joints n."""
        return self.alpha.size

    @property
    def geometry_names(self) -> list[str]:
        """Link, base, tool and SMR parameter names, in vector order."""
        names = [f"{f}{i + 1}" for i in range(self.n_joints) for f in LINK_FIELDS]
        names += [f"base.{f}" for f in FRAME_FIELDS] + [f"tool.{f}" for f in FRAME_FIELDS]
        names += [f"smr{s + 1}.{c}" for s in range(len(self.smr)) for c in "xyz"]
        return names

    @property
    def joint_error_names(self) -> list[str]:
        """The declared joint-error parameter names, in vector order."""
        return [] if self.joint_errors is None else list(self.joint_errors.names)

    @property
    def parameter_names(self) -> list[str]:
        """All parameter names, in vector order (geometry, then joint-error terms).

        Returns
        -------
        list of str
            ``alpha1, a1, beta1, theta1, d1, ...`` per joint, ``base.x ... base.rz``,
            ``tool.x ... tool.rz``, the extra SMRs, then the joint-error terms; the order of
            `values` and `nominal_values`.

        Examples
        --------
        >>> import robocal as rc
        >>> rc.Robot.from_catalog("abb_irb2600").parameter_names[:5]
        ['alpha1', 'a1', 'beta1', 'theta1', 'd1']
        """
        return list(self._names)

    @functools.cached_property
    def _names(self) -> tuple[str, ...]:
        """`parameter_names`, built once (the model is immutable; a calibration asks ~100 times)."""
        return tuple(self.geometry_names + self.joint_error_names)

    def parameter_units(self) -> list[str]:
        """'m' or 'rad' for each parameter, in vector order (joint-error terms: their own unit,
        see `JointErrorModel.units`).

        Returns
        -------
        list of str
            One unit a parameter, in the order of the parameter vector.
        """
        units = ["m" if _LINK_IS_LENGTH[f] else "rad" for _ in range(self.n_joints)
                 for f in LINK_FIELDS]
        units += (["m"] * 3 + ["rad"] * 3) * 2 + ["m"] * self.smr.size
        return units + ([] if self.joint_errors is None else self.joint_errors.units())

    @functools.cached_property
    def _index(self) -> dict[str, int]:
        """Parameter name -> vector index (computed once: the model is immutable)."""
        return {name: i for i, name in enumerate(self.parameter_names)}

    def indices(self, names: Iterable[str]) -> np.ndarray:
        """Vector indices of parameter names; unknown names raise ModelError.

        Parameters
        ----------
        names : iterable of str
            Parameter names (`names`).

        Returns
        -------
        numpy.ndarray of int, shape (k,)
            Their positions in the parameter vector.

        Raises
        ------
        ModelError
            A name the model does not have.
        """
        lookup = self._index
        names = list(names)
        unknown = [nm for nm in names if nm not in lookup]
        if unknown:
            raise ModelError(f"unknown parameter name(s) {unknown}; known: alpha1 a1 beta1 "
                             f"theta1 d1 ... d{self.n_joints}, base.x..base.rz, tool.x..tool.rz"
                             + (", smr1.x.." if len(self.smr) else "")
                             + (f", {' '.join(self.joint_error_names)}" if self.joint_errors else ""))
        return np.array([lookup[nm] for nm in names], dtype=int)

    @functools.cached_property
    def _value_vector(self) -> np.ndarray:
        """The parameter vector, computed once (the model is immutable; read-only)."""
        vec = self._values()
        vec.flags.writeable = False
        return vec

    def _values(self) -> np.ndarray:
        links = np.stack([getattr(self, f) for f in LINK_FIELDS], axis=1).reshape(-1)
        frames = [np.concatenate([T[:3, 3], matrix_to_rotvec(T[:3, :3])])
                  for T in (self.base, self.tool)]
        errors = np.zeros(0) if self.joint_errors is None else self.joint_errors.values
        return np.concatenate([links, *frames, self.smr.reshape(-1), errors])

    @property
    def nominal_values(self) -> np.ndarray:
        """The nominal value of every parameter (order of `parameter_names`; joint-error
        terms zero)."""
        return np.concatenate([self.nominal, np.zeros(len(self.joint_error_names))])

    @property
    def values(self) -> np.ndarray:
        """Current parameter vector (SI), a new array in the order of `parameter_names`."""
        return self._value_vector.copy()

    def get(self, name: str) -> float:
        """One parameter's value (m or rad).

        Parameters
        ----------
        name : str
            A parameter name (`names`).

        Returns
        -------
        float
            Its value (m or rad).

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> robot.get("d1")  # m
        0.445
        >>> robot.indices(["a1", "d1"])  # their places in the parameter vector
        array([1, 4])
        """
        return float(self._value_vector[self.indices([name])[0]])

    def values_of(self, names: Iterable[str]) -> np.ndarray:
        """The values ``(k,)`` (m or rad) of the named parameters, read from the vector computed
        once per model (what a loop over parameters uses instead of `get` per name).

        Parameters
        ----------
        names : iterable of str
            Parameter names.

        Returns
        -------
        numpy.ndarray, shape (k,)
            Their values (m or rad).
        """
        return self._value_vector[self.indices(names)]

    def with_values(self, updates: dict[str, float]) -> Robot:
        """A copy with parameters set by name to absolute values (m, rad).

        Parameters
        ----------
        updates : dict of str to float
            Parameter name (see `parameter_names`) -> new value, metres or radians (joint-error
            terms: their own unit).

        Returns
        -------
        Robot
            A new model; this one is unchanged.

        Raises
        ------
        ModelError
            An unknown parameter name.

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> robot.with_values({"a2": 0.151}).get("a2"), robot.get("a2")
        (0.151, 0.15)
        """
        vec = self.values
        idx = self.indices(updates)
        vec[idx] = _as_vector(list(updates.values()), len(idx), "parameter values")
        return self._from_vector(vec)

    def _geometry_kwargs(self, vec: np.ndarray) -> dict:
        """Link arrays, base, tool and SMR offsets of the geometry part of a parameter vector."""
        n = self.n_joints
        links = vec[: 5 * n].reshape(n, 5)
        base, tool = (make_transform(rotvec_to_matrix(v[3:]), v[:3])
                      for v in (vec[5 * n : 5 * n + 6], vec[5 * n + 6 : 5 * n + 12]))
        smr = vec[5 * n + 12 : len(self.geometry_names)].reshape(-1, 3)
        return {**{f: links[:, k] for k, f in enumerate(LINK_FIELDS)}, "base": base, "tool": tool,
                "smr": smr}

    def _from_vector(self, vec: np.ndarray) -> Robot:
        errors = None if self.joint_errors is None else \
            replace(self.joint_errors, values=vec[len(self.geometry_names):])
        return replace(self, joint_errors=errors, **self._geometry_kwargs(vec))

    def with_joint_errors(self, names: Sequence[str]) -> Robot:
        """A copy that declares the joint-error terms ``names`` (new ones at zero, the nominal
        zero) and no others; values of terms kept from this robot are kept.

        Parameters
        ----------
        names : sequence of str
            The joint-error terms to declare (``robocal robots --terms`` lists them).

        Returns
        -------
        Robot
            The copy; this robot is unchanged.
        """
        names = list(dict.fromkeys(names))
        if not names:
            return replace(self, joint_errors=None)
        old = {} if self.joint_errors is None else \
            dict(zip(self.joint_errors.names, self.joint_errors.values.tolist(), strict=True))
        t_ref = {} if self.joint_errors is None else \
            {"reference_temperature_c": self.joint_errors.reference_temperature_c,
             "calibrated": self.joint_errors.calibrated}
        errors = JointErrorModel(tuple(names), np.array([old.get(nm, 0.0) for nm in names]), **t_ref)
        return replace(self, joint_errors=errors)

    def with_priors(self, priors: PriorSpec | None) -> Robot:
        """A copy with the prior class and group scales ``priors`` (None: chosen and estimated).

        Parameters
        ----------
        priors : PriorSpec or None
            The prior class and group scales (`robocal.identify.priors`).

        Returns
        -------
        Robot
            The copy.
        """
        if priors is not None and not isinstance(priors, PriorSpec):
            raise ModelError("priors must be a PriorSpec (robocal.kinematics.prior_spec)")
        return replace(self, priors=priors)

    def with_reference_temperature(self, celsius: float) -> Robot:
        """A copy whose thermal term's T_ref is ``celsius`` (deg C); self without joint errors.

        Parameters
        ----------
        celsius : float
            The reference temperature T_ref (deg C).

        Returns
        -------
        Robot
            The copy (this robot itself when it has no joint-error terms).
        """
        if self.joint_errors is None:
            return self
        return replace(self, joint_errors=replace(self.joint_errors, reference_temperature_c=float(celsius)))

    def with_calibrated_conditions(self, calibrated) -> Robot:
        """A copy whose error model records the payloads and temperatures its calibration covered
        (a `robocal.kinematics.conditions.CalibratedRange`); self without joint errors.

        Parameters
        ----------
        calibrated : CalibratedRange
            The payloads and temperatures the calibration's data covered.

        Returns
        -------
        Robot
            The copy (this robot itself when it has no joint-error terms).
        """
        if self.joint_errors is None:
            return self
        return replace(self, joint_errors=replace(self.joint_errors, calibrated=calibrated))

    def with_conditions(self, payload=None, temperature: float | None = None) -> Robot:
        """A copy used at a fixed payload ``(kg, x, y, z)`` (kg, m: the centre of mass in the flange
        frame; a mass alone: at the flange) and ``temperature`` deg C wherever the rows give none
        (compensation, programs); None leaves that condition as it was.

        Parameters
        ----------
        payload : float or array_like of 4, optional
            Mass (kg) or ``(kg, x, y, z)`` with the centre of mass in the flange frame (m).
        temperature : float, optional
            deg C.

        Returns
        -------
        Robot
            The copy.
        """
        if self.joint_errors is None:
            return self
        errors = self.joint_errors
        if payload is not None:
            p = np.zeros(4)
            given = np.asarray(payload, float).reshape(-1)
            if given.size not in (1, 4) or not np.isfinite(given).all() or given[0] < 0:
                raise DataError(f"a payload is a mass >= 0 kg, optionally with its centre of mass x, y, z; "
                                f"got {given.tolist()}")
            p[: given.size] = given
            errors = replace(errors, payload=tuple(p.tolist()))
        if temperature is not None:
            errors = replace(errors, temperature_c=float(as_number(temperature, "temperature", DataError)))
        return replace(self, joint_errors=errors)

    def link_scale(self, temperature: np.ndarray | None = None) -> np.ndarray | None:
        """``(N, n)`` the thermal terms' scale of each link length at ``temperature (N,)`` deg C
        (`robocal.kinematics.thermal`: each link by its group's k; ``(1, n)`` at the fixed
        temperature of `with_conditions`); None without a thermal term or a temperature.

        Parameters
        ----------
        temperature : numpy.ndarray, shape (N,), optional
            deg C of each row.

        Returns
        -------
        numpy.ndarray, shape (N, n) or (1, n), or None
            The scale of each link length (1 at T_ref).
        """
        errors = self.joint_errors
        k = None if errors is None else thermal_coefficients(errors.names, errors.values, self.prismatic)
        if k is not None and temperature is None and errors.temperature_c is not None:
            temperature = np.array([errors.temperature_c])  # one for all rows
        return None if k is None else thermal_scale(k, temperature, errors.reference_temperature_c)

    def links_at(self, temperature: np.ndarray | None = None) -> LinkArrays:
        """The link parameters, ``a, d`` ``(N, n)`` scaled by `link_scale` at ``temperature
        (N,)`` deg C; the plain ``(n,)`` links without a thermal term or a temperature.

        Parameters
        ----------
        temperature : numpy.ndarray, shape (N,), optional
            deg C of each row.

        Returns
        -------
        LinkArrays
            The link parameters (m, rad), ``a`` and ``d`` scaled.
        """
        return scaled_links(self.links, self.link_scale(temperature))

    def default_free(self, orientation: bool = False) -> list[str]:
        """Parameters a calibration frees by default: every link parameter (beta only on
        parallel axes), the base frame, the tool translation (and rotation for pose data), the
        extra SMRs and the declared joint-error terms.

        Parameters
        ----------
        orientation : bool, default False
            The data measure orientation (pose data): free the tool rotation too.

        Returns
        -------
        list of str
            Parameter names.
        """
        names = []
        for i in range(self.n_joints):
            for f in LINK_FIELDS:
                if f != "beta" or self.parallel[i]:
                    names.append(f"{f}{i + 1}")
        names += [f"base.{f}" for f in FRAME_FIELDS] + ["tool.x", "tool.y", "tool.z"]
        if orientation:
            names += ["tool.rx", "tool.ry", "tool.rz"]
        names += [f"smr{s + 1}.{c}" for s in range(len(self.smr)) for c in "xyz"]
        return names + self.joint_error_names

    def default_spans(self, names: Iterable[str]) -> np.ndarray:
        """Default search half-widths (m or rad) of the named geometry parameters.

        Parameters
        ----------
        names : iterable of str
            Geometry parameter names.

        Returns
        -------
        numpy.ndarray, shape (k,)
            Half-widths (m or rad).
        """
        units = self.parameter_units()
        spans = []
        for name in names:
            frame = name.startswith(("base.", "tool.", "smr"))
            length = units[self.indices([name])[0]] == "m"
            key = ("frame_" if frame else "") + ("length" if length else "angle")
            spans.append(DEFAULT_SPAN[key])
        return np.array(spans)

    def bounds(self, names: Iterable[str], spans: np.ndarray | None = None):
        """(lower, upper) bounds of displacements from the current model for ``names``.

        Parameters
        ----------
        names : iterable of str
            Parameter names.
        spans : numpy.ndarray, shape (k,), optional
            Half-widths (m or rad); default `default_spans`.

        Returns
        -------
        tuple of numpy.ndarray
            ``(lower, upper)``, each ``(k,)``.
        """
        names = list(names)
        spans = self.default_spans(names) if spans is None else np.asarray(spans, float)
        return -spans, spans

    # ----------------------------------------------------------------- displacements
    def displaced_arrays(self, names: Sequence[str], delta: np.ndarray) -> DisplacedArrays:
        """The model's arrays for displacements ``delta`` ``(..., k)`` of ``names``.

        Link parameters, frame translations, SMR offsets and joint-error terms add; frame
        rotations compose (base: R <- exp(d) R about the world origin; tool: R <- exp(d) R in
        flange axes), matching the identification Jacobian.

        Parameters
        ----------
        names : sequence of str
            k parameter names.
        delta : numpy.ndarray, shape (..., k)
            Displacements (m or rad).

        Returns
        -------
        DisplacedArrays
            Links, frames, SMR offsets and joint-error values, batched over ``delta``'s leading axes.
        """
        delta = np.asarray(delta, dtype=float)
        batch = delta.shape[:-1]
        n = self.n_joints
        idx = self.indices(names)
        full = np.zeros(batch + (len(self.parameter_names),))
        full[..., idx] = delta
        links = np.stack([getattr(self, f) for f in LINK_FIELDS], axis=1).reshape(-1)
        links = links + full[..., : 5 * n]
        links = links.reshape(batch + (n, 5))
        link_arrays = LinkArrays(*(links[..., k] for k in range(5)))
        db, dt = full[..., 5 * n : 5 * n + 6], full[..., 5 * n + 6 : 5 * n + 12]
        Rb = rotvec_to_matrix(db[..., 3:])
        base = make_transform(Rb @ self.base[:3, :3],
                              np.einsum("...ij,j->...i", Rb, self.base[:3, 3]) + db[..., :3])
        tool = make_transform(rotvec_to_matrix(dt[..., 3:]) @ self.tool[:3, :3],
                              self.tool[:3, 3] + dt[..., :3])
        geo = len(self.geometry_names)
        smr = self.smr + full[..., 5 * n + 12 : geo].reshape(batch + self.smr.shape)
        errors = None if self.joint_errors is None else self.joint_errors.values + full[..., geo:]
        return DisplacedArrays(link_arrays, base, tool, smr, errors)

    def displaced(self, names: Sequence[str], delta: np.ndarray) -> Robot:
        """A copy displaced by ``delta`` ``(k,)`` on ``names`` (see `displaced_arrays`).

        Parameters
        ----------
        names : sequence of str
            k parameter names.
        delta : numpy.ndarray, shape (k,)
            Displacements (m or rad).

        Returns
        -------
        Robot
            The displaced copy.
        """
        delta = _as_vector(delta, len(names), "parameter displacement")
        moved = self.displaced_arrays(names, delta)
        errors = None if moved.joint_errors is None else \
            replace(self.joint_errors, values=moved.joint_errors)
        return replace(self, base=moved.base, tool=moved.tool, smr=moved.smr, joint_errors=errors,
                       **moved.links._asdict())

    def with_frames(self, base: np.ndarray | None = None, tool: np.ndarray | None = None) -> Robot:
        """A copy with a new base and/or tool frame (4x4).

        Parameters
        ----------
        base, tool : numpy.ndarray, shape (4, 4), optional
            Homogeneous transforms (m); None keeps this robot's.

        Returns
        -------
        Robot
            The copy.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> tool = np.eye(4)
        >>> tool[2, 3] = 0.25  # a 250 mm tool along the flange's z
        >>> float(robot.with_frames(tool=tool).tool[2, 3]), float(robot.tool[2, 3])  # a copy
        (0.25, 0.0)
        """
        return replace(self, base=self.base if base is None else base,
                       tool=self.tool if tool is None else tool)

    def tools_for(self, smr_index) -> np.ndarray:
        """Tool frames ``(N, 4, 4)`` for SMR indices ``(N,)``: SMR 0 is the tool, s > 0 the
        tool's rotation with translation ``smr[s - 1]``.

        Parameters
        ----------
        smr_index : array_like of int, shape (N,)
            The SMR of each row.

        Returns
        -------
        numpy.ndarray, shape (N, 4, 4)
            Flange -> SMR transforms (m).
        """
        smr_index = np.asarray(smr_index, dtype=int)
        if smr_index.size and (smr_index.min() < 0 or smr_index.max() > len(self.smr)):
            raise ModelError(f"SMR index out of range: the model has {len(self.smr) + 1} SMR(s)")
        offsets = np.vstack([self.tool[:3, 3], self.smr])[smr_index]
        tools = np.broadcast_to(self.tool, smr_index.shape + (4, 4)).copy()
        tools[..., :3, 3] = offsets
        return tools

    def nominal_robot(self) -> Robot:
        """The nominal model (the controller's: no joint-error terms), with this robot's nominal
        as its own.

        Returns
        -------
        Robot
            The nominal model.
        """
        return replace(self, joint_errors=None, **self._geometry_kwargs(self.nominal))

    # ----------------------------------------------------------------- kinematics
    @property
    def links(self) -> LinkArrays:
        """The link arrays (alpha, a, beta, theta, d), each ``(n,)``, as the kinematics kernels take them."""
        return LinkArrays(self.alpha, self.a, self.beta, self.theta, self.d)

    def link_numbers(self, links) -> np.ndarray:
        """The frame numbers ``(N,)`` (0 the base .. n the flange) of markers' links ``links (N,)``:
        numbers, or the names of this model's links (`link_frames`); DataError for an unknown name,
        listing the known ones (`robocal.kinematics.link_names.link_numbers`).

        Parameters
        ----------
        links : array_like, shape (N,)
            Frame numbers or link names.

        Returns
        -------
        numpy.ndarray of int, shape (N,)
            Frame numbers.

        Raises
        ------
        DataError
            An unknown link name.
        """
        return link_numbers(links, self.link_frames, self.name)

    def check_joints(self, q) -> np.ndarray:
        """Joints as a ``(N, n)`` float array (rad; m for prismatic joints); raises DataError on
        wrong shape or NaN.

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joint values (rad; m for a prismatic joint).

        Returns
        -------
        numpy.ndarray, shape (N, n)
            The joints as floats (a single pose ``(n,)`` becomes ``(1, n)``).

        Raises
        ------
        DataError
            A wrong shape or a NaN.
        """
        q = np.asarray(q, dtype=float)
        if q.ndim == 1:
            q = q[None, :]
        if q.ndim != 2 or q.shape[1] != self.n_joints:
            raise DataError(f"joints must have shape (N, {self.n_joints}) for {self.name}, "
                            f"got {q.shape}")
        if not np.isfinite(q).all():
            bad = np.flatnonzero(~np.isfinite(q).all(axis=1))
            raise DataError(f"joints contain NaN or infinite values in row(s) {bad[:10].tolist()}")
        return q

    def reached_joints(self, q: np.ndarray, conditions: Conditions = UNKNOWN) -> np.ndarray:
        """The joints ``(N, n)`` the robot really turns to for commanded ``q`` (rad): ``q + dq(q)``
        with the declared joint-error terms at the rows' ``conditions`` (approach directions for
        backlash, last moves for travel, the payload carried for payload).

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joint values (rad; m for a prismatic joint).
        conditions : Conditions, optional
            The rows' conditions (none given: the model's fixed ones).

        Returns
        -------
        numpy.ndarray, shape (N, n)
            The joints reached (rad; m for a prismatic joint).
        """
        if self.joint_errors is None:
            return q
        return q + self.joint_errors.offsets(self, q, conditions)

    def fk(self, q, frames: bool = False, smr=None, conditions: Conditions = UNKNOWN):
        """TCP poses ``(N, 4, 4)`` (world frame, m) for joints ``(N, n)`` in rad.

        Joint-error terms turn the commanded joints into the joints the robot really reaches
        first (`reached_joints`); a thermal term scales the links at the rows' temperature
        (`links_at`).

        Parameters
        ----------
        q : array_like, shape (N, n)
            Commanded joints, radians.
        frames : bool, default False
            Also return the world poses of the frames {0}..{n}.
        smr : array_like of int, shape (N,), optional
            Each row's SMR index (default: the tool, SMR 0).
        conditions : Conditions, optional
            Each row's approach directions, last moves, payload and temperature
            (`robocal.Conditions`, e.g. ``rc.Conditions(temperature=t)``; ``data.conditions`` of
            measurements), for the backlash, travel, payload and thermal terms.

        Returns
        -------
        numpy.ndarray, shape (N, 4, 4)
            TCP poses in the world frame, metres. With ``frames=True``, ``(tcp, frames)`` where
            ``frames`` ``(N, n + 1, 4, 4)`` are the world poses of frames {0}..{n} (frame {n} is
            the flange, before the tool).

        Raises
        ------
        DataError
            ``q`` of the wrong shape or with NaN.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> q = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [np.pi / 2, 0.0, 0.0, 0.0, 0.0, 0.0]])
        >>> robot.fk(q)[:, :3, 3].round(3)  # joint 1 turns the TCP a quarter turn about z
        array([[1.03, 0.  , 1.26],
               [0.  , 1.03, 1.26]])
        >>> tcp, frames = robot.fk(q, frames=True)
        >>> frames.shape
        (2, 7, 4, 4)
        """
        q = self.reached_joints(self.check_joints(q), conditions)
        tool = self.tool if smr is None else self.tools_for(smr)
        links = self.links_at(conditions.temperature)
        if frames:
            return chain_frames(links, self.base, tool, q, frames=True, prismatic=self.prismatic)
        return chain_fk(links, self.base, tool, q, prismatic=self.prismatic)

    def jacobian(self, q, params: Sequence[str] | None = None, kind: str = "point", smr=None,
                 conditions: Conditions = UNKNOWN):
        """Identification Jacobian ``(N, 3|6, k)``; see
        `robocal.kinematics.jacobian.identification_jacobian`.

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joints, radians.
        params : sequence of str, optional
            The k parameter names (default: `default_free`, with orientation for
            ``kind="pose"``).
        kind : {'point', 'pose'}
            Position rows only, or position then orientation rows.
        smr : array_like of int, shape (N,), optional
            Each row's SMR index (default: the tool).
        conditions : Conditions, optional
            Each row's approach directions, last moves, payload and temperature, as for `fk`.

        Returns
        -------
        numpy.ndarray, shape (N, 3, k) or (N, 6, k)
            d(TCP)/d(parameter): position rows in m per m or m per rad; orientation rows in rad
            per unit.

        Raises
        ------
        ModelError
            An unknown parameter name or ``kind``.
        DataError
            ``q`` of the wrong shape or with NaN.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> q = np.array([[0.1, -0.2, 0.3, 0.4, 0.5, 0.6]])
        >>> J = robot.jacobian(q, ["d1"])
        >>> J.shape
        (1, 3, 1)
        >>> J[0, :, 0].round(6)  # raising joint 2 lifts the TCP straight up
        array([0., 0., 1.])
        """
        names = self.default_free(kind == "pose") if params is None else list(params)
        return identification_jacobian(self, self.check_joints(q), names, kind, smr, conditions)

    def within_limits(self, q) -> np.ndarray:
        """``(N,)`` bool: every joint inside its limits.

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joint values (rad; m for a prismatic joint).

        Returns
        -------
        numpy.ndarray of bool, shape (N,)
            True where the row is inside every limit.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> q = np.zeros((2, 6))
        >>> q[1, 1] = 3.0  # rad: beyond joint 2's limit
        >>> robot.within_limits(q)
        array([ True, False])
        """
        q = self.check_joints(q)
        return ((q >= self.limits[:, 0]) & (q <= self.limits[:, 1])).all(axis=1)

    def outside_limits(self, q) -> np.ndarray:
        """``(N, n)`` bool: joint values ``q`` ``(N, n)`` (rad; m for a prismatic joint) beyond
        their limits by more than `LIMIT_TOL` (a value written at its limit in degrees or mm
        is at it). The one limit check of positioner values (programs, measurements, deployment);
        the caller names the row and the axis.

        Parameters
        ----------
        q : array_like, shape (N, n)
            Joint values (rad; m for a prismatic joint).

        Returns
        -------
        numpy.ndarray of bool, shape (N, n)
            True for each value beyond its limit.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600")
        >>> q = np.zeros((2, 6))
        >>> q[1, 1] = 3.0  # rad: beyond joint 2's limit
        >>> robot.outside_limits(q)[1]
        array([False,  True, False, False, False, False])
        """
        q = self.check_joints(q)
        return (q < self.limits[:, 0] - LIMIT_TOL) | (q > self.limits[:, 1] + LIMIT_TOL)

    # ----------------------------------------------------------------- files
    def save(self, path) -> None:
        """Write the model YAML (SI units, exact round trip), atomically.

        Parameters
        ----------
        path : str or path-like
            The YAML file to write (its format: the model YAML reference page).

        Examples
        --------
        >>> import robocal as rc
        >>> robot = rc.Robot.from_catalog("abb_irb2600").with_values({"a2": 0.1502})
        >>> robot.save("irb2600.yaml")
        >>> rc.Robot.load("irb2600.yaml").get("a2")
        0.1502
        """
        write_atomic(path, dump_model(self))

    @classmethod
    def load(cls, path) -> Robot:
        """Read a model YAML (docs/model-yaml.md: the catalog's format, hand-written or saved, or a
        cell file: a robot on a track, `robocal.kinematics.cell_file`).

        Parameters
        ----------
        path : str or path-like
            The model YAML file (SI units or the units it declares).

        Returns
        -------
        Robot

        Raises
        ------
        ModelError
            A missing or malformed file or an invalid model; the message names the file.

        Examples
        --------
        >>> import robocal as rc
        >>> rc.Robot.from_catalog("ur10e").save("ur10e.yaml")
        >>> rc.Robot.load("ur10e.yaml")
        Robot('ur10e', 6 joints)
        """
        data = read_model_data(path)
        try:
            with reading_model(path):
                if is_workcell(data):
                    return single_arm(data, Path(path))
                if is_cell(data):
                    return cell_from_data(data, Path(path))
                return cls(**robot_kwargs(data))
        except (ModelError, UnitError) as exc:  # the model file's fault, whatever the check
            raise ModelError(f"{path}: {exc}") from None

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, {self.n_joints} joints)"


def load_model(spec: str, tip: str | None = None) -> Robot:
    """A robot from a model YAML path (or a cell file: a robot on a track; a work cell file with one
    arm and no positioner: that arm, placed in the world), a URDF (a serial chain:
    `robocal.kinematics.urdf_read`, ending at link ``tip``, default the deepest leaf) or a catalog
    name (what every ``--robot`` takes). A ``tip`` for anything but a URDF is refused (ModelError).

    Parameters
    ----------
    spec : str
        A model YAML or cell file, a URDF, or a catalog name (``robocal robots`` lists them).
    tip : str, optional
        A URDF's last link.

    Returns
    -------
    Robot
        The model.

    Raises
    ------
    ModelError
        A model that cannot be read, a xacro file, a ``tip`` for anything but a URDF.

    See Also
    --------
    rc.Robot : The model it returns (``Robot.from_catalog``, ``Robot.load``).
    rc.load_cell : A work cell file.
    robocal.kinematics.manufacturer.ur.import_calibration : A UR robot's factory calibration.

    Examples
    --------
    >>> import robocal as rc
    >>> robot = rc.load_model("ur5e")  # a catalog name; a YAML or URDF path reads the file
    >>> robot.name, robot.n_joints
    ('ur5e', 6)
    """
    path = Path(spec)
    if path.suffix.lower() in (".urdf", ".xml", ".xacro") or (on_disk(path, Path.is_file)
                                                                and _looks_like_xml(path)):
        if path.suffix.lower() == ".xacro":
            raise ModelError(f"{spec} is a xacro macro file: expand it first (xacro {path.name} > "
                             "robot.urdf) and give the URDF")
        return Robot(**urdf_kwargs(path, tip))
    if tip is not None:
        raise ModelError(f"tip {tip!r} is a URDF link, but {spec} is not a URDF (its chain ends where its "
                         "model says)")
    if path.suffix.lower() in (".yaml", ".yml") or on_disk(path):
        return Robot.load(path)
    return Robot.from_catalog(spec)


def _looks_like_xml(path: Path) -> bool:
    """The file starts like XML (a URDF given without its suffix)."""
    with open(path, "rb") as fh:
        return fh.read(64).lstrip().startswith(b"<")


def track_chain(arm: Robot, direction, mount: np.ndarray, limits, name: str | None = None,
                description: str = "") -> Robot:
    """The cell chain (`robocal.kinematics.cell_file`'s docstring) of ``arm`` (6 revolute joints, no
    joint-error terms) on a track along unit ``direction`` (world frame) with ``mount`` ``(4, 4)``
    (carriage at e1 = 0 -> robot base, m) and e1 ``limits`` (lower, upper) in m."""
    if arm.has_prismatic or arm.joint_errors is not None:
        raise ModelError(f"{arm.name}: a robot on a track must be a revolute arm without joint-error "
                         "terms (give its geometry; the cell declares the track's own terms)")
    chain = chain_arrays(arm.links, arm.base, arm.tool, arm.parallel, arm.smr, direction, mount)
    nom = arm.nominal_robot()
    nominal = chain_arrays(nom.links, nom.base, nom.tool, nom.parallel, nom.smr, direction, mount)
    kinds = np.r_[True, np.zeros(arm.n_joints, bool)]  # the track, then the arm's revolute joints
    nominal_robot = Robot(**nominal, prismatic=kinds)
    limits = np.vstack([np.asarray(limits, float).reshape(1, 2), arm.limits])
    return Robot(**chain, limits=limits, prismatic=kinds,
                 nominal=nominal_robot.nominal, opw=arm.opw,
                 name=arm.name if name is None else name, description=description,
                 joint_errors=JointErrorModel((TRACK_SCALE,), np.zeros(1)), payload_kg=arm.payload_kg)


def cell_from_data(data: dict, path: Path | None = None) -> Robot:
    """The chain of a cell mapping (`robocal.kinematics.cell_file.read_cell`; its arm, a catalog name or
    a model file relative to ``path``'s folder, loaded by :func:`load_model`)."""
    cell = read_cell(data, path)
    arm = load_model(cell.robot)
    check_cell_offset(cell.mount[:3, 3], cell.length_unit, links_length(arm), "mount")
    name = _text(f"{arm.name} on a track", "name", MAX_NAME) if cell.name is None else cell.name
    return track_chain(arm, cell.direction, cell.mount, cell.limits, name=name, description=cell.description)


def links_length(robot: Robot) -> float:
    """The sum of ``robot``'s link lengths ``|a_i| + |d_i|`` (m): its size, which a cell's offsets
    are checked against (`robocal.core.magnitudes.check_cell_offset`)."""
    return float(np.abs(robot.a).sum() + np.abs(robot.d).sum())


def placed(robot: Robot, mount: np.ndarray | None = None, plate: np.ndarray | None = None) -> Robot:
    """``robot`` with its base frame carried by ``mount`` ``(4, 4)`` (world -> where the model's own
    world was: base ``mount @ base``) and its tool followed by ``plate`` ``(4, 4)`` (tool ``tool @
    plate``), m; its nominal model moved alike (a calibrated model stays calibrated). Neither: the
    robot itself."""
    if mount is None and plate is None:
        return robot

    def move(r: Robot) -> Robot:
        return replace(r, nominal=None, base=r.base if mount is None else np.asarray(mount, float) @ r.base,
                       tool=r.tool if plate is None else r.tool @ np.asarray(plate, float))

    return replace(move(robot), nominal=move(robot.nominal_robot()).nominal)


def arm_from_entry(entry: ArmEntry) -> Robot:
    """The arm of a work cell file's entry (`robocal.kinematics.cell_file.read_arms`): its model (a
    catalog name, a file, or an inline model mapping) placed at the entry's base in the world, or
    on the entry's track (the track cell chain, its mount the entry's base)."""
    arm = Robot(**robot_kwargs(entry.model)) if isinstance(entry.model, dict) else load_model(entry.model)
    if entry.base is not None:  # a riser written in another unit than the file's
        check_cell_offset(entry.base[:3, 3], entry.length_unit, links_length(arm), entry.key)
    if entry.track is not None:
        mount = np.eye(4) if entry.base is None else entry.base
        return track_chain(arm, entry.track[0], mount, entry.track[1], name=f"{arm.name} on a track")
    return placed(arm, mount=entry.base)


def single_arm(data: dict, path: Path | None = None) -> Robot:
    """The arm of a work cell mapping that has exactly one arm and no positioner; otherwise
    ModelError saying to load it as a cell (`robocal.load_cell`)."""
    arms = read_arms(data, path)
    positioners = count_positioners(data)
    if len(arms) != 1 or positioners:
        raise ModelError(f"a work cell ({len(arms)} arm(s), {positioners} positioner(s)), not one robot: "
                         "load it with robocal.load_cell, or give it to a command that takes a cell "
                         "(--model CELL.yaml)")
    return arm_from_entry(next(iter(arms.values())))
