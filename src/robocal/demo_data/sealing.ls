/PROG  SEALING
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "Bead on lid";
PROG_SIZE	= 1520;
CREATE		= DATE 24-05-02  TIME 10:12:44;
MODIFIED	= DATE 24-05-06  TIME 16:40:02;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 14;
MEMORY_SIZE	= 1892;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/APPL
/MN
   1:  !Sealing of the lid, nozzle UT 2 ;
   2:  UFRAME_NUM=1 ;
   3:  UTOOL_NUM=2 ;
   4:J P[1:"approach"] 100% FINE    ;
   5:L P[2] 250mm/sec CNT50    ;
   6:  DO[101:Nozzle]=ON ;
   7:C P[3]    
    :  P[4] 80mm/sec CNT100    ;
   8:  DO[101:Nozzle]=OFF ;
   9:L P[5] 500mm/sec FINE    ;
  10:  //L P[6] 500mm/sec FINE    ;
  11:J P[7:"home"] 100% FINE    ;
  12:  CALL LID_CHECK    ;
/POS
P[1:"approach"]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =    82.889  mm,	Y =   191.649  mm,	Z =   252.510  mm,
	W =   177.584 deg,	P =   -22.574 deg,	R =    31.947 deg
};
P[2]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   141.678  mm,	Y =    56.637  mm,	Z =   257.455  mm,
	W =  -151.603 deg,	P =   -34.848 deg,	R =    13.053 deg
};
P[3]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'F U T, 0, 0, 0',
	X =    12.505  mm,	Y =   412.225  mm,	Z =   393.720  mm,
	W =  -112.641 deg,	P =   -15.403 deg,	R =   -21.423 deg
};
P[4]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   169.181  mm,	Y =   120.936  mm,	Z =   177.954  mm,
	W =  -169.963 deg,	P =    -4.924 deg,	R =    -0.870 deg
};
P[5]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 1',
	X =    89.735  mm,	Y =   497.774  mm,	Z =   495.943  mm,
	W =    85.969 deg,	P =   -22.972 deg,	R =   151.537 deg
};
P[6]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   141.678  mm,	Y =    56.637  mm,	Z =   257.455  mm,
	W =  -151.603 deg,	P =   -34.848 deg,	R =    13.053 deg
};
P[7:"home"]{
   GP1:
	UF : 1, UT : 2,
	J1=     0.000 deg,	J2=     0.000 deg,	J3=     0.000 deg,
	J4=     0.000 deg,	J5=   -90.000 deg,	J6=     0.000 deg
};
/END
