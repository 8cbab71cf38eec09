"""JSON Schema checks in two steps, for the contract's params (``rpc/contract.py``) and scene documents
(``scene.py``): a compiled validator (``jsonschema_rs``, Rust) says whether a value is valid, on every
check; the pure-Python ``jsonschema`` (hundreds of times slower, whose errors carry the paths and context
the messages are made from) runs only on a value the first refused, to say why. What the compiled one
accepts the Python one accepts (``tests/test_rpc_params.py`` compares them on generated values of every
method); a value the compiled one refuses but the Python one finds no error in is accepted: the Python one
is the reference. The compiled one refuses NaN and infinities (serde's JSON numbers are finite), as the
backend's checks do."""

from __future__ import annotations

from typing import Any

import jsonschema_rs


def accepts(validator: Any, value: Any) -> bool:
    """The compiled validator's verdict; False for a value it cannot read (a type JSON does not have, as a
    numpy scalar in a result): the Python validator then judges it."""
    try:
        return bool(validator.is_valid(value))
    except (ValueError, TypeError, OverflowError):
        return False


def compiled(schema: Any) -> Any:
    """The compiled validator of ``schema`` (its draft named by ``$schema``)."""
    return jsonschema_rs.validator_for(schema)
