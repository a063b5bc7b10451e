%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%

MODULE PalletT_ROB1
  ! palletizing cell, robot 1 of 2 (MultiMove, synchronized hand-over)
  RECORD slotdata
    robtarget pos;
    num layer;
  ENDRECORD
  PERS tasks task_list{2}:=[["T_ROB1"],["T_ROB2"]];
  VAR syncident sync1;
  VAR syncident sync2;
  PERS tooldata tGripper:=[TRUE,[[0,0,220],[1,0,0,0]],[8,[0,0,110],[1,0,0,0],0,0,0]];
  CONST num nPitch:=180;
  VAR num nRow:=0;
  VAR num nCol:=0;
  VAR num k:=1;
  CONST robtarget pPickUp:=[[1069.92,-293.72,643.82],[0.022572,0.220436,0.974445,0.036820],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pPick:=[[1192.99,-363.78,588.15],[0.043101,0.076632,0.995965,-0.017992],[-1,-1,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pPalletCorner:=[[943.18,-549.73,402.38],[0.048633,-0.321940,-0.944253,-0.048733],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pHandOver:=[[1046.47,-491.47,585.60],[0.034091,-0.312373,-0.948258,-0.045477],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST slotdata wp{2}:=[[[[1047.82,-302.25,442.95],[0.116948,-0.083999,-0.989073,-0.031669],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],1],[[[1088.43,-486.02,582.49],[0.076578,0.173269,0.981731,0.017851],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],2]];
  VAR robtarget pPlace;
  VAR robtarget pLayer;

  PROC main()
    MoveJ pPickUp, v2000, z100, tGripper;
    GripAt pPick, tGripper;
    pPlace := Offs(pPalletCorner, nCol*nPitch, nRow*nPitch, 0);
    MoveL pPlace, v1000, fine, tGripper;
    pLayer := pPick;
    pLayer.trans.z := pLayer.trans.z + 150;
    MoveL pLayer, v1000, z50, tGripper;
    MoveL wp{k}.pos, v500, fine, tGripper;
    SyncMoveOn sync1, task_list;
    MoveL pHandOver \ID:=10, v200, fine, tGripper;
    SyncMoveOff sync2;
  ENDPROC

  PROC GripAt(robtarget pAt, PERS tooldata tUse)
    MoveL Offs(pAt,0,0,100), v1000, z50, tUse;
    MoveL pAt, v200, fine, tUse;
  ENDPROC
ENDMODULE
