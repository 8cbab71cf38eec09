"""Merging convex pieces to a cap (``model/hull_merge.py``)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from robwot_sim.model.hull_merge import merge_parts


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> np.ndarray:
    corners = [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
    return np.array(corners, float)


def _inside(points: np.ndarray, part: np.ndarray) -> np.ndarray:
    eq = ConvexHull(part).equations
    return np.max(points @ eq[:, :3].T + eq[:, 3], axis=1) <= 1e-9


def test_the_pair_whose_union_adds_least_volume_merges_first() -> None:
    """Two halves of one bar (their union adds nothing) merge before a bar at a right angle to them."""
    a = _box((0, 0, 0), (1, 1, 1))
    b = _box((1, 0, 0), (2, 1, 1))
    c = _box((2, 0, 0), (3, 1, 0.2))  # a flat plate beside b: its union with b adds a wedge
    merged = merge_parts([a, b, c], 2)
    assert len(merged) == 2
    volumes = sorted(ConvexHull(p).volume for p in merged)
    assert volumes == pytest.approx([0.2, 2.0])


def test_every_piece_stays_covered_and_the_cap_holds() -> None:
    """Forty pieces along a ring (no two alike) come out as at most 8 parts covering every input vertex."""
    rng = np.random.default_rng(3)
    pieces = []
    for k in range(40):
        angle = 2 * np.pi * k / 40
        centre = np.array([np.cos(angle), np.sin(angle), 0.0])
        pieces.append(centre + rng.uniform(-0.09, 0.09, (12, 3)))
    merged = merge_parts(pieces, 8)
    assert len(merged) == 8
    for piece in pieces:
        assert np.any([_inside(piece, part) for part in merged], axis=0).all()


def test_islands_far_apart_still_meet_the_cap() -> None:
    """Pieces whose boxes are nowhere near each other (no neighbour candidates) are merged all the same."""
    pieces = [_box((10.0 * k, 0, 0), (10.0 * k + 1, 1, 1)) for k in range(5)]
    merged = merge_parts(pieces, 2)
    assert len(merged) == 2
    for piece in pieces:
        assert np.any([_inside(piece, part) for part in merged], axis=0).all()


def test_few_pieces_pass_through_and_the_result_is_deterministic() -> None:
    pieces = [_box((0, 0, 0), (1, 1, 1)), _box((3, 0, 0), (4, 1, 1))]
    assert [p.tolist() for p in merge_parts(pieces, 8)] == [p.tolist() for p in pieces]
    rng = np.random.default_rng(0)
    many = [rng.uniform(0, 1, 3) + rng.uniform(-0.05, 0.05, (10, 3)) for _ in range(30)]
    first, again = merge_parts(many, 4), merge_parts(many, 4)
    assert [p.tolist() for p in first] == [p.tolist() for p in again]


def _covered(pieces: list[np.ndarray], merged: list[np.ndarray]) -> bool:
    return all(np.any([_inside(piece, part) for part in merged], axis=0).all() for piece in pieces)


def test_cheap_merges_go_on_down_to_the_limit() -> None:
    """Boxes tiling a larger box (every union adds nothing) end at ``limit`` parts, whatever ``most``."""
    pieces = [_box((x, y, 0), (x + 1, y + 1, 1)) for x in range(6) for y in range(4)]
    merged = merge_parts(pieces, 8, most=16, budget=0.02)
    assert len(merged) == 8
    assert _covered(pieces, merged)


def test_costly_merges_stop_between_the_limit_and_the_cap() -> None:
    """Twelve small cubes far apart along an L (every union adds many times their volume) keep more parts
    than ``limit``, never more than ``most``, and stay covered."""
    corners = [(2.0 * k, 0.0) for k in range(7)] + [(0.0, 2.0 * k) for k in range(1, 6)]
    pieces = [_box((x, y, 0), (x + 0.2, y + 0.2, 0.2)) for x, y in corners]
    merged = merge_parts(pieces, 4, most=8, budget=0.02)
    assert len(merged) == 8
    assert _covered(pieces, merged)
    assert 4 < len(merge_parts(pieces, 4, most=16, budget=0.02)) <= 12


def test_the_budget_decides_between_the_limit_and_the_cap() -> None:
    """Pieces along a ring (neighbours of each other): no budget keeps ``most`` parts, a generous one merges
    on to ``limit``; ``most`` defaults to ``limit``."""
    rng = np.random.default_rng(5)
    pieces = [np.array([np.cos(a), np.sin(a), 0.0]) + rng.uniform(-0.15, 0.15, (12, 3))
              for a in np.linspace(0, 2 * np.pi, 30, endpoint=False)]
    assert len(merge_parts(pieces, 4, most=12)) == 12
    assert len(merge_parts(pieces, 4, most=12, budget=1e6)) == 4
    assert len(merge_parts(pieces, 4)) == 4
