"""The VAL3 s6.x XML layout (CS8 controllers, SRS 6.x; s5.x writes the same): root elements
``<project xmlns="ProjectNameSpace">``, ``<programList xmlns="ProgramNameSpace">`` and
``<dataList xmlns="DataNameSpace">`` instead of s7's ``Project`` / ``Programs`` / ``Database``.

Data (``.dtx``): one section per type, one element per datum, its father once per datum::

    <pointSection>
      <point name="p1" public="false">
        <pFather alias="" name="world" fatherIndex="0" />
        <valuePoint index="0">
          <tpValue x="366.58" y="-390.36" z="-359.79" rx="-179.84" ry="4.22" rz="29.87" />
          <cpValue shoulder="ssame" elbow="esame" wrist="wsame" />
        </valuePoint>
    <toolSection> <tool name="tGrip"> <tFather name="flange" .../> <valueTool index="0"> <ttValue .../>
    <frameSection> <frame> <fFather/> <valueFrame> <tfValue/>;  <trsf> <valueTrsf> <trsfValue/>;
    <joint> <valueJoint> <jointValue j1=... />

Programs (``.pgx``): ``<program name="...">`` with ``<paramSection>`` (``<param name type>``),
``<localSection>`` (``<local name type size>``) and ``<source><code>...</code></source>``: the code
is XML text (``&lt;``, ``&quot;`` ...), or CDATA. The reader sees the code with each entity
replaced by its character padded with spaces (offsets kept)."""

from __future__ import annotations

import re
from collections.abc import Iterator

# an s6.x file, told by its root element (and namespace, which some writers leave out)
SIGNATURE = (r"<(?:programList|dataList)\b|"
             r"<project\s+xmlns\s*=\s*\"ProjectNameSpace\"")
# s6 element name -> (VAL3 type, value element): the data that carry a pose or joints
TYPES = {"point": "pointRx", "frame": "frame", "tool": "tool", "trsf": "trsf", "joint": "jointRx"}
VALUE_ELEMENT = {"point": "valuePoint", "frame": "valueFrame", "tool": "valueTool", "trsf": "valueTrsf",
                 "joint": "valueJoint"}
FATHER = {"point": "pFather", "frame": "fFather", "tool": "tFather"}

_ROOT = re.compile(r"<(programList|dataList)\b")
_PROGRAM = re.compile(r"<program\b([^>]*?)>(.*?)</program\s*>", re.DOTALL)
_CODE = re.compile(r"<code\b[^>/]*>(?:\s*<!\[CDATA\[)?(.*?)(?:\]\]>\s*)?</code\s*>", re.DOTALL)
_DECL = re.compile(r"<(param|local)\b([^>]*?)/?>")
_ENTITY = re.compile(r"&(?:#(\d+)|#x([0-9A-Fa-f]+)|(lt|gt|amp|quot|apos));")
_NAMED = {"lt": "<", "gt": ">", "amp": "&", "quot": '"', "apos": "'"}
_SECTION = re.compile(r"<(\w+)Section\b[^>]*?(/?)>")


def is_s6(text: str) -> bool:
    """``text`` is an s6.x program or data file (its root element says so)."""
    return _ROOT.search(text) is not None


def decoded(code: str) -> str:
    """``code`` (XML text) with every character entity replaced by its character and spaces to
    the entity's length: the code as the controller reads it, at the file's offsets."""

    def one(m: re.Match) -> str:
        code = int(m.group(1)) if m.group(1) else int(m.group(2) or "20", 16)
        ch = _NAMED[m.group(3)] if m.group(3) else chr(code)
        return (ch if ch.isprintable() else " ") + " " * (len(m.group()) - 1)

    return _ENTITY.sub(one, code)


def data_items(text: str) -> Iterator[tuple[str, str, int, int, int, bool]]:
    """``(element, name, start, end, body_start, closed)`` of every datum of an s6 .dtx: the
    datum's element name (``point``, ``tool``, ``num`` ...: its section's), its name, its span and
    where its body starts (``end == body_start``: an empty element); ``closed`` False: its closing
    tag is missing before the next datum of its section (its span is its opening tag)."""
    for sec in _SECTION.finditer(text):
        if sec.group(2) == "/":
            continue
        element = sec.group(1)
        stop = re.compile(rf"</{element}Section\s*>").search(text, sec.end())
        end = stop.start() if stop else len(text)
        item = re.compile(rf"<{element}\b([^>]*?)(/?)>")
        close = re.compile(rf"</{element}\s*>")
        pos = sec.end()
        while (m := item.search(text, pos, end)) is not None:
            name = re.search(r"\bname\s*=\s*\"([^\"]*)\"", m.group(1))
            following = item.search(text, m.end(), end)
            found = None if m.group(2) == "/" else close.search(text, m.end(), following.start() if following
                                                                else end)
            stop_item = m.end() if found is None else found.start()
            closed = m.group(2) == "/" or found is not None
            if name:
                yield element, name.group(1), m.start(), stop_item, m.end(), closed
            pos = max(stop_item, m.end())


def programs(text: str) -> Iterator[tuple[str, list[str], dict[str, str], int, str]]:
    """``(name, params [name], kinds {name: type}, code_start, code)`` of every ``<program>``
    of an s6 .pgx (``kinds``: of its parameters and locals; ``code``: decoded, at the file's
    offsets from ``code_start``)."""
    for p in _PROGRAM.finditer(text):
        name = re.search(r"\bname\s*=\s*\"([^\"]*)\"", p.group(1))
        code = _CODE.search(text, p.start(2), p.end(2))
        if code is None:
            continue
        params, kinds = [], {}
        for d in _DECL.finditer(text, p.start(2), code.start()):
            attrs = dict(re.findall(r"(\w+)\s*=\s*\"([^\"]*)\"", d.group(2)))
            if "name" not in attrs:
                continue
            kinds[attrs["name"]] = attrs.get("type", "")
            if d.group(1) == "param":
                params.append(attrs["name"])
        yield (name.group(1) if name else ""), params, kinds, code.start(1), decoded(code.group(1))
