/PROG  TRACK_PICK
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "track";
PROG_SIZE	= 2210;
CREATE		= DATE 24-09-17  TIME 08:02:11;
MODIFIED	= DATE 24-09-18  TIME 14:31:40;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 2;
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
   1:J P[1] 100% FINE    ;
   2:L P[2] 500mm/sec FINE    ;
/POS
P[1]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   -45.648  mm,	Y =   128.862  mm,	Z =   315.162  mm,
	W =   178.389 deg,	P =     -.628 deg,	R =    24.991 deg,
	E1 =  1500.000  mm
};
P[2]{
   GP1:
	UF : 1, UT : 2,		CONFIG : 'N U T, 0, 0, 0',
	X =   -51.803  mm,	Y =   206.941  mm,	Z =   319.400  mm,
	W =  -175.660 deg,	P =    -7.878 deg,	R =    30.689 deg,
	E1 =  2000.000  mm
};
/END
