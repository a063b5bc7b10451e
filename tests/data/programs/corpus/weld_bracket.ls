/PROG  WELD_BRACKET
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "bracket fillet";
PROG_SIZE	= 2210;
CREATE		= DATE 24-09-17  TIME 08:02:11;
MODIFIED	= DATE 24-09-18  TIME 14:31:40;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 18;
MEMORY_SIZE	= 2566;
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
  ARC Welding Equipment : 1,*,*,*,*;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=2 ;
   3:J P[1:"approach"] 100% CNT100    ;
   4:L P[2] 200mm/sec FINE    ;
   5:  Arc Start[1] ;
   6:  Weave Sine[1] ;
   7:L P[3] WELD_SPEED CNT100    ;
   8:C P[4]    
    :  P[5] WELD_SPEED CNT100    ;
   9:  Weave End ;
  10:L P[6] WELD_SPEED FINE    ;
  11:  Arc End[1] ;
  12:L P[6] 100mm/sec FINE Offset,PR[2]    ;
  13:L P[7] 500mm/sec FINE Tool_Offset,PR[3]    ;
  14:L P[9] 50mm/sec FINE INC    ;
  15:L PR[5:service] 500mm/sec FINE    ;
  16:L P[12] 500mm/sec FINE    ;
  17:  //L P[13] 500mm/sec FINE    ;
  18:J P[8] 100% FINE    ;
/POS
P[1:"approach"]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =	-45.648240	mm,	Y =	128.861753	mm,	Z =	315.161588	mm,
	W =	178.388783	deg,	P =	-0.627890	deg,	R =	24.991031	deg
};
P[2]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   -51.803  mm,	Y =   206.941  mm,	Z =   319.400  mm,
	W =  -175.660 deg,	P =    -7.878 deg,	R =    30.689 deg
};
P[3]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =	-35.642816	mm,	Y =	155.124763	mm,	Z =	269.991111	mm,
	W =	174.055834	deg,	P =	5.247926	deg,	R =	36.555010	deg
};
P[4]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =  -107.555  mm,	Y =   166.299  mm,	Z =   235.736  mm,
	W =   175.423 deg,	P =    11.758 deg,	R =    35.800 deg
};
P[5]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =	-91.477019	mm,	Y =	208.496467	mm,	Z =	247.229415	mm,
	W =	-179.846190	deg,	P =	12.512501	deg,	R =	44.765581	deg
};
P[6]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   -54.345  mm,	Y =   144.200  mm,	Z =   318.875  mm,
	W =   172.201 deg,	P =     -.390 deg,	R =    34.901 deg
};
P[7]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =	-9.754577	mm,	Y =	184.805160	mm,	Z =	248.701994	mm,
	W =	-177.032094	deg,	P =	-4.875718	deg,	R =	29.980559	deg
};
P[8]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   -40.508  mm,	Y =   201.618  mm,	Z =   210.924  mm,
	W =   176.550 deg,	P =     2.629 deg,	R =    31.282 deg
};
P[9]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =     .000  mm,	Y =     .000  mm,	Z =   10.000  mm,
	W =     .000 deg,	P =     .000 deg,	R =     .000 deg
};
/END
