"""Files and units shared by every layer: atomic writes (one file or a set, all or none) and the
unit tables that files and the command line use (internal units are SI: m, rad)."""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import shutil
import signal
import stat
import tempfile
import threading
import time
from collections.abc import Mapping
from pathlib import Path

from robocal.core.bom import decode_utf8
from robocal.core.errors import DataError, RobocalError

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3}  # unit name -> metres per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}  # unit name -> radians per unit
_WRITE_BITS = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH  # a file without any is read-only, even for root


def length_scale(unit: str, error: type[RobocalError] = DataError) -> float:
    """Metres per ``unit`` ('m' or 'mm'); ``error`` (a RobocalError type) for anything else."""
    if unit not in LENGTH_UNITS:
        raise error(f"unknown length unit {unit!r}: use 'm' or 'mm'")
    return LENGTH_UNITS[unit]


def short_repr(value, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (an error message quotes a user's value, never
    megabytes of it); containers are not rendered in full first."""
    if isinstance(value, list | tuple | dict | set):
        head = list(value.items())[:8] if isinstance(value, dict) else list(value)[:8]
        text = f"{type(value).__name__} of {len(value)}: {head!r}"
    else:
        text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def as_number(value, where: str, error: type[RobocalError] = DataError) -> float:
    """``value`` (an int or float read from a user's file, not a bool) as a finite float; else
    ``error`` (a RobocalError type) naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise error(f"{where}: expected a number, got {short_repr(value)}")
    try:
        number = float(value)
    except OverflowError:  # an integer of hundreds of digits: beyond any float
        raise error(f"{where}: an integer of {len(str(abs(value)))} digits is beyond the range of "
                    "numbers (about 1.8e308)") from None
    if not math.isfinite(number):
        raise error(f"{where}: {value!r} is not finite")
    return number


def read_text(path, what: str, error: type[RobocalError] = DataError) -> str:
    """The text of a user's file (UTF-8, a byte-order mark allowed); ``error`` (a RobocalError
    type) names the file, ``what`` it should be and the reason when it cannot be read."""
    path = Path(path)
    try:
        if path.exists() and not path.is_file():  # /dev/zero was read until memory ran out, a FIFO forever
            raise error(f"cannot read {what} {path}: it is not a regular file (a device, a pipe or a socket)")
        return decode_utf8(path.read_bytes())
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise error(f"{path}: not a UTF-8 text file (expected a {what})") from None


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def load_json(path, what: str, error: type[RobocalError] = DataError):
    """The data of a user's JSON file (:func:`read_text`); ``error`` with one line naming the file
    for invalid JSON, NaN/Infinity, an integer of thousands of digits or nesting deeper than the
    parser can follow. Validate the structure at the caller (:mod:`robocal.core.schema`)."""
    text = read_text(path, what, error)
    try:
        return json.loads(text, parse_constant=_refuse_constant)
    except json.JSONDecodeError as exc:
        raise error(f"{path} is not a valid {what}: {exc}") from None
    except ValueError as exc:  # NaN, or an integer beyond Python's digit limit
        raise error(f"{path} is not a valid {what}: {' '.join(str(exc).split())[:200]}") from None
    except RecursionError:
        raise error(f"{path} is not a valid {what}: nested too deeply") from None


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
        if path.is_symlink():  # replaced whole, the link would go, not its target (/dev/stdout, as root)
            raise DataError(f"cannot write {path}: it is a symbolic link (to {os.readlink(path)}); robocal "
                            "replaces an output whole, which would replace the link, not what it points to: "
                            "give the target's own name or another name")
        if _exists(path) and not path.is_file():  # run as root, /dev/full was replaced by a file
            raise DataError(f"cannot write {path}: it is not a regular file (a device, a pipe or a socket): "
                            "robocal writes its outputs as files, each replaced whole; give a file name")
        if path.exists() and not (os.access(path, os.W_OK) and path.stat().st_mode & _WRITE_BITS):
            raise DataError(f"cannot write {path}: the file is read-only (robocal does not replace "
                            "read-only files; make it writable or choose another name)")
        if path.is_file() and _is_database(path):  # a history (any caller's: the API's write() too)
            raise DataError(f"cannot write {path}: it is an SQLite database, as a robocal history is (if it "
                            "is the history, replacing it would lose every record); choose another "
                            "output name")


_SQLITE_HEADER = b"SQLite format 3\x00"  # the first 16 bytes of every SQLite 3 database file


def _is_database(path: Path) -> bool:
    """Whether the file ``path`` is an SQLite database (its header; unreadable: no)."""
    try:
        with open(path, "rb") as f:
            return f.read(len(_SQLITE_HEADER)) == _SQLITE_HEADER
    except OSError:
        return False


def _exists(path: Path) -> bool:
    """Whether ``path`` exists (a name no file system holds, thousands of characters: no; a catalog
    name or a mistake the reader names)."""
    try:
        return path.exists()
    except OSError:
        return False


def check_outputs(outputs, inputs=()) -> None:
    """Before any work: the output paths (None entries skipped) are distinct, none is one of the
    ``inputs`` (a user's file is never overwritten by its own results) and all are writable
    (:func:`check_writable`). DataError names the path and the reason."""
    outs = [Path(p) for p in outputs if p is not None]
    ins = {Path(p).resolve() for p in inputs if p is not None and _exists(Path(p))}
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


# output suffix -> the data format written there (robot programs add their own suffixes: ``formats``)
FORMATS = {".json": "JSON", ".yaml": "YAML", ".yml": "YAML", ".csv": "CSV", ".html": "HTML", ".htm": "HTML",
           ".urdf": "URDF", ".npz": "npz"}


def check_format(path, kind: str, option: str, hint: str = "", formats: Mapping | None = None) -> None:
    """Refuse writing ``kind`` (a ``formats`` value, default :data:`FORMATS`) into ``path`` named
    for another known format (``-o result.json`` for a model YAML); unknown or no suffixes are
    allowed. ``option`` names the output (``--json``) and ``hint`` completes the message."""
    if path is None:
        return
    formats = FORMATS if formats is None else formats
    named = formats.get(Path(path).suffix.lower())
    if named is not None and named != kind:
        suffix = next(s for s, k in formats.items() if k == kind)
        raise DataError(f"{option} {path}: {option} writes {kind}, but the name says {named}; name it "
                        f"{Path(path).with_suffix(suffix).name}{hint}")


TEMP_SUFFIX = ".robocal.tmp"  # a new content not yet renamed over its target: ".<name>.<random>.robocal.tmp"
BACKUP_SUFFIX = ".robocal.bak"  # a hard link to a target's old content while a set is committed
LOCK_TIMEOUT_S = 60.0  # how long a writer waits for another robocal process writing in the same folder
_LOCK_POLL_S = 0.02


def _folder(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _fsync_folder(folder: Path) -> None:
    """Make the renames in ``folder`` durable; OSError when the disk fails (a file system that
    cannot fsync a folder, or open one, is not an error)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF):
            raise
    finally:
        os.close(fd)


def _is_ours(name: str, target: str) -> bool:
    """Whether ``name`` is one of robocal's temporary or backup files for the file ``target``."""
    return name.startswith(f".{target}.") and name.endswith((TEMP_SUFFIX, BACKUP_SUFFIX))


def _remove_stale(paths) -> None:
    """Remove robocal's temporaries and backups of ``paths`` left by a killed run (kill -9, power
    loss). Called under the folder lock, when no live writer can own them. Only files: a folder
    that happens to be named like one is the user's and stays; a file that cannot be removed
    (permissions) is left (the next temporaries get other random names)."""
    for folder, names in _by_folder(paths).items():
        try:
            entries = list(os.scandir(folder))
        except OSError:
            continue
        for entry in entries:
            if any(_is_ours(entry.name, name) for name in names):
                with contextlib.suppress(OSError):
                    if not entry.is_dir(follow_symlinks=False):
                        os.unlink(entry.path)


def _by_folder(paths) -> dict[Path, set[str]]:
    folders: dict[Path, set[str]] = {}
    for path in paths:
        folders.setdefault(_folder(path), set()).add(path.name)
    return folders


class _FolderLocks:
    """Exclusive ``flock`` on each output folder (its own file descriptor: no lock file is left
    in the user's folder), taken in a fixed order so that two writers never deadlock. Another
    robocal process writing in the same folder is waited for up to ``LOCK_TIMEOUT_S``; then a
    DataError says so. Where folders cannot be locked (no ``fcntl``, some network file systems),
    writes are not serialised."""

    def __init__(self, paths, signals: _DeferSignals | None = None) -> None:
        self.folders = sorted({_folder(p).resolve() for p in paths})
        self.signals = signals  # waiting for another process ends on a deferred signal
        self.fds: list[int] = []

    def __enter__(self):
        try:
            import fcntl
        except ImportError:  # not POSIX
            return self
        try:
            for folder in self.folders:
                try:
                    fd = os.open(folder, os.O_RDONLY)
                except OSError:  # e.g. a folder without read permission: unserialised
                    continue
                self.fds.append(fd)
                deadline = time.monotonic() + LOCK_TIMEOUT_S
                while True:
                    try:
                        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                        break
                    except BlockingIOError:
                        if self.signals is not None:
                            self.signals.check()
                        if time.monotonic() > deadline:
                            raise DataError(f"cannot write in {folder}: another robocal process has been "
                                            f"writing there for {LOCK_TIMEOUT_S:.0f} s; try again when it "
                                            "has finished") from None
                        time.sleep(_LOCK_POLL_S)
                    except OSError:  # the file system cannot lock: unserialised
                        break
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def __exit__(self, *exc) -> None:
        for fd in self.fds:
            os.close(fd)  # closing the descriptor releases its lock
        self.fds.clear()


class _Deferral:
    """The process's one deferral of SIGINT and SIGTERM (main thread only: signals cannot be
    handled elsewhere). While at least one write is open (``writes``, nested writes share it) the
    two signals are noted in ``pending`` instead of acted on; when the last write closes, the
    handlers found before the first one are put back and the noted signals delivered to them.

    Built so that no Ctrl-C can be lost (issue 47: a loop of writes stopped answering SIGINT):

    * one set of saved handlers for the whole process, never one of its own (a nested or an
      overlapping write cannot save a deferring handler as the one to put back);
    * the note handler itself checks that a write is open: one left installed by an exception
      at an unlucky moment puts the saved handlers back and delivers the signal to them;
    * handlers are swapped with the two signals blocked (a signal arriving during a swap waits
      for the handler put back) and the mask is restored on every path, also when a handler of
      another signal raises inside ``pthread_sigmask`` or ``signal.signal``;
    * putting the handlers back is retried until it is done: ``signal.signal`` and
      ``pthread_sigmask`` run the pending handlers first, and one put back a moment before (a
      signal taken by another thread) or another signal's may raise; the first such exception
      is raised once every handler is back;
    * noted signals are delivered SIGTERM first (a KeyboardInterrupt cannot hide a SIGTERM).
    """

    SIGNALS = (signal.SIGTERM, signal.SIGINT)  # also the order noted signals are delivered in
    DEFAULTS = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}

    def __init__(self) -> None:
        self.writes: list[object] = []  # the open writes (their _DeferSignals)
        self.saved: dict[int, object] = {}  # signal -> its handler before the first open write
        self.pending: list[int] = []
        self.handler = self._note  # one bound method: compared with signal.getsignal()

    def _note(self, signum, frame) -> None:
        if self.writes:
            self.pending.append(signum)
            return
        self.restore()  # left installed although no write is open: the signal is the user's
        signal.raise_signal(signum)

    def open(self, write: object) -> None:
        """Start deferring for ``write`` (an exception leaves nothing open: see `close`)."""
        try:
            self.writes.append(write)
            if len(self.writes) > 1:
                return
            self.pending.clear()
            with _blocked(self.SIGNALS):
                for sig in self.SIGNALS:
                    current = signal.getsignal(sig)
                    if current is signal.SIG_IGN or current == self.handler:  # ignored: stays so
                        continue
                    self.saved[sig] = signal.SIG_DFL if current is None else current
                    signal.signal(sig, self.handler)
        except BaseException:
            self.close(write)
            raise

    def close(self, write: object) -> None:
        """Stop deferring for ``write``; the last one puts the handlers back and delivers the
        noted signals."""
        if write in self.writes:
            self.writes.remove(write)
        if self.writes:
            return
        noted = [sig for sig in self.SIGNALS if sig in self.pending]
        self.pending.clear()
        try:
            self.restore()
        finally:
            for sig in noted:
                signal.raise_signal(sig)

    def restore(self) -> None:
        """Put back every saved handler (and the default where a deferring one is found without
        a saved one), the two signals blocked meanwhile; retried until all are back (see the
        class docstring), the first exception met then raised."""
        error = None
        while True:
            left = {sig: self.saved.get(sig, self.DEFAULTS[sig]) for sig in self.SIGNALS
                    if sig in self.saved or signal.getsignal(sig) == self.handler}
            if not left:
                break
            try:
                with _blocked(self.SIGNALS):
                    for sig, handler in left.items():
                        signal.signal(sig, handler)
                        self.saved.pop(sig, None)
            except BaseException as exc:  # a handler put back a moment before ran and raised
                error = error or exc
        if error is not None:
            raise error


@contextlib.contextmanager
def _blocked(signals):
    """``signals`` blocked in this thread inside the block; the mask as it was afterwards, on
    every path (``pthread_sigmask`` runs the pending handlers after changing the mask: one that
    raises must not leave the signals blocked). Nothing where the platform has no signal masks."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, ())  # the mask, unchanged
    try:
        signal.pthread_sigmask(signal.SIG_BLOCK, signals)
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


_DEFERRAL = _Deferral()


class _DeferSignals:
    """While a set of outputs is written, SIGINT and SIGTERM are noted instead of acted on
    (:class:`_Deferral`); the writer calls `check` between its steps and abandons the write (old
    outputs kept) when one came before the last rename. On exit the previous handlers are back and
    a noted signal is delivered to them (SIGINT: KeyboardInterrupt; SIGTERM: the process ends as it
    would have). Only in the main thread; elsewhere nothing is deferred."""

    def __init__(self) -> None:
        self.active = threading.current_thread() is threading.main_thread()

    def __enter__(self):
        if self.active:
            _DEFERRAL.open(self)
        return self

    def check(self) -> None:
        """Raise KeyboardInterrupt when a signal was noted (the writer then cleans up)."""
        if self.active and _DEFERRAL.pending:
            raise KeyboardInterrupt

    def __exit__(self, *exc) -> None:
        if self.active:
            _DEFERRAL.close(self)


def _temp_for(path: Path, data: str | bytes) -> str:
    """A finished, fsynced temporary file next to ``path`` holding ``data``; returns its name."""
    fd, tmp = tempfile.mkstemp(dir=_folder(path), prefix=f".{path.name}.", suffix=TEMP_SUFFIX)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data.encode("utf-8") if isinstance(data, str) else data)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes the file private; outputs follow the umask
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def _backup_of(path: Path) -> str:
    """A second name for ``path``'s current content (a hard link: the file itself never moves;
    a fsynced copy where the file system has no hard links); returns it."""
    fd, backup = tempfile.mkstemp(dir=_folder(path), prefix=f".{path.name}.", suffix=BACKUP_SUFFIX)
    os.close(fd)
    try:
        try:
            os.unlink(backup)
            os.link(path, backup)
        except OSError as exc:
            if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EXDEV, errno.EMLINK, errno.ENOSYS):
                raise
            shutil.copy2(path, backup)
            with open(backup, "rb") as fh:
                os.fsync(fh.fileno())
    except BaseException:
        Path(backup).unlink(missing_ok=True)
        raise
    return backup


def write_all(outputs: Mapping) -> None:
    """Write every ``{path: text or bytes}`` or none of them.

    1. All paths are checked (:func:`check_writable`) and their folders locked (another robocal
       process writing there waits; see :class:`_FolderLocks`); robocal's temporaries left there
       by a killed run are removed.
    2. Every content is written to a temporary file in its target's folder, flushed and fsynced;
       the old content of each existing target gets a second name (a hard link). No target is
       touched yet: a failure here (full disk, I/O error, Ctrl-C, SIGTERM) leaves every output
       as it was.
    3. Each temporary file is renamed over its target in turn (``os.replace``: each file is at
       every moment either whole old or whole new, never missing), then the folders are fsynced.
       If a rename fails or a signal comes, the targets already replaced get their old content
       back by the same kind of rename (new files are removed).

    Guarantee and its limit: after write_all returns, every output is new; after it raises, every
    output is as before (unless restoring itself fails: the error then names the files). Renaming
    several files is not one atomic step: a program reading the outputs *during* step 3 can see
    some new and some old (each one whole), and if the machine loses power or the process is
    killed with SIGKILL in step 3, that mix stays (the old content of the replaced files is left in
    hidden ``.<name>.*.robocal.bak`` files until the next write of the same outputs). Temporaries
    are removed on every exit path that runs Python code. Errors are DataErrors naming the path and
    the reason.
    """
    items = [(Path(p), data) for p, data in outputs.items()]
    check_writable(p for p, _ in items)
    paths = [p for p, _ in items]
    # the locks are taken and released while signals are deferred: an interrupt never leaves a
    # folder's descriptor open (its lock held) behind
    with _DeferSignals() as signals, _FolderLocks(paths, signals):
        _remove_stale(paths)
        _commit(items, signals)


def _commit(items, signals: _DeferSignals) -> None:
    """Steps 2 and 3 of :func:`write_all` (the folders are locked)."""
    temps: dict[Path, str] = {}
    backups: dict[Path, str | None] = {}  # target -> its old content's second name (None: new file)
    replaced: list[Path] = []
    path = None
    try:
        for path, data in items:
            signals.check()
            temps[path] = _temp_for(path, data)
            signals.check()
            backups[path] = _backup_of(path) if path.exists() else None
        for path, _ in items:
            signals.check()
            os.replace(temps[path], path)
            del temps[path]
            replaced.append(path)
        for folder in _by_folder(replaced):
            _fsync_folder(folder)
        signals.check()
    except BaseException as exc:
        failed = _roll_back(replaced, backups)
        if failed:
            raise DataError(f"cannot write {path}: {_reason(exc)}; restoring the old content failed "
                            f"for {', '.join(failed)}") from None
        if isinstance(exc, OSError):
            raise _write_error(path, exc) from None
        raise
    finally:
        for leftover in [*temps.values(), *(b for b in backups.values() if b is not None)]:
            with contextlib.suppress(OSError):
                Path(leftover).unlink(missing_ok=True)


def _roll_back(replaced: list[Path], backups: dict[Path, str | None]) -> list[str]:
    """Give the replaced targets their old content back; returns the ones that could not be
    (their old content stays in the backup file named)."""
    failed = []
    for target in replaced:
        backup = backups[target]
        try:
            if backup is None:
                target.unlink(missing_ok=True)
            else:
                os.replace(backup, target)
                backups[target] = None
        except OSError as exc:
            failed.append(f"{target} ({exc.strerror or exc}; old content kept in {backup})")
            backups[target] = None  # keep the backup file: it holds the only old copy
    for folder in _by_folder(replaced):
        with contextlib.suppress(OSError):  # the renames back are done; durable as the disk allows
            _fsync_folder(folder)
    return failed


def _reason(exc: BaseException) -> str:
    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    return "interrupted" if isinstance(exc, KeyboardInterrupt) else type(exc).__name__


def write_atomic(path, data: str | bytes) -> None:
    """Write one file via a fsynced temporary file and a rename (never a half-written file; see
    :func:`write_all`)."""
    write_all({path: data})
