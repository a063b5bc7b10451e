"""The robot languages robocal reads and writes: one key per language (``--format``, ``poses
--program``) mapped to its :class:`~robocal.programs.dialects.base.Dialect`.

A language is one folder of :mod:`robocal.programs.dialects` and one line of :data:`DIALECTS`
(or a :func:`register` call): everything else (the filter, the load statements, the provenance
marker, ``--format``, ``poses --program``, the docs' format table) asks the registry.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING

from robocal.core.errors import DataError

if TYPE_CHECKING:
    from robocal.programs.dialects.base import Dialect

# key -> its Dialect class, or where it is ("module:Class"), imported when first used: the command
# line builds its options from the keys without importing every reader
DIALECTS: dict[str, type[Dialect] | str] = {
    "rapid": "robocal.programs.dialects.rapid.reader:RapidDialect",
    "krl": "robocal.programs.dialects.krl.reader:KRLDialect",
    "fanuc": "robocal.programs.dialects.fanuc.reader:FanucDialect",
    "urscript": "robocal.programs.dialects.urscript.reader:URScriptDialect",
    "inform": "robocal.programs.dialects.inform.reader:InformDialect",
    "val3": "robocal.programs.dialects.val3.reader:Val3Dialect",
}
SNIFF_BYTES = 4096  # of a file read to recognise a language by its contents


def register(dialect: type[Dialect]) -> None:
    """Add (or replace) the language ``dialect.key``."""
    DIALECTS[dialect.key] = dialect


def dialect_class(key: str) -> type[Dialect]:
    """The class of the language registered as ``key`` (imported on first use)."""
    found = DIALECTS[key]
    if isinstance(found, str):
        module, name = found.split(":")
        found = DIALECTS[key] = getattr(importlib.import_module(module), name)
    return found


def dialects() -> list[Dialect]:
    """One instance of every registered language, in registry order."""
    return [dialect_class(key)() for key in DIALECTS]


def dialect_named(key: str) -> Dialect:
    """The language registered as ``key``.

    Raises
    ------
    DataError
        No language has that key.
    """
    if key not in DIALECTS:
        raise DataError(f"unknown program format {key!r}: use one of {', '.join(DIALECTS)}")
    return dialect_class(key)()


def dialect_with_name(name: str) -> Dialect:
    """The language whose :attr:`Dialect.name` is ``name`` (a result's ``dialect``)."""
    found = next((d for d in dialects() if d.name == name), None)
    if found is None:
        raise DataError(f"no provenance marker for program format {name!r}")
    return found


def capable(capability: str) -> list[Dialect]:
    """The languages with ``capability`` (a :class:`Dialect` attribute: ``position_registers``,
    ``payload_schedules`` ...)."""
    return [d for d in dialects() if getattr(d, capability)]


def program_formats() -> dict[str, str]:
    """Campaign program suffix -> the format written there (``.mod`` -> its language's name), of
    every language that writes campaign programs: the output-name check's program half."""
    return {d.campaign_suffix: d.campaign_format for d in dialects() if d.campaign_format}


def program_files(paths: list[Path]) -> list[Path]:
    """``paths`` with each application folder (VAL3) replaced by its program files."""
    out = []
    for p in paths:
        files = next((f for d in dialects() if (f := d.folder_files(p) if p.is_dir() else None) is not None),
                     None)
        out += [p] if files is None else files
    return out


def language_of(path: Path) -> Dialect | None:
    """The language whose suffixes name ``path``'s suffix (the first), else None."""
    return next((d for d in dialects() if path.suffix.lower() in d.suffixes), None)


def dialect_for(paths: list[Path], name: str | None = None) -> Dialect:
    """The program dialect from ``name`` (a key of `DIALECTS`) or the suffixes; a language
    that recognises its files by their contents (a Yaskawa job or VAR.DAT, told by its first
    line: ``/JOB``, ``//`` sections) wins over a suffix it shares with another.

    Parameters
    ----------
    paths : list of Path
        The program files (a KRL ``.src`` with its ``.dat``, a VAL3 project's files ...); a
        file whose suffix another language shares is read to tell them apart.
    name : str, optional
        The dialect's key, which overrides the suffixes.

    Returns
    -------
    Dialect
        The reader and writer of that program format (``name``, ``suffixes``).

    Raises
    ------
    DataError
        An unknown ``name``, or files whose suffixes name no dialect or more than one.

    See Also
    --------
    rc.filter_program : Filters a program in its language.

    Examples
    --------
    >>> from pathlib import Path
    >>> from robocal.programs import dialect_for
    >>> dialect_for([Path("weld.mod")]).name
    'ABB RAPID'
    >>> ".src" in dialect_for([Path("weld.src"), Path("weld.dat")]).suffixes  # KUKA KRL
    True
    >>> dialect_for([Path("a.txt")], "val3").suffixes[0]  # named: the suffix does not matter
    '.pgx'
    >>> dialect_for([Path("a.txt")])
    Traceback (most recent call last):
    ...
    robocal.core.errors.DataError: cannot tell the program format of ['a.txt'] from the file suffixes ...
    """
    if name is not None:
        return dialect_named(name)
    every = dialects()
    found = {d.key for p in paths for d in every if p.suffix.lower() in d.suffixes}
    for d in every:
        if not d.shared_suffixes:
            continue  # recognised by its suffixes only
        shared = {o.key for o in every if set(o.suffixes) & set(d.shared_suffixes)}
        if found <= {d.key} | shared and paths and all(p.suffix.lower() in d.suffixes or _sniff(d, p)
                                                       for p in paths):
            found = {d.key}  # jobs and VAR.DAT (a .dat that is not KRL), or a job under another name
    if len(found) != 1:
        known = ", ".join(f"{d.key}: {' '.join(d.suffixes)}" for d in every)
        raise DataError(f"cannot tell the program format of {[p.name for p in paths]} from the file "
                        f"suffixes ({known}); name it with --format")
    return dialect_named(found.pop())


def _sniff(dialect: Dialect, path: Path) -> bool:
    """The file reads as ``dialect`` by its contents (unreadable: False, reported later)."""
    try:
        with open(path, "rb") as f:
            return dialect.recognises(f.read(SNIFF_BYTES).decode("latin-1"))
    except OSError:
        return False


def format_table() -> str:
    """The docs' table of program formats (Markdown): key, language, file suffixes."""
    rows = ["| `--format` | language | files |", "|---|---|---|"]
    rows += [f"| `{d.key}` | {d.title or d.name} | {' '.join(f'`{s}`' for s in d.suffixes)} |"
             for d in dialects()]
    return "\n".join(rows) + "\n"
