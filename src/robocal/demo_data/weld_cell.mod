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
    CONST robtarget pApproach:=[[392.37,421.20,120.43],[0.08282782,0.09591909,-0.99145870,0.03080146],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pSeamStart:=[[276.91,-239.86,161.77],[0.05215538,-0.59114092,-0.79649814,0.11585747],
                                 [-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    ! circle through pSeamMid to pSeamEnd
    CONST robtarget pSeam{2}:=[
        [[404.95,558.12,275.48],[0.12109010,-0.21525780,0.86856320,-0.42965012],[0,1,-2,1],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[580.79,302.20,20.66],[0.21230868,-0.15662840,-0.96236144,-0.06521527],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
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
        MoveL [[667.19,810.42,407.66],[0.43507451,0.40594068,0.67052726,0.44307508],[0,-2,2,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]], v500, z20, tGun\WObj:=wTable;
        MoveAbsJ jHome, v1000, fine, tool0;
    ENDPROC
ENDMODULE
