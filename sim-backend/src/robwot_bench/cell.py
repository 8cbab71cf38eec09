"""Cell benchmark: ``python -m robwot_bench.cell`` (``npm run bench:cell`` runs it after the mashup).

The cost of one simulated second of a cell in the backend, in process (``World.cell.advance``, what the
servient's clock calls): two 2 m belts at 0.05 m/s carrying 5 cubes each (10 objects moving, every one
re-posed in the planning scene each 5 mm sub-step), three sensors watching them (two presence beams, one
colour). Each call advances 1 s of the cell (the contract's largest step: 10 sub-steps); the belts are
long enough that no cube reaches an end during the runs. Prints the median and p95 wall time of a call
(ms per simulated second) and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from typing import Any

from robwot_sim.sim.world import World

BELT_LENGTH = 2.0
CUBES_PER_BELT = 5


def _scene() -> dict[str, Any]:
    belts = [{"name": f"belt{k}", "size": [BELT_LENGTH, 0.1, 0.05], "position": [0.0, y, 0.025],
              "speed": 0.05, "state": "forward", "endStop": True} for k, y in enumerate((-0.5, 0.5))]
    cubes = [{"name": f"cube{k}_{i}", "shape": {"type": "box", "size": [0.04, 0.04, 0.04]},
              "position": [-0.9 + 0.12 * i, y, 0.1], "color": [0.2 * i, 0.5, 0.9]}
             for k, y in enumerate((-0.5, 0.5)) for i in range(CUBES_PER_BELT)]
    beam = {"kind": "presence", "size": [0.004, 0.12, 0.02]}
    sensors = [{"name": "beam0", **beam, "position": [-0.2, -0.5, 0.07]},
               {"name": "beam1", **beam, "position": [-0.2, 0.5, 0.07]},
               {"name": "eye", "kind": "color", "size": [0.06, 0.06, 0.06], "position": [-0.3, 0.5, 0.07]}]
    return {"version": 1, "conveyors": belts, "objects": cubes, "sensors": sensors}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=12, help="simulated seconds timed (default 12)")
    args = parser.parse_args()
    with World() as w:
        w.load_scene(_scene())
        w.cell.advance(1.0)  # warm: the first call builds the belts' caches
        times, moved = [], 0
        for _ in range(args.runs):
            t = time.perf_counter()
            out = w.cell.advance(1.0)
            times.append((time.perf_counter() - t) * 1000)
            moved = max(moved, len(out["moved"]))
    times.sort()
    p95 = times[min(len(times) - 1, round(0.95 * (len(times) - 1)))]
    print("| cell | objects moving | sensors | median ms per simulated s | p95 ms |")
    print("|---|---|---|---|---|")
    print(f"| 2 belts of {BELT_LENGTH:g} m | {moved} | 3 | {statistics.median(times):.1f} | {p95:.1f} |")
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
