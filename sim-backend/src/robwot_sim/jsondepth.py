"""How deep a JSON document nests: the one limit every structured input of the backend obeys.

A JSON-RPC frame, a scene file and a YAML file (``model/yamlsafe.py``) are all refused past `MAX_DEPTH`
levels, so no handler, schema validator, `json.loads` or YAML composer ever recurses deep enough to
exhaust Python's recursion limit (a RecursionError would surface as an internal error instead of naming
the input).
"""

from __future__ import annotations

import json
from typing import Any

#: Deepest array/object nesting accepted (a request carrying a scene document needs 6).
MAX_DEPTH = 64


class TooDeep(ValueError):
    """The document nests arrays/objects deeper than `MAX_DEPTH` levels."""

    def __init__(self) -> None:
        super().__init__(f"nests arrays/objects deeper than {MAX_DEPTH} levels")


def deeper_than(doc: Any, limit: int = MAX_DEPTH) -> bool:
    """True when ``doc`` nests arrays/objects more than ``limit`` levels (the top level is 1); iterative."""
    stack: list[tuple[Any, int]] = [(doc, 1)] if isinstance(doc, dict | list) else []
    while stack:
        value, depth = stack.pop()
        children = value.values() if isinstance(value, dict) else value
        if depth > limit:
            return True
        stack.extend((c, depth + 1) for c in children if isinstance(c, dict | list))
    return False


def loads_bounded(text: str, **kwargs: Any) -> Any:
    """`json.loads`, refusing (`TooDeep`) a document deeper than `MAX_DEPTH` levels, however deep it is."""
    try:
        doc = json.loads(text, **kwargs)
    except RecursionError:
        raise TooDeep() from None
    if text.count("[") + text.count("{") > MAX_DEPTH and deeper_than(doc):
        raise TooDeep()
    return doc
