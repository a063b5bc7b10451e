"""What a writer embeds of a user's text (model and file names, comments) is escaped for the syntax
it lands in, so that no value breaks out of its place (issue 47: a model name holding ``]]>``
became a new ``<Program>`` of a VAL3 application).

* :func:`comment_text`: one line of printable ASCII (a newline ends a line comment in every robot
  language and in YAML and CSV ``#`` comments; controllers' comment charsets are ASCII): every
  other character becomes ``?``;
* :func:`line_text`: one line of any printable text (a ``#`` comment of a UTF-8 CSV: a file name
  with accents stays as it is), every line break or control character a ``?``;
* :func:`cdata_text`: text inside an XML CDATA section (``]]>`` would end it);
* :func:`xml_text`: XML character data or an attribute value (``&``, ``<``, ``>``, quotes);
* :func:`xml_comment_text`: the inside of an XML comment (``--`` is not allowed there).
"""

from __future__ import annotations

REPLACEMENT = "?"  # what stands for a character a comment cannot hold


def comment_text(text: str) -> str:
    """``text`` as one line of printable ASCII (a line comment's content).

    Examples
    --------
    >>> comment_text("model A\\nkinematics: {}\\x00")
    'model A?kinematics: {}?'
    """
    return "".join(ch if 32 <= ord(ch) < 127 else REPLACEMENT for ch in str(text))


def line_text(text: str) -> str:
    """``text`` as one line: every character that breaks a line (``str.splitlines``' separators)
    or is a control character becomes ``?``.

    Examples
    --------
    >>> line_text("mesures été.csv\\nkind: pose\\u2028x")
    'mesures été.csv?kind: pose?x'
    """
    return "".join(ch if ch.isprintable() or ch == "\t" else REPLACEMENT for ch in str(text))


def cdata_text(text: str) -> str:
    """``text`` that cannot end the CDATA section it goes in (``]]>`` split: ``]] >``).

    Examples
    --------
    >>> cdata_text('x]]></Code></Program><Program name="evil">')
    'x]] ></Code></Program><Program name="evil">'
    """
    while "]]>" in text:
        text = text.replace("]]>", "]] >")
    return text


def xml_text(text: str) -> str:
    """``text`` escaped as XML character data or a quoted attribute value.

    Examples
    --------
    >>> xml_text('a<b & "c"\\x00')
    'a&lt;b &amp; &quot;c&quot;?'
    """
    text = (str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
            .replace('"', "&quot;").replace("'", "&apos;"))
    # XML 1.0 cannot hold other control characters even as references (a model name holding
    # one made an exported URDF that no parser reads); line ends and tabs as references keep
    # their value in an attribute (a parser turns a literal one into a space)
    text = "".join(_XML_KEPT.get(ch, ch) if _xml_char(ch) else REPLACEMENT for ch in text)
    return text


_XML_KEPT = {"\n": "&#10;", "\r": "&#13;", "\t": "&#9;"}


def _xml_char(ch: str) -> bool:
    """Whether XML 1.0 allows ``ch`` (its Char production)."""
    code = ord(ch)
    return code in (0x9, 0xA, 0xD) or 0x20 <= code <= 0xD7FF or 0xE000 <= code <= 0xFFFD or code >= 0x10000


def xml_comment_text(text: str) -> str:
    """``text`` that can stand inside ``<!-- -->`` (no ``--``, not ending in ``-``), one line.

    Examples
    --------
    >>> xml_comment_text("a -- b -->")
    'a - - b - ->'
    """
    text = comment_text(text)
    while "--" in text:
        text = text.replace("--", "- -")
    return text + " " if text.endswith("-") else text
