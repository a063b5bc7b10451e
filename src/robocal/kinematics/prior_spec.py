"""What the user says about a robot's parameter priors: its class and any group scales it fixes.

A robot's parameters fall in prior *groups* (:data:`GROUPS`): joint zeros (``theta`` of revolute
joints), twists (``alpha``, ``beta``), lengths (``a``, ``d``; a prismatic joint's zero is its
``d``) and the joint-error terms (``errors``: a factor on each term's own scale). Each *class* of
robot (:data:`CLASSES`) gives every group a default 1-sigma scale; the calibration starts from it
and widens a group where the data ask for it (empirical Bayes, :mod:`robocal.identify.evidence`).
A group scale the user gives is used as given (not estimated).

The text form (``robocal calibrate --priors``) and the model file's ``priors:`` block say the same::

    --priors class=service,zeros=3deg,lengths=10mm,errors=2x,estimate=no

    priors: {class: service, zeros: 3deg, lengths: 10mm, errors: 2x, estimate: no}

Units are part of every value: angles ``deg``, ``mrad`` or ``rad``; lengths ``mm``, ``um`` or
``m``; the joint-error factor ``x``. ``estimate=no`` keeps the class defaults fixed (no empirical
Bayes). docs/priors.md documents the classes and the estimation.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from importlib import resources

import numpy as np

from robocal.core.errors import ModelError

GROUPS = ("zeros", "twists", "lengths", "errors")
GROUP_UNITS = {"zeros": "deg", "twists": "deg", "lengths": "mm", "errors": "x"}  # display units
_ANGLE = {"deg": np.pi / 180.0, "mrad": 1e-3, "rad": 1.0}
_LENGTH = {"mm": 1e-3, "um": 1e-6, "m": 1.0}
_UNITS = {"zeros": _ANGLE, "twists": _ANGLE, "lengths": _LENGTH, "errors": {"x": 1.0}}
# a group scale in SI times this is in its display unit (GROUP_UNITS)
DISPLAY_FACTOR = {g: 1.0 / units[GROUP_UNITS[g]] for g, units in _UNITS.items()}
MAX_SCALE = {"zeros": np.deg2rad(30.0), "twists": np.deg2rad(30.0), "lengths": 0.2, "errors": 1000.0}


@dataclass(frozen=True)
class PriorClass:
    """One class's default 1-sigma scales: zeros and twists (deg), lengths as ``mm_per_m`` of the
    arm's summed link lengths but at least ``min_mm``, and the joint-error factor."""

    zeros_deg: float
    twists_deg: float
    lengths_mm_per_m: float
    lengths_min_mm: float
    errors: float
    why: str


# The industrial defaults are the published corrections of industrial arms (robocal.identify.priors);
# collaborative arms (UR: factory-calibrated, harmonic drives) identify corrections of the same size
# (the UR5/UR10 data robocal leads on were fitted with them), so they share the numbers and only the
# name says what was chosen; the service class (humanoids, mobile manipulators, low-cost arms: plastic
# or sheet-metal links, belt or cable drives, zeros set by eye) carries the corrections FIGAROH's
# calibrations of TIAGo and TALOS identify (2-3 deg zeros, one 50 mrad; 11 mm lengths); the
# positioner class (tilt-and-turn tables, turntables, headstocks: welded frames whose axes are set
# at commissioning, not machined castings mastered at the factory) carries the prior of the
# ROS-Industrial positioner calibration (robot_cal_tools' kinematic calibration example: 0.005 rad
# and 0.005 m, 1 sigma, on every DH offset of its 2-axis positioner), which its real data agree
# with (benchmarks/bench_rosi_positioner.py: corrections of 0.7 mm and 0.02 deg identified).
CLASSES = {
    "industrial": PriorClass(0.5, 0.2, 1.0, 0.5, 1.0, "industrial arm (mastered zeros, machined castings)"),
    "collaborative": PriorClass(0.5, 0.2, 1.0, 0.5, 1.0, "collaborative arm (factory-calibrated)"),
    "service": PriorClass(3.0, 1.0, 10.0, 5.0, 3.0,
                          "humanoid, mobile manipulator or low-cost arm (zeros set by eye, light links)"),
    "positioner": PriorClass(0.3, 0.3, 10.0, 5.0, 1.0,
                             "positioner or turntable (welded frame, axes set at commissioning)"),
}
CLASS_ALIASES = {"humanoid": "service", "mobile": "service", "mobile-manipulator": "service",
                 "low-cost": "service", "lowcost": "service", "cobot": "collaborative"}
# catalog models whose class is not industrial (a pattern matched at the start of the catalog name);
# every other catalog model is an industrial arm, and models outside the catalog go by their joints
CATALOG_CLASS = {r"ur\d": "collaborative"}
SERVICE_MIN_JOINTS = 8  # a chain this long is a torso before an arm: a humanoid or mobile manipulator
POSITIONER_CLASS = "positioner"  # the class of a work cell's positioner and of 1-2 joint chains
POSITIONER_MAX_JOINTS = 2  # a chain this short carries a workpiece (no arm has fewer than 3 joints)
_BOOL = {"yes": True, "true": True, "no": False, "false": False}
_VALUE = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-z]+)\s*$")


def _in_catalog(name: str) -> bool:
    """Whether the catalog has a model file ``name`` (a name no file system holds: no)."""
    try:
        return resources.files("robocal").joinpath("catalog", f"{name}.yaml").is_file()
    except OSError:
        return False


def canonical_class(name) -> str:
    """The class named ``name`` (an alias allowed); ModelError listing the classes otherwise."""
    word = str(name).strip().lower()
    word = CLASS_ALIASES.get(word, word)
    if word not in CLASSES:
        raise ModelError(f"unknown robot class {name!r} for the priors; classes: {', '.join(CLASSES)} "
                         f"(aliases: {', '.join(f'{a}={c}' for a, c in CLASS_ALIASES.items())})")
    return word


def parse_value(group: str, value) -> float:
    """A group scale with its unit (``'3deg'``, ``'10 mm'``, ``'2x'``) in SI (rad, m; the errors
    factor as is); ModelError for a missing or wrong unit or a value out of (0, MAX_SCALE]."""
    units = _UNITS[group]
    match = _VALUE.match(str(value).lower()) if not isinstance(value, bool) else None
    if match is None or match.group(2) not in units:
        raise ModelError(f"priors: {group}={value!r} needs a positive number with its unit, one of "
                         f"{', '.join(units)} (e.g. {group}=2{GROUP_UNITS[group]})")
    si = float(match.group(1)) * units[match.group(2)]
    if not 0 < si <= MAX_SCALE[group]:
        top = MAX_SCALE[group] / units[GROUP_UNITS[group]]
        raise ModelError(f"priors: {group}={value!r} must be above 0 and at most {top:g} "
                         f"{GROUP_UNITS[group]}")
    return si


@dataclass(frozen=True)
class PriorSpec:
    """The priors the user asks for: a class (None: chosen from the model), group scales fixed by
    the user (SI; see :data:`GROUPS`) and whether the other groups are estimated from the data;
    ``estimated``: the scales a calibration estimated (SI; what its fit used, never written to the
    model file: a new calibration estimates them again)."""

    robot_class: str | None = None
    scales: dict = field(default_factory=dict)
    estimate: bool = True
    estimated: dict = field(default_factory=dict)

    def with_estimated(self, estimated: dict) -> PriorSpec:
        """This spec with the group scales a calibration estimated (SI)."""
        return PriorSpec(self.robot_class, self.scales, self.estimate, dict(estimated))

    @classmethod
    def parse(cls, text: str) -> PriorSpec:
        """The text form ``key=value,...`` (module docstring); ModelError naming the bad item."""
        items = {}
        for part in str(text).split(","):
            if not part.strip():
                continue
            key, sep, value = part.partition("=")
            if not sep:
                raise ModelError(f"priors: {part.strip()!r} is not key=value (e.g. class=service or "
                                 "zeros=3deg)")
            if key.strip().lower() in items:
                raise ModelError(f"priors: {key.strip()} is given twice")
            items[key.strip().lower()] = value.strip()
        return cls.from_mapping(items)

    @classmethod
    def from_mapping(cls, items) -> PriorSpec:
        """From the model file's ``priors:`` mapping (the same keys and values as the text form)."""
        if isinstance(items, str):
            return cls.parse(items)
        if not isinstance(items, dict):
            raise ModelError(f"priors: expected a mapping like {{class: service, zeros: 3deg}}, got "
                             f"{items!r:.60}")
        known = {"class", "estimate", *GROUPS}
        unknown = sorted(str(k) for k in items if str(k) not in known)
        if unknown:
            raise ModelError(f"priors: unknown key(s) {unknown}; known: class, estimate, {', '.join(GROUPS)}")
        robot_class = canonical_class(items["class"]) if items.get("class") is not None else None
        estimate = items.get("estimate", True)
        if not isinstance(estimate, bool):
            estimate = _BOOL.get(str(estimate).strip().lower())
            if estimate is None:
                raise ModelError(f"priors: estimate must be yes or no, got {items['estimate']!r}")
        scales = {g: parse_value(g, items[g]) for g in GROUPS if items.get(g) is not None}
        return cls(robot_class, scales, estimate)

    def merged(self, other: PriorSpec | None) -> PriorSpec:
        """This spec with ``other``'s class and scales on top (the command line over the model file)."""
        if other is None:
            return self
        return PriorSpec(other.robot_class or self.robot_class, {**self.scales, **other.scales},
                         self.estimate and other.estimate, {})

    def to_dict(self) -> dict:
        """The model file's ``priors:`` block (display units; only what the user said)."""
        out: dict = {} if self.robot_class is None else {"class": self.robot_class}
        for g, v in self.scales.items():
            unit = GROUP_UNITS[g]
            out[g] = f"{v / _UNITS[g][unit]:.6g}{unit}"
        if not self.estimate:
            out["estimate"] = "no"
        return out


def class_of(robot) -> tuple[str, str]:
    """The robot's prior class and why: its own ``priors`` class, else its catalog maker, else
    :data:`SERVICE_MIN_JOINTS` or more joints (a torso before an arm) the service class, at most
    :data:`POSITIONER_MAX_JOINTS` the positioner class, else industrial (the scales are then
    widened where the data ask)."""
    spec = getattr(robot, "priors", None)
    if spec is not None and spec.robot_class is not None:
        return spec.robot_class, "named"
    name = str(robot.name).lower()
    if _in_catalog(name):  # a catalog model
        cls = next((c for prefix, c in CATALOG_CLASS.items() if re.match(prefix, name)), "industrial")
        return cls, f"model {robot.name}"
    if robot.n_joints >= SERVICE_MIN_JOINTS:
        return "service", f"{robot.n_joints} joints (a torso before an arm)"
    if robot.n_joints <= POSITIONER_MAX_JOINTS:
        joints = f"{robot.n_joints} joint{'s' * (robot.n_joints > 1)}"
        return POSITIONER_CLASS, f"{joints}: no arm has fewer than 3"
    return "industrial", "default for a serial arm"
