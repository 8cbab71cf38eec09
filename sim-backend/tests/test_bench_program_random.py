"""``robwot_bench.program_random`` in its smallest configuration: one short program per arm, planned
against a real backend, its table printed with numbers (the bench must not rot)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

pytest.importorskip("pinocchio")
pytest.importorskip("toppra")

from robwot_bench import program_bound, program_random

NUMBER = r"\d+(?:\.\d+)?"


def test_bound_matches_closed_form_on_a_line() -> None:
    d = np.array([1.0, -0.5, 0.3])
    v = np.array([1.0, 0.8, 1.2])
    q = np.linspace(np.zeros(3), d, 50)
    topp = program_bound.topp_time(q, np.tile(v, (50, 1)), np.tile(v / 0.25, (50, 1)), 3)
    assert topp == pytest.approx(program_bound.trapezoid(d, v, v / 0.25), rel=1e-3)


def test_tcp_acceleration_bound_on_an_arc_lies_between_the_relaxation_and_a_feasible_motion() -> None:
    """A quarter circle of 10 cm radius (the one joint its angle, unlimited), the TCP at 1.2 m/s^2: the bound
    is slower than with the tangential limit alone, never faster than the centripetal limit allows (the
    directions let |a| reach A / cos 10.8 degrees), and never slower than a motion keeping |a| <= A."""
    r, acc, n = 0.1, 1.2, 200
    theta = np.linspace(0.0, math.pi / 2, n)
    pts = np.stack([r * np.cos(theta), r * np.sin(theta), np.zeros(n)], axis=1)
    big = np.full((n, 1), 1e3)
    coords, vl, al = program_bound.with_tcp(theta[:, None], big, big, pts, np.full(n, 1e3), np.full(n, acc))
    bound = program_bound.topp_time(coords, vl, al, 1)
    length = r * math.pi / 2
    tangential = program_bound.topp_time(coords[:, :2], vl[:, :2], al[:, :2], 1)
    assert tangential == pytest.approx(2 * math.sqrt(length / acc), rel=1e-2)
    cover = math.cos(math.radians(10.9))
    assert bound > 1.03 * tangential
    assert bound >= length / math.sqrt(acc * r / cover)
    vmax, at = math.sqrt(acc * r / math.sqrt(2)), acc / math.sqrt(2)  # |a|^2 <= at^2 + (v^2/r)^2 = A^2
    assert bound <= length / vmax + vmax / at


def test_tcp_directions_cover_the_sphere() -> None:
    dirs = program_bound.tcp_directions()
    assert dirs.shape == (program_bound.TCP_DIRECTIONS, 3) and np.allclose(np.linalg.norm(dirs, axis=1), 1)
    probe = np.random.default_rng(0).normal(size=(20_000, 3))
    probe /= np.linalg.norm(probe, axis=1)[:, None]
    assert np.degrees(np.arccos(np.abs(probe @ dirs.T).max(axis=1).min())) < 10.9


def test_smallest_configuration_prints_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["--programs", "1", "--runs", "0", "--steps", "3", "3", "--quiet"]
    results = program_random.run(program_random.parser().parse_args(argv), argv)
    out = capsys.readouterr().out
    assert "python -m robwot_bench.program_random --programs 1" in out
    for r in results:
        assert r.programs == 1
        row = next(line for line in out.splitlines() if line.startswith(f"| {r.name} | "))
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert re.fullmatch(r"\d+/1", cells[1]), row
        if r.valid:  # cycle time / bound, max and median: finite ratios near 1 or above
            assert re.fullmatch(NUMBER, cells[4]) and re.fullmatch(NUMBER, cells[5]), row
            assert 0.9 < float(cells[4]) < 10, row
    jerk = out[out.index("jerk limits ("):]
    for r in results:
        row = next(line for line in jerk.splitlines() if line.startswith(f"| {r.name} | "))
        cells = [c.strip() for c in row.strip("|").split("|")]
        if r.valid and cells[3] == "0":  # planned again with jerk limits: the largest jerk within its limit
            assert re.fullmatch(NUMBER, cells[4]) and float(cells[4]) <= 1.05, row
