"""The load data a program sets, as each vendor writes it: the statements that set the load the
arm carries, read into kg and metres in the flange frame tool0 (the frame of ``--tool``).

The load is the controller's: the total mass on the flange (tool and workpiece) and its centre of
mass. Each language's load reader (its ``dialects/<language>/loads.py``, returned by
:meth:`~robocal.programs.dialects.base.Dialect.load_reader`) says what its statements mean.

A statement this cannot read (a variable, a computed value, ``$LOAD.M = ..``, ``PAYLOAD[R[1]]``,
a ``LOAD_DATA[n]`` or schedule nobody gave) raises :class:`~robocal.core.errors.DataError` naming it
and how to give the load instead: a motion corrected with a load it does not carry would look
right and be wrong.
"""

from __future__ import annotations

from robocal.programs.load_data.base import Load, LoadReader, Setting

__all__ = ["Load", "LoadReader", "Setting"]
