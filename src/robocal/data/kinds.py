"""The kinds of measurement rows and what each observes: the one registry every module asks.

A measurement set (:class:`robocal.data.measurements.Measurements`) holds one kind of row; its
observation model (residuals and Jacobian rows) is the class `KindSpec.observation` names in
`robocal.identify.observations`. A module that treats kinds differently asks the kind's
`KindSpec` a capability (``data.spec.sees_position``) instead of naming kinds; a new kind is one
entry here and one observation module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robocal.core.errors import DataError


@dataclass(frozen=True)
class KindSpec:
    """What one kind of measurement row observes and how its rows belong together.

    Attributes
    ----------
    name : str
        The kind's name (``Measurements.kind``, the CSV's observation columns).
    observation : str
        Its observation model, ``"module:Class"`` in `robocal.identify.observations`.
    arrays : tuple of str
        The observation arrays of `Measurements` it requires.
    optional : tuple of str
        The observation arrays it takes besides (and no others).
    sigma_m : float
        The 1-sigma noise (m) of a row when a set of several kinds has no sigma column and none is
        given: a laser tracker 2-4 m away (points, a 6-DOF pose's position), a touch probe, a scale
        bar or ball bar.
    sees_position : bool
        Each row is a measured position of the TCP (an SMR or probe) in the tracker frame: a
        tracker's data, registration and frame fits apply, candidates are generated from joints
        alone, and a simulation measures it from a tracker at a random place.
    sees_orientation : bool
        Each row also measures the TCP's orientation (a 6-DOF probe).
    sees_tilt : bool
        Each row constrains two angles of the TCP's orientation (a flush face): the tool's
        rotation is estimated by default, as for a 6-DOF probe.
    several_smrs : bool
        One pose may give several rows, one per SMR the tracker sees.
    group : str
        The `Measurements` array whose equal values mark rows that stay together (a pose, or the
        two ends of a distance pair).
    rows_per_placement : int
        Rows one placement of the robot gives with one SMR (a distance pair: its two ends).
    columns : str
        How its CSV columns are named in messages.
    column : str
        The CSV column that marks a file of this kind and holds its integer array (``plane``,
        ``flush_plane``); "" for kinds recognised by their measured columns.
    derived : bool
        Rows a model makes of another kind's (a work cell's plate SMRs in declared nests,
        `robocal.calibration.cell`), not a kind of file, of simulation or of campaign of its own
        (left out of `KINDS`).
    """

    name: str
    observation: str
    arrays: tuple[str, ...]
    sigma_m: float
    optional: tuple[str, ...] = ()
    sees_position: bool = False
    sees_orientation: bool = False
    sees_tilt: bool = False
    several_smrs: bool = False
    group: str = "pose_id"
    rows_per_placement: int = 1
    columns: str = ""
    column: str = ""
    derived: bool = False

    def readings(self, T: np.ndarray) -> dict[str, np.ndarray]:
        """The observation arrays a perfect reading of TCP poses ``T (N, 4, 4)`` (tracker frame, m)
        gives: positions, and orientations for a kind that sees them (kinds that see a position)."""
        out = {"points": T[:, :3, 3]}
        if self.sees_orientation:
            out["rotations"] = T[:, :3, :3]
        return out


# A flush contact's two angle rows are its tilts (rad) times this length (m): the lift of the rim of a
# face of this radius, so its three rows are lengths with one noise (`sigma_m`)
FLUSH_TILT_LENGTH_M = 0.05

OBSERVED = {spec.name: spec for spec in (
    KindSpec("point", "point:PointObservation", ("points",), sigma_m=20e-6, sees_position=True,
             several_smrs=True, columns="x_mm,y_mm,z_mm"),
    KindSpec("pose", "pose:PoseObservation", ("points", "rotations"), sigma_m=20e-6, sees_position=True,
             sees_orientation=True, columns="x_mm,y_mm,z_mm and qw..qz"),
    KindSpec("plane", "plane:PlaneObservation", ("plane",), sigma_m=10e-6, columns="a plane", column="plane"),
    KindSpec("flush", "flush:FlushObservation", ("plane",), sigma_m=10e-6, sees_tilt=True,
             columns="flush_plane (the tool face flush on a plane)", column="flush_plane"),
    KindSpec("distance", "distance:DistanceObservation", ("pair", "distance"), sigma_m=5e-6, group="pair",
             rows_per_placement=2, columns="pair and distance_mm"),
    # SMRs in nests at known places on a tool frame (a positioner's plate): the tool's six parameters
    # seen through the nests, the nests held (the registration of flange SMRs does not apply)
    KindSpec("nest", "nest:NestObservation", ("points",), sigma_m=20e-6, several_smrs=True,
             columns="x_mm,y_mm,z_mm of SMRs in known nests", derived=True),
    # motion capture: markers on any link, their offsets and the capture frame estimated with the robot
    KindSpec("marker", "marker:MarkerObservation", ("points",), optional=("link",), sigma_m=0.3e-3,
             several_smrs=True, columns="x_mm,y_mm,z_mm and link"),
    # a camera's board poses (board in the camera frame): camera in the cell, board on the flange ...
    KindSpec("eye_to_hand", "camera:EyeToHandObservation", ("points", "rotations"), sigma_m=1e-3,
             columns="x_mm,y_mm,z_mm and qw..qz"),
    # ... or camera on the flange, board in the cell (hand-eye)
    KindSpec("eye_in_hand", "camera:EyeInHandObservation", ("points", "rotations"), sigma_m=1e-3,
             columns="x_mm,y_mm,z_mm and qw..qz"),
)}
KINDS = tuple(k for k, spec in OBSERVED.items() if not spec.derived)  # kinds of files, as messages list them


def kind_spec(kind: str) -> KindSpec:
    """The spec of ``kind``; DataError for an unknown kind (naming the known ones)."""
    if kind not in OBSERVED:
        raise DataError(f"unknown measurement kind {kind!r}: use one of {', '.join(KINDS)}")
    return OBSERVED[kind]
