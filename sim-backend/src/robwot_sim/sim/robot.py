"""A URDF joint model (``model/joints.py``) bound to a loaded PyBullet body: index maps, limits, followers
(mimic and coupled joints, set from the joint vector)."""

from __future__ import annotations

import math

import numpy as np

from robwot_sim.errors import InvalidParams, OutOfLimits
from robwot_sim.model.couplings import Followers, chain_to
from robwot_sim.model.fk import ChainFK
from robwot_sim.model.joints import MOVABLE, UrdfModel
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.types import FloatArray

#: joint values this far beyond a limit (rad or m) are clipped to it, not refused
LIMIT_TOL = 1e-9
#: draws of ``random_q`` before it gives up keeping followers within their limits
REJECTION_ROUNDS = 64
#: seed of the draw that replaces a home configuration whose followers leave their limits
HOME_SEED = 0x40E


class BoundRobot:
    """A URDF model bound to a PyBullet body: index maps, limits, followers set with the joint vector."""

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
        #: the joints that follow others (mimic tags and couplings): set with the joint vector, never given
        self.followers = Followers.of(self.ctrl_names, model.couplings, model.joints)
        self.set_idx = self.ctrl_idx + [by_joint[n].idx for n in self.followers.names]
        js = [joints[n] for n in self.ctrl_names]
        self.lower = np.array([j.lower for j in js], dtype=np.float64)
        self.upper = np.array([j.upper for j in js], dtype=np.float64)
        self._lower: list[float] = self.lower.tolist()
        self._upper: list[float] = self.upper.tolist()
        self.continuous = np.array([j.type == "continuous" for j in js], dtype=bool)
        self.ee_link = ee_link
        self.ee_index = self.link_index[ee_link]
        chain = {j.name for j in chain_to(ee_link, model.joints)}
        #: a follower turns on the way to the end effector: IK works in the joint vector's coordinates
        self.linkage_on_chain = any(n in chain for n in self.followers.names)
        moving: set[int] = set()
        for ji in infos:  # parents come before children in PyBullet's order
            if joints[ji.name].type in MOVABLE or ji.parent_index in moving:
                moving.add(ji.idx)
        self.moving_links = sorted(moving)
        self.static_links = [-1] + [ji.idx for ji in infos if ji.idx not in moving]
        #: joints a gripper owns (index in the joint vector -> value): only the gripper moves them; every
        #: move, search and draw keeps them where they are
        self.pinned: dict[int, float] = {}
        #: IK runs on this body instead, shifted by a vector (m): see ``gripper.py`` (PyBullet keeps IK data
        #: per body address, and a body rebuilt where a freed one lay inherits the freed one's)
        self.ik_via: tuple[BoundRobot, tuple[float, float, float]] | None = None
        self.q = self.home()
        self.apply(self.q)

    def home(self) -> FloatArray:
        """Initial configuration: 0 for joints where 0 is at least 10 % of the range away from both limits,
        the middle of the range otherwise (e.g. Panda joints 4 and 6): never starts at a limit."""
        margin = 0.1 * (self.upper - self.lower)
        zero_ok = (self.lower + margin <= 0) & (self.upper - margin >= 0)
        out: FloatArray = np.where(zero_ok, 0.0, (self.lower + self.upper) / 2)
        if not self.followers.within(out)[0]:
            # a linkage whose followers leave their limits there: the first valid draw of a fixed sequence
            out = self.random_q(np.random.default_rng(HOME_SEED))
        return out

    def linkage_fk(self) -> ChainFK:
        """The vectorised FK of the end-effector link at the body's current base pose, followers coupled."""
        position, orientation = self.bullet.base_frame(self.body)
        return ChainFK.from_joints(self.urdf.joints, self.urdf.links, self.ee_link, self.ctrl_names,
                                   self.urdf.couplings, base_position=position, base_orientation=orientation)

    @property
    def dof(self) -> int:
        return len(self.ctrl_idx)

    def full_values(self, q: FloatArray) -> list[float]:
        """Values for ``set_idx``: the controllable joints, then the followers."""
        vals: list[float] = np.asarray(q, dtype=np.float64).tolist()
        if len(self.followers):
            vals += self.followers.values(q).tolist()
        return vals

    def apply(self, q: FloatArray) -> None:
        """Teleport to ``q`` (no validation; use ``validate`` first)."""
        self.bullet.reset_joints(self.body, self.set_idx, self.full_values(q))
        self.q = np.array(q, dtype=np.float64)

    def pin(self, q: FloatArray) -> FloatArray:
        """``q`` (one vector or rows) with the pinned joints at their values."""
        if not self.pinned:
            return q
        out = np.array(q, dtype=np.float64)
        for k, value in self.pinned.items():
            out[..., k] = value
        return out

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
        out = np.clip(arr, self.lower, self.upper) if clipped else arr.copy()
        past = self.followers.first_violation(out, LIMIT_TOL) if len(self.followers) else None
        if past is not None:
            raise OutOfLimits(*past)
        for k, value in self.pinned.items():
            if abs(out[k] - value) > LIMIT_TOL:
                raise InvalidParams(
                    f"{param}[{k}] ({self.ctrl_names[k]}) is {out[k]:.6g}: the gripper's joint is at "
                    f"{value:.6g} and only gripOpen/gripClose move it", param=f"{param}[{k}]",
                    expected=value, got=float(out[k]), joint=self.ctrl_names[k])
        return out

    def random_q(self, rng: np.random.Generator, n: int | None = None) -> FloatArray:
        """Joint vectors drawn uniformly within the limits; with followers, only those keeping every
        follower within its limits (rejection sampling; a linkage no draw satisfies keeps its last draws)."""
        if not len(self.followers):
            return self.pin(rng.uniform(self.lower, self.upper) if n is None
                            else rng.uniform(self.lower, self.upper, size=(n, self.dof)))
        want = 1 if n is None else n
        got = np.empty((0, self.dof))
        for _ in range(REJECTION_ROUNDS):
            draws = rng.uniform(self.lower, self.upper, size=(max(want, 16), self.dof))
            got = np.vstack([got, draws[self.followers.within(draws)]])
            if len(got) >= want:
                break
        if len(got) < want:
            got = np.vstack([got, draws[: want - len(got)]])
        return self.pin(got[0] if n is None else got[:want])
