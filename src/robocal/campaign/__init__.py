"""Planning a calibration campaign: optimal poses, the tracker's line of sight, the robot program.

``plan_poses`` chooses the poses (`robocal.campaign.planner`); the constraints and the
tracker are `Constraints` and `Tracker`; candidates from a file are read with
`read_candidates`; `robocal.campaign.programs` writes RAPID, KRL and URScript.
"""

from robocal.campaign.constraints import Constraints, Tracker
from robocal.campaign.files import read_candidates, read_planned
from robocal.campaign.planner import CampaignResult, CurvePoint, plan_poses

__all__ = ["CampaignResult", "Constraints", "CurvePoint", "Tracker", "plan_poses", "read_candidates",
           "read_planned"]
