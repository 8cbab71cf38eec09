"""Keeping paths read from untrusted files inside the folders they may come from (the jail primitive).

A path named by a file (a URDF's mesh, a xacro's include, a MoveIt config's ``.setup_assistant`` entries
and the files of its package) may lead anywhere: ``..`` segments, absolute paths, symbolic links. It is
accepted only when both its normalised form and its real path (symlinks followed) lie below one of the
allowed roots; otherwise it is refused with `PathEscape` naming the path, the roots and the reason,
before anything reads it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from robwot_sim.errors import PathEscape


def inside(p: Path, roots: Sequence[Path]) -> bool:
    """``p`` is one of ``roots`` or below one (lexically: resolve both first where symlinks matter)."""
    return any(p == r or r in p.parents for r in roots)


def confine(path: Path, roots: Sequence[Path], *, reason: str, urdf: str | None = None) -> Path:
    """The real path of ``path`` (absolute) when it stays below ``roots`` (resolved folders) both as
    written and after symlinks; `PathEscape` (with ``reason``: who named it and where it must stay, and
    ``urdf``: the file naming it) otherwise."""
    written = Path(os.path.normpath(path))
    real = written.resolve()
    if not inside(written, roots) or not inside(real, roots):
        raise PathEscape(str(written if not inside(written, roots) else real), [str(r) for r in roots],
                         urdf=urdf, reason=reason)
    return real
