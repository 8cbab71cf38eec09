"""The backend's loop answers while the world's thread runs a slow search: pings, stops and another
robot's motion steps are served during a plan that takes the detour's whole budget, none of them waiting
for the search. The tests check that design property whatever the machine's speed and print the
latencies; how short they are is measured by the benchmarks (`bench:serve`)."""

from __future__ import annotations

import contextlib
import itertools
import json
import signal
import statistics
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from rpc_backend import LEGACY, BackendProcess
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

MODELS = Path(__file__).parent / "models"
#: a box in the sweep of the planar arm's first link: its joint target beyond it is free but cut off
#: from the start (no detour exists), so the plan searches for the detour's whole budget
WALL = {"name": "wall", "shape": {"type": "box", "size": [0.1, 0.4, 0.1]}, "position": [0.3, 0.0, 0.35]}
CUT_OFF = [1.5, 0.0]
#: a loop that waited for the world's thread would keep one ping (one gap between the other robot's
#: states) waiting for about the whole operation: none may wait for this share of it
SHARE = 0.5
#: pings answered before the operation's reply: the loop kept answering, not only once it was done
MIN_ANSWERED = 5
#: s: the detour's search budget, which the cut-off target uses up (`sim/detour.py` BUDGET)
SEARCH = 2.0


class StateWatch:
    """A connection of its own that timestamps every `robot.state` of one robot as it arrives."""

    def __init__(self, backend: BackendProcess, robot: str) -> None:
        self.ws = connect(backend.url, additional_headers={"Authorization": f"Bearer {backend.token}"},
                          max_size=None, **LEGACY)
        self.robot = robot
        self.times: list[float] = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            for frame in self.ws:
                doc = json.loads(frame)
                if doc.get("method") == "robot.state" and doc["params"]["robot"] == self.robot:
                    self.times.append(time.monotonic())
        except ConnectionClosed:
            pass

    def close(self) -> None:
        self.ws.close()
        self._thread.join(5)


@pytest.fixture
def two_arms() -> Iterator[BackendProcess]:
    """A backend with the planar arm "arm" behind a wall and a second one, "other", far from it."""
    proc = BackendProcess()
    client = proc.client()
    client.call("robot.load", {"urdf": str(MODELS / "planar2.urdf"), "id": "arm"})
    client.call("robot.load", {"urdf": str(MODELS / "planar2.urdf"), "id": "other",
                               "basePosition": [0.0, 3.0, 0.0]})
    client.call("obstacle.add", WALL)
    client.close()
    yield proc
    assert proc.stop() == 0


def _ms(values: list[float]) -> str:
    return (f"median {statistics.median(values) * 1e3:.1f} ms, 90th percentile {_p90(values) * 1e3:.1f} ms, "
            f"max {max(values) * 1e3:.1f} ms ({len(values)})")


def _p90(values: list[float]) -> float:
    return sorted(values)[int(0.9 * (len(values) - 1))]


def _served(values: list[float], what: str, duration: float, period: float = 0.0) -> None:
    """None of ``values`` (beyond ``period``) waited for SHARE of an operation of ``duration`` s."""
    assert max(values) < period + SHARE * duration, f"{what} during {duration:.2f} s: {_ms(values)}"


def _gaps(times: list[float], start: float, end: float) -> list[float]:
    """The gaps between arrivals in [start, end], the window's edges included: none arriving is a gap."""
    return [b - a for a, b in itertools.pairwise([start, *[t for t in times if start < t < end], end])]


def test_pings_and_another_robots_motion_are_served_during_a_slow_plan(two_arms: BackendProcess) -> None:
    """While `robot.plan` searches the detour's whole budget (2 s) for a target cut off by a wall, pings
    keep being answered and the other robot's `robot.state` notifications keep coming: none waits for
    the plan.
    Before the world had one thread, the plan held the world's lock and the other robot's steps (taken
    on the loop under that lock) stopped for the whole plan."""
    planner, prober, mover = two_arms.client(), two_arms.client(), two_arms.client()
    watch = StateWatch(two_arms, "other")
    try:
        # the other arm moves slowly for the whole test (realtime: one step per 1/240 s of wall time)
        move = mover.send("robot.move", {"robot": "other", "target": [1.2, 1.0], "speed": 0.08})
        time.sleep(0.3)
        assert len(watch.times) > 5, "the other robot's motion did not start"
        sent = time.monotonic()
        plan = planner.send("robot.plan", {"robot": "arm", "target": CUT_OFF})
        pings: list[float] = []
        while time.monotonic() - sent < 1.6:
            t = time.monotonic()
            prober.call("ping", timeout=10)
            pings.append(time.monotonic() - t)
            time.sleep(0.01)
        last_ping = time.monotonic()
        verdict = planner.wait(plan, timeout=30)
        answered = time.monotonic()
        assert not verdict["valid"] and answered - sent > 1.8, "the plan was not the slow one"
        assert answered > last_ping  # every ping above was answered while the plan ran
        gaps = _gaps(watch.times, sent, last_ping)
        print(f"\nduring a {answered - sent:.2f} s plan: ping round trip {_ms(pings)}; "
              f"the other robot's robot.state gaps {_ms(gaps)} (period 16.7 ms)")
        assert len(pings) >= MIN_ANSWERED
        _served(pings, "ping round trips during the plan", answered - sent)
        _served(gaps, "the other robot's state gaps during the plan", answered - sent, 1 / 60)
        assert prober.call("robot.stop", {"robot": "other"}) == {"stopped": True}
        assert mover.wait(move)["status"] == "stopped"
    finally:
        watch.close()
        for c in (planner, prober, mover):
            c.close()


def test_a_stop_during_a_slow_plan_is_answered_at_once(two_arms: BackendProcess) -> None:
    """`robot.stop` of a move still planning (the cut-off target: a 2 s detour search) answers without
    waiting for the search (one checkpoint, then the robot's joints read) and the move answers `stopped`
    with nothing moved; `robot.stop` used to wait on the world's lock for the whole plan. A new move may
    follow at once."""
    mover, stopper = two_arms.client(), two_arms.client()
    try:
        start = mover.call("robot.getJointPositions", {"robot": "arm"})["positions"]
        move = mover.send("robot.move", {"robot": "arm", "target": CUT_OFF})
        time.sleep(0.4)  # well inside the search
        latencies = []
        t = time.monotonic()
        assert stopper.call("robot.stop", {"robot": "arm"}, timeout=10) == {"stopped": True}
        latencies.append(time.monotonic() - t)
        assert latencies[0] < SHARE * SEARCH, f"robot.stop took {latencies[0] * 1e3:.0f} ms during the plan"
        result = mover.wait(move, timeout=10)
        assert result["status"] == "stopped" and result["duration"] == 0.0
        assert result["positions"] == pytest.approx(start)
        # the same again with an IK search: a pose move to where the cut-off target puts the tool
        pose = mover.call("robot.fk", {"robot": "arm", "positions": CUT_OFF})
        again = mover.send("robot.move", {"robot": "arm", "position": pose["position"]})
        time.sleep(0.2)
        t = time.monotonic()
        assert stopper.call("robot.stop", {"robot": "arm"}, timeout=10) == {"stopped": True}
        latencies.append(time.monotonic() - t)
        assert mover.wait(again, timeout=10)["status"] == "stopped"
        print(f"\nrobot.stop during a plan: {[round(x * 1e3, 1) for x in latencies]} ms")
        assert max(latencies) < SHARE * SEARCH
    finally:
        mover.close()
        stopper.close()


def test_world_calls_off_the_worlds_thread_are_refused() -> None:
    """A World bound to a thread refuses calls from any other (a handler calling PyBullet on the loop
    would otherwise wait for a search, or race it)."""
    from robwot_sim.sim.world import World
    from robwot_sim.sim.world_thread import WorldThread

    world, owner = World(), WorldThread()
    try:
        owner.call(world.bind)
        assert owner.call(lambda: world.robot_ids()) == []
        with pytest.raises(RuntimeError, match="off the world's thread"):
            world.robot_ids()
    finally:
        owner.shutdown()
        world.close()


def test_a_long_job_serves_short_jobs_at_its_checkpoints_with_its_robot_restored() -> None:
    """A short job queued while a long one runs is served at the long job's next checkpoint; the robot
    the long job holds reads as at its true state meanwhile, and the long job resumes from its own."""
    from robwot_sim.sim.world import World
    from robwot_sim.sim.world_thread import Cancelled, Kind, WorldThread

    world, owner = World(), WorldThread()
    try:
        owner.call(world.bind)
        owner.call(lambda: world.load_robot(MODELS / "planar2.urdf", robot_id="arm"))
        owner.call(lambda: world.add_obstacle(WALL))
        long = owner.submit(lambda: world.check_path("arm", CUT_OFF) and world.detour("arm", CUT_OFF),
                            Kind.LONG, robot="arm")
        time.sleep(0.3)
        t = time.monotonic()
        seen = owner.submit(lambda: world.get_joint_positions("arm").tolist(), Kind.SHORT,
                            robot="arm").future.result(5)
        waited = time.monotonic() - t
        assert not long.future.done(), f"the short job waited {waited:.3f} s, until the long one ended"
        assert seen == [0.0, 0.0]  # its true state, not the search's
        long.cancel.set()
        with pytest.raises(Cancelled):
            long.future.result(5)
        assert owner.call(lambda: world.get_joint_positions("arm").tolist()) == [0.0, 0.0]
    finally:
        owner.shutdown()
        world.close()


def _served_during(proc: BackendProcess, method: str, params: dict[str, object],
                   what: str) -> dict[str, object]:
    """Runs ``method`` while another robot moves and a second client pings: pings are answered before
    the method's reply, and no ping nor gap between the other robot's states waits for SHARE of the
    method. Returns the method's reply."""
    client, prober = proc.client(), proc.client()
    watch = StateWatch(proc, "other")
    try:
        client.call("robot.load", {"urdf": str(MODELS / "planar2.urdf"), "id": "other"})
        move = client.send("robot.move", {"robot": "other", "target": [1.2, 1.0], "speed": 0.08})
        time.sleep(0.3)
        sent = time.monotonic()
        request = client.send(method, params)
        pings: list[float] = []
        while request not in client.replies and time.monotonic() - sent < 120:
            t = time.monotonic()
            prober.call("ping", timeout=10)
            pings.append(time.monotonic() - t)
            with contextlib.suppress(TimeoutError):  # collect the reply when it comes
                client.replies.update({(d := client._next_reply(0.01))["id"]: d})
        done = time.monotonic()
        reply: dict[str, object] = client.wait(request)
        gaps = _gaps(watch.times, sent, done)
        print(f"\nduring a {done - sent:.2f} s {what}: ping round trip {_ms(pings)}; "
              f"the other robot's robot.state gaps {_ms(gaps)}")
        assert len(pings) >= MIN_ANSWERED, f"the {what} was not slow enough to measure anything"
        _served(pings, f"ping round trips during the {what}", done - sent)
        _served(gaps, f"the other robot's state gaps during the {what}", done - sent, 1 / 60)
        client.call("robot.stop", {"robot": "other"})
        client.wait(move)
        return reply
    finally:
        watch.close()
        client.close()
        prober.close()


def test_pings_are_served_during_a_first_load_decomposing_a_mesh(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot's first load decomposes its concave mesh (a fresh cache) off the world's thread: pings
    and the other robot's steps are served meanwhile, none waiting for the load."""
    from test_server_load import URDF
    from test_sim_decompose import to_obj, u_shape

    (tmp_path / "u.obj").write_text(to_obj(*u_shape()))
    (tmp_path / "u_arm.urdf").write_text(URDF)
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path / "cache"))
    proc = BackendProcess()
    try:
        model = _served_during(proc, "robot.load", {"urdf": str(tmp_path / "u_arm.urdf"), "id": "u"},
                               "first load")
        assert model["id"] == "u" and any((tmp_path / "cache").rglob("*.obj"))
    finally:
        assert proc.stop() == 0


def test_a_shutdown_during_a_plan_stops_it_and_exits_cleanly(two_arms: BackendProcess) -> None:
    """SIGTERM while the world's thread searches (the 2 s detour): the shutdown cancels the search at
    its next checkpoint, waits for the thread to end, then closes the world, and the process exits 0
    well before the search would have ended (it used to close the world under the running search)."""
    client = two_arms.client()
    client.send("robot.plan", {"robot": "arm", "target": CUT_OFF})
    time.sleep(0.3)
    t = time.monotonic()
    two_arms.proc.send_signal(signal.SIGTERM)
    assert two_arms.proc.wait(10) == 0
    assert time.monotonic() - t < SHARE * SEARCH
    assert "Traceback" not in two_arms.stderr()


def _bumpy_plate_stl(path: Path, side: int = 317) -> int:
    """A binary STL of a bumpy plate, 2 (side - 1)^2 triangles (a large concave mesh obstacle)."""
    import numpy as np

    xs, ys = np.meshgrid(np.linspace(-1, 1, side), np.linspace(-0.3, 0.3, side))
    vertices = np.stack([xs, ys, 0.02 * np.sin(20 * xs) * np.cos(20 * ys)], -1).reshape(-1, 3)
    idx = np.arange(side * side).reshape(side, side)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([b, d, c], 1)])
    records = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    records["v"] = vertices[faces]
    path.write_bytes(b"\0" * 80 + np.uint32(len(faces)).tobytes() + records.tobytes())
    return len(faces)


def test_pings_are_served_while_a_large_mesh_obstacle_is_added(tmp_path: Path) -> None:
    """A mesh obstacle of 200,000 triangles is parsed and its hull computed off the world's thread (PyBullet
    building the hull from the file held the interpreter, pings waited for it): pings and the other
    robot's steps are served meanwhile, none waiting for the add."""
    triangles = _bumpy_plate_stl(tmp_path / "plate.stl")
    assert triangles > 190_000
    proc = BackendProcess()
    try:
        plate = {"type": "mesh", "file": str(tmp_path / "plate.stl")}
        added = _served_during(proc, "obstacle.add", {"name": "plate", "shape": plate, "position": [5, 5, 0]},
                               f"mesh obstacle add ({triangles} triangles)")
        assert added["name"] == "plate"
    finally:
        assert proc.stop() == 0
