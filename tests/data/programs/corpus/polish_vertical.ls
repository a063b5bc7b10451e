/PROG  POLISH_VERTICAL
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "side polish, tool level";
PROG_SIZE	= 3120;
CREATE		= DATE 24-10-02  TIME 10:15:40;
MODIFIED	= DATE 24-10-03  TIME 07:48:12;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 17;
MEMORY_SIZE	= 3556;
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
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=2 ;
   3:J P[1] 100% CNT0 ACC100 TB    .10sec,P-SPS    ;
   4:J P[2:"above lid"] 100% CNT50    ;
   5:L P[3] 250mm/sec CNT100 COORD PTH    ;
   6:L P[4] 250mm/sec CNT100 COORD PTH    ;
   7:C P[5]    
    :  P[6] 100mm/sec CNT100    ;
   8:L P[4] 250mm/sec FINE Offset,PR[4:lift]    ;
   9:L P[7] 50mm/sec FINE INC    ;
  10:  PR[6,3]=PR[6,3]+5 ;
  11:L PR[6:retract] 500mm/sec FINE    ;
  12:L PR[3:service] 500mm/sec FINE    ;
  13:J P[1] 100% FINE    ;
/POS
P[1]{
   GP1:
	UF : 1, UT : 2,
	J1=    10.000 deg,	J2=   -15.000 deg,	J3=    20.000 deg,
	J4=     0.000 deg,	J5=   -70.000 deg,	J6=    35.000 deg
};
P[2:"above lid"]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =    35.000  mm,	Y =   180.000  mm,	Z =   320.000  mm,
	W =     0.000 deg,	P =   -90.000 deg,	R =   180.000 deg
};
P[3]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =    35.000  mm,	Y =   180.000  mm,	Z =   265.000  mm,
	W =    25.000 deg,	P =   -90.000 deg,	R =   155.000 deg
};
P[4]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =    95.000  mm,	Y =   180.000  mm,	Z =   265.000  mm,
	W =     0.000 deg,	P =   -90.000 deg,	R =   180.000 deg
};
P[5]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   120.000  mm,	Y =   205.000  mm,	Z =   265.000  mm,
	W =    10.000 deg,	P =   -89.995 deg,	R =   175.000 deg
};
P[6]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =    95.000  mm,	Y =   230.000  mm,	Z =   265.000  mm,
	W =     0.000 deg,	P =   -90.000 deg,	R =   180.000 deg
};
P[7]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =     0.000  mm,	Y =     0.000  mm,	Z =    -5.000  mm,
	W =     0.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
/END
