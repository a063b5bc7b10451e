MODULE ArcStation
    !***********************************************************
    ! Station 3 - bracket welding, IRB 2600 with torch (RobotWare Arc)
    ! Written in the style of a RobotStudio export; targets taught on wobjFixture
    !***********************************************************
    PERS tooldata tWeldGun:=[TRUE,[[12.5,0,395.2],[0.906308,0,0.422618,0]],[3.2,[-45,0,180],[1,0,0,0],0,0,0]];
    PERS tooldata tGuns{2}:=[[TRUE,[[12.5,0,395.2],[0.906308,0,0.422618,0]],[3.2,[-45,0,180],[1,0,0,0],0,0,0]],
                             [TRUE,[[0,0,250],[1,0,0,0]],[1.5,[0,0,100],[1,0,0,0],0,0,0]]];
    TASK PERS wobjdata wobjFixture:=[FALSE,TRUE,"",[[900,-250,100],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    PERS seamdata seam1:=[0.5,0.5,[5,0,24,120,0,0,0,0,0],0.5,0,0,0,0,[5,0,24,120,0,0,0,0,0],0,0,[5,0,24,120,0,0,0,0,0],0,0,[5,0,24,120,0,0,0,0,0],0];
    PERS welddata weld1:=[10,0,[5,0,24,120,0,0,0,0,0],[0,0,0,0,0,0,0,0,0]];
    PERS weavedata weave1:=[1,0,3,4,0,0,0,0,0,0,0,0,0,0,0];
    CONST num nLift:=50;
    VAR num nDepth:=12;
    CONST jointtarget jHome:=[[0,0,0,0,30,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pApproach:=[[101.98,511.28,67.60],[0.423686,0.066739,-0.901342,0.060152],[0,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pSeam{3}:=[[[107.64,526.71,219.36],[0.412652,0.005930,-0.909228,-0.054659],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[24.79,340.98,-14.90],[0.537978,-0.153398,-0.826888,-0.057486],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]],
        [[223.76,320.48,115.06],[0.404785,-0.071439,-0.899019,-0.151032],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]]];
    CONST robtarget pCirc1:=[[340.85,468.09,234.56],[0.297578,-0.025694,-0.943080,-0.146246],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pCirc2:=[[190.11,416.38,32.13],[0.388933,-0.139600,-0.902126,-0.124143],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pEnd:=[[275.42,362.82,142.83],[0.382257,-0.090640,-0.918459,-0.045803],[0,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS robtarget pStartA:=[[415.50,213.57,296.04],[0.225568,-0.161213,-0.955417,-0.101528],[-1,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PERS robtarget pEndA:=[[145.12,489.20,180.79],[0.412092,0.025113,-0.909545,0.047734],[0,-1,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pDepart:=[[240.19,533.31,334.41],[0.348205,0.031271,-0.936620,-0.022774],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pFlip:=[[152.26,378.45,-78.10],[0.442507,-0.115035,-0.886715,-0.068496],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pCheck:=[[263.42,267.65,155.11],[0.314502,-0.083280,-0.934719,-0.143014],[-1,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    VAR robtarget pTemp;
    VAR robtarget pCur;
    VAR num i;

    PROC main()
        MoveAbsJ jHome, v1000, fine, tool0;
        Seam1;
        WeldStitch pStartA, pEndA;
        Leave;
        MoveAbsJ jHome, v1000, fine, tool0;
    ENDPROC

    PROC Seam1()
        MoveJ pApproach, v1000, z50, tWeldGun\WObj:=wobjFixture;
        ArcLStart pSeam{1}, v200, seam1, weld1, fine, tWeldGun\WObj:=wobjFixture;
        FOR i FROM 2 TO 3 DO
            ArcL pSeam{i}, v20, seam1, weld1\Weave:=weave1, z1, tWeldGun\WObj:=wobjFixture;
        ENDFOR
        ArcC pCirc1, pCirc2, v20, seam1, weld1, z1, tWeldGun\WObj:=wobjFixture;
        ArcLEnd pEnd, v20, seam1, weld1, fine, tWeldGun\WObj:=wobjFixture;
    ENDPROC

    PROC WeldStitch(robtarget pFrom, robtarget pTo)
        ! a stitch between two taught points
        MoveL Offs(pFrom,0,0,nLift), v500, z10, tGuns{1}\WObj:=wobjFixture;
        ArcLStart pFrom, v200, seam1, weld1, fine, tGuns{1}\WObj:=wobjFixture;
        ArcLEnd pTo, v20, seam1, weld1, fine, tGuns{1}\WObj:=wobjFixture;
    ENDPROC

    PROC Leave()
        pTemp := pDepart;
        MoveL Offs(pTemp,0,0,nLift), v500, z20, tWeldGun\WObj:=wobjFixture;
        ConfL\Off;
        MoveL pFlip, v500, z20, tWeldGun\WObj:=wobjFixture;
        ConfL\On;
        MoveL Offs(pCheck,0,0,nDepth), v100, fine, tWeldGun\WObj:=wobjFixture;
        pCur := CRobT(\Tool:=tWeldGun\WObj:=wobjFixture);
        MoveL Offs(pCur,0,0,100), v500, z20, tWeldGun\WObj:=wobjFixture;
        MoveJ pService, v1000, z50, tool0;
    ENDPROC
ENDMODULE
