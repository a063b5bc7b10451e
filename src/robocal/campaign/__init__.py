"""Planning a calibration campaign: optimal poses, the tracker's line of sight, the robot program.

``plan_poses`` chooses the poses (`robocal.campaign.planner`), ``plan_cell`` a work cell's
(each arm's poses, each positioner's table angles: `robocal.campaign.cell`); the constraints and the
tracker are `Constraints` and `Tracker`; candidates from a file are read with
`read_candidates`; `robocal.campaign.programs` writes RAPID, KRL and URScript.
"""

from robocal.campaign.cell import CellCampaignResult, plan_cell
from robocal.campaign.constraints import Constraints, Tracker
from robocal.campaign.files import read_candidates, read_planned
from robocal.campaign.planner import CampaignResult, CurvePoint, plan_poses

__all__ = ["CampaignResult", "CellCampaignResult", "Constraints", "CurvePoint", "Tracker", "plan_cell",
           "plan_poses", "read_candidates", "read_planned"]
