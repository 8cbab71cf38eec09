"""Param validation: every failure is -32602 naming the param, the expectation and what was received."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest

from robwot_sim.rpc.params import Params
from robwot_sim.rpc.protocol import INVALID_PARAMS, Fault

ALLOWED = ("v", "n", "s", "b", "q", "i", "m")


def _fault(fn: Callable[[], Any]) -> Fault:
    with pytest.raises(Fault) as info:
        fn()
    assert info.value.code == INVALID_PARAMS
    assert info.value.data["code"] == "E_INVALID_PARAMS"
    return info.value


@pytest.mark.parametrize(
    ("raw", "call", "param", "got"),
    [
        ({"v": [1, 2]}, lambda p: p.vector("v", 3), "v", "array of length 2"),
        ({"v": [1, float("nan"), 3]}, lambda p: p.vector("v", 3), "v[1]", "NaN"),
        ({"v": [1, 2, float("inf")]}, lambda p: p.vector("v", 3), "v[2]", "Infinity"),
        ({"v": [1, "2", 3]}, lambda p: p.vector("v", 3), "v[1]", "string '2'"),
        ({"v": [1, True, 3]}, lambda p: p.vector("v", 3), "v[1]", "boolean true"),
        ({"v": "abc"}, lambda p: p.vector("v", 3), "v", "string 'abc'"),
        ({}, lambda p: p.vector("v", 3), "v", "nothing (missing)"),
        ({"n": float("-inf")}, lambda p: p.number("n"), "n", "-Infinity"),
        ({"n": 0}, lambda p: p.number("n", minimum=0.0, exclusive_minimum=True), "n", "number 0"),
        ({"n": 2}, lambda p: p.number("n", maximum=1.0), "n", "number 2"),
        ({"s": 5}, lambda p: p.string("s"), "s", "number 5"),
        ({"s": ""}, lambda p: p.string("s"), "s", "string ''"),
        ({"b": 1}, lambda p: p.boolean("b", True), "b", "number 1"),
        ({"q": [0, 0, 0, 0]}, lambda p: p.quaternion("q"), "q", "array of length 4"),
        ({"i": 1.5}, lambda p: p.integer("i"), "i", "number 1.5"),
        ({"m": {"pkg": 3}}, lambda p: p.string_map("m"), "m.pkg", "number 3"),
    ],
)
def test_invalid_values_name_the_param(raw: dict[str, Any], call: Callable[[Params], Any], param: str,
                                       got: str) -> None:
    """Wrong type, wrong length, NaN/Infinity, out-of-range and missing values name the param."""
    fault = _fault(lambda: call(Params(raw, ALLOWED)))
    assert fault.data["param"] == param
    assert fault.data["got"] == got
    assert param in fault.message


def test_unknown_param_is_refused_with_valid_names() -> None:
    """A misspelt param is refused and the valid names are listed."""
    fault = _fault(lambda: Params({"robt": "x"}, ("robot",)))
    assert fault.data["param"] == "robt"
    assert "robot" in fault.data["expected"]


def test_positional_params_are_refused() -> None:
    """Params given as an array are refused: methods take named params."""
    assert _fault(lambda: Params([1, 2], ())).data["param"] == "params"


def test_valid_values_are_converted() -> None:
    """Valid values come back typed: floats, normalised quaternions, defaults for absent/null params."""
    p = Params({"v": [1, 2, 3], "q": [0, 0, 0, 2], "i": 4.0, "n": None, "m": {"a": "/x"}}, ALLOWED)
    assert p.vector("v", 3) == [1.0, 2.0, 3.0]
    assert p.quaternion("q") == [0.0, 0.0, 0.0, 1.0]
    assert p.integer("i") == 4
    assert p.number("n", 0.5) == 0.5
    assert p.string("s", None) is None
    assert p.string_map("m") == {"a": "/x"}
    assert p.string("s", "d") == "d"
    assert p.has("v") and not p.has("n")
    assert math.isclose(Params({"n": 1e-3}, ALLOWED).number("n", minimum=0.0), 1e-3)
