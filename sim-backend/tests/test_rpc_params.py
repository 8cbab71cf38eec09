"""Params are checked against the contract: every failure is -32602 naming the param, the expectation
and what was received; defaults come from the contract."""

from __future__ import annotations

import math
import random
from typing import Any

import pytest

from robwot_sim import scene
from robwot_sim.rpc.contract import contract
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.protocol import INVALID_PARAMS, Fault
from robwot_sim.schemacheck import accepts

BOX = {"type": "box", "size": [1, 1, 1]}


def _fault(method: str, raw: Any) -> Fault:
    with pytest.raises(Fault) as info:
        contract().validate_params(method, raw)
    assert info.value.code == INVALID_PARAMS
    assert info.value.data["code"] == "E_INVALID_PARAMS"
    return info.value


@pytest.mark.parametrize(
    ("method", "raw", "param", "got"),
    [
        ("robot.ik", {"robot": "k", "position": [1, 2]}, "position", "array of length 2"),
        ("robot.ik", {"robot": "k", "position": [1, math.nan, 3]}, "position[1]", "NaN"),
        ("robot.ik", {"robot": "k", "position": [1, 2, math.inf]}, "position[2]", "Infinity"),
        ("robot.ik", {"robot": "k", "position": [1, "2", 3]}, "position[1]", "string '2'"),
        ("robot.ik", {"robot": "k", "position": [1, True, 3]}, "position[1]", "boolean true"),
        ("robot.ik", {"robot": "k", "position": "abc"}, "position", "string 'abc'"),
        ("robot.ik", {"robot": "k"}, "position", "nothing (missing)"),
        ("robot.ik", {"robot": "k", "position": [0, 0, 0], "collisionFree": 1}, "collisionFree", "number 1"),
        ("robot.move", {"robot": "k", "target": [0], "speed": -math.inf}, "speed", "-Infinity"),
        ("robot.move", {"robot": "k", "target": [0], "speed": 0}, "speed", "number 0"),
        ("robot.move", {"robot": "k", "target": [0], "speed": 2}, "speed", "number 2"),
        ("robot.move", {"robot": "k", "target": [0], "realtime": 0.001}, "realtime", "number 0.001"),
        ("robot.model", {"robot": 5}, "robot", "number 5"),
        ("robot.model", {"robot": ""}, "robot", "string ''"),
        ("workspace.generate", {"robot": "k", "outDir": "o", "samples": 1.5}, "samples", "number 1.5"),
        ("robot.load", {"urdf": "u", "packageRoots": {"pkg": 3}}, "packageRoots.pkg", "number 3"),
        ("obstacle.add", {"name": "b", "shape": {"type": "box", "size": [1, 0, 1]}, "position": [0, 0, 0]},
         "shape.size[1]", "number 0"),
        ("obstacle.add", {"name": "b", "shape": {"type": "cone"}, "position": [0, 0, 0]}, "shape.type",
         "string 'cone'"),
        ("obstacle.add", {"name": "b", "shape": BOX, "position": [0, 0, 0], "color": [1, 2, 0]}, "color[1]",
         "number 2"),
    ],
)
def test_invalid_values_name_the_param(method: str, raw: dict[str, Any], param: str, got: str) -> None:
    """Wrong type, wrong length, NaN/Infinity, out-of-range and missing values name the param."""
    fault = _fault(method, raw)
    assert fault.data["param"] == param
    assert fault.data["got"] == got
    assert param in fault.message


def test_unknown_param_is_refused_with_valid_names() -> None:
    """A misspelt param is refused and the valid names are listed."""
    fault = _fault("robot.model", {"robt": "x"})
    assert fault.data["param"] == "robt"
    assert "robot" in fault.data["expected"]


def test_positional_params_are_refused() -> None:
    """Params given as an array are refused: methods take named params."""
    assert _fault("robot.model", [1, 2]).data["param"] == "params"


def test_valid_values_come_back_with_the_contracts_defaults() -> None:
    """Valid values pass; absent and null params read as the contract's defaults; quaternions are
    normalised; a zero quaternion or a joint vector of the wrong length is refused."""
    c = contract()
    values = c.validate_params("robot.move", {"robot": "k", "target": [1, 2], "speed": None})
    p = Params(values, c.methods["robot.move"].defaults)
    assert p["speed"] == 1 and p["realtime"] == 1 and math.isclose(p["dt"], 1 / 240)
    assert p.joint_vector("target", 2) == [1.0, 2.0]
    with pytest.raises(Fault) as info:
        p.joint_vector("target", 7)
    assert info.value.data["param"] == "target"
    q = Params({"q": [0, 0, 0, 2]})
    assert q.quaternion("q") == [0.0, 0.0, 0.0, 1.0]
    with pytest.raises(Fault):
        Params({"q": [0, 0, 0, 0]}).quaternion("q")
    assert not p.has("speed") and p["seed"] is None


HOSTILE: list[Any] = [None, math.nan, math.inf, -math.inf, "x", "", "a=b", -1, 0, 0.5, 3.0, 1e308, 10**20,
                      True, [], [1, 2, 3], [[1]], {}, {"type": "box"}, {"type": "sphere", "radius": 0.1},
                      "é" * 300]


def _scene_resolve(schema: Any) -> Any:
    while "$ref" in schema:
        schema = scene.schema()["$defs"][schema["$ref"].split("/")[-1]]
    return schema


def _sample(schema: Any, rng: random.Random, resolve: Any = None) -> Any:
    """A value the schema describes (mostly valid: `not` and cross-field rules are ignored); ``resolve``
    follows a `$ref` (default: the contract's)."""
    resolve = resolve or contract().resolve
    schema = resolve(schema)
    members = schema.get("oneOf") or schema.get("anyOf")
    if members:
        return _sample(rng.choice(members), rng, resolve)
    if "const" in schema or "enum" in schema:
        return schema.get("const", rng.choice(schema.get("enum", [None])))
    kind = schema.get("type")
    if kind == "object" or "properties" in schema:
        required = set(schema.get("required", []))
        return {k: _sample(sub, rng, resolve) for k, sub in schema.get("properties", {}).items()
                if k in required or rng.random() < 0.5}
    if kind == "array":
        lo = schema.get("minItems", 0)
        count = rng.randint(lo, min(schema.get("maxItems", 9), lo + 3))
        return [_sample(schema.get("items", {}), rng, resolve) for _ in range(count)]
    if kind in ("number", "integer"):
        lo = schema.get("minimum", schema.get("exclusiveMinimum", -10.0))
        value = lo + rng.random() * (schema.get("maximum", lo + 10.0) - lo)
        return round(value) if kind == "integer" else value
    if kind == "string":
        return "a=b" if "pattern" in schema else "k"[: schema.get("maxLength", 1)]
    return rng.random() < 0.5 if kind == "boolean" else None


def _mutate(value: Any, rng: random.Random) -> Any:
    """``value`` with one place along a random path replaced, removed or given an unknown field."""
    if isinstance(value, dict) and value and rng.random() < 0.7:
        key = rng.choice(sorted(value))
        roll = rng.random()
        if roll < 0.15:
            return {k: v for k, v in value.items() if k != key}
        if roll < 0.25:
            return {**value, "zz": 1}
        return {**value, key: _mutate(value[key], rng)}
    if isinstance(value, list) and value and rng.random() < 0.7:
        at = rng.randrange(len(value))
        return [*value[:at], _mutate(value[at], rng), *value[at + 1:]]
    return rng.choice(HOSTILE)


def test_the_compiled_validator_accepts_nothing_the_python_one_refuses() -> None:
    """On generated params of every method (valid ones, and each mutated in one place), a value the
    compiled validator accepts is one the Python validator accepts: the fast path never lets through what
    the errors' validator refuses. Both verdicts occur (the comparison is not vacuous)."""
    c, rng = contract(), random.Random(39)
    verdicts = {True: 0, False: 0}
    for name, method in sorted(c.methods.items()):
        for _ in range(60):
            value = _sample(method.params_schema, rng)
            for candidate in (value, _mutate(value, rng), _mutate(_mutate(value, rng), rng)):
                fast = accepts(c.fast(name), candidate)
                slow = not any(True for _ in c._params[name].iter_errors(candidate))
                assert slow or not fast, (name, candidate)
                verdicts[slow] += 1
    assert min(verdicts.values()) > 1000, verdicts


def test_scene_documents_the_compiled_validator_accepts_the_python_one_accepts() -> None:
    """The same comparison on generated scene documents (and each mutated in one place and two)."""
    rng, compiled, reference = random.Random(40), scene._compiled(), scene._validator()
    verdicts = {True: 0, False: 0}
    for _ in range(400):
        doc = _sample(scene.schema(), rng, _scene_resolve)
        for candidate in (doc, _mutate(doc, rng), _mutate(_mutate(doc, rng), rng)):
            slow = not any(True for _ in reference.iter_errors(candidate))
            assert slow or not accepts(compiled, candidate), candidate
            verdicts[slow] += 1
    assert min(verdicts.values()) > 100, verdicts
