"""Sans-I/O JSON-RPC 2.0: parse one text frame, build responses and notifications.

Nothing here imports asyncio, websockets or pybullet: the server feeds frames in and sends the
strings this module returns. One JSON object per frame; batches are refused (E_INVALID_REQUEST).
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from typing import Any

from robwot_sim.errors import rpc_code_of
from robwot_sim.jsondepth import MAX_DEPTH, TooDeep, loads_bounded

__all__ = ["MAX_DEPTH"]

#: the JSON-RPC numbers of the protocol's own errors, as the contract gives them
PARSE_ERROR = rpc_code_of("E_PARSE")
INVALID_REQUEST = rpc_code_of("E_INVALID_REQUEST")
METHOD_NOT_FOUND = rpc_code_of("E_METHOD_NOT_FOUND")
INVALID_PARAMS = rpc_code_of("E_INVALID_PARAMS")
INTERNAL_ERROR = rpc_code_of("E_INTERNAL")

DEFAULT_MAX_MESSAGE_BYTES = 4 * 1024 * 1024
_DOUBLE_MAX = int(sys.float_info.max)


def _json_int(text: str) -> int | float:
    """A JSON integer; one beyond a double's range reads as the infinity it rounds to, as `1e400` does
    (and as JavaScript reads both), so that the params check names it instead of a handler failing."""
    value = int(text)
    return value if -_DOUBLE_MAX <= value <= _DOUBLE_MAX else float(text)

RequestId = str | int | None


@dataclass
class Fault(Exception):
    """A JSON-RPC error object: numeric `code`, `message`, and `data` carrying a stable `data.code`."""

    code: int
    message: str
    data: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, code: str, message: str, **data: Any) -> Fault:
        """The fault of the contract's error ``code``: its number from the contract, ``data.code`` the
        code itself."""
        return cls(rpc_code_of(code), message, {"code": code, **data})

    def __str__(self) -> str:
        return self.message

    def to_json(self) -> dict[str, Any]:
        return {"code": self.code, "message": self.message, "data": self.data}


@dataclass(frozen=True)
class Request:
    """A parsed call. `id` is absent (`is_notification`) for client notifications (no reply sent)."""

    method: str
    params: dict[str, Any] | list[Any] | None
    id: RequestId
    is_notification: bool


@dataclass(frozen=True)
class Rejected:
    """A frame that could not become a Request: reply with `fault` under `id` (None when unknown)."""

    fault: Fault
    id: RequestId


def _describe(value: Any) -> str:
    if isinstance(value, bool):
        return "boolean"
    if value is None:
        return "null"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "string"
    if isinstance(value, list):
        return "array"
    return "object"


def invalid_request(message: str, req_id: RequestId = None, **data: Any) -> Rejected:
    return Rejected(Fault.of("E_INVALID_REQUEST", message, **data), req_id)


def _too_deep() -> Rejected:
    fault = Fault.of("E_TOO_DEEP", f"message nests arrays/objects deeper than {MAX_DEPTH} levels",
                     limit=MAX_DEPTH)
    return Rejected(fault, None)


def parse_frame(frame: str | bytes, max_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> Request | Rejected:
    """Turn one WebSocket frame into a `Request`, or a `Rejected` to answer with an error."""
    if isinstance(frame, bytes | bytearray | memoryview):
        return invalid_request("binary frames are not accepted: send JSON-RPC as a text frame")
    size = len(frame.encode("utf-8", "surrogatepass")) if len(frame) * 4 > max_bytes else len(frame)
    if size > max_bytes:
        fault = Fault.of("E_TOO_LARGE", f"message of {size} bytes exceeds the limit of {max_bytes} bytes",
                         limit=max_bytes, got=size)
        return Rejected(fault, None)
    try:
        # NaN/Infinity literals are accepted here so that param validation can name the param.
        doc = loads_bounded(frame, parse_int=_json_int)
    except TooDeep:
        return _too_deep()
    except ValueError as exc:
        return Rejected(Fault.of("E_PARSE", f"not valid JSON: {exc}"), None)
    if isinstance(doc, list):
        return invalid_request("batch requests are not supported: send one JSON object per frame")
    if not isinstance(doc, dict):
        return invalid_request(f"a request must be a JSON object, got {_describe(doc)}")
    raw_id = doc.get("id")
    req_id: RequestId = raw_id if isinstance(raw_id, str | int) and not isinstance(raw_id, bool) else None
    if "id" in doc and raw_id is not None and req_id is None:
        return invalid_request(f"'id' must be a string, an integer or null, got {_describe(raw_id)}")
    if doc.get("jsonrpc") != "2.0":
        return invalid_request("'jsonrpc' must be \"2.0\"", req_id)
    method = doc.get("method")
    if not isinstance(method, str) or not method:
        return invalid_request("'method' must be a non-empty string", req_id)
    params = doc.get("params")
    if params is not None and not isinstance(params, dict | list):
        return invalid_request(f"'params' must be an object or an array, got {_describe(params)}", req_id)
    extra = sorted(set(doc) - {"jsonrpc", "method", "params", "id"})
    if extra:
        return invalid_request(f"unknown request member(s): {', '.join(extra)}", req_id)
    return Request(method, params, req_id, "id" not in doc)


def _finite(value: Any) -> Any:
    """Replace non-finite floats (which JSON cannot carry) with None, recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def _dumps(doc: dict[str, Any]) -> str:
    try:
        return json.dumps(doc, allow_nan=False, separators=(",", ":"))
    except ValueError:
        return json.dumps(_finite(doc), allow_nan=False, separators=(",", ":"))


def result_message(req_id: RequestId, result: Any) -> str:
    return _dumps({"jsonrpc": "2.0", "id": req_id, "result": result})


def error_message(req_id: RequestId, fault: Fault) -> str:
    return _dumps({"jsonrpc": "2.0", "id": req_id, "error": fault.to_json()})


def notification_message(method: str, params: dict[str, Any]) -> str:
    return _dumps({"jsonrpc": "2.0", "method": method, "params": params})
