"""The path check and its checkpoints, in-process with a fake robot and checker: states found free for sure
are passed without a checkpoint (nothing else moves between checkpoints), and when a checkpoint lets
another body move, the states ahead are classified again."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from robwot_sim.sim import pathcheck
from robwot_sim.sim.sweep import Guard

CLEARANCE = 0.002


class Line:
    """A robot with one joint moving its one point along a line (1 m per unit) towards a wall at ``wall``;
    the outer bounds find a state free for sure when it is 5 cm short of the clearance from the wall and
    outside a narrow band (0.28, 0.32) where they cannot decide (as near self-contact)."""

    def __init__(self) -> None:
        self.q = np.zeros(1)
        self.wall = 10.0
        self.asked: list[float] = []
        self.tested: list[int] = []  # per ``sure_free`` call: the states it tested

    def apply(self, q: Any) -> None:
        self.q = np.array(q, dtype=float)

    def sure_free(self, states: np.ndarray, clearance: float, unsure: int) -> tuple[np.ndarray, int]:
        x = states[:, 0]
        free = np.asarray((x < self.wall - clearance - 0.05) & ~((x > 0.28) & (x < 0.32)))
        tested = len(states)
        met = np.flatnonzero(~free)
        if 0 < unsure <= len(met):  # tested in order until ``unsure`` states not known free are met
            tested = int(met[unsure - 1]) + 1
        self.tested.append(tested)
        return free, tested

    def gap(self, cap: float) -> float:
        return min(cap, self.wall - float(self.q[0]))

    def is_free(self, clearance: float, others_apart: bool = False) -> bool:
        self.asked.append(float(self.q[0]))
        return others_apart or self.wall - float(self.q[0]) > clearance


def _check(line: Line, monkeypatch: pytest.MonkeyPatch, move_at: int | None) -> tuple[Any, int]:
    """The first contact from 0 to 1, the wall moved to 0.6 at checkpoint ``move_at`` (counted from 1)."""
    calls = {"n": 0}

    def checkpoint() -> bool:
        calls["n"] += 1
        if calls["n"] == move_at:
            line.wall = 0.6
            return True
        return False

    monkeypatch.setattr(pathcheck, "checkpoint", checkpoint)
    guard = Guard(reach=np.ones(1), clearance=CLEARANCE)
    hit = pathcheck.first_contact_along(line, line, np.array([[0.0], [1.0]]), guard,  # type: ignore[arg-type]
                                        CLEARANCE)
    return hit, calls["n"]


def test_states_free_for_sure_pass_without_bullet_or_a_checkpoint(monkeypatch: pytest.MonkeyPatch) -> None:
    """250 states (4 mm each), 9 of them in the undecided band: Bullet is asked about those 9 only, with a
    checkpoint before each and one before the segment."""
    line = Line()
    hit, calls = _check(line, monkeypatch, None)
    assert hit is None
    assert len(line.asked) == 9 and all(0.28 < x < 0.32 for x in line.asked)
    assert calls == 1 + 9
    assert line.q[0] == 1.0  # the robot stands at the path's end


@pytest.mark.parametrize("move_at", [1, 2, 6])
def test_a_body_moved_at_a_checkpoint_is_seen_by_the_states_ahead(monkeypatch: pytest.MonkeyPatch,
                                                                 move_at: int) -> None:
    """The wall moves from far away to 0.6 at the segment's checkpoint or at one in the undecided band:
    the states ahead, found free for sure before, are classified again and the first contact is the first
    state within the clearance of the wall (0.6 itself; 0.596 keeps 4 mm)."""
    line = Line()
    hit, _ = _check(line, monkeypatch, move_at)
    assert hit is not None
    j, frac, q = hit
    assert (j, frac) == (0, pytest.approx(0.6)) and q[0] == pytest.approx(0.6)


def test_a_walk_into_a_wall_leaves_the_states_past_its_contact_untested(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The wall at 0.2: the first contact is the state at 0.2 (no clearance left), as Bullet at every state
    would find it; the outer bounds are asked in batches that stop at the states they cannot decide
    (from 0.152 on), so of the segment's 250 states they test 79 (39 + 8 + 32), not all."""
    line = Line()
    line.wall = 0.2
    hit, _ = _check(line, monkeypatch, None)
    assert hit is not None
    assert hit[2][0] == pytest.approx(0.2)
    assert line.asked[0] == pytest.approx(0.152)  # the first state they leave undecided
    assert line.tested == [39, 8, 32]
