"""The robot catalog: real robots in their vendor joint convention with ROS-Industrial ``tool0``.

Each entry is one model YAML file in ``robocal/catalog/`` (the format of
:mod:`robocal.kinematics.model_file`: the source parameter set as published -- an OPW set, a
standard DH table or a modified DH table -- its units, joint limits and, in comments, where every
number comes from). ``Robot.from_catalog(name)`` builds one.
"""

from __future__ import annotations

from functools import cache
from importlib import resources

from robocal.core.errors import ModelError
from robocal.core.yaml_load import load_yaml
from robocal.kinematics.model_file import MAX_NAME, robot_kwargs


@cache
def _file(file_name: str) -> dict:
    """The raw YAML mapping of one shipped catalog file."""
    item = resources.files("robocal").joinpath("catalog", *file_name.split("/"))
    return load_yaml(item.read_text(encoding="utf-8"), file_name, ModelError)


@cache
def _entries() -> dict[str, dict]:
    """name -> raw YAML mapping of every shipped catalog file (each file is named ``<name>.yaml``)."""
    names = sorted(p.name for p in resources.files("robocal").joinpath("catalog").iterdir())
    return {data["name"]: data for data in (_file(n) for n in names if n.endswith(".yaml"))}


def catalog_names() -> list[str]:
    """Names of the catalog robots, sorted."""
    return sorted(_entries())


def catalog_descriptions() -> dict[str, str]:
    """name -> one-line description (model, reach, where the parameters come from)."""
    return {name: _entries()[name]["description"] for name in catalog_names()}


def catalog_specs() -> dict[str, tuple[float | None, float | None]]:
    """name -> (reach mm, payload kg) as the vendor quotes them (None where the entry gives none)."""
    return {name: (_entries()[name].get("reach_mm"), _entries()[name].get("payload_kg"))
            for name in catalog_names()}


def catalog_entry(name: str) -> dict:
    """The raw mapping of catalog robot ``name``; an unknown name raises ModelError listing the
    known ones."""
    # (a name longer than a model's is none, and no file system holds a file name of thousands)
    if name.isidentifier() and len(name) <= MAX_NAME and \
            resources.files("robocal").joinpath("catalog", f"{name}.yaml").is_file():
        return _file(f"{name}.yaml")  # one file, not the 30 (a tenth of a calibration's start-up)
    entries = _entries()
    if name not in entries:
        raise ModelError(f"unknown robot {name!r}; the catalog has: {', '.join(catalog_names())} "
                         "(run `robocal robots` for descriptions)")
    return entries[name]


def catalog_kwargs(name: str) -> dict:
    """Robot keyword arguments of catalog robot ``name``."""
    try:
        return robot_kwargs(catalog_entry(name))
    except ModelError as exc:
        raise ModelError(f"catalog entry {name!r}: {exc}") from None


POSITIONERS = "positioners"  # the catalog's folder of positioners (robocal.kinematics.workcell reads them)


@cache
def _positioner_entries() -> dict[str, dict]:
    """name -> raw YAML mapping of every shipped positioner (``catalog/positioners/<name>.yaml``)."""
    folder = resources.files("robocal").joinpath("catalog", POSITIONERS)
    names = sorted(p.name for p in folder.iterdir() if p.name.endswith(".yaml")) if folder.is_dir() else []
    return {data["name"]: data for data in (_file(f"{POSITIONERS}/{n}") for n in names)}


def positioner_names() -> list[str]:
    """Names of the catalog positioners, sorted."""
    return sorted(_positioner_entries())


def positioner_entry(name: str) -> dict | None:
    """The raw mapping of catalog positioner ``name``, None when the catalog has none of that name."""
    return _positioner_entries().get(name)
