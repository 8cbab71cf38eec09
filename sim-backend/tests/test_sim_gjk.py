"""The outer bounds' GJK (``sim/gjk_kernel.py``) against Coal's exact distances (Pinocchio's collision
library, the benches' independent reference): its lower bound never above the true distance, equal to it
on polytopes, and an intersection it claims always real; the known positives (shapes that plainly
overlap) found."""

from __future__ import annotations

import coal
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from robwot_sim.sim.gjk_kernel import gjk
from robwot_sim.sim.outerbounds import Bodies

KINDS = {0: "box", 1: "sphere", 2: "cylinder"}


def _polytope(points: np.ndarray) -> coal.ConvexBase:
    m = coal.BVHModelOBBRSS()
    m.beginModel(0, len(points))
    m.addVertices(np.ascontiguousarray(points, dtype=np.float64))
    m.endModel()
    m.buildConvexHull(False, "Qt")
    return m.convex


def _coal_body(kind: int, size: np.ndarray) -> coal.CollisionGeometry:
    if kind == 0:
        return coal.Box(*(2 * size))
    if kind == 1:
        return coal.Sphere(size[0])
    return coal.Cylinder(size[0], 2 * size[1])


def _distance(a: coal.CollisionGeometry, ta: coal.Transform3s, b: coal.CollisionGeometry,
              tb: coal.Transform3s) -> float:
    return float(coal.distance(a, ta, b, tb, coal.DistanceRequest(), coal.DistanceResult()))


def _transform(p: np.ndarray, r: np.ndarray) -> coal.Transform3s:
    t = coal.Transform3s()
    t.setRotation(r)
    t.setTranslation(p)
    return t


def _case(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray, Bodies]:
    """A random part (points in its frame, the frame's pose as ``P``, ``R``) and a random body near it."""
    points = rng.normal(size=(int(rng.integers(4, 40)), 3)) * rng.uniform(0.02, 0.2, size=3)
    P = np.array([[0.0, 0.0, 0.0], rng.uniform(-0.3, 0.3, size=3)])
    R = np.stack([np.eye(3), Rotation.random(random_state=rng).as_matrix()])
    kind = int(rng.integers(0, 3))
    bodies = Bodies(np.array([kind], dtype=np.int64), rng.uniform(0.02, 0.2, size=(1, 3)),
                    rng.uniform(-0.3, 0.3, size=(1, 3)), Rotation.random(random_state=rng).as_matrix()[None],
                    np.ones(1, dtype=np.bool_))
    return points, P, R, bodies


def _coal_of(points: np.ndarray, P: np.ndarray, R: np.ndarray, b: Bodies, shrink: float = 0.0) -> float:
    body = _coal_body(int(b.kind[0]), b.size[0] - shrink)
    return _distance(_polytope(points), _transform(P[1], R[1]), body, _transform(b.centre[0], b.rotation[0]))


def _gjk(points: np.ndarray, P: np.ndarray, R: np.ndarray, b: Bodies, shrink: float = 0.0,
         enough: float = np.inf, least: float = -1.0) -> tuple[float, bool]:
    u = b.centre[0] - P[1]
    return gjk(points, 0, len(points), 1, points, 0, 0, -1, b, 0, shrink, P, R, u, enough, least)


def test_lower_bound_never_exceeds_the_distance_and_meets_it_on_boxes() -> None:
    rng = np.random.default_rng(7)
    apart = exact = 0
    for _ in range(400):
        points, P, R, b = _case(rng)
        truth = _coal_of(points, P, R, b)
        bound, inside = _gjk(points, P, R, b)
        assert bound <= max(truth, 0.0) + 1e-9, (bound, truth, KINDS[int(b.kind[0])])
        if inside:
            assert truth <= 1e-9
        if truth > 1e-3:
            apart += 1
            # a box: GJK on two polytopes ends exact; a curved body: within what its steps reach
            tight = 1e-7 if b.kind[0] == 0 else 1e-4
            exact += bound >= truth - tight
    assert apart > 100
    assert exact == apart


def test_an_intersection_claimed_is_real_and_plain_overlaps_are_found() -> None:
    rng = np.random.default_rng(11)
    claimed = overlapping = 0
    for _ in range(400):
        points, P, R, b = _case(rng)
        shrink = float(rng.uniform(0.0, 0.01))
        if (b.size[0, :1 if b.kind[0] == 1 else (2 if b.kind[0] == 2 else 3)] <= shrink).any():
            continue
        truth = _coal_of(points, P, R, b, shrink)
        inside = _gjk(points, P, R, b, shrink, enough=0.0)[1]
        claimed += inside
        if inside:
            assert truth <= 1e-9, truth  # the part meets the body shrunk by ``shrink``
        if truth < -0.01:  # overlapping by more than a centimetre: a known positive
            overlapping += 1
            assert inside, truth
    assert claimed > 50 and overlapping > 20


def test_two_parts_against_each_other() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        a = rng.normal(size=(20, 3)) * 0.1
        c = rng.normal(size=(15, 3)) * 0.1
        P = np.array([[0.0, 0.0, 0.0], rng.uniform(-0.2, 0.2, size=3), rng.uniform(-0.2, 0.2, size=3)])
        R = np.stack([np.eye(3), *(Rotation.random(2, random_state=rng).as_matrix())])
        truth = _distance(_polytope(a), _transform(P[1], R[1]), _polytope(c), _transform(P[2], R[2]))
        b = Bodies(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3)),
                   np.zeros(0, dtype=np.bool_))
        pts = np.concatenate([a, c])
        bound, inside = gjk(pts, 0, 20, 1, pts, 20, 35, 2, b, -1, 0.0, P, R, P[2] - P[1], np.inf, -1.0)
        assert bound <= max(truth, 0.0) + 1e-9
        if truth > 1e-3:
            assert bound >= truth - 1e-7
        if inside:
            assert truth <= 1e-9


@pytest.mark.parametrize("points", [np.zeros((5, 3)),  # one point, five times
                                    np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]),  # a segment
                                    np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0],
                                              [0.1, 0.1, 0.0]])])  # a flat square
def test_degenerate_parts_stay_sound(points: np.ndarray) -> None:
    """Flat, thin or single-point parts: no exception, never a bound above the distance, never an
    intersection claimed that is not there (the simplex degenerates; the certificate does not)."""
    rng = np.random.default_rng(5)
    for _ in range(100):
        _, P, R, b = _case(rng)
        bound, inside = _gjk(points, P, R, b)
        body = _coal_body(int(b.kind[0]), b.size[0])
        tb = _transform(b.centre[0], b.rotation[0])
        # the reference: the least distance of its points (the hull's is never more)
        truth = min(_distance(coal.Sphere(1e-12), _transform(P[1] + R[1] @ p, np.eye(3)), body, tb)
                    for p in points)
        assert bound <= max(truth, 0.0) + 1e-9
        if inside and not points.any():
            assert truth <= 1e-9
