"""The help the command line gives about the robot languages (``robocal filter``'s and ``robocal
poses``' descriptions and epilogs): examples and notations of every language, kept beside the
registry (:mod:`robocal.programs.registry`) so that the command line names no language itself."""

FILTER_DESCRIPTION = ("Every Cartesian target of an ABB RAPID, KUKA KRL, FANUC TP (.ls), "
                      "URScript, Yaskawa INFORM or Staubli VAL3 program is replaced by the "
                      "target the controller's nominal model must be given so that the real "
                      "robot lands where the program meant; all else in the file stays byte "
                      "for byte.")

FILTER_EPILOG = """Examples:
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 -o weld_cal.mod
  robocal filter weld.mod --calibrated cal.yaml --nominal abb_irb2600 --tcp tGun=50.12,0.03,199.71,0,30,0 \\
      -o weld_cal.mod --table weld_targets
  robocal filter pal.src pal.dat --references KRC/R1/System/$config.dat --calibrated cal.yaml \\
      --nominal kuka_kr16_2 -o filtered/
  robocal filter seal.ls --frame 1=450,-150,100,0,0,-10 --tool 2=0,0,120,0,0,0 --calibrated cal.yaml \\
      --nominal fanuc_lrmate200id -o seal_cal.ls
  robocal filter pick.script --tool 0,0.02,0.15,0,0,0.5 --calibrated cal.yaml --nominal ur5 -o pick_cal.script
  robocal filter WELD.JBI VAR.DAT --frame 2=1250,-300,450,0,0,15 --tool 1=0,-35,410,0,-30,0 \\
      --calibrated cal.yaml --nominal yaskawa_gp25 -o filtered/
  robocal filter stn_weld.mod --model cell.yaml --calibrated calibrated_cell.yaml -o stn_weld_cal.mod
      (a cell with a positioner: targets in a work object it moves are corrected on its plate)
Formats (from the suffix, or --format): rapid (.mod .modx .prg .sys), krl (.src .dat .sub), fanuc (.ls),
urscript (.script .urscript), inform (.JBI, and the controller's VAR.DAT), val3 (an application's
folder, or its .pgx and .dtx files). --tool / --frame give the controller's tool and frame data the
files do not hold, NAME=values in the program's own notation: ABB x,y,z (mm),q1,q2,q3,q4; KUKA X,Y,Z
(mm),A,B,C (deg); FANUC X,Y,Z (mm),W,P,R (deg); Yaskawa X,Y,Z (mm),Rx,Ry,Rz (deg); VAL3 x,y,z (mm),
rx,ry,rz (deg); URScript x,y,z (m),rx,ry,rz (rad); names are the tooldata/wobjdata names, the KUKA
TOOL_DATA/BASE_DATA, FANUC UT/UF and Yaskawa TOOL/USER numbers, VAL3 data (fPart[0], tGripper[0]),
URScript feature variables (an unnamed URScript --tool is the installation's TCP). --tcp
NAME=x,y,z,rx,ry,rz (mm, deg, fixed-axis XYZ) is the real TCP of that tool identified on the
calibrated model (robocal tool); default: the tool data.
The calibrated model's identified frame {0} is the controller's base unless --robot-base gives the
controller's base in the calibrated model's world frame (x,y,z,rx,ry,rz, mm, deg).
Writes the filtered program(s) and the per-target table (CSV and JSON) together, or nothing. A filtered
program carries one comment line naming the calibrated model (fingerprint) and robocal's version;
filtering it again is refused unless --force."""

POSES_EPILOG = """Examples:
  robocal poses --robot abb_irb2600 -n 20 --smr-mm 20,-30,80 -o poses.csv --curve 10:60 --html campaign.html
  robocal poses --robot abb_irb2600 -n 25 --smr-mm 20,-30,80 --tracker-mm 2500,500,300 \\
      --box 500 -1000 0 1800 1000 1800 --min-joint-distance-deg 10 -o poses.csv \\
      --program rapid campaign.mod --program krl campaign.src --program urscript campaign.script
  robocal poses --robot fanuc_lrmate200id -n 20 --smr-mm 20,-30,60 -o poses.csv --fanuc campaign.ls
  robocal poses --robot yaskawa_gp25 -n 20 --smr-mm 20,-30,60 -o poses.csv --inform CAMPAIGN.JBI
  robocal poses --robot staubli_tx2_140 -n 20 --smr-mm 20,-30,60 -o poses.csv --val3 campaign
  robocal poses --robot meca500 -n 20 --from taught.csv --region taught.csv -o poses.csv
  robocal poses --robot abb_irb2600 --check -n 20 --from poses.csv -o check_poses.csv --rapid check.mod
  robocal poses --model cell.yaml -n 30 --table-poses 24 --smr-mm 20,-30,80 --tracker-mm 1200,2800,2000 \
      --acceptance-deg 45 -o poses.csv --rapid campaign.mod   # an arm and its positioner's table angles
  robocal simulate --robot abb_irb2600 --joints poses.csv --smr-mm 20,-30,80 -o data.csv --truth truth.yaml
Lengths in mm in the robot's base frame (SMR positions and facing directions in the flange frame),
angles in deg; write a value that starts with a minus as --smr-mm=-50,50,60.
poses.csv: q1_deg..q6_deg in measuring order (with --from: the chosen rows' joint
cells exactly as read, and their line numbers); visible_smr0.. with several SMRs. The programs
move to each pose (MoveAbsJ / PTP / movej / J P[k]; INFORM: MOVJ to RECTAN positions in the robot
frame, TOOL 0, with the planned joints' RCONF), wait --settle-s, and call --procedure: replace its
body with your tracker trigger (FANUC: a TP program of that name, taking the pose number; INFORM: a
job of that name, the pose number in I000; VAL3: movej(jPose[k], flange, ...) and call of a program
of that name, the pose number its argument).
Every output is written, or none.
"""

FILTER_OPTIONS = {
    "programs": "program file(s); a KUKA .src with its .dat; a VAL3 application's folder",
    "references": "files read for tool/frame/load declarations only ($config.dat, system modules, a Yaskawa "
                  "TOOL.CND / UFRAME.CND, a FANUC SYSFRAME.VA), and a FANUC backup's POSREG.VA: motions "
                  "to PR[n] are corrected, the corrected registers written as the TP program PR_CAL.LS "
                  "beside the output; a Yaskawa backup's VAR.DAT: its P variables corrected in VAR_CAL.DAT",
    "payload_schedules": "FANUC: the payload schedules PAYLOAD[n] selects, the controller's SYSVARS.VA "
                         "($PLST_GRP1) or a CSV schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm",
    "position_registers": "FANUC: the position registers' values (register,x_mm,y_mm,z_mm,w_deg,p_deg,r_deg,"
                          "config): motions to PR[n] are corrected and the corrected registers written to "
                          "OUTPUT.registers.csv",
}
PROGRAM_OPTION = ("a campaign program in language LANG ({languages}) written as PATH: an ABB RAPID module, "
                  "a KUKA KRL .src (its .dat is written next to it), a URScript program, a FANUC TP program "
                  "(ASCII .ls; J3 in FANUC's convention), a Yaskawa INFORM job (RECTAN positions with their "
                  "RCONF), a Staubli VAL3 application (a folder named like the application, created if "
                  "absent); repeat for several")
# where the flow of a program without configuration data starts (robocal.programs.flow)
ENTRY_ROUTINES = ("URScript: top-level code or one def nothing calls; RAPID: PROC main; KRL: the DEF named "
                  "like the .src file")
