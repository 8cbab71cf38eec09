"""PROTOCOL.md is kept in step with the server: every registered method documented and vice versa, and
its plain-WebSocket example runs."""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from rpc_backend import BackendProcess

from robwot_sim import errors

ROOT = Path(__file__).resolve().parents[1]
DOC = (ROOT / "PROTOCOL.md").read_text()
EXAMPLE = ROOT / "examples" / "plain_client.py"
NOTIFICATIONS = {"robot.state", "robot.collision", "workspace.progress", "robot.loadProgress"}


@pytest.fixture(scope="module")
def registered() -> Iterator[set[str]]:
    """The method names the real server registers (from its E_METHOD_NOT_FOUND reply)."""
    backend = BackendProcess()
    client = backend.client()
    err = client.error("no.such.method")
    client.close()
    backend.stop()
    yield set(err.data["available"])


def _headings() -> set[str]:
    return set(re.findall(r"^### `([\w.]+)`", DOC, flags=re.MULTILINE))


def test_every_registered_method_is_documented(registered: set[str]) -> None:
    """Each method the server registers has a `### \\`name\\`` section in PROTOCOL.md."""
    assert "ping" in registered and "robot.move" in registered
    assert registered - _headings() == set()


def test_every_documented_method_is_registered(registered: set[str]) -> None:
    """Every documented method (notifications aside) exists on the server."""
    assert _headings() - NOTIFICATIONS - registered == set()
    assert _headings() >= NOTIFICATIONS


def test_every_error_code_is_in_the_table() -> None:
    """Each stable error code of errors.py appears in the PROTOCOL.md error table with its number."""
    classes = [c for name, c in vars(errors).items()
               if isinstance(c, type) and issubclass(c, errors.SimError) and not name.startswith("_")]
    for cls in classes:
        row = re.search(rf"^\| {cls.rpc_code} \|.*\b{cls.code}\b", DOC, flags=re.MULTILINE)
        assert row is not None, f"{cls.__name__} ({cls.rpc_code}, {cls.code}) missing from PROTOCOL.md"


def test_example_uses_no_project_code() -> None:
    """The plain client example imports only the standard library and websockets."""
    tree = ast.parse(EXAMPLE.read_text())
    modules = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    modules |= {n.module.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert "robwot_sim" not in modules
    assert modules - set(sys.stdlib_module_names) == {"websockets"}


def test_example_runs() -> None:
    """The documented example starts a server, moves the robot and prints an error reply."""
    proc = subprocess.run([sys.executable, str(EXAMPLE)], capture_output=True, text=True, timeout=120,
                          check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "move: reached" in proc.stdout
    assert "robot.state" in proc.stdout
    assert "E_OUT_OF_LIMITS" in proc.stdout


def test_generated_files_are_fresh() -> None:
    """PROTOCOL.md, core's backend-contract.ts and the scene schema's shared $defs are what
    `npm run gen:contract` makes of the contract."""
    script = ROOT.parent / "scripts" / "gen-contract.mjs"
    proc = subprocess.run(["node", str(script), "--check"], capture_output=True, text=True, timeout=120,
                          check=False)
    assert proc.returncode == 0, proc.stderr


def test_the_contract_is_a_valid_openrpc_document_of_what_the_server_serves(registered: set[str]) -> None:
    """Every method the server registers is in the contract and vice versa; every error a method may
    answer and every `$ref` resolves; every param schema is a valid JSON Schema (draft 7)."""
    from jsonschema import Draft7Validator

    from robwot_sim.rpc.contract import contract

    doc = contract().document
    assert doc["openrpc"].startswith("1.")
    assert {m["name"] for m in doc["methods"]} == registered
    assert {n["name"] for n in doc["x-notifications"]} == NOTIFICATIONS
    refs = re.findall(r'"\$ref": "#/components/(\w+)/(\w+)"', json.dumps(doc))
    for section, name in refs:
        assert name in doc["components"][section], f"dangling $ref {section}/{name}"
    for m in doc["methods"]:
        for p in m["params"]:
            Draft7Validator.check_schema(p["schema"])
