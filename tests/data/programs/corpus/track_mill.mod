MODULE TrackCell
  ! IRB 2600 on a linear track (external axis eax_a, mm)
  PERS tooldata tSpindle:=[TRUE,[[0,0,300],[1,0,0,0]],[12,[0,0,150],[1,0,0,0],0,0,0]];
  CONST robtarget pMill10:=[[1083.73,-120.27,512.57],[0.003387,0.044010,0.997487,-0.055423],[-1,-1,0,0],[800,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pMill20:=[[1160.99,-92.60,718.50],[0.127765,0.001924,0.991755,0.009753],[-1,0,-1,0],[1450,9E+09,9E+09,9E+09,9E+09,9E+09]];
  CONST robtarget pMill30:=[[1124.53,-8.18,494.40],[0.048816,-0.044892,-0.997641,-0.017714],[-1,0,0,0],[2100,9E+09,9E+09,9E+09,9E+09,9E+09]];

  PROC main()
    MoveJ pMill10, v500, z10, tSpindle;
    MoveL pMill20, v100, z1, tSpindle;
    MoveL pMill30, v100, fine, tSpindle;
  ENDPROC
ENDMODULE
