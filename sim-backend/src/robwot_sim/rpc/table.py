"""The method table: every Contract 1 method registered on one dispatcher."""

from __future__ import annotations

from robwot_sim.rpc import (
    methods_cell,
    methods_gripper,
    methods_motion,
    methods_obstacle,
    methods_robot,
    methods_ros,
    methods_scan,
    methods_workspace,
    methods_world,
)
from robwot_sim.rpc.dispatch import Dispatcher
from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES
from robwot_sim.rpc.services import Services


def build_dispatcher(services: Services, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES, *,
                     check_results: bool = False) -> Dispatcher:
    """A dispatcher with every method of the contract bound to `services`."""
    d = Dispatcher(max_message_bytes, check_results=check_results)
    for module in (methods_world, methods_robot, methods_motion, methods_obstacle, methods_workspace,
                   methods_ros, methods_gripper, methods_cell, methods_scan):
        module.register(d, services)
    if d.unbound():
        raise RuntimeError(f"contract methods without a handler: {d.unbound()}")
    return d
