"""Joint model of a URDF (limits, mimic joints, default end effector) and its binding to a PyBullet body."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from robwot_sim.errors import InvalidParams, NoMovableJoint, OutOfLimits, UrdfError
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.types import FloatArray, JointInfo, Mimic
from robwot_sim.urdf import UrdfDoc

MOVABLE = ("revolute", "continuous", "prismatic")
LIMIT_TOL = 1e-9


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


@dataclass(frozen=True)
class UrdfModel:
    """Links and joints read from a URDF, with the tree structure."""

    name: str
    root_link: str
    links: tuple[str, ...]
    joints: tuple[JointInfo, ...]
    children: dict[str, list[JointInfo]] = field(hash=False)

    @property
    def controllable(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints if j.type in MOVABLE and j.mimic is None)

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
    """Read links, joints, limits and mimic tags; check the tree. Raises UrdfError / NoMovableJoint."""
    f = str(doc.file)
    root = doc.root
    links = [el.get("name", "") for el in root.findall("link")]
    for el in root.findall("link"):
        if not el.get("name"):
            raise UrdfError("<link> without name", file=f, line=doc.line_of(el))
    joints: list[JointInfo] = []
    parent_of: dict[str, str] = {}
    for el in root.findall("joint"):
        name, jtype = el.get("name"), el.get("type")
        line = doc.line_of(el)
        if not name or not jtype:
            raise UrdfError("<joint> needs name and type", file=f, line=line)
        if jtype not in (*MOVABLE, "fixed"):
            raise UrdfError(
                f"joint {name!r}: unsupported type {jtype!r} (revolute, continuous, prismatic, fixed)",
                file=f,
                line=line,
                joint=name,
            )
        pel, cel = el.find("parent"), el.find("child")
        parent = pel.get("link", "") if pel is not None else ""
        child = cel.get("link", "") if cel is not None else ""
        for what, ln in (("parent", parent), ("child", child)):
            if ln not in links:
                raise UrdfError(
                    f"joint {name!r}: {what} link {ln!r} is not defined", file=f, line=line, joint=name
                )
        if child in parent_of:
            raise UrdfError(f"link {child!r} is the child of two joints", file=f, line=line, joint=name)
        parent_of[child] = parent
        lim = el.find("limit")
        if jtype in ("revolute", "prismatic"):
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
        elif jtype == "continuous":
            lower, upper = -math.pi, math.pi
        else:
            lower = upper = 0.0
        velocity = _float(lim, "velocity", 0.0, doc)
        if not (velocity <= 0 or MIN_VELOCITY <= velocity <= MAX_VELOCITY):
            raise UrdfError(
                f"joint {name!r}: velocity limit {velocity:g} outside [{MIN_VELOCITY:g}, {MAX_VELOCITY:g}] "
                "(0 or absent: 1 rad/s or m/s)",
                file=f,
                line=doc.line_of(lim) if lim is not None else line,
                joint=name,
            )
        mel = el.find("mimic")
        mimic = None
        if mel is not None and jtype in MOVABLE:
            mimic = Mimic(
                mel.get("joint", ""), _float(mel, "multiplier", 1.0, doc), _float(mel, "offset", 0.0, doc)
            )
        joints.append(
            JointInfo(
                name,
                jtype,
                parent,
                child,
                lower,
                upper,
                velocity,
                _float(lim, "effort", 0.0, doc),
                mimic,
            )
        )
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
    roots = [ln for ln in links if ln not in parent_of]
    if len(roots) != 1:
        raise UrdfError(f"URDF must have exactly one root link, found {roots}", file=f)
    children: dict[str, list[JointInfo]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    model = UrdfModel(root.get("name", "robot"), roots[0], tuple(links), tuple(joints), children)
    if not model.controllable:
        raise NoMovableJoint(f)
    return model


class BoundRobot:
    """A URDF model bound to a loaded PyBullet body: index maps, limits, mimic enforcement."""

    def __init__(self, bullet: Bullet, body: int, model: UrdfModel, ee_link: str) -> None:
        self.bullet, self.body, self.urdf = bullet, body, model
        base_name, _ = bullet.body_name(body)
        infos = bullet.joints(body)
        by_joint = {ji.name: ji for ji in infos}
        self.link_index: dict[str, int] = {base_name: -1, **{ji.link_name: ji.idx for ji in infos}}
        self.link_names: dict[int, str] = {v: k for k, v in self.link_index.items()}
        joints = {j.name: j for j in model.joints}
        self.ctrl_names = model.controllable
        self.ctrl_idx = [by_joint[n].idx for n in self.ctrl_names]
        self.movable_idx = [ji.idx for ji in infos if joints[ji.name].type in MOVABLE]
        self.ik_slots = np.array([self.movable_idx.index(i) for i in self.ctrl_idx], dtype=np.intp)
        pos = {n: k for k, n in enumerate(self.ctrl_names)}
        self.mimic = [
            (by_joint[j.name].idx, pos[j.mimic.joint], j.mimic.multiplier, j.mimic.offset)
            for j in model.joints
            if j.mimic is not None
        ]
        self.set_idx = self.ctrl_idx + [m[0] for m in self.mimic]
        js = [joints[n] for n in self.ctrl_names]
        self.lower = np.array([j.lower for j in js], dtype=np.float64)
        self.upper = np.array([j.upper for j in js], dtype=np.float64)
        self._lower: list[float] = self.lower.tolist()
        self._upper: list[float] = self.upper.tolist()
        self.continuous = np.array([j.type == "continuous" for j in js], dtype=bool)
        self.ee_link = ee_link
        self.ee_index = self.link_index[ee_link]
        moving: set[int] = set()
        for ji in infos:  # parents come before children in PyBullet's order
            if joints[ji.name].type in MOVABLE or ji.parent_index in moving:
                moving.add(ji.idx)
        self.moving_links = sorted(moving)
        self.static_links = [-1] + [ji.idx for ji in infos if ji.idx not in moving]
        self.q = self.home()
        self.apply(self.q)

    def home(self) -> FloatArray:
        """Initial configuration: 0 for joints where 0 is at least 10 % of the range away from both limits,
        the middle of the range otherwise (e.g. Panda joints 4 and 6): never starts at a limit."""
        margin = 0.1 * (self.upper - self.lower)
        zero_ok = (self.lower + margin <= 0) & (self.upper - margin >= 0)
        out: FloatArray = np.where(zero_ok, 0.0, (self.lower + self.upper) / 2)
        return out

    @property
    def dof(self) -> int:
        return len(self.ctrl_idx)

    def full_values(self, q: FloatArray) -> list[float]:
        """Values for ``set_idx``: the controllable joints then the mimic joints (follower = m * q + off)."""
        vals: list[float] = np.asarray(q, dtype=np.float64).tolist()
        if self.mimic:
            vals += [vals[k] * m + off for _, k, m, off in self.mimic]
        return vals

    def apply(self, q: FloatArray) -> None:
        """Teleport to ``q`` (no validation; use ``validate`` first)."""
        self.bullet.reset_joints(self.body, self.set_idx, self.full_values(q))
        self.q = np.array(q, dtype=np.float64)

    def validate(self, q: object, param: str = "positions") -> FloatArray:
        """Check a joint vector: a list of dof finite numbers within limits. Returns a float array."""
        arr: FloatArray | None = None
        if isinstance(q, np.ndarray):
            if q.ndim == 1 and q.dtype.kind in "fiu":
                arr = q.astype(np.float64, copy=False)
        elif isinstance(q, (list, tuple)) and all(
            isinstance(v, (int, float, np.floating, np.integer)) and not isinstance(v, bool) for v in q
        ):
            arr = np.array(q, dtype=np.float64)
        if arr is None:
            raise InvalidParams(
                f"{param} must be an array of {self.dof} numbers",
                param=param,
                expected=f"array of {self.dof} numbers",
                got=q,
            )
        if arr.shape != (self.dof,):
            raise InvalidParams(
                f"{param} must have {self.dof} values ({', '.join(self.ctrl_names)}), got {arr.shape[0]}",
                param=param,
                expected=self.dof,
                got=int(arr.shape[0]),
            )
        values: list[float] = arr.tolist()
        clipped = False
        for k, (x, lo, hi) in enumerate(zip(values, self._lower, self._upper, strict=True)):
            if not lo <= x <= hi:  # also catches NaN
                if not math.isfinite(x):
                    raise InvalidParams(
                        f"{param}[{k}] ({self.ctrl_names[k]}) is {x}, not a finite number",
                        param=f"{param}[{k}]",
                        expected="finite number",
                        got=x,
                        joint=self.ctrl_names[k],
                    )
                if x < lo - LIMIT_TOL or x > hi + LIMIT_TOL:
                    raise OutOfLimits(self.ctrl_names[k], x, lo, hi)
                clipped = True
        return np.clip(arr, self.lower, self.upper) if clipped else arr.copy()

    def random_q(self, rng: np.random.Generator, n: int | None = None) -> FloatArray:
        if n is None:
            return rng.uniform(self.lower, self.upper)
        return rng.uniform(self.lower, self.upper, size=(n, self.dof))
