"""A twin generated and served by the real CLI (`robwot generate`, `robwot serve --port 0`), for the
tests that drive the servient over HTTP (wotpy consumer, OpenAPI conformance)."""

from __future__ import annotations

import re
import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CLI = REPO / "packages" / "cli" / "dist" / "main.js"
NODE = shutil.which("node") or "node"


def robwot(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """Runs `robwot ARGS` and raises when it fails."""
    return subprocess.run([NODE, str(CLI), *args], check=True, capture_output=True, text=True,
                          timeout=timeout)


@contextmanager
def served_twin(out: Path, samples: int = 2000, serve_args: tuple[str, ...] = ()) -> Iterator[str]:
    """Generates a KUKA twin into `out` and serves it on a free port; yields the TD URL."""
    robwot("generate", "kuka_iiwa", "--samples", str(samples), "--out", str(out))
    proc = subprocess.Popen([NODE, str(CLI), "serve", str(out), "--port", "0", *serve_args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        url = None
        deadline = time.monotonic() + 120
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            found = re.search(r"TD\s+(http://\S+)", line)
            url = found.group(1) if found else None
        assert url is not None, "robwot serve printed no TD URL"
        yield url
    finally:
        proc.terminate()
        proc.wait(30)
