"""The time left of a first load's decomposition: never 0 while a mesh is left, unknown when it cannot be."""

from __future__ import annotations

from robwot_sim.model.mesh_eta import MeshEta


def test_a_large_mesh_still_running_is_never_estimated_at_zero() -> None:
    """Two workers: the large mesh started first, small ones done beside it. The time left counts what the
    large one still needs at the measured rate; once it has run longer than that, the time left is
    unknown, not 0; with nothing left it is 0."""
    eta = MeshEta({"big": 10_000, "a": 100, "b": 100}, workers=2)
    eta.start("big", 0.0)
    eta.start("a", 0.0)
    left = eta.done("a", 1.0)  # 0.01 s per triangle: the big one needs 100 s, 99 s left
    assert left is not None and abs(left - 99.0) < 1e-9
    eta.start("b", 1.0)
    left = eta.done("b", 2.0)
    assert left is not None and abs(left - 98.0) < 1e-9
    assert eta.done("nothing-else", 150.0) is None  # the big mesh has outrun its estimate
    assert eta.done("big", 160.0) == 0.0


def test_unknown_before_any_concave_mesh_is_done_and_queued_work_is_spread_over_the_workers() -> None:
    """No rate before a mesh is done; a running mesh at its estimate makes it unknown; the running meshes'
    time left and the queued ones' share the workers."""
    eta = MeshEta({"a": 100, "b": 100, "c": 100, "d": 100, "e": 100}, workers=2)
    eta.start("a", 0.0)
    eta.start("b", 0.0)
    assert eta.done("nothing", 0.5) is None  # no mesh done: no rate
    assert eta.done("a", 1.0) is None  # 0.01 s per triangle: b has run its whole 1 s estimate
    eta.start("c", 1.0)
    left = eta.done("b", 2.0)  # 0.015 s per triangle: c 1.5 - 1 = 0.5 s left, d and e 1.5 s each queued
    assert left is not None and abs(left - 1.75) < 1e-9
    eta.start("d", 2.0)
    left = eta.done("c", 2.5)  # still 0.015: d 1.5 - 0.5 = 1 s left, e 1.5 s queued, over two workers
    assert left is not None and abs(left - 1.25) < 1e-9
