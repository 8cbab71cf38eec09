"""DTD-free XML parsing shared by every robot description we read (URDF, SRDF, COLLADA meshes).

A document containing ``<!DOCTYPE`` or ``<!ENTITY`` is refused before parsing (XXE, billion laughs), and
the expat parser refuses DTDs and entities again if they slip through an encoding. The caller turns the
two exceptions below into its own error naming the file.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from typing import Any

FORBIDDEN = re.compile(rb"<!\s*(DOCTYPE|ENTITY)", re.IGNORECASE)


class XmlRefused(Exception):
    """The document declares a DTD or entities (``line``, ``what``: DOCTYPE, ENTITY or DTD/entity)."""

    def __init__(self, line: int, what: str) -> None:
        super().__init__(f"line {line}: XML {what} declarations are refused")
        self.line, self.what = line, what


class XmlMalformed(Exception):
    """Not well-formed XML (``line``, ``column``, expat's ``reason``)."""

    def __init__(self, line: int, column: int, reason: str) -> None:
        super().__init__(f"line {line}: {reason}")
        self.line, self.column, self.reason = line, column, reason


def parse(data: bytes) -> tuple[ET.Element, dict[int, int]]:
    """The root element and the source line of each element (by ``id``); raises XmlRefused/XmlMalformed."""
    m = FORBIDDEN.search(data)
    if m is not None:
        raise XmlRefused(data.count(b"\n", 0, m.start()) + 1, m.group(1).decode().upper())
    builder = ET.TreeBuilder()
    parser = xml.parsers.expat.ParserCreate()
    lines: dict[int, int] = {}

    def start(tag: str, attrs: dict[str, str]) -> None:
        lines[id(builder.start(tag, attrs))] = parser.CurrentLineNumber

    def refuse(*_: Any) -> Any:
        raise XmlRefused(parser.CurrentLineNumber, "DTD/entity")

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    parser.ExternalEntityRefHandler = refuse
    try:
        parser.Parse(data, True)
        return builder.close(), lines
    except xml.parsers.expat.ExpatError as e:
        raise XmlMalformed(e.lineno, e.offset + 1, xml.parsers.expat.ErrorString(e.code)) from None
