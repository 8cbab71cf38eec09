"""Sure hits against Bullet alone: ``python -m robwot_bench.surehits`` (``npm run bench:surehits``).

For each robot and scene, the same seeded configurations labelled by ``World.collision_free_batch``
without the outer bounds (``bounds=False``; ``bench:bounds`` measures those, which include this test
compiled) with the sure-hit test (``robwot_sim/sim/surehit.py``) and with every row sent to Bullet,
alternately in blocks of a worker's batch in one process (the machine's load hits both alike): CPU time per
configuration of each and their ratio, the share of rows that are sure hits, the test's own time, the
labels that differ and how many rows Bullet alone labels differently when it checks them in reverse order
(none where every row's verdict is its pair's own test: ``client.Recheck``). Each differing row is
explained or not: a sure hit whose contact a fresh Bullet distance query confirms (``unsound`` counts
those it does not), or a row Bullet checked after another row than without the test: ``after`` counts
those whose label is the one Bullet gives when it checks that same predecessor and then the row. Prints the
load average.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pybullet as pb

from robwot_bench.bounds import setup, sweep
from robwot_sim.sim import surehit
from robwot_sim.sim.world import World

BLOCK = 2_500  # rows per batch, as a generation's chunk


@contextmanager
def bullet_only() -> Iterator[None]:
    """Every row to Bullet, as without the sure-hit test."""
    saved = surehit.SureHits.hits
    surehit.SureHits.hits = lambda self, qs: np.zeros(len(qs), dtype=bool)  # type: ignore[method-assign]
    try:
        yield
    finally:
        surehit.SureHits.hits = saved  # type: ignore[method-assign]


def _predecessor(qs: np.ndarray, hits: np.ndarray, i: int) -> np.ndarray | None:
    """The configuration Bullet checked just before row ``i`` in the run with the test: the previous row
    of its block that is not a sure hit, else the last row of the previous block (checked by Bullet alone,
    the runs alternating), else none."""
    start = i - i % BLOCK
    before = np.flatnonzero(~hits[start:i])
    if len(before):
        return np.asarray(qs[start + before[-1]])
    return np.asarray(qs[start - 1]) if start else None


def _touches(world: World, rid: str, q: np.ndarray) -> bool:
    """Fresh Bullet distance queries find the robot, at ``q``, at distance <= 0 from another body or
    between two links of a pair the sure-hit test checks."""
    body, cid = world.scene.entry(rid).bound.body, world.scene.bullet.cid
    sure = world.queries.sure_hits(rid)
    world.set_joint_positions(rid, q)
    return (any(c[8] <= 0.0 for other in world.scene.table.names if other != body
                for c in pb.getClosestPoints(body, other, 0.0, physicsClientId=cid))
            or any(c[8] <= 0.0 for a, b in sure.pairs
                   for c in pb.getClosestPoints(body, body, 0.0, sure.links[a].link, sure.links[b].link,
                                                physicsClientId=cid)))


def measure(name: str, scene: str | None, samples: int, seed: int) -> dict[str, Any]:
    with World() as world:
        rid, qs = setup(world, name, scene, samples, seed)
        world.collision_free_batch(rid, qs[:100], bounds=False)  # builds the mirror world and the test first
        times = {True: 0.0, False: 0.0}
        labels: dict[bool, list[np.ndarray]] = {True: [], False: []}
        for a in range(0, samples, BLOCK):
            for sure in (True, False):
                t0 = time.process_time()
                if sure:
                    labels[sure].append(world.collision_free_batch(rid, qs[a:a + BLOCK], bounds=False))
                else:
                    with bullet_only():
                        labels[sure].append(world.collision_free_batch(rid, qs[a:a + BLOCK], bounds=False))
                times[sure] += time.process_time() - t0
        t0 = time.process_time()
        sure_hits = world.queries.sure_hits(rid)
        hits = np.concatenate([sure_hits.hits(qs[a:a + BLOCK]) for a in range(0, samples, BLOCK)])
        test = time.process_time() - t0
        new, old = np.concatenate(labels[True]), np.concatenate(labels[False])
        differ = np.flatnonzero(new != old)
        unsound = sum(not _touches(world, rid, qs[i]) for i in differ if hits[i])
        with bullet_only():
            reverse = world.collision_free_batch(rid, qs[::-1], bounds=False)[::-1]
            after = 0
            for i in differ[~hits[differ]]:
                prev = _predecessor(qs, hits, i)
                pair = qs[i:i + 1] if prev is None else np.stack([prev, qs[i]])
                after += bool(world.collision_free_batch(rid, pair, bounds=False)[-1] == new[i])
    return {"robot": name, "scene": scene or "-", "samples": samples,
            "us_bullet": 1e6 * times[False] / samples, "us_sure": 1e6 * times[True] / samples,
            "ratio": times[True] / max(times[False], 1e-12), "hits": float(hits.mean()),
            "us_test": 1e6 * test / samples, "colliding": float((~old).mean()),
            "differ": len(differ), "sure": int(hits[differ].sum()), "unsound": unsound, "after": after,
            "order": int((old != reverse).sum())}


def main() -> None:
    sweep(__doc__ or "", "bench-surehits", measure,
          [("us_bullet", "us Bullet", ".1f"), ("us_sure", "us sure", ".1f"), ("ratio", "ratio", ".2f"),
           ("colliding", "colliding", ".3f"), ("hits", "hits", ".3f"), ("us_test", "us test", ".1f"),
           ("differ", "differ", "d"), ("sure", "sure", "d"), ("unsound", "unsound", "d"),
           ("after", "after", "d"), ("order", "order", "d")], "obstacles-4.json,obstacles-239.json")


if __name__ == "__main__":
    main()
