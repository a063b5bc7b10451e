"""YAML for engineering data: PyYAML's SafeLoader (no tag ever runs code) with the rules a number
file needs, every violation a one-line error naming the line and the key path.

- Numbers follow YAML 1.2: a plain ``12``, ``-0.5``, ``1e-3``, ``.5``, ``.inf``; ``true`` /
  ``false`` are the only booleans (``yes``, ``no``, ``on``, ``off`` stay text). Forms that
  YAML 1.1 (PyYAML's default) and YAML 1.2 read differently, or that look like a number but are
  not one, are refused: a leading zero (``0135``: octal 93 for 1.1), sexagesimal ``1:30`` (90),
  hex ``0x1F``, octal ``0o17``, binary ``0b101`` and digit separators ``1_000``. Quote a text.
- A key given twice in one mapping is refused (PyYAML keeps the last silently).
- Bounded: the document size (bytes), the nesting depth, the number of aliases and the size of
  the data once aliases are expanded (no "billion laughs"); an alias may not refer to the
  collection it is in.
"""

from __future__ import annotations

import re

import yaml
from yaml.events import AliasEvent
from yaml.nodes import MappingNode, ScalarNode, SequenceNode

from robocal.core.errors import DataError, RobocalError

MAX_BYTES = 4_000_000  # a model or settings file is a few kB
MAX_DEPTH = 32  # nesting of collections
MAX_ALIASES = 64  # alias references (*name) in one document
MAX_NODES = 1_000_000  # scalars and collections once aliases are expanded

_AMBIGUOUS_TAG = "tag:robocal,2026:ambiguous-number"
_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)$")
_FLOAT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")
_SPECIAL_FLOAT = re.compile(r"[-+]?\.(?:inf|Inf|INF)$|\.(?:nan|NaN|NAN)$")
_BOOL = re.compile(r"(?:true|True|TRUE|false|False|FALSE)$")
_NULL = re.compile(r"(?:~|null|Null|NULL|)$")
# what YAML 1.1 reads as a number (or PyYAML as text) but YAML 1.2 reads otherwise, or is a typo
_AMBIGUOUS = re.compile(r"""[-+]?(?:
      0[0-9_]+(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?      # leading zero: 0135 (1.1 octal), 007.5
    | 0[xX][0-9a-fA-F_]*                              # hex
    | 0[oO][0-7_]*                                    # octal (YAML 1.2 form)
    | 0[bB][01_]*                                     # binary
    | [0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?     # sexagesimal 1:30, 1:30:15.5
    | [0-9_]*[0-9]_[0-9_]*(?:\.[0-9_]*)?(?:[eE][-+]?[0-9_]+)?  # digit separators 1_000
    | [0-9_]*\.[0-9_]*_[0-9_]*(?:[eE][-+]?[0-9_]+)?
    )$""", re.X)


class _Limit(yaml.YAMLError):
    """A bound of this module exceeded while composing (one line)."""


class EngineeringLoader(yaml.SafeLoader):
    """SafeLoader with YAML 1.2 scalars, ambiguous numbers tagged for refusal, and composing
    bounded in depth and aliases (the checks that need the whole graph are in :func:`load_yaml`)."""

    yaml_implicit_resolvers: dict = {}
    max_depth = MAX_DEPTH
    max_aliases = MAX_ALIASES

    def __init__(self, stream) -> None:
        super().__init__(stream)
        self._depth = 0
        self._aliases = 0

    def compose_node(self, parent, index):
        if self.check_event(AliasEvent):
            self._aliases += 1
            if self._aliases > self.max_aliases:
                mark = self.peek_event().start_mark
                raise _Limit(f"line {mark.line + 1}: more than {self.max_aliases} aliases (*name) in one "
                             "document; write the values out")
        self._depth += 1
        try:
            if self._depth > self.max_depth:
                mark = self.peek_event().start_mark
                raise _Limit(f"line {mark.line + 1}: nested deeper than {self.max_depth} levels")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


for _tag, _regex, _first in (  # in this order: the ambiguous forms before the numbers
        (_AMBIGUOUS_TAG, _AMBIGUOUS, "-+0123456789._"),
        ("tag:yaml.org,2002:bool", _BOOL, "tTfF"),
        ("tag:yaml.org,2002:int", _INT, "-+0123456789"),
        ("tag:yaml.org,2002:float", _FLOAT, "-+0123456789."),
        ("tag:yaml.org,2002:float", _SPECIAL_FLOAT, "-+."),
        ("tag:yaml.org,2002:null", _NULL, ["~", "n", "N", ""]),
        ("tag:yaml.org,2002:merge", re.compile(r"<<$"), "<")):
    EngineeringLoader.add_implicit_resolver(_tag, _regex, list(_first))


def _construct_float(loader, node) -> float:
    text = loader.construct_scalar(node).lower()
    if text.lstrip("+-") == ".inf":
        return float("-inf") if text.startswith("-") else float("inf")
    return float("nan") if text == ".nan" else float(text)


EngineeringLoader.add_constructor("tag:yaml.org,2002:float", _construct_float)
EngineeringLoader.add_constructor("tag:yaml.org,2002:int",
                                  lambda loader, node: int(loader.construct_scalar(node)))


class EngineeringDumper(yaml.SafeDumper):
    """SafeDumper that quotes every text :class:`EngineeringLoader` would read as something else
    (``1e5``, ``0135``, ``yes`` stays plain): what it writes reads back exactly."""

    yaml_implicit_resolvers = EngineeringLoader.yaml_implicit_resolvers


def dump_yaml(data) -> str:
    """YAML text of plain ``data`` (keys in their order) that :func:`load_yaml` reads back exactly."""
    return yaml.dump(data, Dumper=EngineeringDumper, sort_keys=False)


def _children(node):
    if isinstance(node, MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, SequenceNode):
        return list(node.value)
    return []


def _line(node) -> str:
    return f"line {node.start_mark.line + 1}"


def _check_expansion(root, max_nodes: int) -> None:
    """Refuse a cycle through an alias and a document larger than ``max_nodes`` once its aliases
    are expanded (iterative: no recursion limit)."""
    size: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack = [(root, False)]
    while stack:
        node, finished = stack.pop()
        key = id(node)
        if finished:
            open_nodes.discard(key)
            size[key] = 1 + sum(size[id(c)] for c in _children(node))
            if size[key] > max_nodes:
                raise _Limit(f"{_line(node)}: more than {max_nodes} values once its aliases are expanded")
            continue
        if key in size:
            continue
        if key in open_nodes:
            raise _Limit(f"{_line(node)}: an alias refers to the collection it is in")
        open_nodes.add(key)
        stack.append((node, True))
        stack.extend((c, False) for c in _children(node) if id(c) not in size)


def _path(parent: str, part) -> str:
    return f"{parent}[{part}]" if isinstance(part, int) else (f"{parent}.{part}" if parent else str(part))


def _check_values(root) -> None:
    """Refuse duplicate keys, non-scalar keys and ambiguous numbers, naming the key path."""
    seen: set[int] = set()
    stack = [(root, "")]
    while stack:
        node, where = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, ScalarNode):
            if node.tag == _AMBIGUOUS_TAG:
                raise _Limit(f"{_line(node)}: {where or 'the document'}: {node.value!r} is not a plain "
                             "decimal number (YAML versions read leading zeros, 1:30, 0x.., 0o.., 0b.. "
                             "and 1_000 differently); write the decimal value, or quote it if it is text")
        elif isinstance(node, SequenceNode):
            stack.extend((child, _path(where, i)) for i, child in enumerate(node.value))
        elif isinstance(node, MappingNode):
            keys: dict[tuple[str, str], int] = {}
            for key, value in node.value:
                if not isinstance(key, ScalarNode):
                    raise _Limit(f"{_line(key)}: {where or 'the document'}: a key must be a plain value")
                if key.tag == "tag:yaml.org,2002:merge":
                    stack.append((value, where))
                    continue
                name = _path(where, key.value)
                if (key.tag, key.value) in keys:
                    raise _Limit(f"{_line(key)}: {name} is given twice (first on line "
                                 f"{keys[key.tag, key.value]}); keep one")
                keys[key.tag, key.value] = key.start_mark.line + 1
                stack.append((key, name))
                stack.append((value, name))


def load_yaml(text: str, where: str, error: type[RobocalError] = DataError, *, max_bytes: int = MAX_BYTES,
              max_nodes: int = MAX_NODES):
    """The data of one YAML document ``text`` (None when empty) under this module's rules;
    ``error`` (a RobocalError type) with one line starting with ``where`` (e.g. the file name)
    for invalid YAML and for every refusal."""
    if len(text) > max_bytes:
        raise error(f"{where}: {len(text)} characters is larger than a data file can be "
                    f"({max_bytes}); is it the right file?")
    loader = None
    try:
        loader = EngineeringLoader(text)  # the reader refuses control characters here
        node = loader.get_single_node()
        if node is None:
            return None
        _check_expansion(node, max_nodes)
        _check_values(node)
        return loader.construct_document(node)
    except _Limit as exc:
        raise error(f"{where}: {exc}") from None
    except yaml.YAMLError as exc:
        raise error(f"{where}: not valid YAML: {' '.join(str(exc).split())}") from None
    except (ValueError, OverflowError, TypeError) as exc:  # e.g. a merge key on a non-mapping
        raise error(f"{where}: not valid YAML: {exc}") from None
    finally:
        if loader is not None:
            loader.dispose()
