"""One package per robot language: everything robocal knows of it (reader, load statements,
configuration scheme, provenance marker, campaign and test programs) behind the
:class:`~robocal.programs.dialects.base.Dialect` protocol; :mod:`robocal.programs.registry` maps
each language's key to it."""
