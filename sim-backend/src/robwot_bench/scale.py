"""Scale benchmark: ``python -m robwot_bench.scale`` (``npm run bench:scale``; needs the ``cluster``
extra, ``ROBWOT_EXTRAS=cluster npm install``).

For kuka with the 4-obstacle example scene, prints:

1. samples/s with 1 and 2 workers, locally (the process pool) and through Ray (a local ``ray start --head``
   with 1 and 2 CPUs): ``--samples`` samples, full ``generate_workspace`` (files included); the rate is
   samples / wall time of the labelling stage (sampling + FK + collision checks + CSV on a cluster);
2. the wall time of ``--big`` samples (default 10^6), locally and through Ray with 2 workers;
3. with ``--huge`` (default the contract's largest sample count, 0 skips it), a cluster run of that
   many samples in a fresh process: its wall time, the driver's peak RSS (``ru_maxrss``: the backend
   process of a ``--cluster`` run) and the
   peak RSS of the Ray worker processes (sampled every 0.2 s).

Every run is a fresh ``generate_workspace`` into a temporary folder; clusters are started and stopped by
the benchmark (``cluster.LocalCluster``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from robwot_bench.backend import SCENES
from robwot_sim.limits import value_schema
from robwot_sim.sim.world import World
from robwot_sim.workspace.cluster import LocalCluster
from robwot_sim.workspace.generate import generate_workspace

URDF = "kuka_iiwa/model.urdf"
SCENE = SCENES / "obstacles-4.json"


def cpu_seconds(pids: list[int]) -> float:
    """User + system CPU seconds of these processes and all their descendants (alive ones)."""
    import psutil

    total, seen = 0.0, set()
    for pid in pids:
        try:
            root = psutil.Process(pid)
            procs = [root, *root.children(recursive=True)]
        except psutil.Error:
            continue
        for p in procs:
            if p.pid in seen:
                continue
            seen.add(p.pid)
            try:
                t = p.cpu_times()
                total += t.user + t.system
            except psutil.Error:
                continue
    return total


def run(samples: int, workers: int, cluster: str | None, head: int | None = None) -> dict[str, Any]:
    """One generation: wall time, the summary's timings and the CPU seconds it took (this process and
    its workers: the pool's processes, or the Ray processes under ``head``)."""
    pids = [os.getpid(), *([head] if head is not None else [])]
    with tempfile.TemporaryDirectory(prefix="robwot-bench-scale-") as out, World() as w:
        w.load_robot(URDF, robot_id="kuka")
        w.load_scene(SCENE)
        c0 = cpu_seconds(pids)
        t0 = time.perf_counter()
        s = generate_workspace(w, "kuka", samples=samples, seed=1, workers=workers, out_dir=out,
                               cluster=cluster)
        wall = time.perf_counter() - t0
        cpu = cpu_seconds(pids) - c0
    label = s["timings"]["collide"] + s["timings"]["sample"]
    return {"samples": samples, "wall": wall, "label": label, "rate": samples / label, "cpu": cpu,
            "cpu_rate": samples / max(cpu, 1e-9), "alpha": s["timings"]["alpha"], "free": s["collisionFree"]}


class PeakRss:
    """Peak RSS (bytes) of every process under ``pid`` that is a Ray worker, sampled in a thread."""

    def __init__(self, pid: int) -> None:
        import psutil

        self.root = psutil.Process(pid)
        self.peak_one = self.peak_sum = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import psutil

        while not self._stop.wait(0.2):
            total = 0
            for p in self.root.children(recursive=True):
                try:
                    if p.name().startswith("ray::") and "Dashboard" not in p.name():
                        rss = p.memory_info().rss
                        total += rss
                        self.peak_one = max(self.peak_one, rss)
                except psutil.Error:
                    continue
            self.peak_sum = max(self.peak_sum, total)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def huge(samples: int, temp: Path) -> dict[str, Any]:
    """A cluster run of ``samples`` in a fresh process (``--one``), with the workers' peak RSS."""
    with LocalCluster(2, temp / "huge") as c:
        peak = PeakRss(c.head.pid)
        try:
            out = subprocess.run([sys.executable, "-m", "robwot_bench.scale", "--one", str(samples),
                                  "--cluster", c.address], capture_output=True, text=True, check=True)
        finally:
            peak.stop()
    r: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    r["worker_peak_rss"], r["workers_peak_rss_sum"] = peak.peak_one, peak.peak_sum
    return r


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=100_000, help="samples of the rate runs")
    ap.add_argument("--big", type=int, default=1_000_000, help="samples of the wall-time runs (0: skip)")
    ap.add_argument("--huge", type=int, default=int(value_schema("Samples")["maximum"]),
                    help="samples of the peak-memory run (0: skip; default the contract's most)")
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--cluster", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        r = run(args.one, 2, args.cluster)
        r["driver_peak_rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
        print(json.dumps(r))
        return 0

    print(f"robwot bench:scale — kuka, {SCENE.name}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory(prefix="robwot-bench-ray-") as tmp:
        temp = Path(tmp)
        rows: list[tuple[str, int, dict[str, Any]]] = []
        for workers in (1, 2):
            run(2000, workers, None)  # start the pool and its workers' worlds
            rows.append(("local pool", workers, run(args.samples, workers, None)))
        for cpus in (1, 2):
            with LocalCluster(cpus, temp / f"ray{cpus}") as c:
                run(2000, 2, c.address, c.head.pid)  # connect, start the workers and their worlds
                rows.append(("Ray (local cluster)", cpus, run(args.samples, 2, c.address, c.head.pid)))
        print(f"\n{args.samples:,} samples: labelling rate (sampling, FK, collision checks; CSV on Ray); "
              "per CPU-s = samples / CPU seconds of the whole run (driver and workers)")
        print("| mode | workers | samples/s | labelling (s) | total (s) | samples per CPU-s |\n"
              "|---|---|---|---|---|---|")
        for mode, n, r in rows:
            print(f"| {mode} | {n} | {r['rate']:,.0f} | {r['label']:.2f} | {r['wall']:.2f} | "
                  f"{r['cpu_rate']:,.0f} |")
        if args.big:
            run(2000, 2, None)
            local = run(args.big, 2, None)
            with LocalCluster(2, temp / "big") as c:
                run(2000, 2, c.address, c.head.pid)
                ray = run(args.big, 2, c.address, c.head.pid)
            print(f"\n{args.big:,} samples, 2 workers: wall time\n| mode | total (s) | labelling (s) | "
                  "alpha (s) | collision-free |\n|---|---|---|---|---|")
            for mode, r in (("local pool", local), ("Ray", ray)):
                print(f"| {mode} | {r['wall']:.1f} | {r['label']:.1f} | {r['alpha']:.1f} | {r['free']:,} |")
        if args.huge:
            h = huge(args.huge, temp)
            mib = 1 << 20
            print(f"\n{args.huge:,} samples through Ray (2 workers)\n| total (s) | samples/s | driver peak "
                  "RSS (MiB) | worker peak RSS (MiB) | all workers (MiB) |\n|---|---|---|---|---|")
            print(f"| {h['wall']:.0f} | {h['samples'] / h['wall']:,.0f} | "
                  f"{h['driver_peak_rss'] / mib:,.0f} | {h['worker_peak_rss'] / mib:,.0f} | "
                  f"{h['workers_peak_rss_sum'] / mib:,.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
