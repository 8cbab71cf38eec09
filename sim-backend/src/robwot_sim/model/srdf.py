"""SRDF (MoveIt's Semantic Robot Description Format): the link pairs a robot never needs checked.

``<disable_collisions link1="..." link2="..." reason="..."/>``: MoveIt's setup assistant writes one per pair
that is adjacent, always in contact or never in contact, and every ROS user relies on them. Those pairs are
taken out of every check of the twin (workspace labels, validation, motion).

``read_srdf`` also reads what ``robwot generate`` takes from a MoveIt config: planning groups (links,
joints, chains, subgroups), named group states (``home``), end effectors; every link and joint they name is
checked against the URDF, so an SRDF written for another robot is refused at its first foreign name.

The file is read with the same DTD-free XML reader as URDFs; a malformed file, a DOCTYPE, a root that is
not ``<robot>`` or a name the URDF does not have is refused with the file and line.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robwot_sim.errors import SrdfError
from robwot_sim.model.urdf import UrdfDoc, parse_xml


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


@dataclass
class SrdfGroup:
    name: str
    links: list[str] = field(default_factory=list)
    joints: list[str] = field(default_factory=list)
    #: (base_link, tip_link) of each ``<chain>``
    chains: list[tuple[str, str]] = field(default_factory=list)
    subgroups: list[str] = field(default_factory=list)


@dataclass
class Srdf:
    """The parts of an SRDF a twin uses, every name checked against the URDF."""

    file: Path
    robot: str
    groups: dict[str, SrdfGroup]
    #: group -> state name -> joint values (rad or m)
    group_states: dict[str, dict[str, dict[str, float]]]
    #: ``(name, parent_link, group, parent_group or None)`` in file order
    end_effectors: list[tuple[str, str, str, str | None]]

    def to_json(self) -> dict[str, Any]:
        effectors = [{"name": n, "parentLink": link, "group": g, **({"parentGroup": pg} if pg else {})}
                     for n, link, g, pg in self.end_effectors]
        return {
            "robot": self.robot,
            "groups": [{"name": g.name, "links": g.links, "joints": g.joints,
                        "chains": [{"base": b, "tip": t} for b, t in g.chains], "subgroups": g.subgroups}
                       for g in self.groups.values()],
            "groupStates": [{"group": g, "name": n, "joints": v} for g, states in self.group_states.items()
                            for n, v in states.items()],
            "endEffectors": effectors,
        }


def _need(doc: UrdfDoc, el: ET.Element, attr: str) -> str:
    value = el.get(attr)
    if not value:
        raise SrdfError(f"<{el.tag}> needs {attr}", file=str(doc.file), line=doc.line_of(el))
    return value


def read_srdf(path: str | Path, links: Collection[str], joints: Collection[str]) -> Srdf:
    """Groups, group states and end effectors of an SRDF, refusing (SrdfError with file and line) any
    link or joint the URDF lacks (virtual joints the SRDF declares count as joints), a group or subgroup
    that does not exist, or a state value that is not a number."""
    doc = parse_xml(path, root_tag="robot", error=SrdfError, what="SRDF file")
    f = str(doc.file)
    # a virtual joint (robot base to world) is a joint groups and states may name
    joints = {*joints, *(str(v.get("name")) for v in doc.root.findall("virtual_joint") if v.get("name"))}

    def known(el: ET.Element, kind: str, name: str) -> str:
        pool = links if kind == "link" else joints
        if name not in pool:
            names = ", ".join(sorted(pool))
            raise SrdfError(f"{kind} {name!r} is not a {kind} of the robot ({kind}s: {names}): is this the "
                            "SRDF of another robot?", file=f, line=doc.line_of(el), name=name, kind=kind)
        return name

    disabled_pairs(path, links)  # the pairs' links too
    groups: dict[str, SrdfGroup] = {}
    refs: list[tuple[ET.Element, str]] = []  # (element, group name) checked once every group is known
    for g in doc.root.findall("group"):
        group = SrdfGroup(_need(doc, g, "name"))
        for el in g:
            if el.tag == "link":
                group.links.append(known(el, "link", _need(doc, el, "name")))
            elif el.tag == "joint":
                group.joints.append(known(el, "joint", _need(doc, el, "name")))
            elif el.tag == "chain":
                group.chains.append((known(el, "link", _need(doc, el, "base_link")),
                                     known(el, "link", _need(doc, el, "tip_link"))))
            elif el.tag == "group":
                group.subgroups.append(_need(doc, el, "name"))
                refs.append((el, group.subgroups[-1]))
        groups[group.name] = group
    states: dict[str, dict[str, dict[str, float]]] = {}
    for st in doc.root.findall("group_state"):
        if not st.get("group"):
            continue  # MoveIt skips a state of no group too (some published SRDFs have them)
        name, group_name = _need(doc, st, "name"), _need(doc, st, "group")
        refs.append((st, group_name))
        values: dict[str, float] = {}
        for j in st.findall("joint"):
            joint = known(j, "joint", _need(doc, j, "name"))
            try:
                values[joint] = float(_need(doc, j, "value").split()[0])
            except ValueError:
                raise SrdfError(f"joint {joint!r}: value {j.get('value')!r} is not a number", file=f,
                                line=doc.line_of(j)) from None
        states.setdefault(group_name, {})[name] = values
    effectors: list[tuple[str, str, str, str | None]] = []
    for ee in doc.root.findall("end_effector"):
        parent_group = ee.get("parent_group") or None
        refs.append((ee, _need(doc, ee, "group")))
        if parent_group is not None:
            refs.append((ee, parent_group))
        effectors.append((_need(doc, ee, "name"), known(ee, "link", _need(doc, ee, "parent_link")),
                          _need(doc, ee, "group"), parent_group))
    for vj in doc.root.findall("virtual_joint"):
        known(vj, "link", _need(doc, vj, "child_link"))
    for pj in doc.root.findall("passive_joint"):
        known(pj, "joint", _need(doc, pj, "name"))
    for el, group_name in refs:
        if group_name not in groups:
            raise SrdfError(f"<{el.tag}> names group {group_name!r}, which the SRDF does not define (groups: "
                            f"{', '.join(groups) or 'none'})", file=f, line=doc.line_of(el), group=group_name)
    return Srdf(doc.file, doc.root.get("name", ""), groups, states, effectors)
