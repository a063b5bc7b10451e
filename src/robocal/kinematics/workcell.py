"""A work cell: arms and positioners (bodies) in one world frame, and its file.

Each body is a `Robot`: an arm (a fixed base, or a track cell chain) whose base is its base in the
world, or a positioner (`Positioner`: 1-3 axes, `robocal.kinematics.positioner`) whose base is its
mount and whose tool is its plate frame. The cell file (docs/model-yaml.md, "Work cells") extends the
track cell file (`robocal.kinematics.cell_file`)::

    units: {length: mm, angle: deg}
    name: welding cell
    robot: abb_irb2600                  # one arm (optional track: and mount: as a track cell), or
    robots: {left: {model: abb_irb2600, base: {xyz: [0, 0, 0]}, unit: ROB_1}, right: {...}}
    positioner:                         # one, or positioners: {STN1: {...}, STN2: {...}}
      model: abb_irbp_a250              # a catalog positioner, a file, an inline model; or axes:
      unit: STN1
      mount: {xyz: [1400, 0, 0], rpy: [0, 0, 0]}
      axes: [{type: revolute, axis: [1, 0, 0], origin: [0, 0, 900], limits: [-90, 90]}, ...]
      plate: {xyz: [0, 0, 0]}
      nests: [[200, 0, 0], [0, 200, 0], [-150, -150, 0]]
      columns: [e1, e2]
      external_axes: [2, 3]             # the controller's logical external axes it drives (default
                                        # the columns' numbers); each program language names them

Calibration (docs): the measurements of bodies seen in one tracker frame are block-diagonal: one
ordinary calibration per body, all in that frame; `Cell.in_world` then puts the calibrated bodies
in the controller's world, anchored on the first arm (`Cell.anchor`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError, ModelError, UnitError
from robocal.core.io import ANGLE_UNITS, LENGTH_UNITS, short_repr, write_atomic
from robocal.core.magnitudes import check_cell_offset
from robocal.core.yaml_load import dump_yaml
from robocal.kinematics.catalog import positioner_entry, positioner_names
from robocal.kinematics.cell_file import (
    SINGLE_ARM,
    _mapping,
    _numbers,
    _resolve,
    _text,
    _units,
    is_workcell,
    named,
    placement,
    read_arms,
)
from robocal.kinematics.model import (
    PRISMATIC,
    REVOLUTE,
    JointSpec,
    Robot,
    _looks_like_xml,
    arm_from_entry,
    links_length,
    load_model,
    placed,
)
from robocal.kinematics.model_file import (
    MAX_DESCRIPTION,
    MAX_NAME,
    _frame,
    _frame_dict,
    on_disk,
    read_model_data,
    reading_model,
    robot_kwargs,
    robot_to_dict,
)
from robocal.kinematics.positioner import check_chain, nests_in_last_frame, positioner_chain
from robocal.kinematics.transforms import invert_transform

FORMAT = "robocal-cell/1"
GEOMETRY_FORMS = ("model", "axes", "dh", "mdh", "joints")
SECTION_KEYS = {*GEOMETRY_FORMS, "limits", "unit", "mount", "plate", "nests", "columns", "external_axes",
                "name", "description"}
DEFINITION_KEYS = {"format", "name", "description", "units", "axes", "plate", "payload_kg"}
URDF_SUFFIXES = (".urdf", ".xml")  # a positioner's model given as a URDF (load_model reads it)
# a positioner joint's column (its measurement column is e<k>_deg|_mm); at most 6 digits (a longer
# number is no axis, and int() of thousands of digits fails)
COLUMN = re.compile(r"^e([1-9]\d{0,5})$")
SINGLE_POSITIONER = "positioner"  # the body name of a ``positioner:`` without name or unit
# What a calibration of a positioner identifies (docs/model-yaml.md, "Work cells"): Positioner.identifiability
WITH_NESTS = ("positioner {name}: SMR nests at known plate positions fix the plate frame: its axes, the "
              "plate frame and the last axis' zero ({zero}) are identified")
WITHOUT_NESTS = ("positioner {name}: no SMR nests at known plate positions: the SMRs' plate positions are "
                 "estimated, and the last axis' zero ({zero}) and the plate frame's turn about that axis "
                 "are one freedom: the zero is held at its nominal value")
ANCHOR_ALIAS = "flange"  # a body label: the anchor arm
PLATE_ALIAS = "plate"  # a body label: the only positioner


def _nests_in_flange(chain: Robot, nests: np.ndarray) -> Robot:
    """``chain`` with its extra SMRs the ``nests`` ``(K, 3)`` (plate frame, m) seen from its last
    frame {n} (``tool @ nest``; its nominal alike): SMR k is nest k."""
    def move(r: Robot) -> Robot:
        return replace(r, nominal=None, smr=nests_in_last_frame(r, nests))

    return replace(move(chain), nominal=move(chain.nominal_robot()).nominal)


@dataclass(frozen=True, eq=False)
class Positioner:
    """A positioner of a work cell: its chain, its program unit, its columns and its SMR nests.

    Parameters
    ----------
    chain : Robot
        1-3 axes (`robocal.kinematics.positioner.positioner_chain`): ``base`` the mount in the world,
        ``tool`` the plate frame (where the workpiece and its work object sit), joints its axes.
    unit : str
        Its mechanical unit in programs: ``"STN1"`` (RAPID ufmec), the KRL machine (EASYS / K_ROOT
        name), INFORM ``"ST1"``, FANUC ``"GP2"``.
    columns : tuple of str
        The measurement / joint columns of its axes, ``("e1", "e2")`` (files: ``e1_deg``, ``e2_mm``);
        default ``e1..en``.
    nests : numpy.ndarray, shape (K, 3), optional
        SMR nests at known positions in the plate frame (m); None: unknown. Nest k (1-based) is the
        chain's SMR k: its ``smr`` rows are the nests seen from its last frame (``tool @ nest``),
        so ``chain.fk(e, smr=k)`` is nest k's world pose; SMR 0 (the plate origin) is no nest.
    external_axes : tuple of int
        The controller's logical external-axis numbers of its axes, 1-based, in axis order: ``(2, 3)``
        is a robtarget's ``eax_b``, ``eax_c`` in RAPID, ``E2``, ``E3`` in KRL (each program language
        names them: `robocal.programs.dialects.base.Dialect.positioner_axes`); default the columns'
        numbers (``e2`` -> 2).

    See Also
    --------
    rc.Cell : The cell it belongs to.
    robocal.kinematics.positioner.positioner_chain : Its chain from axis descriptions.
    robocal.campaign.plan_cell : Plan the table angles of a cell's campaign.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.kinematics.positioner import positioner_chain
    >>> chain = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.8]}],
    ...                          mount=np.diag([1.0, 1.0, 1.0, 1.0]))
    >>> table = rc.Positioner(chain, unit="STN1", nests=np.array([[0.2, 0.0, 0.0]]))
    >>> table.columns, table.external_axes
    (('e1',), (1,))
    >>> table.plate(np.array([[np.pi / 2]]))[0, :3, 3].round(3)  # plate origin, m
    array([0. , 0. , 0.8])
    >>> table.chain.fk(np.array([[np.pi / 2]]), smr=[1])[0, :3, 3].round(3)  # nest 1 turned
    array([0. , 0.2, 0.8])
    """

    chain: Robot
    unit: str
    columns: tuple[str, ...] = ()
    nests: np.ndarray | None = None
    external_axes: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.chain, Robot):
            raise ModelError(f"a positioner's chain must be a Robot, got {type(self.chain).__name__}")
        check_chain(self.chain, self.chain.name)
        n = self.chain.n_joints
        set_(self, "unit", _text(self.unit, f"{self.chain.name}: unit", MAX_NAME))
        if not self.unit.strip():
            raise ModelError(f"{self.chain.name}: unit is empty: name its mechanical unit (STN1...)")
        columns = tuple(self.columns) or tuple(f"e{i + 1}" for i in range(n))
        bad = [c for c in columns if not isinstance(c, str) or not COLUMN.match(c)]
        if bad or len(columns) != n or len(set(columns)) != n:
            raise ModelError(f"{self.chain.name}: columns {list(columns)}: expected {n} distinct names "
                             "e1, e2, ... (one per axis)")
        set_(self, "columns", columns)
        axes = tuple(self.external_axes) or tuple(int(COLUMN.match(c)[1]) for c in columns)
        if len(axes) != n or len(set(axes)) != n or not all(
                isinstance(a, int | np.integer) and not isinstance(a, bool) and a >= 1 for a in axes):
            raise ModelError(f"{self.chain.name}: external_axes {list(axes)}: expected {n} distinct logical "
                             "external-axis numbers 1, 2, ... (one per axis)")
        set_(self, "external_axes", tuple(int(a) for a in axes))
        if self.nests is not None:
            nests = np.array(self.nests, dtype=float)
            if nests.ndim != 2 or nests.shape[1] != 3 or not len(nests) or not np.isfinite(nests).all():
                raise ModelError(f"{self.chain.name}: nests must be a finite (K, 3) array of plate "
                                 f"positions, got shape {nests.shape}")
            nests.flags.writeable = False
            set_(self, "nests", nests)
            if not len(self.chain.smr):
                set_(self, "chain", _nests_in_flange(self.chain, nests))
            elif len(self.chain.smr) != len(nests):
                raise ModelError(f"{self.chain.name}: {len(nests)} nests but its chain has "
                                 f"{len(self.chain.smr)} SMR offsets")

    @classmethod
    def from_catalog(cls, name: str, unit: str, mount: np.ndarray | None = None,
                     plate: np.ndarray | None = None, **kwargs) -> Positioner:
        """A catalog positioner (``robocal robots`` lists them) at ``mount`` ``(4, 4)`` (world -> its
        base, m) with an extra ``plate`` ``(4, 4)`` after the catalog's plate frame; ``kwargs``:
        ``columns``, ``nests`` (K, 3) m, ``external_axes``.

        Parameters
        ----------
        name : str
            A catalog positioner.
        unit : str
            Its program unit (``STN1``...).
        mount : numpy.ndarray, shape (4, 4), optional
            World -> its base (m); default identity.
        plate : numpy.ndarray, shape (4, 4), optional
            An extra transform after the catalog's plate frame (m).
        **kwargs
            ``columns``, ``nests``, ``external_axes`` (`Positioner`).

        Returns
        -------
        Positioner
            The positioner.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> mount = np.eye(4)
        >>> mount[0, 3] = 1.5
        >>> table = rc.Positioner.from_catalog("abb_irbp_a250", "STN1", mount)
        >>> table.plate(np.zeros((1, 2)))[0, :3, 3].round(3)  # 1.5 m out, plate 1.15 m up
        array([1.5 , 0.  , 1.15])
        """
        return cls(placed(catalog_positioner(name)[0], mount, plate), unit, **kwargs)

    @property
    def n_axes(self) -> int:
        """The number of axes (joints of the chain)."""
        return self.chain.n_joints

    @property
    def joints(self) -> tuple[JointSpec, ...]:
        """Each axis as messages, range checks and joints files name it: its column (``e1``), its
        kind and limits (rad or m); ``.column`` is its CSV column (``e1_deg``, ``e2_mm``)."""
        return tuple(JointSpec(c, PRISMATIC if slides else REVOLUTE, (float(lo), float(hi)))
                     for c, slides, (lo, hi) in zip(self.columns, self.chain.prismatic, self.chain.limits,
                                                    strict=True))

    @property
    def identifiability(self) -> str:
        """What a calibration identifies of this positioner, in words: with nests, the axes, the
        plate frame and the last axis' zero; without, the zero is confounded with the plate's turn
        about the last axis and held at its nominal value (the parameter named)."""
        template = WITH_NESTS if self.nests is not None else WITHOUT_NESTS
        return template.format(name=self.chain.name, zero=self.chain.joint_params[-1])

    def plate(self, e) -> np.ndarray:
        """World poses ``(N, 4, 4)`` (m) of the plate frame at axis values ``e`` ``(N, n)`` (rad; m
        for a prismatic axis).

        Parameters
        ----------
        e : array_like, shape (N, n)
            Axis values (rad; m for a prismatic axis).

        Returns
        -------
        numpy.ndarray, shape (N, 4, 4)
            World poses of the plate frame (m).

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> from robocal.kinematics.positioner import positioner_chain
        >>> chain = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.8]}])
        >>> rc.Positioner(chain, unit="STN1").plate(np.zeros((2, 1))).shape
        (2, 4, 4)
        """
        return self.chain.fk(e)

    def __repr__(self) -> str:
        return f"Positioner({self.chain.name!r}, unit {self.unit!r}, columns {list(self.columns)})"

    def to_dict(self) -> dict:
        """The positioner's entry of a saved cell file (SI: its chain as an inline model).

        Returns
        -------
        dict
            The cell file's entry of this positioner.
        """
        out = {"model": robot_to_dict(self.chain), "unit": self.unit, "columns": list(self.columns),
               "external_axes": list(self.external_axes)}
        if self.nests is not None:
            out["nests"] = self.nests.tolist()
        return out


@dataclass(frozen=True, eq=False)
class Cell:
    """A work cell: arms and positioners (bodies) in one world frame.

    Parameters
    ----------
    arms : dict of str to Robot
        Body name -> arm; its ``base`` is the arm's base in the world (a track cell chain allowed).
    positioners : dict of str to Positioner
        Body name -> positioner (its chain's base is its mount in the world).
    name, description : str
        The cell's name and description.
    arm_units : dict of str to str
        Arm name -> its mechanical unit in programs (``ROB_1``); an arm not named: its body name.
    flanges : dict of str to numpy.ndarray
        Arm name -> its flange frame tool0 ``(4, 4)`` as its model composes it (`flange`), where
        the arm's ``tool`` is not it: a model file's ``tool`` describes the measured SMR 0. An arm
        not named: its tool is its flange.

    See Also
    --------
    rc.Positioner : A positioner of the cell.
    rc.load_cell : A cell from its file.
    rc.CellMeasurements : A cell's measurements, split per body.
    rc.CellCalibration : The calibration of a cell.

    Notes
    -----
    Bodies are named uniquely; units are unique; a body's name may not be another body's unit
    (a measurement's ``body`` column names either). Positioner columns are distinct and do not
    take a track's ``e1``. The anchor (`anchor`) is the first arm, or the first positioner when
    the cell has no arm: `in_world` ties the tracker frame to the world on it.

    Examples
    --------
    >>> import numpy as np
    >>> import robocal as rc
    >>> from robocal.kinematics.positioner import positioner_chain
    >>> arm = rc.Robot.from_catalog("abb_irb2600")
    >>> mount = np.eye(4)
    >>> mount[0, 3] = 1.4  # 1.4 m in front of the arm
    >>> turn = positioner_chain([{"type": "revolute", "axis": [0, 0, 1], "origin": [0, 0, 0.8]}], mount)
    >>> cell = rc.Cell({"arm": arm}, {"STN1": rc.Positioner(turn, unit="STN1")}, name="turn cell")
    >>> cell.anchor, cell.resolve("plate"), cell.body("STN1").n_joints
    ('arm', 'STN1', 1)
    >>> cell.save("cell.yaml")
    >>> again = rc.load_cell("cell.yaml")
    >>> bool(np.array_equal(again.positioners["STN1"].chain.base, turn.base))
    True
    """

    arms: dict[str, Robot]
    positioners: dict[str, Positioner] = field(default_factory=dict)
    name: str = "cell"
    description: str = ""
    arm_units: dict[str, str] = field(default_factory=dict)
    flanges: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "arms", dict(self.arms))
        set_(self, "positioners", dict(self.positioners))
        set_(self, "name", _text(self.name, "name", MAX_NAME))
        set_(self, "description", _text(self.description, "description", MAX_DESCRIPTION))
        for label, kind, group in (("arm", Robot, self.arms), ("positioner", Positioner, self.positioners)):
            for name, body in group.items():
                if not isinstance(name, str) or not name.strip():
                    raise ModelError(f"a {label}'s name must be a non-empty text, got {short_repr(name)}")
                if not isinstance(body, kind):
                    raise ModelError(f"{label} {name!r}: expected a {kind.__name__}, got "
                                     f"{type(body).__name__}")
        if not self.arms and not self.positioners:
            raise ModelError("a cell needs at least one body (an arm or a positioner)")
        both = sorted(set(self.arms) & set(self.positioners))
        if both:
            raise ModelError(f"body name {both[0]!r} used twice (an arm and a positioner)")
        unknown = sorted(set(self.arm_units) - set(self.arms))
        if unknown:
            raise ModelError(f"arm_units names no arm: {unknown}; arms: {sorted(self.arms)}")
        set_(self, "arm_units", {n: _text(self.arm_units.get(n, n), f"robots.{n}.unit", MAX_NAME)
                                 for n in self.arms})
        stray = sorted(set(self.flanges) - set(self.arms))
        if stray:
            raise ModelError(f"flanges names no arm: {stray}; arms: {sorted(self.arms)}")
        set_(self, "flanges", {n: np.asarray(f, float).reshape(4, 4) for n, f in self.flanges.items()})
        empty = [n for n, u in self.arm_units.items() if not u.strip()]
        if empty:
            raise ModelError(f"robots.{empty[0]}.unit is empty: name its mechanical unit (ROB_1...)")
        self._check_units()
        self._check_columns()

    def _check_units(self) -> None:
        units = {**{n: u for n, u in self.arm_units.items()},
                 **{n: p.unit for n, p in self.positioners.items()}}
        seen: dict[str, str] = {}
        for body, unit in units.items():
            if unit in seen:
                raise ModelError(f"unit {unit!r} named twice (bodies {seen[unit]!r} and {body!r})")
            seen[unit] = body
        for body in units:
            owner = seen.get(body)
            if owner is not None and owner != body:
                raise ModelError(f"body name {body!r} is also the unit of body {owner!r}: a measurement's "
                                 "body column could mean either")

    def _check_columns(self) -> None:
        taken = {"e1": name for name, arm in self.arms.items() if arm.external_axes}  # noqa: B035 (any track)
        for name, p in self.positioners.items():
            for column in p.columns:
                if column in taken:
                    other = taken[column]
                    what = f"the track of arm {other!r}" if other in self.arms else f"positioner {other!r}"
                    raise ModelError(f"positioner {name!r}: column {column} is already {what}'s")
                taken[column] = name

    def flange(self, name: str) -> np.ndarray:
        """Arm ``name``'s flange frame tool0 ``(4, 4)`` in its model's last frame: what a
        controller's tool data and a program's targets are given on. The arm's model's tool is the
        measured SMR 0 (the cell file's ``tool`` of its model), so the flange is its model without
        that tool (`flanges`), or its tool when the model gives none.

        Parameters
        ----------
        name : str
            The arm's name.

        Returns
        -------
        numpy.ndarray, shape (4, 4)
            The flange frame (m) in the model's last frame.
        """
        return self.flanges.get(name, self.arms[name].tool)

    def controller_arm(self, name: str) -> Robot:
        """Arm ``name`` with its flange (`flange`) as its TCP: the arm a controller computes with.

        Parameters
        ----------
        name : str
            The arm's name.

        Returns
        -------
        Robot
            The arm with its flange as tool.
        """
        return self.arms[name].with_frames(tool=self.flange(name))

    @property
    def anchor(self) -> str:
        """The body that ties the tracker frame to the world: the first arm, else the first
        positioner."""
        return next(iter(self.arms)) if self.arms else next(iter(self.positioners))

    @property
    def bodies(self) -> list[str]:
        """Every body's name: the arms, then the positioners."""
        return [*self.arms, *self.positioners]

    def resolve(self, label: str) -> str:
        """The body name of a label: a body's name or unit, ``"flange"`` (the anchor arm) or
        ``"plate"`` (the only positioner); ModelError listing the bodies otherwise.

        Parameters
        ----------
        label : str
            A body's name or unit, ``"flange"`` or ``"plate"``.

        Returns
        -------
        str
            The body's name.

        Raises
        ------
        ModelError
            No body has that label.

        Examples
        --------
        >>> import robocal as rc
        >>> cell = rc.Cell({"left": rc.Robot.from_catalog("abb_irb2600")}, arm_units={"left": "ROB_1"})
        >>> cell.resolve("ROB_1"), cell.resolve("flange")
        ('left', 'left')
        """
        if label in self.arms or label in self.positioners:
            return label
        units = {**{u: n for n, u in self.arm_units.items()},
                 **{p.unit: n for n, p in self.positioners.items()}}
        if label in units:
            return units[label]
        if label == ANCHOR_ALIAS and self.arms:
            return next(iter(self.arms))
        if label == PLATE_ALIAS and len(self.positioners) == 1:
            return next(iter(self.positioners))
        raise ModelError(f"no body {label!r} in cell {self.name!r}: bodies {self.bodies} (units "
                         f"{sorted(units)}; {ANCHOR_ALIAS!r} is the first arm, {PLATE_ALIAS!r} the only "
                         "positioner)")

    def pick(self, kind: str, given: str | None = None, *, optional: bool = False) -> str | None:
        """The body a caller works on among the cell's ``kind`` (``"arm"`` or ``"positioner"``):
        ``given`` (any label `resolve` takes), else the only one (None when ``optional`` and the
        cell has none). DataError naming the bodies of that kind when ``given`` is not one of them
        or there is no single one; callers add their context (an option's name, what it is for).

        Parameters
        ----------
        kind : {"arm", "positioner"}
            The kind of body.
        given : str, optional
            A label `resolve` takes.
        optional : bool, default False
            No body of that kind is not an error (None is returned).

        Returns
        -------
        str or None
            The body's name.

        Raises
        ------
        DataError
            ``given`` is not a body of that kind, or there is not exactly one.

        Examples
        --------
        >>> import robocal as rc
        >>> cell = rc.Cell({"left": rc.Robot.from_catalog("abb_irb2600")}, arm_units={"left": "ROB_1"})
        >>> cell.pick("arm"), cell.pick("arm", "ROB_1"), cell.pick("positioner", optional=True)
        ('left', 'left', None)
        """
        names = {"arm": self.arms, "positioner": self.positioners}[kind]
        listed = ", ".join(names) or "none"
        if given is not None:
            try:
                name = self.resolve(given)
            except ModelError:
                name = None
            if name not in names:  # another kind of body: its name is valid, its use is not
                raise DataError(f"{given!r} is not one of the cell's {kind}s ({listed})")
            return name
        if optional and not names:
            return None
        if len(names) != 1:
            raise DataError(f"the cell has {len(names)} {kind}s ({listed}): name the one to use")
        return next(iter(names))

    def body(self, name: str) -> Robot:
        """The `Robot` of a body (an arm, or a positioner's chain), by any label `resolve` takes.

        Parameters
        ----------
        name : str
            Any label `resolve` takes.

        Returns
        -------
        Robot
            The body's model.

        Examples
        --------
        >>> import robocal as rc
        >>> rc.Cell({"left": rc.Robot.from_catalog("abb_irb2600")}).body("left").n_joints
        6
        """
        name = self.resolve(name)
        return self.arms[name] if name in self.arms else self.positioners[name].chain

    def joints(self, name: str) -> tuple[JointSpec, ...]:
        """The joints of a body (by any label `resolve` takes) as measurement files name them: an
        arm's ``q1..`` (a track's ``e1``), a positioner's `Positioner.columns`.

        Parameters
        ----------
        name : str
            Any label `resolve` takes.

        Returns
        -------
        tuple of JointSpec
            One a joint: its column name and unit.

        Examples
        --------
        >>> import robocal as rc
        >>> cell = rc.load_cell("abb_irb2600")
        >>> [j.column for j in cell.joints("flange")][:2]
        ['q1_deg', 'q2_deg']
        """
        name = self.resolve(name)
        return self.arms[name].joints if name in self.arms else self.positioners[name].joints

    def unit_of(self, name: str) -> str:
        """The program unit of a body (by any label `resolve` takes).

        Parameters
        ----------
        name : str
            Any label `resolve` takes.

        Returns
        -------
        str
            The unit (``ROB_1``, ``STN1``...).
        """
        name = self.resolve(name)
        return self.arm_units[name] if name in self.arms else self.positioners[name].unit

    def in_world(self, calibrated: Mapping[str, Robot]) -> Cell:
        """The cell with calibrated bodies (identified in one tracker frame) put in the
        controller's world.

        The anchor's identified frame {0} is where the controller believes its base is:
        ``world_T_tracker = nominal_anchor.base @ inv(calibrated_anchor.base)``, and each other
        calibrated body's base in the world is ``world_T_tracker @ calibrated.base``. A body not in
        ``calibrated`` stays nominal. Each moved body's nominal model is this cell's (a parameter the
        cell's body lacks, such as an SMR the calibration estimated, keeps the calibration's nominal),
        so ``nominal_robot()`` is the controller's model.

        Parameters
        ----------
        calibrated : mapping of str to Robot
            Body label -> its calibrated model, every base in the one tracker frame; must include
            the anchor.

        Returns
        -------
        Cell

        Raises
        ------
        ModelError
            The anchor is missing, a label names no body, or a model's joints differ from the body's.

        Examples
        --------
        >>> import numpy as np
        >>> import robocal as rc
        >>> arm = rc.Robot.from_catalog("abb_irb2600")
        >>> cell = rc.Cell({"arm": arm})
        >>> seen = arm.with_values({"base.x": 2.0, "a2": 0.151})  # identified in the tracker frame
        >>> world = cell.in_world({"arm": seen})
        >>> world.arms["arm"].get("base.x"), world.arms["arm"].get("a2")
        (0.0, 0.151)
        """
        labels = {self.resolve(label): model for label, model in calibrated.items()}
        if self.anchor not in labels:
            raise ModelError(f"the anchor body {self.anchor!r} must be among the calibrated bodies: its "
                             "frame {0} ties the tracker frame to the world")
        world_T_tracker = self.body(self.anchor).base @ invert_transform(labels[self.anchor].base)
        arms, positioners = dict(self.arms), dict(self.positioners)
        for name, model in labels.items():
            nominal = self.body(name)
            if not isinstance(model, Robot) or model.n_joints != nominal.n_joints \
                    or not np.array_equal(model.prismatic, nominal.prismatic):
                raise ModelError(f"calibrated {name!r}: its joints differ from the cell's {nominal.name} "
                                 f"({nominal.n_joints} joints)")
            base = nominal.base if name == self.anchor else world_T_tracker @ model.base
            moved = replace(model, base=base, nominal=_controllers_nominal(model, nominal))
            if name in arms:
                arms[name] = moved
            else:
                positioners[name] = replace(positioners[name], chain=moved)
        return replace(self, arms=arms, positioners=positioners)

    def to_dict(self) -> dict:
        """The saved cell file's mapping (SI; every body as an inline model).

        Returns
        -------
        dict
            The cell file's content.
        """
        out: dict = {"format": FORMAT, "name": self.name, "description": self.description,
                     "units": {"length": "m", "angle": "rad"}}
        if self.arms:
            out["robots"] = {n: {"model": robot_to_dict(a), "unit": self.arm_units[n],
                                 **({"flange": _frame_dict(self.flanges[n])} if n in self.flanges else {})}
                             for n, a in self.arms.items()}
        if self.positioners:
            out["positioners"] = {n: p.to_dict() for n, p in self.positioners.items()}
        return out

    def save(self, path) -> None:
        """Write the cell file (SI units, every body's model inline: an exact round trip),
        atomically.

        Parameters
        ----------
        path : str or pathlib.Path
            The YAML file to write.

        Examples
        --------
        >>> import robocal as rc
        >>> rc.Cell({"arm": rc.Robot.from_catalog("ur10e")}).save("one_arm.yaml")
        >>> rc.load_model("one_arm.yaml").name  # one arm, no positioner: a robot too
        'ur10e'
        """
        write_atomic(path, dump_yaml(self.to_dict()))

    @classmethod
    def load(cls, path) -> Cell:
        """Read a cell file (`load_cell`).

        Parameters
        ----------
        path : str or pathlib.Path
            A cell file.

        Returns
        -------
        Cell
            The cell.
        """
        return load_cell(path)

    def __repr__(self) -> str:
        return f"Cell({self.name!r}, arms {list(self.arms)}, positioners {list(self.positioners)})"


def _controllers_nominal(model: Robot, body: Robot) -> np.ndarray:
    """The nominal geometry vector of calibrated ``model`` in the world: the cell's ``body``'s
    nominal value of every parameter both have, ``model``'s own nominal for the others."""
    nominal = model.nominal.copy()
    names = model.geometry_names
    known = dict(zip(body.geometry_names, body.nominal, strict=True))
    shared = [i for i, name in enumerate(names) if name in known]
    nominal[shared] = [known[names[i]] for i in shared]
    return nominal


def _axes_si(values, length: float, angle: float, where: str) -> list[dict]:
    """A file's ``axes`` list in SI (origins and prismatic limits in ``length``, rpy and revolute
    limits in ``angle``); the rest is checked by `positioner_chain`."""
    if not isinstance(values, list):
        raise ModelError(f"{where}: expected a list of axes {{type, axis, origin, rpy, limits}}, got "
                         f"{short_repr(values)}")
    out = []
    for i, spec in enumerate(values, 1):
        if not isinstance(spec, dict):
            raise ModelError(f"{where}[{i}]: expected a mapping {{type, axis, origin, rpy, limits}}")
        axis = dict(spec)
        for key, scale in (("origin", length), ("rpy", angle), ("axis", 1.0)):
            if key in axis:
                axis[key] = _numbers(axis[key], f"{where}[{i}].{key}", 3) * scale
        if axis.get("limits") is not None:
            axis["limits"] = _numbers(axis["limits"], f"{where}[{i}].limits", 2) * \
                (length if axis.get("type") == "prismatic" else angle)
        out.append(axis)
    return out


def _definition(data: dict, where: str, name: str) -> Robot:
    """The chain of a positioner definition (a catalog positioner, its file, or an inline mapping
    with ``axes``: units, axes, plate)."""
    data = _mapping(data, where, DEFINITION_KEYS, {"units", "axes"})
    length_unit, angle_unit = _units(data)
    length, angle = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit]
    return positioner_chain(_axes_si(data["axes"], length, angle, f"{where}.axes"),
                            plate=_frame(data.get("plate"), length, angle, f"{where}.plate"),
                            name=_text(data.get("name", name), f"{where}.name", MAX_NAME),
                            description=_text(data.get("description", ""), f"{where}.description",
                                              MAX_DESCRIPTION))


def catalog_positioner(name: str) -> tuple[Robot, float | None]:
    """The chain (mount at the identity, plate frame as the catalog gives it) and the payload (kg,
    None when the entry gives none) of catalog positioner ``name``; ModelError listing the catalog
    for an unknown name.

    Examples
    --------
    >>> from robocal.kinematics.workcell import catalog_positioner
    >>> chain, payload = catalog_positioner("abb_irbp_a250")
    >>> chain.n_joints, payload
    (2, 250)
    """
    entry = positioner_entry(name)
    if entry is None:
        raise ModelError(f"unknown positioner {name!r}; the catalog has: {', '.join(positioner_names())} "
                         "(run `robocal robots`)")
    return _definition(entry, f"catalog positioner {name!r}", name), entry.get("payload_kg")


def _model_chain(model, path: Path | None, where: str, name: str) -> Robot:
    """The chain a positioner's ``model:`` names: a catalog positioner, a file (a positioner
    definition or a model file), or an inline mapping (either)."""
    if isinstance(model, str) and positioner_entry(model) is not None:
        return catalog_positioner(model)[0]
    if isinstance(model, str):
        spec = _resolve(model, path, f"{where}.model")
        if not Path(spec).suffix and not on_disk(Path(spec)):
            raise ModelError(f"{where}.model: unknown positioner {model!r}; the catalog has: "
                             f"{', '.join(positioner_names())} (run `robocal robots`), or give a file")
        file = Path(spec)
        if file.suffix.lower() in URDF_SUFFIXES or (on_disk(file, Path.is_file) and _looks_like_xml(file)):
            return load_model(spec)  # a URDF of the positioner's chain (its root link the mount)
        model = read_model_data(spec)
        where = f"{where}.model ({spec})"
    if not isinstance(model, dict):
        raise ModelError(f"{where}.model: expected a catalog positioner, a file or a mapping, got "
                         f"{short_repr(model)}")
    if "axes" in model:
        return _definition(model, where, name)
    return Robot(**robot_kwargs({"name": name, **model}))


def _positioner(spec, name: str, data: dict, path: Path | None, first: int,
                reach_m: float | None) -> Positioner:
    """A positioner section of a cell file (module docstring); its columns default to
    ``e<first>..``; its mount and axis origins are checked in the file's unit against the size
    ``reach_m`` (m) of the cell's arms (None: a cell without arms, against its own)."""
    where = "positioner" if "positioner" in data else f"positioners.{name}"
    spec = _mapping(spec, where, SECTION_KEYS if where == "positioner" else SECTION_KEYS - {"name"})
    length_unit, angle_unit = _units(data)
    length, angle = LENGTH_UNITS[length_unit], ANGLE_UNITS[angle_unit]
    forms = [k for k in GEOMETRY_FORMS if k in spec]
    if len(forms) != 1:
        raise ModelError(f"{where}: give exactly one geometry: model (a catalog positioner or a file), "
                         f"axes, dh, mdh or joints (found {forms or 'none'})")
    if "limits" in spec and forms[0] not in ("dh", "mdh"):
        raise ModelError(f"{where}.limits: only with a dh or mdh table (axes and joints rows carry "
                         "their own)")
    mount = placement(spec.get("mount"), length_unit, angle, f"{where}.mount")
    plate = _frame(spec.get("plate"), length, angle, f"{where}.plate")
    description = _text(spec.get("description", ""), f"{where}.description", MAX_DESCRIPTION)
    if forms[0] == "axes":
        chain = positioner_chain(_axes_si(spec["axes"], length, angle, f"{where}.axes"), mount, plate,
                                 name=name, description=description)
    elif forms[0] == "model":
        chain = placed(_model_chain(spec["model"], path, where, name), mount, plate)
    else:
        table = {"units": data["units"], "name": name, forms[0]: spec[forms[0]],
                 **({"limits": spec["limits"]} if "limits" in spec else {})}
        chain = placed(Robot(**robot_kwargs(table)), mount, plate)
    size = links_length(chain) if reach_m is None else reach_m
    if size > 0:  # a positioner written in another unit than the file's (a riser, an axis height)
        if mount is not None:
            check_cell_offset(mount[:3, 3], length_unit, size, f"{where}.mount")
        if forms[0] == "axes":
            axes = _axes_si(spec["axes"], length, angle, f"{where}.axes")
            check_cell_offset(np.reshape([a["origin"] for a in axes if "origin" in a], (-1, 3)), length_unit,
                              size, f"{where}.axes' origins")
    if description:
        chain = replace(chain, description=description)
    nests = None
    if spec.get("nests") is not None:
        if not isinstance(spec["nests"], list) or not spec["nests"]:
            raise ModelError(f"{where}.nests: expected a list of [x, y, z] plate positions")
        nests = np.array([_numbers(v, f"{where}.nests[{i}]", 3)
                          for i, v in enumerate(spec["nests"], 1)]) * length
    columns = _names(spec.get("columns"), f"{where}.columns") or \
        tuple(f"e{first + i}" for i in range(chain.n_joints))
    unit = _text(spec.get("unit", name), f"{where}.unit", MAX_NAME)
    return Positioner(chain, unit, columns, nests, _numbers_list(spec.get("external_axes"),
                                                                 f"{where}.external_axes"))


def _numbers_list(values, where: str) -> tuple:
    """A file's list (``external_axes: [2, 3]``) as a tuple, () when absent; `Positioner` checks
    its items."""
    if values is None:
        return ()
    if not isinstance(values, list):
        raise ModelError(f"{where}: expected a list of logical external-axis numbers ([2, 3]: the "
                         f"controller's second and third external axes), got {short_repr(values)}")
    return tuple(values)


def _names(values, where: str) -> tuple[str, ...]:
    if values is None:
        return ()
    if not isinstance(values, list) or not all(isinstance(v, str) for v in values):
        raise ModelError(f"{where}: expected a list of names, got {short_repr(values)}")
    return tuple(values)


def cell_from_data(data: dict, path: Path | None = None) -> Cell:
    """The `Cell` of a work cell mapping (module docstring); arm and positioner files relative to
    ``path``'s folder. ModelError names the key."""
    entries = read_arms(data, path)
    arms = {name: arm_from_entry(entry) for name, entry in entries.items()}
    units = {name: entry.unit for name, entry in entries.items()}
    flanges = {name: f for name, entry in entries.items() if (f := _flange(entry)) is not None}
    if "positioner" in data and "positioners" in data:
        raise ModelError("give either positioner: (one) or positioners: {name: ...}, not both")
    if "positioner" in data:
        spec = data["positioner"]
        label = spec.get("name", spec.get("unit", SINGLE_POSITIONER)) if isinstance(spec, dict) else ""
        sections = {_text(label, "positioner.name", MAX_NAME): spec}
    else:
        sections = named(data["positioners"], "positioners") if "positioners" in data else {}
        if "positioners" in data and not sections:
            raise ModelError("positioners: expected at least one positioner {name: {axes or model, ...}}")
    positioners: dict[str, Positioner] = {}
    following = 1 + any(arm.external_axes for arm in arms.values())  # after a track's e1
    reach = max((links_length(arm) for arm in arms.values()), default=None)
    for name, spec in sections.items():
        positioner = _positioner(spec, name, data, path, following, reach)
        positioners[name] = positioner
        following = max(int(COLUMN.match(c)[1]) for c in positioner.columns) + 1
    default_name = next(iter(arms.values())).name if len(arms) == 1 and not positioners else "cell"
    return Cell(arms, positioners, _text(data.get("name", default_name), "name", MAX_NAME),
                _text(data.get("description", ""), "description", MAX_DESCRIPTION), units, flanges)


TABLE_FORMS = ("opw", "dh", "mdh")  # a model file's geometry that its base and tool wrap (docs/model-yaml.md)


def _flange(entry) -> np.ndarray | None:
    """The flange frame of a cell file's arm whose model gives a ``tool`` (the SMR 0 its
    measurements call the tool): its model loaded without ``tool``, when the geometry is a table
    form whose conversion the tool wraps; a saved cell's ``flange``; else None (the tool is the
    flange: a catalog arm, a model without tool, ``joints`` rows whose tool is the model's own)."""
    if entry.flange is not None:
        return entry.flange
    model = entry.model
    if isinstance(model, str) and Path(model).suffix.lower() in (".yaml", ".yml") and on_disk(Path(model),
                                                                                                Path.is_file):
        model = read_model_data(Path(model))
    if not isinstance(model, dict) or model.get("tool") is None or "joints" in model \
            or not any(k in model for k in TABLE_FORMS):
        return None
    return Robot(**robot_kwargs({k: v for k, v in model.items() if k not in ("tool", "smr")})).tool


def load_cell(path) -> Cell:
    """A work cell from its file (docs/model-yaml.md, "Work cells"), or a one-arm cell from any model
    `load_model` reads (a model file, a track cell file, a URDF, a catalog name).

    Parameters
    ----------
    path : str or path-like
        The cell file (YAML), or any robot model.

    Returns
    -------
    Cell
        Arms in file order (the first is the anchor), positioners in file order. A one-arm input's
        arm is named ``arm`` (``robot:`` cells too).

    Raises
    ------
    ModelError
        A malformed file, one line naming the file, the key and the cause: an unknown key, a
        positioner whose axes are zero or coaxial, a unit or body named twice, nests that are not
        3-vectors, positioner columns clashing with a track's e1...

    See Also
    --------
    rc.Cell : The cell it returns.
    rc.load_model : A robot (a cell of one arm is one too).

    Examples
    --------
    >>> import robocal as rc
    >>> _ = open("cell.yaml", "w").write('''
    ... units: {length: mm, angle: deg}
    ... name: welding cell
    ... robots:
    ...   left: {model: abb_irb2600, unit: ROB_1}
    ...   right: {model: abb_irb2600, base: {xyz: [3000, 0, 0], rpy: [0, 0, 180]}, unit: ROB_2}
    ... positioner:
    ...   unit: STN1
    ...   mount: {xyz: [1500, 0, 0]}
    ...   axes: [{type: revolute, axis: [1, 0, 0], origin: [0, 0, 900], limits: [-90, 90]},
    ...          {type: revolute, axis: [0, 0, 1], origin: [0, 0, 250], limits: [-360, 360]}]
    ...   nests: [[200, 0, 0], [0, 200, 0], [-150, -150, 0]]
    ... ''')
    >>> cell = rc.load_cell("cell.yaml")
    >>> cell
    Cell('welding cell', arms ['left', 'right'], positioners ['STN1'])
    >>> cell.positioners["STN1"].columns, cell.anchor
    (('e1', 'e2'), 'left')
    >>> cell.arms["right"].base[:3, 3].round(3).tolist()
    [3.0, 0.0, 0.0]
    """
    spec = Path(path)
    if spec.suffix.lower() in (".yaml", ".yml") or (on_disk(spec, Path.is_file)
                                                     and not _looks_like_xml(spec)):
        data = read_model_data(spec)
        if is_workcell(data):
            try:
                with reading_model(spec):
                    return cell_from_data(data, spec)
            except (ModelError, UnitError) as exc:
                raise ModelError(f"{path}: {exc}") from None
    arm = load_model(str(path))
    return Cell({SINGLE_ARM: arm}, name=arm.name, description=arm.description)
