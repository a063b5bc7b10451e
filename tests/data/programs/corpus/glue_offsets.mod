MODULE GlueOffsets
    !================================================================
    ! Cell 7 - glue bead on housing lids, IRB 2600
    ! Approach heights and bead offsets as the integrator wrote them
    !================================================================
    PERS tooldata tNozzle:=[TRUE,[[0,-80.5,212.4],[1,0,0,0]],[2.1,[0,-20,90],[1,0,0,0],0,0,0]];
    TASK PERS wobjdata wLid:=[FALSE,TRUE,"",[[1050,-300,420],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
    CONST num K:=2.5;
    CONST num nApproach:=(-1) * K * 40;
    CONST num nBead{2,2}:=[[1.5,2],[3,4.25]];
    VAR num nRow:=1;
    CONST jointtarget jSafe:=[[0,-10,20,0,60,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pLid:=[[120.00,85.50,12.00],[0,0.707107,0.707107,0],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    CONST robtarget pCorner:=[[310.25,85.50,12.00],[0,0.707107,0.707107,0],[0,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    VAR robtarget pNow;

    PROC main()
        MoveAbsJ jSafe, v1000, fine, tool0;
        MoveJ Offs(pLid, 0, 0, -nApproach), v1000, z50, tNozzle\WObj:=wLid;
        MoveL pLid, v200, fine, tNozzle\WObj:=wLid;
        MoveL Offs(pLid, nBead{1, 2} * ((-1) * K), 0, 0), v50, z1, tNozzle\WObj:=wLid;
        MoveL Offs(pCorner, nBead{nRow, 1}, 0, 0), v50, z1, tNozzle\WObj:=wLid;
        MoveL reltool(pCorner, 0, 0, (-1) * K * 4), v50, fine, tNozzle\WObj:=wLid;
        MoveL RelTool(pCorner,0,0,-20\Rz:=15), v200, z10, tNozzle\WObj:=wLid;
        pNow := CRobT(\Tool:=tNozzle \WObj:=wLid);
        MoveL Offs(pNow, 0, 0, 50), v500, z20, tNozzle\WObj:=wLid;
        MoveJ pPurge, v1000, fine, tNozzle;
        MoveAbsJ jSafe, v1000, fine, tool0;
    ENDPROC

    PROC Rework(robtarget pSpot)
        ! called from the HMI by the operator (not from this module)
        MoveL Offs(pSpot, 0, 0, 30), v200, z10, tNozzle\WObj:=wLid;
        MoveL pSpot, v50, fine, tNozzle\WObj:=wLid;
    ENDPROC
ENDMODULE
