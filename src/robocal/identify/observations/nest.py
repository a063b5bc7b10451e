"""SMRs in nests at known places on a tool (a positioner's plate): 3 residuals per row.

A row of SMR s > 0 measures nest s, at the known position ``n_s`` in the TOOL frame (the plate
frame of a positioner, `robocal.kinematics.workcell.Positioner.nests`), which the model carries as
``robot.smr[s - 1]`` (SMR 0 is the tool's origin)::

    p = B F(q) E n_s

with ``B`` the base frame, ``F(q)`` the flange pose and ``E`` the tool (the plate frame). Unlike a
tracker's SMRs on a flange (`robocal.kinematics.model.Robot.tools_for`: offsets in the FLANGE frame,
estimated), the nests move with the tool frame: the tool's six parameters are seen through every
nest (its rotation turns the nests about the tool's origin), and the nests themselves are known
(held: ``smr*`` are not observable). Each row's Jacobian is that of the row's point ``B F E n_s``:
the motion axes of the chain to the tool (`robocal.kinematics.jacobian.robot_motion_axes`, tool
rotations through the tool's origin) applied at the nest.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robocal.core.errors import IdentificationError
from robocal.identify.observations.point import PointObservation
from robocal.kinematics.jacobian import jacobian_from_axes, robot_motion_axes


def _tool_chain(robot):
    """``robot`` without its SMR offsets: the chain to the tool, the nests taken out."""
    return replace(robot, smr=np.zeros((0, 3)), nominal=None)


class NestObservation(PointObservation):
    kind = "nest"
    blind_spot = "the nests' positions on the plate are known (the cell file's nests)"

    def __init__(self, data, robot) -> None:
        super().__init__(data, robot)
        if self.smr.max(initial=0) > len(robot.smr):
            raise IdentificationError(f"nest {int(self.smr.max())} is not declared: the plate has "
                                      f"{len(robot.smr)} nest(s)")

    def not_observable(self, robot) -> list[str]:
        return [f"smr{s + 1}.{c}" for s in range(len(robot.smr)) for c in "xyz"]

    def _nests(self, robot) -> np.ndarray:
        """``(N, 3)`` each row's nest in the tool frame (SMR 0: the tool's origin), m."""
        return np.vstack([np.zeros(3), robot.smr])[self.smr]

    def _at_nests(self, tool_poses: np.ndarray, robot) -> np.ndarray:
        """``(..., N, 3)`` the rows' nests in the world from the tool's poses ``(..., N, 4, 4)``."""
        R, t = tool_poses[..., :3, :3], tool_poses[..., :3, 3]
        return np.einsum("...nij,nj->...ni", R, self._nests(robot)) + t

    def modelled_points(self, robot, nuisance=None) -> np.ndarray:
        return self._at_nests(robot.fk(self.q, conditions=self.conditions), robot)

    def _fk(self, robot) -> np.ndarray:
        """The rows' poses: the tool's orientation at each nest."""
        T = robot.fk(self.q, conditions=self.conditions)
        T[:, :3, 3] = self._at_nests(T, robot)
        return T

    def jacobian(self, robot, names, nuisance=None) -> np.ndarray:
        chain = _tool_chain(robot)
        idx = chain.indices(names)  # a nest (smr*) named: not a parameter here (they are known)
        tcp, u, o, rotation = robot_motion_axes(chain, self.q, None, self.conditions)
        at = tcp.copy()
        at[:, :3, 3] = self._at_nests(tcp, robot)
        return jacobian_from_axes(at, u[:, idx], o[:, idx], rotation[idx]).reshape(-1, len(names))

    def residuals_batch(self, robot, names, X, nuisance=None) -> np.ndarray:
        tool, _ = self.batch_tcp(_tool_chain(robot), names, X, frames=True)  # (P, N, 4, 4): the tool
        return (self.measured[None] - self._at_nests(tool, robot)).reshape(X.shape[0], -1)
