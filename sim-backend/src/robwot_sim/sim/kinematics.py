"""Forward and inverse kinematics of a bound robot (end-effector *link frame*, world frame).

IK: PyBullet damped least squares with a small damping (1e-3) and ~100 iterations (the defaults stop
several cm off; measured <0.01 mm this way),
the result clipped to the limits (continuous joints wrapped) and re-solved from there (chained), then
random restarts. Solutions are always within limits; collision-free when a checker is given and one is
found; otherwise the best colliding solution is returned flagged, or ``Unreachable`` with the best error.
A position outside the chain's reach sphere (`reach_sphere`) is ``Unreachable`` at once: no restart can
reach it, and trying all of them took most of the time of validating far targets.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import pybullet as pb

from robwot_sim.errors import Unreachable
from robwot_sim.model.chain_ik import solve_chain_ik
from robwot_sim.model.rotations import quat_angle, quat_matrix
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import FloatArray, IkResult, Pose
from robwot_sim.sim.world_thread import checkpoint

DAMPING = 1e-3
ITERATIONS = 100
RESIDUAL = 1e-7
CHAIN = 3
FIRST_CHAINED = 2  # seed and mid-range attempts: one solve each, then chained random restarts
RESTARTS = 120
CHAIN_POSITION = 1e-5  # m: stop chaining solves below this
CHAIN_ORIENTATION = 1e-4  # rad
GOOD_POSITION = 1e-4  # m: stop restarting below this
GOOD_ORIENTATION = 1e-3  # rad
ACCEPT_POSITION = 1e-3  # m: best result above this is "unreachable"
ACCEPT_ORIENTATION = math.radians(1.0)  # rad


def fk_pose(robot: BoundRobot) -> Pose:
    """End-effector link frame at the robot's current state."""
    pos, quat = robot.bullet.link_frame(robot.body, robot.ee_index)
    return Pose(pos, quat, robot.ee_link)


def wrap_clip(robot: BoundRobot, q: FloatArray) -> FloatArray:
    """Wrap continuous joints into [-pi, pi] and clip the others to their limits."""
    if robot.continuous.any():
        q = np.where(robot.continuous, np.mod(q + math.pi, 2 * math.pi) - math.pi, q)
    out: FloatArray = np.minimum(np.maximum(q, robot.lower), robot.upper)
    return out


def reach_sphere(robot: BoundRobot) -> tuple[FloatArray, float]:
    """A sphere (centre, radius in m, world frame) that holds the end-effector link frame's origin in
    every configuration, from the rigid chain (triangle inequality, no sampling): the centre is the last
    frame origin on the chain that no joint moves (it lies on the axis of every revolute joint before it,
    and no prismatic joint comes before it); the radius adds up the distances between the following
    frame origins, plus each prismatic joint's whole range. The chain is read at the current state:
    a point on every earlier axis stays on them in every configuration."""
    b, body = robot.bullet, robot.body
    infos = {ji.idx: ji for ji in b.joints(body)}
    chain = []
    link = robot.ee_index
    while link >= 0:
        chain.append(infos[link])
        link = infos[link].parent_index
    chain.reverse()
    ranges = {i: hi - lo for i, lo, hi in zip(robot.ctrl_idx, robot.lower, robot.upper, strict=True)}
    spans = np.abs(robot.followers.matrix) @ (robot.upper - robot.lower)
    for k, idx in enumerate(robot.set_idx[robot.dof:]):
        ranges[idx] = float(spans[k])
    origins, axes = [], []
    for ji in chain:
        pos, quat = b.link_frame(body, ji.idx)
        origins.append(np.array(pos))
        rot = quat_matrix(quat)
        axes.append(rot @ np.array(ji.axis) / max(float(np.linalg.norm(ji.axis)), 1e-12))
    centre, first, lines = np.array(b.link_frame(body, -1)[0]), -1, []
    for k, ji in enumerate(chain):
        if ji.type == pb.JOINT_PRISMATIC:
            break
        if ji.type == pb.JOINT_REVOLUTE:
            lines.append((origins[k], axes[k]))
        o = origins[k]
        if all(np.linalg.norm(np.cross(o - p, a)) <= 1e-9 for p, a in lines):
            centre, first = o, k
    radius = 0.0
    for k in range(first + 1, len(chain)):
        start = centre if k == first + 1 and first < 0 else origins[k - 1]
        radius += float(np.linalg.norm(origins[k] - start))
        if chain[k].type == pb.JOINT_PRISMATIC:
            radius += float(ranges.get(chain[k].idx, 0.0))
    return centre, radius + 1e-6  # PyBullet's frames are single precision


def solve_ik(
    robot: BoundRobot,
    position: Sequence[float],
    quat_xyzw: Sequence[float] | None,
    seed: FloatArray,
    rng: Callable[[], np.random.Generator],
    is_free: Callable[[FloatArray], bool] | None = None,
    sphere: tuple[FloatArray, float] | None = None,
) -> IkResult:
    """IK from ``seed``, then random restarts drawn from ``rng()`` (made only when they are needed: most
    targets near the seed are solved from it). Moves the robot: the caller restores its state.

    ``collision_free`` in the result is True unless only colliding solutions were found (``is_free``).
    Raises Unreachable when no configuration reaches within 1 mm / 1 degree; at once when ``position``
    lies farther than ``ACCEPT_POSITION`` outside ``sphere`` (`reach_sphere`; the error is then its
    lower bound, the distance to the sphere).
    """
    if sphere is not None:
        beyond = float(np.linalg.norm(np.asarray(position, dtype=np.float64) - sphere[0])) - sphere[1]
        if beyond > ACCEPT_POSITION:
            raise Unreachable(beyond, 0.0, [float(v) for v in seed], beyond_reach=True)
    if robot.linkage_on_chain:
        return _solve_linkage(robot, position, quat_xyzw, seed, rng(), is_free)
    b = robot.bullet
    damping = [DAMPING] * len(robot.movable_idx)
    target_p = tuple(float(v) for v in position)
    quat = None if quat_xyzw is None else [float(v) for v in quat_xyzw]
    if quat is not None:
        n = math.sqrt(sum(v * v for v in quat))
        quat = [v / n for v in quat]

    def error(q: FloatArray) -> tuple[float, float]:
        robot.apply(q)
        p, o = b.link_frame(robot.body, robot.ee_index)
        pe = math.dist(p, target_p)
        return pe, (quat_angle(o, quat) if quat is not None else 0.0)

    best: tuple[float, FloatArray, float, float] | None = None  # (score, q, pe, oe) of any solution
    fallback: tuple[float, FloatArray, float, float] | None = None  # best colliding one within tolerance
    mid = robot.pin((robot.lower + robot.upper) / 2)
    restarts: np.random.Generator | None = None
    for attempt in range(RESTARTS + 2):
        checkpoint()  # between attempts: the robot is only held (world_thread.py)
        # the caller's seed first, then the middle of the limits (far from them), then random restarts
        if attempt < 2:
            q = seed if attempt == 0 else mid
        else:
            restarts = restarts or rng()
            q = robot.random_q(restarts)
        robot.apply(q)
        for _ in range(CHAIN if attempt >= FIRST_CHAINED else 1):
            solver, shift = robot.ik_via or (robot, (0.0, 0.0, 0.0))
            if solver is not robot:
                solver.apply(robot.q)
            goal = [p + d for p, d in zip(position, shift, strict=True)]
            raw = np.asarray(b.ik(solver.body, solver.ee_index, goal, quat, damping, ITERATIONS, RESIDUAL))[
                solver.ik_slots
            ]
            q = robot.pin(wrap_clip(robot, raw))
            pe, oe = error(q)  # also leaves the robot at q for the next chained solve
            if pe <= CHAIN_POSITION and oe <= CHAIN_ORIENTATION:
                break
            if pe > ACCEPT_POSITION and np.array_equal(q, raw):
                break  # converged inside the limits to a wrong point: restarting beats re-solving
        score = pe + oe * 0.1
        within = pe <= ACCEPT_POSITION and oe <= ACCEPT_ORIENTATION
        if within and is_free is not None and not is_free(q):
            if fallback is None or score < fallback[0]:
                fallback = (score, q, pe, oe)
            continue
        if best is None or score < best[0]:
            best = (score, q, pe, oe)
        if pe <= GOOD_POSITION and oe <= GOOD_ORIENTATION:
            break
    if best is not None and best[2] <= ACCEPT_POSITION and best[3] <= ACCEPT_ORIENTATION:
        return IkResult(tuple(float(v) for v in best[1]), best[2], best[3], True)
    if fallback is not None:
        return IkResult(tuple(float(v) for v in fallback[1]), fallback[2], fallback[3], False)
    assert best is not None
    raise Unreachable(best[2], best[3], [float(v) for v in best[1]])


#: starts of the linkage solver's first batch (the seed, the middle of the limits, random ones); the rest
#: of ``RESTARTS`` form the second batch, run only when the first finds no acceptable solution
LINKAGE_BATCH = 16


def _good(pe: FloatArray, oe: FloatArray) -> bool:
    """Some start is already good enough to stop restarting."""
    return bool(((pe <= GOOD_POSITION) & (oe <= GOOD_ORIENTATION)).any())


def _solve_linkage(robot: BoundRobot, position: Sequence[float], quat_xyzw: Sequence[float] | None,
                   seed: FloatArray, rng: np.random.Generator,
                   is_free: Callable[[FloatArray], bool] | None) -> IkResult:
    """``solve_ik`` for a robot with a follower on its end-effector chain: PyBullet's IK would turn the
    follower on its own, so the solver works in the controllable joints' coordinates
    (``model/chain_ik.py``); a solution must keep every follower within its limits."""
    fk = robot.linkage_fk()
    target = np.asarray(position, dtype=np.float64)
    from scipy.spatial.transform import Rotation

    rotation = None if quat_xyzw is None else Rotation.from_quat([float(v) for v in quat_xyzw])
    mid = (robot.lower + robot.upper) / 2
    batches = [np.vstack([seed, mid, robot.random_q(rng, LINKAGE_BATCH - 2)]),
               robot.random_q(rng, RESTARTS - LINKAGE_BATCH)]
    best: tuple[float, FloatArray, float, float] | None = None
    fallback: tuple[float, FloatArray, float, float] | None = None
    for starts in batches:
        checkpoint()
        res = solve_chain_ik(fk, target, rotation, starts, robot.lower, robot.upper, stop=_good)
        linked = robot.followers.within(res.q)
        score = res.position_error + 0.1 * res.orientation_error
        for k in np.argsort(score):
            pe, oe, q = float(res.position_error[k]), float(res.orientation_error[k]), res.q[k]
            if not linked[k]:
                continue
            within = pe <= ACCEPT_POSITION and oe <= ACCEPT_ORIENTATION
            if within and is_free is not None and not is_free(q):
                fallback = fallback or (float(score[k]), q, pe, oe)
                continue
            if best is None or score[k] < best[0]:
                best = (float(score[k]), q, pe, oe)
            break
        if best is not None and best[2] <= ACCEPT_POSITION and best[3] <= ACCEPT_ORIENTATION:
            return IkResult(tuple(float(v) for v in best[1]), best[2], best[3], True)
    if fallback is not None:
        return IkResult(tuple(float(v) for v in fallback[1]), fallback[2], fallback[3], False)
    q = best[1] if best is not None else seed
    pe = best[2] if best is not None else math.inf
    raise Unreachable(pe, best[3] if best is not None else math.inf, [float(v) for v in q])
