"""Sans-I/O JSON-RPC 2.0 layer: protocol (frames), contract (the OpenRPC document: params, results),
params (validated access), dispatch (method table)."""

from robwot_sim.rpc.contract import Contract, contract, invalid_param
from robwot_sim.rpc.dispatch import Call, Dispatcher, Method, fault_from_exception
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.protocol import Fault, Rejected, Request, parse_frame

__all__ = [
    "Call",
    "Contract",
    "Dispatcher",
    "Fault",
    "Method",
    "Params",
    "Rejected",
    "Request",
    "contract",
    "fault_from_exception",
    "invalid_param",
    "parse_frame",
]
