"""Dispatcher: method lookup, params checking and mapping of handler exceptions to JSON-RPC errors."""

from __future__ import annotations

import asyncio
import json
from typing import Any

from robwot_sim.errors import OutOfLimits
from robwot_sim.rpc.contract import Contract
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params

NUMBER = {"type": "number"}
CONTRACT = Contract({"methods": [
    {"name": "echo", "params": [{"name": "x", "schema": NUMBER, "required": True}],
     "result": {"name": "r", "schema": {"type": "object", "properties": {"x": NUMBER}}}},
    {"name": "limits", "params": [], "result": {"name": "r", "schema": {}}},
    {"name": "bug", "params": [], "result": {"name": "r", "schema": {}}},
    {"name": "liar", "params": [], "result": {"name": "r", "schema": {"type": "object", "required": ["x"]}}},
]})


def _dispatcher(check_results: bool = False) -> tuple[Dispatcher, list[tuple[str, dict[str, Any]]]]:
    d = Dispatcher(max_message_bytes=10_000, contract=CONTRACT, check_results=check_results)
    sent: list[tuple[str, dict[str, Any]]] = []

    @d.method("echo")
    async def echo(p: Params, call: Call) -> Any:
        call.notify("echo.seen", {"x": float(p["x"])})
        return {"x": float(p["x"])}

    @d.method("liar")
    async def liar(p: Params, call: Call) -> Any:
        return {"y": 1}

    @d.method("limits")
    async def limits(p: Params, call: Call) -> Any:
        raise OutOfLimits("j1", 3.5, -1.0, 1.0)

    @d.method("bug")
    async def bug(p: Params, call: Call) -> Any:
        raise ZeroDivisionError("division by zero")

    return d, sent


def _handle(d: Dispatcher, frame: str | bytes, sent: list[tuple[str, dict[str, Any]]]) -> Any:
    reply = asyncio.run(d.handle(frame, lambda m, p: sent.append((m, p))))
    return None if reply is None else json.loads(reply)


def test_result_and_notification_sink() -> None:
    """A call returns its result under its id and the handler can notify the caller."""
    d, sent = _dispatcher()
    assert _handle(d, '{"jsonrpc":"2.0","id":1,"method":"echo","params":{"x":2}}', sent) == {
        "jsonrpc": "2.0", "id": 1, "result": {"x": 2.0}}
    assert sent == [("echo.seen", {"x": 2.0})]


def test_unknown_method_lists_available() -> None:
    """An unknown method answers -32601 with the method name and the available methods."""
    d, sent = _dispatcher()
    reply = _handle(d, '{"jsonrpc":"2.0","id":2,"method":"nope"}', sent)
    assert reply["error"]["code"] == -32601
    assert reply["error"]["data"] == {"code": "E_METHOD_NOT_FOUND", "method": "nope",
                                      "available": ["bug", "echo", "liar", "limits"]}


def test_sim_error_maps_to_its_codes() -> None:
    """A SimError keeps its rpc_code, data.code and structured fields."""
    d, sent = _dispatcher()
    reply = _handle(d, '{"jsonrpc":"2.0","id":"a","method":"limits"}', sent)
    assert reply["id"] == "a"
    assert reply["error"]["code"] == -32002
    assert reply["error"]["data"] == {"code": "E_OUT_OF_LIMITS", "joint": "j1", "value": 3.5,
                                      "lower": -1.0, "upper": 1.0}


def test_unexpected_exception_is_internal_error() -> None:
    """A bug in a handler is -32603 E_INTERNAL naming the method, not a crash."""
    d, sent = _dispatcher()
    reply = _handle(d, '{"jsonrpc":"2.0","id":3,"method":"bug"}', sent)
    assert reply["error"]["code"] == -32603
    assert reply["error"]["data"] == {"code": "E_INTERNAL", "method": "bug"}
    assert "ZeroDivisionError" in reply["error"]["message"]


def test_invalid_params_before_handler() -> None:
    """Unknown params and bad values are refused with -32602 before any side effect."""
    d, sent = _dispatcher()
    reply = _handle(d, '{"jsonrpc":"2.0","id":4,"method":"echo","params":{"x":NaN}}', sent)
    assert reply["error"]["code"] == -32602
    assert reply["error"]["data"]["param"] == "x"
    assert sent == []
    reply = _handle(d, '{"jsonrpc":"2.0","id":5,"method":"echo","params":{"y":1}}', sent)
    assert reply["error"]["data"]["param"] == "y"
    # an integer beyond a double's range is the infinity it rounds to, named as such (not a handler's crash)
    reply = _handle(d, '{"jsonrpc":"2.0","id":6,"method":"echo","params":{"x":-1%s}}' % ("0" * 400), sent)
    data = reply["error"]["data"]
    assert (data["code"], data["param"], data["got"]) == ("E_INVALID_PARAMS", "x", "-Infinity")
    assert sent == []


def test_client_notifications_get_no_reply() -> None:
    """A request without id is executed but never answered, even on error."""
    d, sent = _dispatcher()
    assert _handle(d, '{"jsonrpc":"2.0","method":"echo","params":{"x":1}}', sent) is None
    assert sent == [("echo.seen", {"x": 1.0})]
    assert _handle(d, '{"jsonrpc":"2.0","method":"nope"}', sent) is None


def test_oversized_frame_is_answered() -> None:
    """A frame above the dispatcher's limit gets an E_TOO_LARGE error reply."""
    d, sent = _dispatcher()
    reply = _handle(d, json.dumps({"jsonrpc": "2.0", "id": 1, "method": "echo", "pad": "x" * 20_000}), sent)
    assert reply["error"]["data"]["code"] == "E_TOO_LARGE"
    assert reply["error"]["data"]["limit"] == 10_000


def test_results_checked_against_the_contract_when_asked() -> None:
    """With check_results a result the contract does not allow is -32603 naming the method (a bug)."""
    d, sent = _dispatcher()
    assert _handle(d, '{"jsonrpc":"2.0","id":1,"method":"liar"}', sent)["result"] == {"y": 1}
    d, sent = _dispatcher(check_results=True)
    reply = _handle(d, '{"jsonrpc":"2.0","id":1,"method":"liar"}', sent)
    assert reply["error"]["code"] == -32603 and "contradicts the contract" in reply["error"]["message"]


def test_only_contract_methods_can_be_registered() -> None:
    """A handler for a method the contract does not describe is a programming error."""
    d, _ = _dispatcher()
    try:
        d.register("secret", Call)  # type: ignore[arg-type]
    except ValueError as exc:
        assert "not in the contract" in str(exc)
    else:
        raise AssertionError("registered a method outside the contract")


def test_the_pybullet_version_is_read_from_its_metadata_once(monkeypatch: Any) -> None:
    """``ping`` (the heartbeat, several times a second) and every workspace summary name PyBullet's version:
    its package metadata is parsed from disk once per process, not at each."""
    from importlib import metadata

    from robwot_sim.sim import client

    client.pybullet_version.cache_clear()
    calls: list[str] = []
    real = metadata.version
    monkeypatch.setattr(metadata, "version", lambda name: calls.append(name) or real(name))
    assert client.pybullet_version() == client.pybullet_version() == real("pybullet")
    assert calls == ["pybullet"]
