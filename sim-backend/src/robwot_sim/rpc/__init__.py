"""Sans-I/O JSON-RPC 2.0 layer: protocol (frames), params (validation), dispatch (method table)."""

from robwot_sim.rpc.dispatch import Call, Dispatcher, Method, fault_from_exception
from robwot_sim.rpc.params import Params, invalid_param
from robwot_sim.rpc.protocol import Fault, Rejected, Request, parse_frame

__all__ = [
    "Call",
    "Dispatcher",
    "Fault",
    "Method",
    "Params",
    "Rejected",
    "Request",
    "fault_from_exception",
    "invalid_param",
    "parse_frame",
]
