"""A model in other software's formats: URDF for ROS, the Universal Robots ROS driver's
ur_calibration YAML, and robocal's own model YAML (e.g. of an imported URDF)."""

from __future__ import annotations

from dataclasses import dataclass, field

from robocal.core.errors import DataError, RobocalError
from robocal.core.io import write_all
from robocal.deploy.models import controller_for
from robocal.kinematics.manufacturer.ur import not_representable, to_ur_calibration
from robocal.kinematics.model import Robot
from robocal.kinematics.model_file import dump_model
from robocal.kinematics.urdf import not_carried, to_urdf

URDF_FRAMES = {
    "robot": "base_link = the robot's base (frame {0}), tool0 = the flange; the model's world frame and "
             "tool are in a comment (--frames model to use them)",
    "model": "world = the model's world frame (e.g. the tracker), tool0 = the model's tool (e.g. the "
             "measured SMR)"}
UR_CALIBRATION = ("ur_calibration YAML: the geometry from the controller's base to the flange (tool0); the "
                  "model's world frame and tool are not part of it; its hash is robocal's, so the ROS driver "
                  "reports that it differs from the robot's own calibration")


@dataclass
class ModelExport:
    """The files of `export_model`: ``texts`` {path: content}, and what to tell the user, in
    order: ``said`` (line, shown even when quiet) pairs; ``warnings`` the lines a model's content
    could not carry; ``refused``: why a file asked for cannot be made (raised by `write`, after
    what was said of the files before it).

    Examples
    --------
    >>> import robocal as rc
    >>> from robocal.deploy.formats import export_model
    >>> out = export_model(rc.Robot.from_catalog("abb_irb2600"), urdf="irb2600.urdf")
    >>> list(out.texts), out.warnings
    (['irb2600.urdf'], [])
    >>> out.write()
    ['irb2600.urdf']
    """

    robot: Robot
    texts: dict = field(default_factory=dict)
    said: list[tuple[str, bool]] = field(default_factory=list)
    refused: RobocalError | None = None

    @property
    def warnings(self) -> list[str]:
        """What the written files do not carry (one line each)."""
        return [line.removeprefix("WARNING: ") for line, _ in self.said if line.startswith("WARNING: ")]

    def lines(self, quiet: bool = False) -> list[str]:
        """What to tell the user before writing, in order (notes and warnings even when ``quiet``)."""
        return [line for line, always in self.said if always or not quiet]

    def summary(self) -> str:
        """The notes, warnings and frame descriptions, then the files."""
        files = ", ".join(str(path) for path in self.texts)
        return "\n".join([*self.lines(), f"{self.robot.name} ({self.robot.n_joints} joints): {files}"])

    def to_dict(self) -> dict:
        """The files' contents by path, and the warnings."""
        return {"files": {str(path): text for path, text in self.texts.items()}, "warnings": self.warnings}

    def write(self) -> list[str]:
        """Write every file (all or none); the paths written.

        Raises
        ------
        RobocalError
            ``refused``: a file asked for cannot be made; nothing is written.
        """
        if self.refused is not None:
            raise self.refused
        write_all(self.texts)
        return [str(path) for path in self.texts]


def export_model(robot: Robot, urdf=None, yaml=None, ur_calibration=None, frames: str = "robot",
                 nominal: str | None = None) -> ModelExport:
    """``robot`` as URDF (``frames`` 'robot': base_link at the robot's base and tool0 at the flange
    of the controller's model ``nominal``, a catalog name or model file, default the catalog robot
    of the model's name; 'model': its world frame and tool), as robocal's model YAML, and as a
    ur_calibration YAML (the geometry from the controller's base to its flange); None skips one.
    A file that cannot be made (e.g. a ur_calibration YAML of a robot outside the catalog without
    ``nominal``) is ``refused``: `ModelExport.write` raises it, after what was said of the files
    before it.
    """
    out = ModelExport(robot)
    try:
        _make(out, urdf, yaml, ur_calibration, frames, nominal)
    except RobocalError as exc:
        out.refused = exc
    return out


def _make(out: ModelExport, urdf, yaml, ur_calibration, frames: str, nominal: str | None) -> None:
    """The texts of `export_model`, in order, and what to say of them."""
    robot = out.robot
    if urdf:
        controller = controller_for(robot, nominal) if frames == "robot" else None
        if frames == "robot" and controller is None:
            note = (f"note: {robot.name} is not a catalog robot and no --nominal is given: base_link is "
                    "the model's frame {0}, tool0 the flange centre with the model's tool rotation")
            out.said.append((note, True))
        out.texts[urdf] = to_urdf(robot, frames=frames, nominal=controller)
        if not_carried(robot):
            out.said.append((f"WARNING: {not_carried(robot)}", True))
        out.said.append((f"URDF frames: {URDF_FRAMES[frames]}", False))
    if yaml:
        out.texts[yaml] = dump_model(robot)
    if ur_calibration:
        controller = controller_for(robot, nominal)
        if controller is None:
            raise DataError(f"--ur-calibration: {robot.name} is not a catalog robot: give --nominal, the "
                            "controller's model (e.g. ur5e, or factory.yaml from robocal import-calibration)")
        out.texts[ur_calibration] = to_ur_calibration(robot, controller)
        if not_representable(robot):
            out.said.append((f"WARNING: {not_representable(robot)}", True))
        out.said.append((UR_CALIBRATION, False))
