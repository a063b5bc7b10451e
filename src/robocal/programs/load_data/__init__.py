"""The load data a program sets, as each vendor writes it: the statements that set the load the
arm carries, read into kg and metres in the flange frame tool0 (the frame of ``--tool``).

The load is the controller's: the total mass on the flange (tool and workpiece) and its centre of
mass. Per dialect:

* ABB RAPID: a motion runs with its tool's ``tload`` (tooldata ``[robhold, tframe, [mass, [x, y,
  z], aom, ix, iy, iz]]``: kg, mm in the wrist frame tool0) plus the payload the last ``GripLoad
  name`` connected (loaddata ``[mass, [x, y, z], aom, ix, iy, iz]``: its centre of gravity in mm
  in the *tool* frame, turned into tool0 through the tool's tframe; ``GripLoad load0``
  disconnects it); a motion's optional ``\\TLoad:=name`` is its total load (the tool's and the
  payload's together, centre of gravity in tool0) and replaces both. ``tool0`` and ``load0``
  carry nothing.
* KUKA KRL: ``$LOAD = {M m, CM {X x, Y y, Z z, A.., B.., C..}, J {..}}`` (kg, mm in the flange
  frame), ``$LOAD = LOAD_DATA[n]``, ``BAS(#TOOL, n)`` and an inline form's ``FDAT_ACT = F``
  (tool ``F.TOOL_NO``: the controller loads ``LOAD_DATA[TOOL_NO]`` with the tool; tool 0, the
  flange, has no LOAD_DATA and changes nothing here), and a KSS 8
  motion's ``WITH $LOAD = SLOAD(F.TOOL_NO)`` (that motion only). ``LOAD_DATA[n]={M.., CM {..}}``
  is read from the program files or a reference ($config.dat). ``M -1`` is the controller's
  default load from its machine data: not known here. A bare ``$TOOL = TOOL_DATA[n]`` leaves
  ``$LOAD`` as it was (the controller keeps them apart).
* FANUC TP: ``PAYLOAD[n]`` selects payload schedule n of motion group 1, whose values live in the
  controller (``$PLST_GRP1[n].$PAYLOAD`` kg, ``$PAYLOAD_X/_Y/_Z`` cm in the faceplate frame): they
  are read from the controller's SYSVARS.VA (:func:`read_schedules`) or a CSV
  ``schedule,payload_kg,payload_x_cm,payload_y_cm,payload_z_cm`` the user gives.
* Yaskawa INFORM: a job sets no load; each motion runs with the load of its position's tool
  (``///TOOL n``) registered in the controller's tool file TOOL.CND (W kg, Xg, Yg, Zg mm in the
  flange coordinates), given as a reference (:mod:`robocal.programs.dialects.inform.tool_file`).
  A tool the file lacks, or whose W is 0 (no load registered), stops the motions that use it.
* Staubli VAL3: no statement or data type of the language holds a load (a ``tool`` is a frame and
  its gripper output, an ``mdesc`` speeds, accelerations and blending): ``--payload``.
* URScript: ``set_payload(m, [x, y, z])`` / ``set_target_payload(m, [x, y, z], ...)`` (kg, m from
  the tool flange, in its frame), ``set_payload(m)`` (the centre of gravity kept),
  ``set_payload_mass(m)``, ``set_payload_cog([x, y, z])``.

A statement this cannot read (a variable, a computed value, ``$LOAD.M = ..``, ``PAYLOAD[R[1]]``,
a ``LOAD_DATA[n]`` or schedule nobody gave) raises :class:`~robocal.errors.DataError` naming it
and how to give the load instead: a motion corrected with a load it does not carry would look
right and be wrong.
"""

from __future__ import annotations

from robocal.programs.load_data.base import Load, LoadReader, Setting

__all__ = ["Load", "LoadReader", "Setting"]
