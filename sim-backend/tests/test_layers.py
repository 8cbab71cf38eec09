"""Imports run one way: every module of the backend imports only its own layer and the layers below.

From the bottom: primitives (errors, limits, JSON depth, whole files, parameter checks) -> the robot model
(`model/`: URDF/SRDF/meshes, decomposition, joint tree, rotations, FK) -> scene documents -> the simulation
(`sim/`) -> workspace generation (`workspace/`) -> motions -> the JSON-RPC layer (`rpc/`) -> the server.
The benchmarks (`robwot_bench`) stand outside and above: the backend never imports them.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

#: module name prefixes, lowest layer first
LAYERS: list[tuple[str, ...]] = [
    ("robwot_sim", "robwot_sim.errors", "robwot_sim.limits", "robwot_sim.jsondepth", "robwot_sim.wholefile",
     "robwot_sim.validate"),
    ("robwot_sim.model",),
    ("robwot_sim.scene",),
    ("robwot_sim.sim",),
    ("robwot_sim.workspace", "robwot_sim.scan"),
    ("robwot_sim.motion_runner",),
    ("robwot_sim.rpc",),
    ("robwot_sim.server", "robwot_sim.__main__"),
    ("robwot_bench",),
]


def layer(module: str) -> int:
    """The layer of a module: the longest prefix that names it."""
    best, found = -1, -1
    for i, prefixes in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, found = len(p), i
    assert found >= 0, f"{module} is in no layer: add it to LAYERS"
    return found


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[tuple[int, str]]:
    """(line, module) of every import of our packages in a file, relative imports resolved."""
    out: set[tuple[int, str]] = set()
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {(node.lineno, a.name) for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            for a in node.names:
                full = f"{base}.{a.name}"
                out.add((node.lineno, full if _is_module(full) else base))
    return {(line, m) for line, m in out if m.split(".")[0] in ("robwot_sim", "robwot_bench")}


def _is_module(name: str) -> bool:
    p = SRC.joinpath(*name.split("."))
    return p.with_suffix(".py").is_file() or (p / "__init__.py").is_file()


def test_imports_never_point_up_a_layer() -> None:
    """No module imports a module of a higher layer (a function-local import included)."""
    up = []
    files = sorted(SRC.glob("robwot_sim/**/*.py")) + sorted(SRC.glob("robwot_bench/**/*.py"))
    assert len(files) > 50
    for path in files:
        here = layer(module_name(path))
        for line, target in sorted(imports(path)):
            if layer(target) > here:
                up.append(f"{path.relative_to(SRC)}:{line} {module_name(path)} -> {target}")
    assert up == []


def test_the_check_sees_an_upward_import() -> None:
    """The layer order itself: the simulation sits above the model, the RPC layer above both."""
    assert layer("robwot_sim.model.fk") < layer("robwot_sim.sim.surehit") < layer("robwot_sim.rpc.table")
    assert layer("robwot_sim.sim.surehit") > layer("robwot_sim.model.fk")
    assert layer("robwot_bench.fidelity") > layer("robwot_sim.server")


def test_the_backends_start_loads_no_scipy() -> None:
    """The server and the labelling pool's forkserver (its preload) start without scipy's spatial, sparse,
    image and interpolation code (a third of the backend's import time): they load where a request first
    needs them (scan, alpha shape, shape fitting of a robot not cached yet, IK of a coupled chain)."""
    import subprocess
    import sys

    code = ("import sys, robwot_sim.server.app, robwot_sim.workspace.preload; "
            "print(sorted(m for m in sys.modules if m.split('.')[:2] in "
            "(['scipy', 'spatial'], ['scipy', 'sparse'], ['scipy', 'ndimage'], ['scipy', 'interpolate'])))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=300)
    assert out.stdout.strip() == "[]", out.stdout


def test_the_labelling_forkserver_loads_no_json_schema_validator() -> None:
    """The labelling pool's forkserver imports what its workers run (``pool._PRELOAD``), not the Python JSON
    Schema validator: it only words why a scene is refused, and a worker's scene is the backend's, valid
    (every worker waits for what the forkserver imports)."""
    import subprocess
    import sys

    from robwot_sim.workspace.pool import _PRELOAD

    code = f"import sys, {', '.join(_PRELOAD)}; print('jsonschema' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=300)
    assert out.stdout.strip() == "False", out.stdout


def test_the_labelling_forkserver_loads_the_kernels_without_scipys_linear_algebra() -> None:
    """The forkserver's kernels load without scipy's linear algebra, which numba imports to probe for a BLAS
    no kernel calls (``workspace/preload.py``); they load, and the package imports again afterwards."""
    import subprocess
    import sys

    from robwot_sim.workspace.pool import _PRELOAD

    code = (f"import sys, {', '.join(_PRELOAD)}; from robwot_sim.sim.kernels import kernels_loaded; "
            "print(kernels_loaded(), 'scipy.linalg' in sys.modules); "
            "import scipy.linalg.cython_blas; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         timeout=900)
    assert out.stdout.split() == ["True", "False", "ok"], out.stdout + out.stderr
