"""SRDF (MoveIt's Semantic Robot Description Format): the link pairs a robot never needs checked.

``<disable_collisions link1="..." link2="..." reason="..."/>``: MoveIt's setup assistant writes one per pair
that is adjacent, always in contact or never in contact, and every ROS user relies on them. Those pairs are
taken out of every check of the twin (workspace labels, validation, motion).

``read_srdf`` also reads what ``robwot generate`` takes from a MoveIt config: planning groups (links,
joints, chains, subgroups), named group states (``home``), end effectors.

Every link and joint an SRDF names is checked against the URDF as MoveIt (srdfdom) checks it: an entry
naming one the URDF lacks (a group's link, joint or chain, a state's joint value, an end effector, a
virtual or passive joint, a disabled pair) is skipped, and a warning names the file, the line and the
name; the rest of the SRDF is honoured. Published SRDFs carry such slips (example-robot-data's Unitree Z1
names a chain base ``base`` its URDF calls ``link00``). An SRDF most of whose names are unknown (more
distinct unknown names than known ones) was written for another robot and is refused, with the file and
the line of its first unknown name.

The file is read with the same DTD-free XML reader as URDFs; a malformed file, a DOCTYPE, a root that is
not ``<robot>``, a missing attribute, a group that is not defined or a value that is not a number is
refused with the file and line.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Collection
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robwot_sim.errors import SrdfError
from robwot_sim.model.urdf import UrdfDoc, parse_xml


class _Names:
    """The links and joints one SRDF names, checked against the URDF's: known ones counted, unknown ones
    warned about (their entry is skipped by the caller) and counted for ``refuse_foreign``. ``joints``
    None: joint names are not checked (taken as known, not counted)."""

    def __init__(self, doc: UrdfDoc, links: Collection[str], joints: Collection[str] | None) -> None:
        self.doc, self.links, self.joints = doc, links, joints
        self.known: set[tuple[str, str]] = set()
        #: (kind, name) -> the first element naming it
        self.unknown: dict[tuple[str, str], ET.Element] = {}
        self._skipped: list[tuple[int, str]] = []  # (line, warning)

    def check(self, el: ET.Element, kind: str, name: str, entry: str) -> bool:
        """Whether ``name`` is a ``kind`` ("link" or "joint") of the robot; if not, a warning says that
        ``entry`` (what the caller skips) is skipped."""
        pool = self.links if kind == "link" else self.joints
        if pool is None:
            return True
        if name in pool:
            self.known.add((kind, name))
            return True
        self.unknown.setdefault((kind, name), el)
        line = self.doc.line_of(el)
        text = (f"{self.doc.file}:{line}: {kind} {name!r} is not a {kind} of the robot: {entry} skipped, "
                "as MoveIt does")
        self._skipped.append((line or 0, text))
        return False

    @property
    def warnings(self) -> list[str]:
        """One line per skipped entry, in file order."""
        return [text for _, text in sorted(self._skipped, key=lambda s: s[0])]

    def refuse_foreign(self) -> None:
        """SrdfError when most distinct names are unknown: the SRDF of another robot."""
        if len(self.unknown) <= len(self.known):
            return
        (kind, name), el = next(iter(self.unknown.items()))
        pool = self.links if kind == "link" else self.joints
        total = len(self.unknown) + len(self.known)
        raise SrdfError(
            f"{kind} {name!r} is not a {kind} of the robot ({kind}s: {', '.join(sorted(pool or ()))}): "
            f"{len(self.unknown)} of the {total} links and joints the SRDF names are not the robot's: is "
            "this the SRDF of another robot?",
            file=str(self.doc.file), line=self.doc.line_of(el), name=name, kind=kind,
            unknown=len(self.unknown), names=total,
        )


def _need(doc: UrdfDoc, el: ET.Element, attr: str) -> str:
    value = el.get(attr)
    if not value:
        raise SrdfError(f"<{el.tag}> needs {attr}", file=str(doc.file), line=doc.line_of(el))
    return value


def _pairs(doc: UrdfDoc, names: _Names) -> frozenset[tuple[str, str]]:
    """The ``<disable_collisions>`` pairs as sorted (link, link) tuples; a pair naming an unknown link is
    skipped (MoveIt: "Cannot disable collisions")."""
    pairs: set[tuple[str, str]] = set()
    for el in doc.root.iter("disable_collisions"):
        a, b = el.get("link1"), el.get("link2")
        if not a or not b:
            raise SrdfError("<disable_collisions> needs link1 and link2", file=str(doc.file),
                            line=doc.line_of(el))
        entry = f"the disabled pair ({a}, {b})"
        if all([names.check(el, "link", a, entry), names.check(el, "link", b, entry)]) and a != b:
            pairs.add((min(a, b), max(a, b)))
    return frozenset(pairs)


def disabled_pairs(path: str | Path, links: Collection[str],
                   joints: Collection[str] | None = None) -> frozenset[tuple[str, str]]:
    """The ``<disable_collisions>`` pairs of an SRDF of known links (`read_srdf`'s rules: an unknown
    name's entry skipped, an SRDF mostly of unknown names refused). ``joints`` None: joint names are not
    checked."""
    return read_srdf(path, links, joints).disabled


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
    """The parts of an SRDF a twin uses, every name the robot's (entries naming others skipped)."""

    file: Path
    robot: str
    groups: dict[str, SrdfGroup]
    #: group -> state name -> joint values (rad or m)
    group_states: dict[str, dict[str, dict[str, float]]]
    #: ``(name, parent_link, group, parent_group or None)`` in file order
    end_effectors: list[tuple[str, str, str, str | None]]
    #: sorted (link, link) pairs never checked for collision
    disabled: frozenset[tuple[str, str]] = frozenset()
    #: ``FILE:LINE: ...`` per skipped entry naming a link or joint the robot lacks, in file order
    warnings: list[str] = field(default_factory=list)

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
            "warnings": self.warnings,
        }


def _groups(doc: UrdfDoc, names: _Names, refs: list[tuple[ET.Element, str]]) -> dict[str, SrdfGroup]:
    groups: dict[str, SrdfGroup] = {}
    for g in doc.root.findall("group"):
        group = SrdfGroup(_need(doc, g, "name"))
        of = f"of group {group.name!r}"
        for el in g:
            if el.tag in ("link", "joint"):
                name = _need(doc, el, "name")
                if names.check(el, el.tag, name, f"<{el.tag}> {of}"):
                    (group.links if el.tag == "link" else group.joints).append(name)
            elif el.tag == "chain":
                base, tip = _need(doc, el, "base_link"), _need(doc, el, "tip_link")
                entry = f"the chain {base} -> {tip} {of}"
                if all([names.check(el, "link", base, entry), names.check(el, "link", tip, entry)]):
                    group.chains.append((base, tip))
            elif el.tag == "group":
                group.subgroups.append(_need(doc, el, "name"))
                refs.append((el, group.subgroups[-1]))
        groups[group.name] = group
    return groups


def _states(doc: UrdfDoc, names: _Names,
            refs: list[tuple[ET.Element, str]]) -> dict[str, dict[str, dict[str, float]]]:
    states: dict[str, dict[str, dict[str, float]]] = {}
    for st in doc.root.findall("group_state"):
        if not st.get("group"):
            continue  # MoveIt skips a state of no group too (some published SRDFs have them)
        name, group_name = _need(doc, st, "name"), _need(doc, st, "group")
        refs.append((st, group_name))
        values: dict[str, float] = {}
        for j in st.findall("joint"):
            joint = _need(doc, j, "name")
            if not names.check(j, "joint", joint, f"its value in group state {name!r}"):
                continue
            try:
                values[joint] = float(_need(doc, j, "value").split()[0])
            except ValueError:
                raise SrdfError(f"joint {joint!r}: value {j.get('value')!r} is not a number",
                                file=str(doc.file), line=doc.line_of(j)) from None
        states.setdefault(group_name, {})[name] = values
    return states


def _effectors(doc: UrdfDoc, names: _Names,
               refs: list[tuple[ET.Element, str]]) -> list[tuple[str, str, str, str | None]]:
    effectors: list[tuple[str, str, str, str | None]] = []
    for ee in doc.root.findall("end_effector"):
        name, group = _need(doc, ee, "name"), _need(doc, ee, "group")
        parent_link = _need(doc, ee, "parent_link")
        parent_group = ee.get("parent_group") or None
        refs.append((ee, group))
        if parent_group is not None:
            refs.append((ee, parent_group))
        if names.check(ee, "link", parent_link, f"end effector {name!r}"):
            effectors.append((name, parent_link, group, parent_group))
    return effectors


def read_srdf(path: str | Path, links: Collection[str], joints: Collection[str] | None) -> Srdf:
    """Groups, group states, end effectors and disabled pairs of an SRDF. An entry naming a link or joint
    the URDF lacks is skipped with a warning (``Srdf.warnings``); virtual joints the SRDF declares on a
    known link count as joints. Refuses (SrdfError with file and line) an SRDF most of whose names are
    unknown, a group or subgroup that is not defined, a missing attribute, a state value that is not a
    number. ``joints`` None: joint names are not checked."""
    doc = parse_xml(path, root_tag="robot", error=SrdfError, what="SRDF file")
    names = _Names(doc, links, joints)
    virtual = [str(v.get("name")) for v in doc.root.findall("virtual_joint")
               if names.check(v, "link", _need(doc, v, "child_link"), f"virtual joint {v.get('name')!r}")
               and v.get("name")]
    if joints is not None:  # a virtual joint (robot base to world) is a joint groups and states may name
        names.joints = {*joints, *virtual}
    refs: list[tuple[ET.Element, str]] = []  # (element, group name) checked once every group is known
    groups = _groups(doc, names, refs)
    states = _states(doc, names, refs)
    effectors = _effectors(doc, names, refs)
    for pj in doc.root.findall("passive_joint"):
        names.check(pj, "joint", _need(doc, pj, "name"), "the passive joint")
    disabled = _pairs(doc, names)
    names.refuse_foreign()
    for el, group_name in refs:
        if group_name not in groups:
            raise SrdfError(f"<{el.tag}> names group {group_name!r}, which the SRDF does not define (groups: "
                            f"{', '.join(groups) or 'none'})", file=str(doc.file), line=doc.line_of(el),
                            group=group_name)
    return Srdf(doc.file, doc.root.get("name", ""), groups, states, effectors, disabled, names.warnings)
