"""Sans-I/O JSON-RPC framing: parse_frame and the message builders."""

from __future__ import annotations

import json

import pytest

from robwot_sim.rpc.protocol import (
    INVALID_REQUEST,
    PARSE_ERROR,
    Fault,
    Rejected,
    Request,
    error_message,
    notification_message,
    parse_frame,
    result_message,
)


def test_parses_request_with_id_and_params() -> None:
    """A well-formed request becomes a Request carrying method, params and id."""
    parsed = parse_frame('{"jsonrpc":"2.0","id":7,"method":"ping","params":{"a":1}}')
    assert parsed == Request("ping", {"a": 1}, 7, False)


def test_request_without_id_is_a_notification() -> None:
    """A request without `id` is a client notification."""
    parsed = parse_frame('{"jsonrpc":"2.0","method":"ping"}')
    assert isinstance(parsed, Request)
    assert parsed.is_notification and parsed.id is None


@pytest.mark.parametrize(
    ("frame", "code", "data_code", "reply_id"),
    [
        ("not json", PARSE_ERROR, "E_PARSE", None),
        ("{", PARSE_ERROR, "E_PARSE", None),
        ("[" * 100_000, INVALID_REQUEST, "E_TOO_DEEP", None),
        ('[{"jsonrpc":"2.0","id":1,"method":"ping"}]', INVALID_REQUEST, "E_INVALID_REQUEST", None),
        ("42", INVALID_REQUEST, "E_INVALID_REQUEST", None),
        ('{"jsonrpc":"1.0","id":3,"method":"ping"}', INVALID_REQUEST, "E_INVALID_REQUEST", 3),
        ('{"jsonrpc":"2.0","id":3}', INVALID_REQUEST, "E_INVALID_REQUEST", 3),
        ('{"jsonrpc":"2.0","id":3,"method":5}', INVALID_REQUEST, "E_INVALID_REQUEST", 3),
        ('{"jsonrpc":"2.0","id":"x","method":"ping","params":3}', INVALID_REQUEST, "E_INVALID_REQUEST", "x"),
        ('{"jsonrpc":"2.0","id":{"a":1},"method":"ping"}', INVALID_REQUEST, "E_INVALID_REQUEST", None),
        ('{"jsonrpc":"2.0","id":true,"method":"ping"}', INVALID_REQUEST, "E_INVALID_REQUEST", None),
        ('{"jsonrpc":"2.0","id":1,"method":"ping","extra":1}', INVALID_REQUEST, "E_INVALID_REQUEST", 1),
        (b'{"jsonrpc":"2.0","id":1,"method":"ping"}', INVALID_REQUEST, "E_INVALID_REQUEST", None),
    ],
)
def test_rejects_bad_frames(frame: str | bytes, code: int, data_code: str, reply_id: object) -> None:
    """Bad frames become Rejected with the JSON-RPC code, a stable data.code and the id when known."""
    parsed = parse_frame(frame)
    assert isinstance(parsed, Rejected)
    assert parsed.fault.code == code
    assert parsed.fault.data["code"] == data_code
    assert parsed.id == reply_id


def test_too_large_frame_names_the_limit() -> None:
    """A frame above the limit is refused with E_TOO_LARGE and the limit in bytes."""
    doc = {"jsonrpc": "2.0", "id": 1, "method": "ping", "params": {"x": "é" * 600}}
    frame = json.dumps(doc, ensure_ascii=False)
    parsed = parse_frame(frame, max_bytes=1000)
    assert isinstance(parsed, Rejected)
    assert parsed.fault.code == INVALID_REQUEST
    assert parsed.fault.data["code"] == "E_TOO_LARGE"
    assert parsed.fault.data["limit"] == 1000
    assert parsed.fault.data["got"] > 1000
    assert isinstance(parse_frame(frame, max_bytes=2000), Request)


def test_nan_literal_reaches_param_validation() -> None:
    """NaN/Infinity literals parse, so that param validation can name the offending param."""
    parsed = parse_frame('{"jsonrpc":"2.0","id":1,"method":"m","params":{"x":NaN,"y":-Infinity}}')
    assert isinstance(parsed, Request)
    assert isinstance(parsed.params, dict)
    assert parsed.params["x"] != parsed.params["x"]


def test_builders_emit_strict_json() -> None:
    """Replies are strict JSON: non-finite floats in results become null."""
    assert json.loads(result_message(1, {"v": float("nan"), "w": [1.5]})) == {
        "jsonrpc": "2.0", "id": 1, "result": {"v": None, "w": [1.5]}}
    err = json.loads(error_message("a", Fault(-32001, "nope", {"code": "E_UNKNOWN_ROBOT"})))
    assert err["error"] == {"code": -32001, "message": "nope", "data": {"code": "E_UNKNOWN_ROBOT"}}
    note = json.loads(notification_message("robot.state", {"robot": "r"}))
    assert note == {"jsonrpc": "2.0", "method": "robot.state", "params": {"robot": "r"}}
    assert "id" not in note
