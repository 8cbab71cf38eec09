"""Params are checked against the contract: every failure is -32602 naming the param, the expectation
and what was received; defaults come from the contract."""

from __future__ import annotations

import math
from typing import Any

import pytest

from robwot_sim.rpc.contract import contract
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.protocol import INVALID_PARAMS, Fault

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
