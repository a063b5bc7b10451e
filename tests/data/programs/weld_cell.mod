MODULE WeldCell
    !*****************************************************
    ! Weld cell 4, IRB 2600-12/1.65 - fixture on table 1
    ! Taught 2024-03-12; do not edit targets by hand!
    !*****************************************************
    ! a commented-out target must stay as it is:
    ! CONST robtarget pOld:=[[1,2,3],[1,0,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS tooldata tGun:=[TRUE,[[50,0,200],[0.96592583,0,0.25881905,0]],[2.5,[0,0,120],[1,0,0,0],0,0,0]];
    PERS tooldata tGripper:=[TRUE,[[0,0,150],[1,0,0,0]],[1.2,[0,0,60],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wTable:=[FALSE,TRUE,"",[[900,-300,400],[0.99144486,0,0,0.13052619]],
                                [[0,0,0],[1,0,0,0]]];
    CONST string sMsg:="Weld seam 1 [left] ! done";
    CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pApproach:=[[248.12,409.56,491.46],[0.42399835,-0.09846910,0.90004233,0.02128470],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pSeamStart:=[[291.48,-2.46,481.20],[0.35308119,0.45401432,0.71586531,-0.39590597],
                                 [-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    ! circle through pSeamMid to pSeamEnd
    CONST robtarget pSeam{2}:=[
        [[90.04,697.26,475.69],[0.53914870,-0.40124379,0.69165275,-0.26445902],[0,1,-2,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[510.13,173.89,416.05],[0.29813322,0.12448504,0.94555777,-0.03924998],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
    VAR robtarget pScratch;

    PROC main()
        ! go home first
        MoveAbsJ jHome, v1000, fine, tool0;
        WeldSeam;
        Leave;
        TPWrite sMsg;
    ENDPROC

    PROC WeldSeam()
        MoveJ pApproach, v1000, z50, tGun\WObj:=wTable;
        MoveL Offs(pApproach,0,0,50), v200, z10, tGun\WObj:=wTable;
        MoveL pSeamStart, v100, fine, tGun\WObj:=wTable;
        MoveC pSeam{1}, pSeam{2}, v20, z1, tGun \WObj:=wTable;
    ENDPROC

    PROC Leave()
        ! inline target, robot coordinates
        MoveL [[285.28,918.67,439.95],[0.71204921,0.57309248,0.36315638,0.18074393],[0,-2,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]], v500, z20, tGun\WObj:=wTable;
        MoveAbsJ jHome, v1000, fine, tool0;
    ENDPROC
ENDMODULE
