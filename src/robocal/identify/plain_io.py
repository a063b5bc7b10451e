"""Learned models saved as plain arrays: ``.json`` or ``.npz``, written atomically, never pickle."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from robocal.core.errors import DataError
from robocal.core.io import load_json, write_atomic


def encode_plain(path, data: dict, what: str) -> str | bytes:
    """The file content of ``data`` (numbers, strings, lists/arrays of them) for ``path``'s
    suffix: JSON text for ``.json``, npz bytes for ``.npz``."""
    path = Path(path)
    if path.suffix == ".json":
        return json.dumps(data, indent=1)
    if path.suffix != ".npz":
        raise DataError(f"{path}: save a {what} as .json or .npz")
    buffer = io.BytesIO()
    np.savez(buffer, **{k: np.asarray(v) for k, v in data.items()})
    return buffer.getvalue()


def save_plain(path, data: dict, what: str) -> None:
    """Write ``data`` to ``.json`` or ``.npz`` atomically (:func:`encode_plain`)."""
    write_atomic(path, encode_plain(path, data, what))


def load_plain(path, what: str, fmt: str) -> dict:
    """Read what :func:`save_plain` wrote; ``fmt`` is the expected ``format`` field.

    Values come back as JSON types or numpy arrays (0-d for scalars): convert at the caller."""
    path = Path(path)
    try:
        if path.suffix == ".json":
            data = load_json(path, f"{what} file")
        else:
            with np.load(path, allow_pickle=False) as z:
                data = {k: z[k] for k in z.files}
    except (OSError, ValueError, KeyError) as exc:
        raise DataError(f"cannot read {what} file {path}: {exc}") from None
    if not isinstance(data, dict) or str(data.get("format")) != fmt:
        raise DataError(f"{path} is not a robocal {what} ({fmt})")
    return data
