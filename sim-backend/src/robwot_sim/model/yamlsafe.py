"""The one YAML reader of the backend (a MoveIt config's ``.setup_assistant``, ``joint_limits.yaml`` files).

A file is read whole within ``MAX_YAML_BYTES`` or refused (``wholefile.py``), loaded with PyYAML's safe
loader (no tags that build objects), and refused when it nests mappings or sequences deeper than the one
nesting limit of every structured input (``jsondepth.MAX_DEPTH``). The depth is counted on the parser's
events before anything is composed: PyYAML composes and constructs nested collections by recursion, so a
deeper document would otherwise end in a RecursionError (an internal error naming nothing). Every refusal
is an `UrdfError` naming the file and, where known, the line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from robwot_sim.errors import UrdfError
from robwot_sim.jsondepth import MAX_DEPTH
from robwot_sim.wholefile import TooLarge, read_whole

#: largest YAML file read (a MoveIt joint_limits.yaml of a large robot is a few KiB)
MAX_YAML_BYTES = 1024 * 1024


def load_yaml(path: Path) -> Any:
    """The document of the YAML file ``path`` (see the module docstring for what is refused)."""
    try:
        data = read_whole(path, MAX_YAML_BYTES)
    except TooLarge as e:
        raise UrdfError(str(e), file=str(path), size=e.size, limit=e.limit) from None
    except OSError as e:
        raise UrdfError(f"cannot be read: {e.strerror}", file=str(path)) from None
    try:
        depth = 0
        for event in yaml.parse(data, Loader=yaml.SafeLoader):
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    line = event.start_mark.line + 1 if event.start_mark is not None else None
                    raise UrdfError(f"YAML nests mappings/sequences deeper than {MAX_DEPTH} levels",
                                    file=str(path), line=line, limit=MAX_DEPTH)
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
        return yaml.safe_load(data)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        raise UrdfError(f"not valid YAML: {getattr(e, 'problem', None) or e}", file=str(path),
                        line=mark.line + 1 if mark is not None else None) from None
