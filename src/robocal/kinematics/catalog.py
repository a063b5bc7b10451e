"""The robot catalog: real robots in their vendor joint convention with ROS-Industrial ``tool0``.

Each entry is one YAML file in ``robocal/catalog/`` holding the source parameter set as published
(an OPW set, a standard DH table or a modified DH table), its units, joint limits and, in comments,
where every number comes from. Entries are converted exactly to MDH + beta when loaded.
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from pathlib import Path

import yaml

from robocal.errors import ModelError
from robocal.kinematics.model import Robot
from robocal.kinematics.opw import GEOMETRY

_FORMS = ("opw", "dh", "mdh")


@cache
def _entries() -> dict[str, dict]:
    """name -> raw YAML mapping of every shipped catalog file."""
    out = {}
    for item in sorted(resources.files("robocal").joinpath("catalog").iterdir(), key=lambda p: p.name):
        if item.name.endswith(".yaml"):
            data = yaml.safe_load(item.read_text(encoding="utf-8"))
            out[data["name"]] = data
    return out


def catalog_names() -> list[str]:
    """Names of the catalog robots, sorted."""
    return sorted(_entries())


def catalog_descriptions() -> dict[str, str]:
    """name -> one-line description (model, reach, where the parameters come from)."""
    return {name: _entries()[name]["description"] for name in catalog_names()}


def robot_from_entry(data: dict) -> Robot:
    """Build a Robot from one catalog mapping (``units``, ``limits`` and one of opw/dh/mdh)."""
    units = data.get("units", {})
    if units.get("length") not in ("m", "mm") or units.get("angle") not in ("deg", "rad"):
        raise ModelError(f"catalog entry {data.get('name')!r}: units must be "
                         "{length: m|mm, angle: deg|rad}")
    forms = [f for f in _FORMS if f in data]
    if len(forms) != 1:
        raise ModelError(f"catalog entry {data.get('name')!r} needs exactly one of {_FORMS}")
    form, table = forms[0], data[forms[0]]
    kw = {"degrees": units["angle"] == "deg", "length_unit": units["length"],
          "limits": data.get("limits"), "name": data["name"], "description": data["description"]}
    if form == "opw":
        return Robot.from_opw(*(table[k] for k in GEOMETRY), table["offsets"], table["signs"], **kw)
    if form == "dh":
        return Robot.from_dh(table["theta"], table["d"], table["a"], table["alpha"], **kw)
    return Robot.from_mdh(table["alpha"], table["a"], table["theta"], table["d"], **kw)


def load_model(spec: str) -> Robot:
    """A robot from a model YAML path or a catalog name (what every ``--robot`` option takes)."""
    path = Path(spec)
    if path.suffix.lower() in (".yaml", ".yml") or path.exists():
        return Robot.load(path)
    return load_catalog_robot(spec)


def load_catalog_robot(name: str) -> Robot:
    """The catalog robot ``name``; an unknown name raises ModelError listing the known ones."""
    entries = _entries()
    if name not in entries:
        raise ModelError(f"unknown robot {name!r}; the catalog has: {', '.join(catalog_names())} "
                         "(run `robocal robots` for descriptions)")
    return robot_from_entry(entries[name])
