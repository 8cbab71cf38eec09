"""Method table and dispatch: frame in, reply frame out (sans-I/O: handlers are awaited, nothing else).

Handlers receive `Params` already checked against the method's params schema in the contract (unknown
names, types, ranges; defaults filled in) and a `Call` giving the id and a way to notify the calling
connection. With `check_results` every result is checked against the contract too (test suites).
Exceptions become JSON-RPC errors: `Fault` as is, `SimError`-like objects (`rpc_code`, `code`, `data`)
with their stable codes, anything else E_INTERNAL naming the method (and the traceback goes to
the log, not the client).
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from robwot_sim.rpc.contract import Contract, contract
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.protocol import (
    DEFAULT_MAX_MESSAGE_BYTES,
    Fault,
    Rejected,
    RequestId,
    error_message,
    parse_frame,
    result_message,
)

log = logging.getLogger("robwot_sim.rpc")

Notify = Callable[[str, dict[str, Any]], None]


@dataclass(frozen=True)
class Call:
    """One call in progress: its id, method name and a sink for notifications to the caller."""

    id: RequestId
    method: str
    notify: Notify


Handler = Callable[[Params, Call], Awaitable[Any]]


@dataclass(frozen=True)
class Method:
    name: str
    handler: Handler


def fault_from_exception(exc: BaseException, method: str) -> Fault:
    """Map an exception raised by a handler to a JSON-RPC error object."""
    if isinstance(exc, Fault):
        return exc
    rpc_code = getattr(exc, "rpc_code", None)
    code = getattr(exc, "code", None)
    if isinstance(rpc_code, int) and isinstance(code, str):
        data = getattr(exc, "data", None)
        payload = {"code": code, **(data if isinstance(data, dict) else {})}
        payload["code"] = code
        message = getattr(exc, "message", None)
        return Fault(rpc_code, message if isinstance(message, str) else str(exc), payload)
    log.error("internal error in %s", method, exc_info=exc)
    return Fault.of("E_INTERNAL", f"internal error in {method}: {type(exc).__name__}: {exc}", method=method)


class Dispatcher:
    """Registered methods plus the frame -> reply logic."""

    def __init__(self, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES, *,
                 contract: Contract | None = None, check_results: bool = False) -> None:
        self.max_message_bytes = max_message_bytes
        self.contract = contract or _own_contract()
        self.check_results = check_results
        self._methods: dict[str, Method] = {}

    def register(self, name: str, handler: Handler) -> None:
        """Bind a handler to a method the contract describes."""
        if name in self._methods:
            raise ValueError(f"method {name!r} registered twice")
        if name not in self.contract.methods:
            raise ValueError(f"method {name!r} is not in the contract")
        self._methods[name] = Method(name, handler)

    def method(self, name: str) -> Callable[[Handler], Handler]:
        """Decorator form of `register`."""

        def wrap(handler: Handler) -> Handler:
            self.register(name, handler)
            return handler

        return wrap

    def unbound(self) -> list[str]:
        """Contract methods without a handler (none once every module has registered)."""
        return sorted(set(self.contract.methods) - set(self._methods))

    @property
    def names(self) -> list[str]:
        return sorted(self._methods)

    def get(self, name: str) -> Method | None:
        return self._methods.get(name)

    async def handle(self, frame: str | bytes, notify: Notify) -> str | None:
        """Process one frame; return the reply frame, or None for a client notification."""
        parsed = parse_frame(frame, self.max_message_bytes)
        if isinstance(parsed, Rejected):
            return error_message(parsed.id, parsed.fault)
        method = self._methods.get(parsed.method)
        try:
            if method is None:
                raise Fault.of(
                    "E_METHOD_NOT_FOUND",
                    f"unknown method {parsed.method!r}; available: {', '.join(self.names)}",
                    method=parsed.method, available=self.names,
                )
            values = self.contract.validate_params(method.name, parsed.params)
            params = Params(values, self.contract.methods[method.name].defaults)
            result = await method.handler(params, Call(parsed.id, parsed.method, notify))
            result = {} if result is None else result
            if self.check_results:
                self.contract.check_result(method.name, result)
        except Exception as exc:
            if parsed.is_notification:
                return None
            return error_message(parsed.id, fault_from_exception(exc, parsed.method))
        if parsed.is_notification:
            return None
        return result_message(parsed.id, result)


def _own_contract() -> Contract:
    return contract()
