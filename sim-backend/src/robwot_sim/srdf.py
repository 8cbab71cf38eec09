"""SRDF (MoveIt's Semantic Robot Description Format): the link pairs a robot never needs checked.

Only ``<disable_collisions link1="..." link2="..." reason="..."/>`` is used: MoveIt's setup assistant
writes one per pair that is adjacent, always in contact or never in contact, and every ROS user relies on
them. Those pairs are taken out of every check of the twin (workspace labels, validation, motion). Other
SRDF elements (groups, end effectors, virtual joints) are read past.

The file is read with the same DTD-free XML reader as URDFs; a malformed file, a DOCTYPE, a root that is
not ``<robot>`` or a pair naming a link the URDF does not have is refused with the file and line.
"""

from __future__ import annotations

from collections.abc import Collection
from pathlib import Path

from robwot_sim.errors import SrdfError
from robwot_sim.urdf import parse_xml


def disabled_pairs(path: str | Path, links: Collection[str]) -> frozenset[tuple[str, str]]:
    """The ``<disable_collisions>`` pairs of an SRDF as sorted (link, link) tuples of known links."""
    doc = parse_xml(path, root_tag="robot", error=SrdfError, what="SRDF file")
    pairs: set[tuple[str, str]] = set()
    for el in doc.root.iter("disable_collisions"):
        a, b = el.get("link1"), el.get("link2")
        line = doc.line_of(el)
        if not a or not b:
            raise SrdfError("<disable_collisions> needs link1 and link2", file=str(doc.file), line=line)
        for name in (a, b):
            if name not in links:
                raise SrdfError(
                    f"link {name!r} is not a link of the robot (links: {', '.join(sorted(links))})",
                    file=str(doc.file), line=line, link=name,
                )
        if a != b:
            pairs.add((min(a, b), max(a, b)))
    return frozenset(pairs)
