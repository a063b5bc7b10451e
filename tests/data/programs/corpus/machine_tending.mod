MODULE MachineTending
    !***********************************************************
    ! Cell 4 - CNC tending, IRB 2600 with a double gripper
    ! Gripper data measured with LoadIdentify; part data from the CAD model
    !***********************************************************
    PERS tooldata tGripper:=[TRUE,[[0,0,185],[1,0,0,0]],[18.5,[0,12,95],[1,0,0,0],0.21,0.25,0.08]];
    PERS loaddata ldBlank:=[6.2,[0,0,60],[1,0,0,0],0.02,0.02,0.01];
    PERS loaddata ldFinished:=[4.9,[0,0,55],[1,0,0,0],0.015,0.015,0.01];
    ! gripper and finished part together, for \TLoad (total load, wrist frame)
    PERS loaddata ldGripFinished:=[23.4,[0,10,124],[1,0,0,0],0.3,0.32,0.09];
    CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pConveyorAbove:=[[1138.40,220.30,536.63],[0.04357787,-0.15023716,0.98700374,0.03678822],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pConveyorPick:=[[1162.79,265.71,246.43],[0.02491487,-0.13474896,0.98992764,0.03557004],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pChuckAbove:=[[907.62,-811.72,515.45],[0.03688154,0.53249010,0.84211810,-0.07701391],[-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pChuck:=[[895.50,-854.87,237.91],[0.03037365,0.55793446,0.82620362,-0.07193163],[-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pOutfeed:=[[1113.11,-298.26,757.50],[0.04324622,0.13040196,0.99050123,-0.00569347],[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];

    PROC main()
        MoveAbsJ jHome\NoEOffs, v1000, fine, tGripper;
        PickBlank;
        LoadChuck;
        UnloadChuck;
        MoveL pOutfeed, v800, fine, tGripper\TLoad:=ldGripFinished;
        GripLoad load0;
        MoveAbsJ jHome\NoEOffs, v1000, fine, tGripper;
    ENDPROC

    PROC PickBlank()
        MoveJ pConveyorAbove, v1000, z50, tGripper;
        MoveL pConveyorPick, v300, fine, tGripper;
        ! close jaw A, then tell the controller what it holds
        SetDO doJawA_Close, 1;
        WaitTime 0.3;
        GripLoad ldBlank;
        MoveL pConveyorAbove, v300, z10, tGripper;
    ENDPROC

    PROC LoadChuck()
        MoveJ pChuckAbove, v1000, z50, tGripper;
        MoveL pChuck, v200, fine, tGripper;
        SetDO doJawA_Close, 0;
        WaitTime 0.3;
        GripLoad load0;
        MoveL pChuckAbove, v300, z10, tGripper;
    ENDPROC

    PROC UnloadChuck()
        ! jaw B takes the finished part (the chuck position again, now empty-handed in)
        MoveL pChuck, v200, fine, tGripper;
        SetDO doJawB_Close, 1;
        WaitTime 0.3;
        GripLoad ldFinished;
        MoveL pChuckAbove, v300, z10, tGripper;
    ENDPROC
ENDMODULE
