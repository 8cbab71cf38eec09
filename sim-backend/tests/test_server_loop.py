"""The backend's loop answers while the world's thread runs a slow search: pings, stops and another
robot's motion steps are served within 50 ms during a plan that takes the detour's whole budget."""

from __future__ import annotations

import itertools
import json
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
BOUND = 0.050  # s


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
    return f"median {statistics.median(values) * 1e3:.1f} ms, max {max(values) * 1e3:.1f} ms ({len(values)})"


def test_pings_and_another_robots_motion_are_served_during_a_slow_plan(two_arms: BackendProcess) -> None:
    """While `robot.plan` searches the detour's whole budget (2 s) for a target cut off by a wall, pings
    answer and the other robot's `robot.state` notifications keep coming within 50 ms of their period.
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
        during = [t for t in watch.times if sent + 0.05 < t < last_ping]
        gaps = [b - a for a, b in itertools.pairwise(during)]
        print(f"\nduring a {answered - sent:.2f} s plan: ping round trip {_ms(pings)}; "
              f"the other robot's robot.state gaps {_ms(gaps)} (period 16.7 ms)")
        assert len(during) > 40, f"only {len(during)} states of the other robot during the plan"
        assert max(pings) < BOUND, f"ping round trips during the plan: {_ms(pings)}"
        assert max(gaps) < 1 / 60 + BOUND, f"the other robot's state gaps during the plan: {_ms(gaps)}"
        assert prober.call("robot.stop", {"robot": "other"}) == {"stopped": True}
        assert mover.wait(move)["status"] == "stopped"
    finally:
        watch.close()
        for c in (planner, prober, mover):
            c.close()


def test_a_stop_during_a_slow_plan_is_answered_at_once(two_arms: BackendProcess) -> None:
    """`robot.stop` of a move still planning (the cut-off target: a 2 s detour search) answers within
    50 ms and the move answers `stopped` with nothing moved; `robot.stop` used to wait on the world's
    lock for the whole plan. A new move may follow at once."""
    mover, stopper = two_arms.client(), two_arms.client()
    try:
        start = mover.call("robot.getJointPositions", {"robot": "arm"})["positions"]
        move = mover.send("robot.move", {"robot": "arm", "target": CUT_OFF})
        time.sleep(0.4)  # well inside the search
        latencies = []
        t = time.monotonic()
        assert stopper.call("robot.stop", {"robot": "arm"}, timeout=10) == {"stopped": True}
        latencies.append(time.monotonic() - t)
        assert latencies[0] < BOUND, f"robot.stop took {latencies[0] * 1e3:.0f} ms during the plan"
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
        assert max(latencies) < BOUND
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
        assert time.monotonic() - t < BOUND and not long.future.done()
        assert seen == [0.0, 0.0]  # its true state, not the search's
        long.cancel.set()
        with pytest.raises(Cancelled):
            long.future.result(5)
        assert owner.call(lambda: world.get_joint_positions("arm").tolist()) == [0.0, 0.0]
    finally:
        owner.shutdown()
        world.close()
