/PROG  PNS0012
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "Palletize bag";
PROG_SIZE	= 1482;
CREATE		= DATE 24-03-11  TIME 09:12:40;
MODIFIED	= DATE 24-03-18  TIME 14:02:16;
FILE_NAME	= PNS0012;
VERSION		= 0;
LINE_COUNT	= 12;
MEMORY_SIZE	= 1890;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=1 ;
   3:  !Empty gripper ;
   4:  PAYLOAD[1] ;
   5:J P[1:Above infeed] 100% CNT50    ;
   6:L P[2:Pick] 1000mm/sec FINE    ;
   7:  DO[101:Gripper close]=ON ;
   8:  WAIT   0.40(sec) ;
   9:  PAYLOAD[2:Bag 50kg] ;
  10:J P[3:Above pallet] 100% CNT50    ;
  11:L P[4:Place] 1000mm/sec FINE    ;
  12:  DO[101:Gripper close]=OFF ;
/POS
P[1:"Above infeed"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   278.433  mm,	Y =     0.000  mm,	Z =   787.313  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[2:"Pick"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   479.765  mm,	Y =   173.207  mm,	Z =   484.137  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    10.000 deg
};
P[3:"Above pallet"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  -616.821  mm,	Y = -1529.711  mm,	Z =   550.186  mm,
	W =   180.000 deg,	P =     5.000 deg,	R =   -60.000 deg
};
P[4:"Place"]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  -575.270  mm,	Y = -1739.164  mm,	Z =   275.939  mm,
	W =   180.000 deg,	P =     3.000 deg,	R =   -62.000 deg
};
/END
