"""The joint tree of a URDF: links, joints (type, limits, mimic, origin, axis), checked once.

The one parser of a URDF's kinematics: the simulation's robot model (``sim/robot.py``) and the vectorised
forward kinematics (``fk.py``) are both built from what ``parse_model`` returns. Limits in rad (revolute,
continuous) or m (prismatic); origins in m and rad (fixed-axis roll-pitch-yaw); axes unit vectors in the
joint frame. Every refusal names the file, the line and the joint (``UrdfError``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from robwot_sim.errors import NoMovableJoint, UrdfError
from robwot_sim.model.couplings import Coupling, keep_level, parse_coupling, resolve
from robwot_sim.model.urdf import UrdfDoc

Vec3 = tuple[float, float, float]

@dataclass(frozen=True)
class Mimic:
    joint: str
    multiplier: float = 1.0
    offset: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {"joint": self.joint, "multiplier": self.multiplier, "offset": self.offset}


@dataclass(frozen=True)
class JointInfo:
    """A URDF joint. Limits in rad (revolute/continuous) or m (prismatic); continuous = [-pi, pi]."""

    name: str
    type: str
    parent: str
    child: str
    lower: float
    upper: float
    velocity: float
    effort: float
    mimic: Mimic | None = None
    #: the joint frame in the parent link's frame: ``<origin xyz>`` (m) and ``rpy`` (rad, fixed axes)
    origin_xyz: Vec3 = (0.0, 0.0, 0.0)
    origin_rpy: Vec3 = (0.0, 0.0, 0.0)
    #: the unit ``<axis>`` in the joint frame (movable joints; fixed joints keep the default)
    axis: Vec3 = (1.0, 0.0, 0.0)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "name": self.name,
            "type": self.type,
            "parent": self.parent,
            "child": self.child,
            "lower": self.lower,
            "upper": self.upper,
            "velocity": self.velocity,
            "effort": self.effort,
        }
        if self.mimic is not None:
            out["mimic"] = self.mimic.to_json()
        return out


MOVABLE = ("revolute", "continuous", "prismatic")


#: largest joint limit accepted, rad (revolute: 16 turns) or m (prismatic)
MAX_LIMIT = 100.0
#: accepted URDF velocity limits (rad/s or m/s); 0 or absent means 1
MIN_VELOCITY, MAX_VELOCITY = 1e-6, 1e4


def _float(el: ET.Element | None, attr: str, default: float, doc: UrdfDoc) -> float:
    if el is None or el.get(attr) is None:
        return default
    raw = el.get(attr, "")
    try:
        v = float(raw)
    except ValueError:
        raise UrdfError(
            f"attribute {attr}={raw!r} of <{el.tag}> is not a number",
            file=str(doc.file),
            line=doc.line_of(el),
        ) from None
    if not math.isfinite(v):
        raise UrdfError(
            f"attribute {attr}={raw!r} of <{el.tag}> is not finite", file=str(doc.file), line=doc.line_of(el)
        )
    return v


def _vec3(el: ET.Element | None, attr: str, default: Vec3, doc: UrdfDoc, *, joint: str) -> Vec3:
    """Three finite numbers of attribute ``attr`` (``default`` when the element or attribute is absent)."""
    raw = None if el is None else el.get(attr)
    if raw is None:
        return default
    try:
        vals = tuple(float(p) for p in raw.split())
    except ValueError:
        vals = ()
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
        assert el is not None  # raw came from it
        raise UrdfError(f"joint {joint!r}: <{el.tag} {attr}> must be 3 finite numbers, got {raw[:40]!r}",
                        file=str(doc.file), line=doc.line_of(el), joint=joint)
    return (vals[0], vals[1], vals[2])


@dataclass(frozen=True)
class UrdfModel:
    """Links and joints read from a URDF, with the tree structure."""

    name: str
    root_link: str
    links: tuple[str, ...]
    joints: tuple[JointInfo, ...]
    children: dict[str, list[JointInfo]] = field(hash=False)
    #: every joint that follows others, written in the controllable joints' coordinates (``<mimic>`` tags
    #: and the couplings given at load)
    couplings: tuple[Coupling, ...] = ()

    @property
    def controllable(self) -> tuple[str, ...]:
        """The movable joints that follow no other: a joint vector's order."""
        followers = {c.follower for c in self.couplings}
        return tuple(j.name for j in self.joints if j.type in MOVABLE and j.name not in followers)

    def coupled(self, rules: Sequence[str] = (), level_links: Sequence[str] = ()) -> UrdfModel:
        """This model with the couplings ``rules`` (``FOLLOWER=EXPR``; one replaces the ``<mimic>`` of its
        follower) and, after them, those keeping each of ``level_links`` level (``couplings.keep_level``)."""
        given = [parse_coupling(text, f"couplings[{k}]") for k, text in enumerate(rules)]
        named = {c.follower for c in given}
        mimics = [c for c in _mimic_couplings(self.joints) if c.follower not in named]
        out = [*mimics, *given]
        for link in level_links:
            out.append(keep_level(link, self.joints, {c.follower for c in out}))
        return replace(self, couplings=resolve(out, self.joints))

    def default_ee(self) -> str:
        """Tip of the longest serial chain: from the root, follow the child subtree holding strictly the
        most movable joints; stop at a leaf or where subtrees tie (e.g. Panda's hand between its fingers)."""
        memo: dict[str, int] = {}

        def count(link: str) -> int:
            if link not in memo:
                memo[link] = sum(count(j.child) + (j.type in MOVABLE) for j in self.children.get(link, []))
            return memo[link]

        link = self.root_link
        while True:
            kids = self.children.get(link, [])
            if not kids:
                return link
            scores = sorted(((count(j.child) + (j.type in MOVABLE), j.child) for j in kids), reverse=True)
            if len(scores) > 1 and scores[0][0] == scores[1][0]:
                return link
            if scores[0][0] == 0 and len(scores) > 1:
                return link
            link = scores[0][1]


def parse_model(doc: UrdfDoc) -> UrdfModel:
    """Read links, joints, limits and mimic tags; check the tree. Raises UrdfError / NoMovableJoint.

    Each joint is checked in document order and each of its checks in the order of the steps below, so the
    first refusal is the first fault a reader of the file meets."""
    f = str(doc.file)
    root = doc.root
    links = [el.get("name", "") for el in root.findall("link")]
    for el in root.findall("link"):
        if not el.get("name"):
            raise UrdfError("<link> without name", file=f, line=doc.line_of(el))
    joints: list[JointInfo] = []
    parent_of: dict[str, str] = {}
    for el in root.findall("joint"):
        name, jtype, line = _joint_kind(el, doc)
        parent, child = _joint_ends(el, doc, name, links)
        if child in parent_of:
            raise UrdfError(f"link {child!r} is the child of two joints", file=f, line=line, joint=name)
        parent_of[child] = parent
        joints.append(_joint_info(el, doc, name, jtype, parent, child))
    _check_unique_and_mimics(joints, links, f)
    roots = [ln for ln in links if ln not in parent_of]
    if len(roots) != 1:
        raise UrdfError(f"URDF must have exactly one root link, found {roots}", file=f)
    children: dict[str, list[JointInfo]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    model = UrdfModel(root.get("name", "robot"), roots[0], tuple(links), tuple(joints), children,
                      resolve(_mimic_couplings(joints), joints))
    if not model.controllable:
        raise NoMovableJoint(f)
    return model


def _joint_kind(el: ET.Element, doc: UrdfDoc) -> tuple[str, str, int | None]:
    """A ``<joint>``'s name, its type (one this model supports) and its line."""
    name, jtype = el.get("name"), el.get("type")
    line = doc.line_of(el)
    if not name or not jtype:
        raise UrdfError("<joint> needs name and type", file=str(doc.file), line=line)
    if jtype not in (*MOVABLE, "fixed"):
        raise UrdfError(
            f"joint {name!r}: unsupported type {jtype!r} (revolute, continuous, prismatic, fixed)",
            file=str(doc.file),
            line=line,
            joint=name,
        )
    return name, jtype, line


def _joint_ends(el: ET.Element, doc: UrdfDoc, name: str, links: list[str]) -> tuple[str, str]:
    """A joint's parent and child links, both defined links of the document."""
    pel, cel = el.find("parent"), el.find("child")
    parent = pel.get("link", "") if pel is not None else ""
    child = cel.get("link", "") if cel is not None else ""
    for what, ln in (("parent", parent), ("child", child)):
        if ln not in links:
            raise UrdfError(
                f"joint {name!r}: {what} link {ln!r} is not defined",
                file=str(doc.file),
                line=doc.line_of(el),
                joint=name,
            )
    return parent, child


def _joint_info(el: ET.Element, doc: UrdfDoc, name: str, jtype: str, parent: str, child: str) -> JointInfo:
    """The checked joint: its limits, its origin, its unit axis and its mimic tag."""
    lim = el.find("limit")
    lower, upper = _joint_range(lim, doc, name, jtype, doc.line_of(el))
    velocity = _joint_velocity(lim, doc, name, doc.line_of(el))
    origin = el.find("origin")
    xyz = _vec3(origin, "xyz", (0.0, 0.0, 0.0), doc, joint=name)
    rpy = _vec3(origin, "rpy", (0.0, 0.0, 0.0), doc, joint=name)
    axis = _joint_axis(el, doc, name, jtype) if jtype in MOVABLE else (1.0, 0.0, 0.0)
    mel = el.find("mimic")
    mimic = None
    if mel is not None and jtype in MOVABLE:
        mimic = Mimic(
            mel.get("joint", ""), _float(mel, "multiplier", 1.0, doc), _float(mel, "offset", 0.0, doc)
        )
    effort = _float(lim, "effort", 0.0, doc)
    return JointInfo(name, jtype, parent, child, lower, upper, velocity, effort, mimic, xyz, rpy, axis)


def _joint_range(
    lim: ET.Element | None, doc: UrdfDoc, name: str, jtype: str, line: int | None
) -> tuple[float, float]:
    """A joint's ``[lower, upper]``: read for revolute and prismatic, a turn for continuous, 0 for fixed."""
    f = str(doc.file)
    if jtype == "continuous":
        return -math.pi, math.pi
    if jtype not in ("revolute", "prismatic"):
        return 0.0, 0.0
    if lim is None or lim.get("lower") is None or lim.get("upper") is None:
        raise UrdfError(
            f"{jtype} joint {name!r} needs <limit lower=... upper=...>", file=f, line=line, joint=name
        )
    lower, upper = _float(lim, "lower", 0.0, doc), _float(lim, "upper", 0.0, doc)
    if max(abs(lower), abs(upper)) > MAX_LIMIT:
        unit = "rad" if jtype == "revolute" else "m"
        raise UrdfError(
            f"joint {name!r}: limits [{lower:g}, {upper:g}] {unit} beyond +-{MAX_LIMIT:g} {unit}",
            file=f,
            line=doc.line_of(lim),
            joint=name,
        )
    if lower > upper:
        raise UrdfError(
            f"joint {name!r}: lower limit {lower} > upper limit {upper}",
            file=f,
            line=doc.line_of(lim),
            joint=name,
        )
    return lower, upper


def _joint_velocity(lim: ET.Element | None, doc: UrdfDoc, name: str, line: int | None) -> float:
    """A joint's velocity limit: 0 (absent) or within the accepted range."""
    velocity = _float(lim, "velocity", 0.0, doc)
    if not (velocity <= 0 or MIN_VELOCITY <= velocity <= MAX_VELOCITY):
        raise UrdfError(
            f"joint {name!r}: velocity limit {velocity:g} outside [{MIN_VELOCITY:g}, {MAX_VELOCITY:g}] "
            "(0 or absent: 1 rad/s or m/s)",
            file=str(doc.file),
            line=doc.line_of(lim) if lim is not None else line,
            joint=name,
        )
    return velocity


def _joint_axis(el: ET.Element, doc: UrdfDoc, name: str, jtype: str) -> Vec3:
    """A movable joint's ``<axis>``, normalised; a zero axis is refused."""
    axis_el = el.find("axis")
    ax = _vec3(axis_el, "xyz", (1.0, 0.0, 0.0), doc, joint=name)
    norm = math.sqrt(sum(a * a for a in ax))
    if norm == 0.0:
        where = doc.line_of(axis_el) if axis_el is not None else doc.line_of(el)
        raise UrdfError(f"joint {name!r}: zero axis", file=str(doc.file), line=where, joint=name)
    return (ax[0] / norm, ax[1] / norm, ax[2] / norm)


def _mimic_couplings(joints: Sequence[JointInfo]) -> list[Coupling]:
    return [Coupling(j.name, ((j.mimic.joint, j.mimic.multiplier),), j.mimic.offset, "mimic")
            for j in joints if j.mimic is not None]


def _check_unique_and_mimics(joints: list[JointInfo], links: list[str], f: str) -> None:
    """Joint and link names are unique; every mimic follows a movable joint that mimics nothing."""
    names = [j.name for j in joints]
    if len(set(names)) != len(names):
        raise UrdfError("duplicate joint names", file=f)
    if len(set(links)) != len(links):
        raise UrdfError("duplicate link names", file=f)
    by_name = {j.name: j for j in joints}
    for j in joints:
        if j.mimic is not None:
            master = by_name.get(j.mimic.joint)
            if master is None or master.type not in MOVABLE or master.mimic is not None:
                raise UrdfError(
                    f"joint {j.name!r} mimics {j.mimic.joint!r}, which is not a movable non-mimic joint",
                    file=f,
                    joint=j.name,
                )
