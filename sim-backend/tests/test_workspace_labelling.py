"""Parallel chunks (robwot_sim.workspace.labelling: chunk.label_chunk on the worker pool) against the
in-process World."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from robwot_sim.errors import SimError
from robwot_sim.sim.kernels import KERNELS_WAIT, kernels_ready
from robwot_sim.sim.world import World
from robwot_sim.workspace import pool as workspace_pool
from robwot_sim.workspace.chunk import ChunkJob
from robwot_sim.workspace.generate import chain_fk
from robwot_sim.workspace.io import csv_layout
from robwot_sim.workspace.labelling import Labelling, chunk_size, label_samples, spec_key, warm_up
from robwot_sim.workspace.sampling import sample_configurations


def make_job(w: World, robot_id: str, seed: int) -> ChunkJob:
    """The ChunkJob generate_workspace builds for ``robot_id`` of ``w``."""
    model = w.robot_model(robot_id)
    lo, hi = model.limits()
    spec = w.scene_spec()
    _, row_format = csv_layout(None, model.controllable)
    return ChunkJob(spec_key(spec), spec, robot_id, chain_fk(w, robot_id), np.asarray(lo, dtype=np.float64),
                    np.asarray(hi, dtype=np.float64), seed, 0.01, row_format, False)


def label_configurations(job: ChunkJob, samples: int, workers: int,
                         helper: Callable[[npt.NDArray[np.float64]], npt.NDArray[np.bool_]] | None = None
                         ) -> npt.NDArray[np.bool_]:
    """The collision-free flags of the chunks of ``samples`` rows, in order."""
    return np.concatenate([c.flags for c in label_samples(job, samples, workers, helper=helper)])


def test_parallel_labels_equal_serial() -> None:
    """1 and 2 worker processes give exactly World.collision_free_batch's labels, scene included."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        w.add_obstacle({"name": "wall", "shape": {"type": "box", "size": [0.1, 1.0, 1.0]},
                        "position": [0.5, 0.0, 0.5]})
        lo, hi = w.robot_model("kuka").limits()
        qs = sample_configurations(lo, hi, 6000, seed=4)
        serial = w.collision_free_batch("kuka", qs)
        job = make_job(w, "kuka", 4)
        assert 0.1 < serial.mean() < 0.95  # the wall and self-collision both matter here
        for workers in (2, 1):
            assert np.array_equal(label_configurations(job, 6000, workers), serial)
        helped: list[int] = []

        def helper(q: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
            helped.append(len(q))
            return w.collision_free_batch("kuka", q)

        workspace_pool.shutdown_pool()  # workers that have not started yet
        assert np.array_equal(label_configurations(job, 6000, 2, helper=helper), serial)
        assert sum(helped) > 0  # the caller labelled chunks while the workers started


def test_a_chunks_labels_do_not_depend_on_the_chunk_labelled_before_it() -> None:
    """Which chunks a worker labels, and in which order, changes from run to run; Bullet's verdict on a
    grazing contact (the Panda's fingers) would follow its previous test of the pair (row 45,000 of seed 1
    followed chunk 10,000's last row to the other label) but for ``client.Recheck`` and each batch
    starting by a test at the robot's own state: a Panda chunk among 239 boxes gets the same labels in a
    fresh world as after any other chunk, and the same labels by the path without the outer bounds (a
    process's path before its kernels are loaded: the calling process's while the workers start)."""
    assert kernels_ready(timeout=KERNELS_WAIT)
    with World() as w:
        w.load_scene(str(Path(__file__).resolve().parents[2] / "examples" / "scenes" / "obstacles-239.json"))
        w.load_robot("franka_panda/panda.urdf", robot_id="panda")
        lo, hi = w.robot_model("panda").limits()
        chunk = 2500

        def rows(start: int) -> npt.NDArray[np.float64]:
            return sample_configurations(lo, hi, chunk, seed=1, start=start)

        fresh = w.collision_free_batch("panda", rows(45000))
        assert np.array_equal(w.collision_free_batch("panda", rows(45000), bounds=False), fresh)
        for before in (0, 10000, 20000):
            with World() as other:
                other.load_scene(w.scene_spec())
                other.collision_free_batch("panda", rows(before))
                assert np.array_equal(other.collision_free_batch("panda", rows(45000)), fresh), before


def test_a_worker_reads_no_mesh_the_backend_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker building its world takes the meshes the backend's process checked as checked (it parsed
    every mesh and convex part of the robot again: a fifth of its start) and labels as the backend does;
    without them it reads them all."""
    from robwot_sim.model import meshcheck

    monkeypatch.setattr(meshcheck, "SETTLED_NS", 0)  # parts decomposed by this very test count
    monkeypatch.setattr(meshcheck, "_passed", set())
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        lo, hi = w.robot_model("kuka").limits()
        qs = sample_configurations(lo, hi, 300, seed=5)
        serial = w.collision_free_batch("kuka", qs)
        job = make_job(w, "kuka", 5)
    checked = meshcheck.checked_meshes()
    reads: list[Path] = []
    original = meshcheck._read
    monkeypatch.setattr(meshcheck, "_read", lambda f: reads.append(f) or original(f))
    for vouched, read in ((checked, False), (frozenset(), True)):
        monkeypatch.setattr(meshcheck, "_passed", set())  # a new worker: nothing checked there
        monkeypatch.setattr(workspace_pool, "_worker_world", None)
        try:
            flags = workspace_pool.worker_label(job.key, job.spec, "kuka", qs, vouched)
        finally:
            if workspace_pool._worker_world is not None:
                workspace_pool._worker_world[1].close()
        assert np.array_equal(flags, serial)
        assert bool(reads) == read and (not read or {str(f) for f in reads} >= {s[0] for s in checked})
        reads.clear()


def test_the_caller_leaves_the_chunks_to_the_workers_once_one_has_answered() -> None:
    """The caller helps only while the pool has not answered: here its first chunk waits for that answer,
    so it labels exactly one chunk and the workers every other one, with the same labels."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        lo, hi = w.robot_model("kuka").limits()
        serial = w.collision_free_batch("kuka", sample_configurations(lo, hi, 6000, seed=5))
        job = make_job(w, "kuka", 5)
        workspace_pool.shutdown_pool()  # workers that have not started yet
        labelling = Labelling(job, 6000, 2)
        helped: list[int] = []

        def helper(q: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
            while labelling._up is None:
                threading.Event().wait(0.01)
            labelling._up.result(timeout=300)
            helped.append(len(q))
            return w.collision_free_batch("kuka", q)

        got = np.concatenate([c.flags for c in labelling.result(helper=helper)])
        assert np.array_equal(got, serial)
        first = labelling.chunks[0]
        assert sum(helped) == first[1] - first[0] < 6000


def test_worker_error_is_structured() -> None:
    """An error inside a worker comes back as a SimError with its code and fields."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        job = make_job(w, "kuka", 1)
    with pytest.raises(SimError) as exc:
        label_configurations(dataclasses.replace(job, robot_id="other"), 10, 2)
    assert exc.value.code == "E_UNKNOWN_ROBOT" and exc.value.rpc_code == -32001
    assert exc.value.data["available"] == ["kuka"]


def test_chunks_and_keys() -> None:
    """Chunks stay within bounds; the spec key ignores dict order and sees every change."""
    assert chunk_size(80_000, 2) == 2500 and chunk_size(100, 2) == 500 and chunk_size(10**6, 2) == 12_000
    a = {"version": 1, "obstacles": [{"name": "b", "position": [0, 0, 1]}], "robots": []}
    b = {"robots": [], "obstacles": [{"position": [0, 0, 1], "name": "b"}], "version": 1}
    assert spec_key(a) == spec_key(b)
    b["obstacles"][0]["position"] = [0, 0, 1.001]  # type: ignore[index]
    assert spec_key(a) != spec_key(b)


def test_key_sees_edited_urdf(tmp_path: Path) -> None:
    """Rewriting a robot's URDF file (same path) changes the key, so workers rebuild their world."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text("<robot name='a'/>")
    spec = {"version": 1, "obstacles": [], "robots": [{"id": "r", "urdf": str(urdf)}]}
    before = spec_key(spec)
    urdf.write_text("<robot name='ab'/>")
    assert spec_key(spec) != before


def test_warm_up_starts_workers() -> None:
    """warm_up returns at once and leaves the worker processes running for the next labelling."""
    thread = warm_up(2)
    thread.join(timeout=120)
    assert not thread.is_alive()
    pool = workspace_pool._pools[2]
    assert len(pool._processes) == 2  # type: ignore[attr-defined]
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        job = make_job(w, "kuka", 2)
        qs = sample_configurations(job.lower, job.upper, 3, seed=2)
        assert np.array_equal(label_configurations(job, 3, 2), w.collision_free_batch("kuka", qs))
        # its workers answered the warm-up: a caller leaves every chunk to them
        assert workspace_pool.answered(2)
        helped: list[int] = []

        def helper(q: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
            helped.append(len(q))
            return np.ones(len(q), dtype=bool)

        qs = sample_configurations(job.lower, job.upper, 3000, seed=2)
        got = label_configurations(job, 3000, 2, helper=helper)
        assert np.array_equal(got, w.collision_free_batch("kuka", qs)) and helped == []
    assert workspace_pool._pools[2] is pool


def test_the_caller_leaves_the_chunks_to_a_pool_a_warm_up_is_starting() -> None:
    """A generation that starts while a warm-up starts the workers (the backend's ``--warm-workers``, the
    CLI's ``workspace.warmUp``) waits for them instead of labelling chunks itself (it would build a world
    of its own on a core they need): same labels, nothing helped."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        job = make_job(w, "kuka", 7)
        qs = sample_configurations(job.lower, job.upper, 3000, seed=7)
        serial = w.collision_free_batch("kuka", qs)
        workspace_pool.shutdown_pool()  # the workers start from nothing
        thread = warm_up(2)
        assert workspace_pool.warming(2) and not workspace_pool.answered(2)
        helped: list[int] = []

        def helper(q: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
            helped.append(len(q))
            return w.collision_free_batch("kuka", q)

        assert np.array_equal(label_configurations(job, 3000, 2, helper=helper), serial)
        assert helped == []
        thread.join(timeout=120)
        assert not workspace_pool.warming(2) and workspace_pool.answered(2)


def test_caller_finishes_when_workers_cannot_start() -> None:
    """With __main__ read from stdin, spawned workers cannot start: the caller labels everything."""
    script = """
import numpy as np
from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import chain_fk
from robwot_sim.workspace.chunk import ChunkJob
from robwot_sim.workspace.labelling import label_samples, spec_key
from robwot_sim.workspace.sampling import sample_configurations
w = World()
w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
lo, hi = w.robot_model("kuka").limits()
qs = sample_configurations(lo, hi, 2000, seed=3)
spec = w.scene_spec()
job = ChunkJob(spec_key(spec), spec, "kuka", chain_fk(w, "kuka"), np.asarray(lo), np.asarray(hi), 3, 0.01,
               "%.6f,%.6f,%.6f,%d", False)
got = np.concatenate([c.flags for c in label_samples(job, 2000, 2,
                                                     helper=lambda q: w.collision_free_batch("kuka", q))])
print("SAME" if np.array_equal(got, w.collision_free_batch("kuka", qs)) else "DIFFERENT")
"""
    run = subprocess.run([sys.executable, "-"], input=script, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "SAME" in run.stdout
    assert "<stdin>" in run.stderr  # the workers really failed to start
