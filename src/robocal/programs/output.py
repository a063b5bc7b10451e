"""Write several output files all together or none (temporary files, then renames)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from robocal.errors import DataError


def write_all(files: dict[Path, bytes]) -> None:
    """Write every ``path: bytes`` via temporary files in the same folders, renamed only after
    all were written (a failure leaves no output and no temporary file behind)."""
    temps: list[tuple[str, Path]] = []
    try:
        for path, data in files.items():
            path = Path(path)
            try:
                fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
            except OSError as exc:
                raise DataError(f"cannot write {path}: {exc.strerror} (does its folder exist and is it "
                                "writable?)") from None
            temps.append((tmp, path))
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        for tmp, path in temps:
            os.replace(tmp, path)
    except BaseException:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
        raise
