"""Error numbers come from the contract: every error code the backend can raise is one the contract
declares (`components.errors`), and the JSON-RPC number sent with it is the contract's."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from robwot_sim import errors
from robwot_sim.limits import contract_document
from robwot_sim.rpc.dispatch import fault_from_exception
from robwot_sim.rpc.protocol import Fault

SRC = Path(__file__).resolve().parents[1] / "src"
CONTRACT_ERRORS = contract_document()["components"]["errors"]
CODE = re.compile(r"E_[A-Z][A-Z0-9_]*")


def _subclasses(cls: type) -> list[type]:
    out = []
    for sub in cls.__subclasses__():
        out += [sub, *_subclasses(sub)]
    return out


def _code_literals() -> list[tuple[str, str]]:
    """(where, code) of every string literal in the backend's source that spells an error code."""
    found = []
    for path in sorted(SRC.glob("robwot_*/**/*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and CODE.fullmatch(node.value):
                found.append((f"{path.relative_to(SRC)}:{node.lineno}", node.value))
    return found


def test_every_error_class_code_is_in_the_contract_with_its_number() -> None:
    """Each error class's code is a contract error, and its rpc_code the contract's number."""
    classes = [errors.SimError, *_subclasses(errors.SimError)]
    assert len(classes) > 20
    for cls in classes:
        if cls.__name__.startswith("_"):
            continue
        assert cls.code in CONTRACT_ERRORS, f"{cls.__name__}: {cls.code} is not in the contract"
        assert cls.rpc_code == CONTRACT_ERRORS[cls.code]["code"], cls.__name__


def test_every_code_spelled_in_the_source_is_in_the_contract() -> None:
    """No source file raises (or builds a fault with) a code the contract does not declare."""
    literals = _code_literals()
    assert len(literals) > 20
    missing = [f"{where} {code}" for where, code in literals if code not in CONTRACT_ERRORS]
    assert missing == []


def test_a_code_missing_from_the_contract_is_refused() -> None:
    """A class, an instance or a fault naming an unknown code fails at once, naming the code."""
    with pytest.raises(LookupError, match="E_NOT_IN_CONTRACT"):
        type("Stray", (errors.SimError,), {"code": "E_NOT_IN_CONTRACT"})
    with pytest.raises(LookupError, match="E_NOT_IN_CONTRACT"):
        errors.SimError("x", code="E_NOT_IN_CONTRACT")
    with pytest.raises(LookupError, match="E_NOT_IN_CONTRACT"):
        Fault.of("E_NOT_IN_CONTRACT", "x")


def test_an_instance_code_brings_its_own_number() -> None:
    """An error raised under another code (a worker's error rebuilt) is sent with that code's number."""
    exc = errors.SimError("collision worker: mesh", code="E_MESH", file="a.stl")
    fault = fault_from_exception(exc, "workspace.generate")
    assert fault.code == CONTRACT_ERRORS["E_MESH"]["code"]
    assert fault.data == {"code": "E_MESH", "file": "a.stl"}
