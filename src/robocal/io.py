"""Files and units shared by every layer: atomic writes (one file or a set, all or none) and the
unit tables that files and the command line use (internal units are SI: m, rad)."""

from __future__ import annotations

import math
import os
import stat
import tempfile
from collections.abc import Mapping
from pathlib import Path

from robocal.errors import DataError, RobocalError

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3}  # unit name -> metres per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}  # unit name -> radians per unit
_WRITE_BITS = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH  # a file without any is read-only, even for root


def length_scale(unit: str, error: type[RobocalError] = DataError) -> float:
    """Metres per ``unit`` ('m' or 'mm'); ``error`` (a RobocalError type) for anything else."""
    if unit not in LENGTH_UNITS:
        raise error(f"unknown length unit {unit!r}: use 'm' or 'mm'")
    return LENGTH_UNITS[unit]


def as_number(value, where: str, error: type[RobocalError] = DataError) -> float:
    """``value`` (an int or float read from a user's file, not a bool) as a finite float; else
    ``error`` (a RobocalError type) naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise error(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise error(f"{where}: {value!r} is not finite")
    return float(value)


def read_text(path, what: str, error: type[RobocalError] = DataError) -> str:
    """The text of a user's file (UTF-8, a byte-order mark allowed); ``error`` (a RobocalError
    type) names the file, ``what`` it should be and the reason when it cannot be read."""
    path = Path(path)
    try:
        return path.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text file (expected a {what})") from None


def _write_error(path: Path, exc: OSError) -> DataError:
    reason = exc.strerror or str(exc)
    return DataError(f"cannot write {path}: {reason}")


def check_writable(paths) -> None:
    """Raise DataError (one line: the path and the reason) unless every path can be written:
    its folder exists and is writable, and an existing file is a writable regular file (a
    read-only file is never replaced)."""
    for path in paths:
        path = Path(path)
        folder = path.parent if str(path.parent) else Path(".")
        if path.is_dir():
            raise DataError(f"cannot write {path}: it is a folder")
        if not folder.is_dir():
            raise DataError(f"cannot write {path}: its folder {folder} does not exist")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise DataError(f"cannot write {path}: its folder {folder} is not writable")
        if path.exists() and not (os.access(path, os.W_OK) and path.stat().st_mode & _WRITE_BITS):
            raise DataError(f"cannot write {path}: the file is read-only (robocal does not replace "
                            "read-only files; make it writable or choose another name)")


def check_outputs(outputs, inputs=()) -> None:
    """Before any work: the output paths (None entries skipped) are distinct, none is one of the
    ``inputs`` (a user's file is never overwritten by its own results) and all are writable
    (:func:`check_writable`). DataError names the path and the reason."""
    outs = [Path(p) for p in outputs if p is not None]
    ins = {Path(p).resolve() for p in inputs if p is not None and Path(p).exists()}
    seen = set()
    for path in outs:
        where = path.resolve()
        if where in ins:
            raise DataError(f"cannot write {path}: it is one of this command's input files (robocal "
                            "never overwrites its inputs); choose another output name")
        if where in seen:
            raise DataError(f"cannot write {path} twice: give each output its own file name")
        seen.add(where)
    check_writable(outs)


def _temp_for(path: Path, data: str | bytes) -> str:
    """A finished temporary file next to ``path`` holding ``data``; returns its name."""
    fd, tmp = tempfile.mkstemp(dir=path.parent if str(path.parent) else ".", prefix=f".{path.name}.",
                               suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes the file private; outputs follow the umask
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def write_all(outputs: Mapping) -> None:
    """Write every ``{path: text or bytes}`` or none of them.

    All paths are checked first (:func:`check_writable`); every content goes to a temporary file
    next to its target; then each existing target is renamed aside (its old content kept whole)
    and the temporary file renamed into place. If any step fails (an interrupt included), the
    targets already replaced get their old files back and nothing is left behind. Errors are
    DataErrors naming the path and the reason.
    """
    items = [(Path(p), data) for p, data in outputs.items()]
    check_writable(p for p, _ in items)
    temps: dict[Path, str] = {}
    backups: dict[Path, str] = {}
    replaced: list[Path] = []
    path = None
    try:
        for path, data in items:
            temps[path] = _temp_for(path, data)
        for path, _ in items:
            if path.exists():
                fd, backups[path] = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".bak")
                os.close(fd)
                os.replace(path, backups[path])
            os.replace(temps[path], path)
            del temps[path]
            replaced.append(path)
    except BaseException as exc:
        for done in replaced:
            done.unlink(missing_ok=True)
        for target, backup in backups.items():
            os.replace(backup, target)
        backups.clear()
        if isinstance(exc, OSError):
            raise _write_error(path, exc) from None
        raise
    finally:
        for leftover in [*temps.values(), *backups.values()]:
            Path(leftover).unlink(missing_ok=True)


def write_atomic(path, data: str | bytes) -> None:
    """Write one file via a temporary file and a rename (never a half-written file)."""
    write_all({path: data})
