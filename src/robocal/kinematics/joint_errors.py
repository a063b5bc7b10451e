"""Non-geometric joint errors: compliance under gravity, gear (harmonic) errors, backlash,
travel-proportional errors and cyclic (reducer) errors.

The joint a robot really turns to is ``q + dq(q)`` with ``dq`` linear in the parameters::

    compliance  comp{i}_{j}:  dq_i += c_ij * tau_ij(q)
    gear        gear{i}_s1, gear{i}_c1, gear{i}_s2, gear{i}_c2:
                dq_i += s1 sin q_i + c1 cos q_i + s2 sin 2q_i + c2 cos 2q_i
    backlash    backlash{i}:  dq_i += b_i * s_i
    travel      travel{i}:    dq_i += t_i * m_i
    cyclic      cyc{i}_{f}_s, cyc{i}_{f}_c:  dq_i += s sin(f q_i) + c cos(f q_i)
    scale       scale{i}:     dq_i += k_i * q_i

Scale: the joint's encoder (or transmission ratio) is off by the factor 1 + k_i (dimensionless):
a prismatic joint's (a linear track's) scale error, in m per m; on a revolute joint, the gear
ratio error. Its zero is the joint's d_i (prismatic) or theta_i (revolute).

Backlash (lost motion): a joint stops b_i short of or beyond its command depending on the
direction s_i in {-1, 0, +1} from which it approached the pose (the sign of its last move; 0
where unknown, which predicts the middle of the band). ``approach`` arrays carry s (N, n);
:func:`robocal.data.measurements.approach_from_order` derives them from the measurement order.

Travel: the joint ends ``t_i`` (dimensionless) times its last move ``m_i`` (rad, signed: this
pose's joint minus the previous pose's, from the measurement order) away from its command; it is
what remains of a settling / wind-up error that grows with the length of the move. ``travel``
arrays carry m (N, n) (:func:`robocal.data.measurements.travel_from_order`; zeros when not given:
a model used without them predicts a pose reached without moving).

Cyclic: a transmission's periodic error at ``f`` cycles per revolution of the joint (``f`` > 2, a
reducer's ratio or a multiple of it: an error that repeats with every turn of the motor or an
intermediate shaft). The frequency is part of the parameter name (up to 2 decimals, e.g.
``cyc4_50.14_s``), so a name alone fixes its basis; the frequencies are found from the data by
:mod:`robocal.identify.frequency_search`.

Mass model of the compliance term: the links beyond joint i are lumped into point masses at the
origins o_j of the distal frames {j}, j = i+1..n (frame {n} is the flange, which also carries
the payload). tau_ij(q) = z_i . ((o_j - o_i) x g) is the gravity torque about axis i of a unit
weight at o_j (m), with g the unit vector -z of the robot base frame {0} (a floor-mounted robot),
all computed from the frames at the commanded joints (the deflection is small: first order).
c_ij = k_i m_j |g| (rad/m) is the compliance k_i of joint i (rad/(N m)) times the weight of
the lumped mass m_j (N): the product is what position data identify, and keeping one
coefficient per (joint, mass) keeps the model linear (no scale ambiguity between k and m).
Gear, backlash and cyclic parameters are in rad, travel in rad per rad. Joints are 1-based in
the names.

Two terms depend on the conditions recorded with each row (``Measurements.payload`` and
``.temperature``) and live in their own modules: ``payload`` (``payload{i}``, the joints' deflection
under the payload's gravity moment: :mod:`robocal.kinematics.load`) and ``thermal`` (one parameter,
the arm's link lengths scaled by ``1 + k (T - T_ref)``) with ``thermal_groups`` (per link group, the
group's deviation ``thermal_<group>`` from that k): :mod:`robocal.kinematics.thermal`; not joint
offsets, so their columns of the joint-offset basis are zero and the FK and Jacobian apply them).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

import robocal.kinematics.load as load
import robocal.kinematics.thermal as thermal
from robocal.core.errors import IdentificationError, ModelError
from robocal.core.io import as_number
from robocal.kinematics.conditions import KEY as CONDITIONS_KEY
from robocal.kinematics.conditions import UNKNOWN, CalibratedRange, Conditions, beyond
from robocal.kinematics.fk import chain_frames

TERMS = ("compliance", "gear", "backlash", "travel", "cyclic", "scale", "payload", "thermal",
         thermal.GROUPS_TERM)
CONDITION_TERMS = ("payload", "thermal")  # the terms that use the rows' recorded conditions
UNITS = {"compliance": "rad/m", "gear": "rad", "backlash": "rad", "travel": "rad/rad",
         "cyclic": "rad", "scale": "1", "payload": load.UNIT,
         "thermal": thermal.UNIT, thermal.GROUPS_TERM: thermal.UNIT}  # SI unit of each term's parameters
CYCLIC_MIN_FREQUENCY = 2.0  # cycles per joint revolution; 1 and 2 are the gear term's harmonics
_COMP = re.compile(r"^comp(\d+)_(\d+)$")
_GEAR = re.compile(r"^gear(\d+)_([sc][12])$")
_BACKLASH = re.compile(r"^backlash(\d+)$")
_TRAVEL = re.compile(r"^travel(\d+)$")
_CYCLIC = re.compile(r"^cyc(\d+)_(\d+(?:\.\d{1,2})?)_([sc])$")
_SCALE = re.compile(r"^scale(\d+)$")
_THERMAL = re.compile(f"^{thermal.NAME}$")
_THERMAL_GROUP = re.compile(f"^({'|'.join(thermal.GROUP_NAMES)})$")
_PATTERNS = {"compliance": _COMP, "gear": _GEAR, "backlash": _BACKLASH, "travel": _TRAVEL,
             "cyclic": _CYCLIC, "scale": _SCALE, "payload": load.PATTERN, "thermal": _THERMAL,
             thermal.GROUPS_TERM: _THERMAL_GROUP}


def term_names(n: int, term: str) -> list[str]:
    """All parameter names of one term for an ``n``-joint robot (none for ``cyclic``, whose
    frequencies come from the data: see :func:`cyclic_names`)."""
    if term == "compliance":
        return [f"comp{i}_{j}" for i in range(1, n + 1) for j in range(i + 1, n + 1)]
    if term == "gear":
        return [f"gear{i}_{h}" for i in range(1, n + 1) for h in ("s1", "c1", "s2", "c2")]
    if term == "backlash":
        return [f"backlash{i}" for i in range(1, n + 1)]
    if term == "travel":
        return [f"travel{i}" for i in range(1, n + 1)]
    if term == "scale":
        return [f"scale{i}" for i in range(1, n + 1)]
    if term == "cyclic":
        return []
    if term == "payload":
        return load.names(n)
    if term == "thermal":
        return [thermal.NAME]
    if term == thermal.GROUPS_TERM:  # the groups' deviations from the shared k, which they need
        return [thermal.NAME, *thermal.GROUP_NAMES]
    raise ModelError(f"unknown non-geometric term {term!r}; choose from {', '.join(TERMS)}")


def cyclic_names(joint: int, frequency: float) -> list[str]:
    """The two parameter names (sine, cosine) of a cyclic error of ``joint`` (1-based) at
    ``frequency`` cycles per revolution, rounded to 0.01."""
    f = round(float(frequency), 2)
    if not f > CYCLIC_MIN_FREQUENCY:
        raise ModelError(f"a cyclic error needs a frequency above {CYCLIC_MIN_FREQUENCY:g} cycles per "
                         f"revolution (lower ones are the gear term), got {frequency!r}")
    text = f"{f:.2f}".rstrip("0").rstrip(".")
    return [f"cyc{joint}_{text}_s", f"cyc{joint}_{text}_c"]


def term_of(name: str) -> str:
    """The term ('compliance', 'gear', ...) a joint-error parameter name belongs to."""
    for term, pattern in _PATTERNS.items():
        if pattern.match(name):
            return term
    raise ModelError(f"{name!r} is not a joint-error parameter name")


def is_refinement(name: str) -> bool:
    """Whether ``name`` refines another parameter's value (a link group's thermal deviation from
    the shared k; a payload lever correction, which on a wrist joint whose axis passes through a
    point fixed to the flange is redundant with the joint's compliance): the identifiability
    analysis selects it after the others, so of a redundant set the refinement is set aside."""
    return bool(_THERMAL_GROUP.match(name)) or load.is_lever(name)


def is_parameter_name(name: str) -> bool:
    """Whether ``name`` has the form of a joint-error parameter (for some joint count)."""
    return any(rx.match(name) for rx in _PATTERNS.values())


def parse_terms(spec) -> list[str]:
    """``'compliance,gear'`` / a list -> validated term names and explicit joint-error parameter
    names (e.g. ``cyc4_50_s``), order kept, no repeats."""
    items = spec.replace(",", " ").split() if isinstance(spec, str) else list(spec or [])
    bad = [t for t in items if t not in TERMS and not is_parameter_name(str(t))]
    if bad:
        raise IdentificationError(f"unknown non-geometric term(s) {bad}; choose from {', '.join(TERMS)}, "
                                  "auto or none (comma separated), or name joint-error parameters "
                                  "such as backlash2 or cyc4_50_s")
    return list(dict.fromkeys(items))


def candidate_names(n: int, terms) -> list[str]:
    """The parameter names of terms and explicit names ``terms`` (see :func:`parse_terms`) for an
    ``n``-joint robot, without repeats."""
    names = [nm for t in parse_terms(terms) for nm in (term_names(n, t) if t in TERMS else [t])]
    return list(dict.fromkeys(names))


def _parse(name: str, n: int) -> tuple[int, str, int | str | tuple | None]:
    """(joint index 0-based, kind, detail) of a parameter name; ModelError if unknown."""
    m = _COMP.match(name)
    if m and 1 <= int(m[1]) < int(m[2]) <= n:
        return int(m[1]) - 1, "comp", int(m[2])
    m = _GEAR.match(name)
    if m and 1 <= int(m[1]) <= n:
        return int(m[1]) - 1, "gear", m[2]
    m = _BACKLASH.match(name)
    if m and 1 <= int(m[1]) <= n:
        return int(m[1]) - 1, "backlash", None
    m = _TRAVEL.match(name)
    if m and 1 <= int(m[1]) <= n:
        return int(m[1]) - 1, "travel", None
    m = _CYCLIC.match(name)
    if m and 1 <= int(m[1]) <= n and float(m[2]) > CYCLIC_MIN_FREQUENCY:
        return int(m[1]) - 1, "cyclic", (m[3], float(m[2]))
    m = _SCALE.match(name)
    if m and 1 <= int(m[1]) <= n:
        return int(m[1]) - 1, "scale", None
    joint = load.joint_of(name, n)
    if joint is not None:
        return joint, "payload", load.axis_of(name)
    if thermal.is_name(name):
        return 0, "thermal", None
    raise ModelError(f"unknown joint-error parameter {name!r} for a {n}-joint robot: "
                     "use comp{i}_{j} (i < j <= n), gear{i}_s1|c1|s2|c2, backlash{i}, travel{i}, scale{i}, "
                     f"cyc{{i}}_{{f}}_s|c (f > {CYCLIC_MIN_FREQUENCY:g} cycles per revolution), "
                     f"payload{{i}}, payload{{i}}_x|y|z ({load.FIRST_JOINT} <= i <= n; no payload{{n}}_z), "
                     f"{thermal.NAME} or "
                     f"{', '.join(thermal.GROUP_NAMES)}")


def parse_name(name: str, n: int) -> tuple[int, str, int | str | tuple | None]:
    """``(joint index 0-based, term, detail)`` of joint-error parameter ``name`` of an ``n``-joint
    robot (gear: ``(s|c, 1|2)``; cyclic: ``(s|c, frequency)``); ModelError if unknown."""
    return _parse(name, n)


def joint_error_basis(robot, q: np.ndarray, names: Sequence[str],
                      conditions: Conditions = UNKNOWN) -> tuple[np.ndarray, np.ndarray]:
    """``(B (N, k), joint (k,))``: d(dq_joint[p])/d(param p) at joints ``q (N, n)`` (rad).

    ``dq[:, joint[p]] += B[:, p] * value[p]``. Compliance and payload columns use the robot's
    frames at ``q`` (its link parameters and base; the robot's own joint-error model is not
    applied); backlash columns are the ``conditions``' approach directions ``(N, n)``, travel
    columns their joint moves ``(N, n)`` rad and payload columns the moments of their payload
    ``(N, 4)`` (:func:`robocal.kinematics.load.moment_basis`) (zeros when not given). The thermal columns
    are zero: they scale the links, not a joint."""
    n = robot.n_joints
    parsed = [_parse(nm, n) for nm in names]
    B = np.empty((q.shape[0], len(parsed)))
    frames = None
    loaded = [p for p, t in enumerate(parsed) if t[1] == "payload" and t[2] is None]
    levers = [p for p, t in enumerate(parsed) if t[1] == "payload" and t[2] is not None]
    approach, travel = conditions.approach, conditions.travel
    payload = conditions_of(robot, q.shape[0], conditions).payload
    if (loaded or levers) and payload is not None:
        _, frames = chain_frames(robot.links, robot.base, robot.tool, q, frames=True,
                                 prismatic=robot.prismatic)
        B[:, loaded] = load.moment_basis(frames, payload, np.array([parsed[p][0] for p in loaded], dtype=int))
        B[:, levers] = load.lever_basis(frames, payload, np.array([parsed[p][0] for p in levers], dtype=int),
                                        np.array([parsed[p][2] for p in levers], dtype=int))
    for p, (i, kind, detail) in enumerate(parsed):
        if kind == "payload":
            if payload is None:
                B[:, p] = 0.0
            continue
        if kind == "thermal":
            B[:, p] = 0.0
            continue
        if kind == "gear":
            h = 2.0 if detail[1] == "2" else 1.0
            B[:, p] = np.sin(h * q[:, i]) if detail[0] == "s" else np.cos(h * q[:, i])
            continue
        if kind == "cyclic":
            B[:, p] = np.sin(detail[1] * q[:, i]) if detail[0] == "s" else np.cos(detail[1] * q[:, i])
            continue
        if kind == "backlash":
            B[:, p] = 0.0 if approach is None else approach[:, i]
            continue
        if kind == "travel":
            B[:, p] = 0.0 if travel is None else travel[:, i]
            continue
        if kind == "scale":
            B[:, p] = q[:, i]
            continue
        if frames is None:
            _, frames = chain_frames(robot.links, robot.base, robot.tool, q, frames=True,
                                     prismatic=robot.prismatic)
        g = -frames[:, 0, :3, 2]
        z_i, o_i = frames[:, i + 1, :3, 2], frames[:, i + 1, :3, 3]
        arm = frames[:, detail, :3, 3] - o_i
        B[:, p] = np.einsum("ij,ij->i", z_i, np.cross(arm, g))
    return B, np.array([t[0] for t in parsed], dtype=int)


def scatter_offsets(B: np.ndarray, joint: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Joint offsets ``dq (..., N, n)`` rad of the terms with basis ``B (N, k)`` on joints
    ``joint (k,)`` (:func:`joint_error_basis`) and values ``(..., k)`` (one set, or a batch
    ``(P, k)``): ``dq[..., joint[p]] += B[:, p] * values[..., p]``, terms added in order."""
    contrib = B * np.asarray(values, float)[..., None, :]  # (..., N, k)
    dq = np.zeros(contrib.shape[:-1] + (n,))
    np.add.at(np.moveaxis(dq, -1, 0), joint, np.moveaxis(contrib, -1, 0))
    return dq


def conditions_of(robot, N: int, conditions: Conditions = UNKNOWN) -> Conditions:
    """The N rows' ``conditions`` with their payload ``(N, 4)`` and temperature ``(N,)`` as given,
    else the fixed ones the robot's error model is used at
    (:meth:`robocal.kinematics.model.Robot.with_conditions`), else None."""
    payload, temperature = conditions.payload, conditions.temperature
    errors = getattr(robot, "joint_errors", None)
    if errors is not None:
        if payload is None and errors.payload is not None:
            payload = np.broadcast_to(np.asarray(errors.payload, float), (N, 4))
        if temperature is None and errors.temperature_c is not None:
            temperature = np.full(N, float(errors.temperature_c))
    return replace(conditions, payload=payload, temperature=temperature)


CONDITION_OPTIONS = ("--payload KG[,X,Y,Z]", "--temperature C")  # how a command is given them


def assumed_conditions(robot, hints: tuple[str, str] = CONDITION_OPTIONS) -> list[str]:
    """One warning per condition term of ``robot`` used without its condition (no rows' values,
    no :meth:`~robocal.kinematics.model.Robot.with_conditions`), naming the default assumed;
    ``hints``: how the user gives the payload and the temperature."""
    errors, out = robot.joint_errors, []
    terms = condition_terms(robot)
    if "payload" in terms and errors.payload is None:
        out.append(f"the model of {robot.name} has a payload term but no payload was given "
                   f"({hints[0]}): assumed no payload (0 kg)")
    if "thermal" in terms and errors.temperature_c is None:
        out.append(f"the model of {robot.name} has a thermal term but no temperature was given "
                   f"({hints[1]}): assumed its reference temperature "
                   f"{errors.reference_temperature_c:.4g} deg C (the calibration's mean)")
    return out


def extrapolated_conditions(robot, conditions: Conditions = UNKNOWN, rows: str = "") -> list[str]:
    """Warnings where the conditions ``robot``'s error model is used at lie beyond the ones its
    calibration covered (:mod:`robocal.kinematics.conditions`): the rows' payload ``(N, 4)`` and
    temperature ``(N,)`` where ``conditions`` give them (``rows`` names them), else its fixed ones
    (:meth:`~robocal.kinematics.model.Robot.with_conditions`)."""
    errors, terms = robot.joint_errors, condition_terms(robot)
    if errors is None or errors.calibrated is None:
        return []
    named = rows if conditions.payload is not None or conditions.temperature is not None else ""
    filled = conditions_of(robot, 1, conditions)
    payload, temperature = filled.payload, filled.temperature
    mass = payload[:, 0] if "payload" in terms and payload is not None else None
    return beyond(errors.calibrated, mass, temperature if "thermal" in terms else None, named)


def condition_warnings(robot, hints: tuple[str, str] = CONDITION_OPTIONS) -> list[str]:
    """What to say of the fixed conditions ``robot``'s error model is used at: the defaults it
    assumes (:func:`assumed_conditions`) and those beyond its calibration
    (:func:`extrapolated_conditions`)."""
    return [*assumed_conditions(robot, hints), *extrapolated_conditions(robot)]


def condition_terms(robot) -> set[str]:
    """The terms of :data:`CONDITION_TERMS` ``robot``'s error model declares (per-group thermal
    deviations count as ``thermal``: they use the temperature)."""
    errors = getattr(robot, "joint_errors", None)
    if errors is None:
        return set()
    terms = {"thermal" if t == thermal.GROUPS_TERM else t for t in errors.terms}
    return terms & set(CONDITION_TERMS)


@dataclass(frozen=True, eq=False)
class JointErrorModel:
    """Named joint-error parameters and their values (SI units of :data:`UNITS`);
    ``reference_temperature_c``: the thermal term's T_ref (deg C); ``payload`` (kg, then the
    centre of mass x, y, z in m in the flange frame) and ``temperature_c``: the fixed conditions the
    model is used at where the rows give none (None: no payload, the arm at T_ref; not saved);
    ``calibrated``: the payloads and temperatures the calibration covered (None: not known)."""

    names: tuple[str, ...]
    values: np.ndarray
    reference_temperature_c: float = thermal.DEFAULT_REFERENCE_C
    payload: tuple[float, float, float, float] | None = None
    temperature_c: float | None = None
    calibrated: CalibratedRange | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "names", tuple(str(n) for n in self.names))
        values = np.array(self.values, dtype=float).reshape(-1)
        if values.shape != (len(self.names),) or not np.isfinite(values).all():
            raise ModelError(f"joint-error model needs {len(self.names)} finite values")
        if len(set(self.names)) != len(self.names):
            raise ModelError("a joint-error parameter is named twice")
        values.flags.writeable = False
        object.__setattr__(self, "values", values)

    @property
    def terms(self) -> list[str]:
        """The terms present, in the order of :data:`TERMS`."""
        kinds = {term_of(n) for n in self.names}
        return [t for t in TERMS if t in kinds]

    def units(self) -> list[str]:
        """SI unit of each parameter (:data:`UNITS` of its term; a payload lever correction's
        :data:`robocal.kinematics.load.LEVER_UNIT`)."""
        return [load.unit_of(nm) if term_of(nm) == "payload" else UNITS[term_of(nm)] for nm in self.names]

    def offsets(self, robot, q: np.ndarray, conditions: Conditions = UNKNOWN) -> np.ndarray:
        """Joint offsets ``dq (N, n)`` (rad) at commanded joints ``q (N, n)`` reached at
        ``conditions``: from their approach directions (backlash; None: unknown, mid-band) by
        their moves (None: no move) carrying their payload (None: none)."""
        B, joint = joint_error_basis(robot, q, self.names, conditions)
        return scatter_offsets(B, joint, self.values, q.shape[-1])

    def thermal_k(self) -> float | None:
        """The shared thermal expansion coefficient (1/K), or None without the thermal term."""
        return float(self.values[self.names.index(thermal.NAME)]) if thermal.NAME in self.names else None

    def thermal_groups(self) -> dict[str, float] | None:
        """Each link group's expansion coefficient (1/K) (:func:`robocal.kinematics.thermal.
        group_coefficients`), or None without per-group deviations."""
        if not any(nm in self.names for nm in thermal.GROUP_NAMES):
            return None
        return thermal.group_coefficients(dict(zip(self.names, self.values.tolist(), strict=True)))

    def to_dict(self) -> dict:
        """Plain data for the model YAML (SI units of :data:`UNITS`)."""
        out = {"units": "SI (comp: rad per m of unit-weight moment arm; gear, backlash, cyc: rad; "
                        "travel: rad per rad of move; scale: per unit of joint value; payload: rad per kg m "
                        "of payload moment, payload{i}_x..z: rad per kg of payload times m of centre-of-mass "
                        "error; thermal: 1/K)",
               "parameters": dict(zip(self.names, self.values.tolist(), strict=True))}
        if any(thermal.is_name(nm) for nm in self.names):
            out["reference_temperature_c"] = float(self.reference_temperature_c)
        groups = self.thermal_groups()
        if groups is not None:  # derived, for the reader; checked against the parameters on loading
            out[GROUP_K_KEY] = groups
        if self.calibrated is not None and self.calibrated.to_dict() and \
                set(self.terms) & {*CONDITION_TERMS, thermal.GROUPS_TERM}:
            out[CONDITIONS_KEY] = self.calibrated.to_dict()
        return out

    @classmethod
    def from_dict(cls, data, n: int) -> JointErrorModel:
        if not isinstance(data, dict) or not isinstance(data.get("parameters"), dict):
            raise ModelError("joint_errors must be a mapping with 'parameters: {name: value}'")
        params = data["parameters"]
        for name in params:
            _parse(str(name), n)
        values = [as_number(v, f"joint_errors.parameters.{name}", ModelError) for name, v in params.items()]
        t_ref = as_number(data.get("reference_temperature_c", thermal.DEFAULT_REFERENCE_C),
                          "joint_errors.reference_temperature_c", ModelError)
        calibrated = data.get(CONDITIONS_KEY)
        calibrated = None if calibrated is None else CalibratedRange.from_dict(calibrated)
        model = cls(tuple(params), np.array(values), t_ref, calibrated=calibrated)
        _check_group_k(model, data.get(GROUP_K_KEY))
        return model


GROUP_K_KEY = "thermal_k_per_group"  # the model file's derived per-group ks (1/K)
GROUP_K_RTOL = 1e-9  # relative agreement of a written per-group k with its parameters (YAML round trip)


def _check_group_k(model: JointErrorModel, written) -> None:
    """A model file's ``thermal_k_per_group`` must agree with its thermal parameters (it is derived
    from them: an edit there alone would change nothing, silently)."""
    if written is None:
        return
    derived = model.thermal_groups()
    if not isinstance(written, dict) or derived is None or set(written) != set(derived):
        raise ModelError(f"joint_errors.{GROUP_K_KEY} must list the groups {', '.join(thermal.GROUPS)} and "
                         f"comes with the parameters {', '.join(thermal.GROUP_NAMES)}")
    for g, k in derived.items():
        v = as_number(written[g], f"joint_errors.{GROUP_K_KEY}.{g}", ModelError)
        if abs(v - k) > GROUP_K_RTOL * max(abs(k), 1e-6):
            raise ModelError(f"joint_errors.{GROUP_K_KEY}.{g} = {v:.6g} disagrees with the parameters "
                             f"{thermal.NAME} + {thermal.NAME}_{g} = {k:.6g}: it is derived from them, "
                             "edit the parameters")
