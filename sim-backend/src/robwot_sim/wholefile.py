"""Files read whole or refused, and written whole or not at all: never a prefix of either.

Every file the backend reads from outside (URDF, SRDF, xacro includes, YAML, launch files, package.xml,
scenes, meshes, convex-part manifests) goes through `read_whole` with the size limit of its kind. A file
above the limit is refused before it is read, and one that turns out longer while it is read (it grew,
or it is a device or a pipe reporting no size) is refused too: no reader ever parses the first part of
a file as if it were all of it (a cut YAML drops the joints past the cut; a cut XML reads as malformed
at a line that is not wrong). The reader turns `TooLarge` into its own error naming the file.

Every file the backend writes for others to read (the twin's point cloud and STL, the kernels' stamp) goes
through `atomic_write`: a reader, in this process or another, sees the old file or the new one.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


class TooLarge(ValueError):
    """A file above its limit: ``size`` bytes (at least that many when it has no size), ``limit`` bytes."""

    def __init__(self, size: int, limit: int, exact: bool = True) -> None:
        self.size, self.limit = size, limit
        what = f"{size} bytes" if exact else f"more than {limit} bytes"
        super().__init__(f"file of {what} is larger than the limit of {limit} bytes: refused whole, "
                         "never read in part")


def read_whole(path: str | Path, limit: int) -> bytes:
    """The whole content of ``path``, or `TooLarge` when it holds more than ``limit`` bytes (OSError as
    ``open`` raises it)."""
    with open(path, "rb") as f:
        size = os.fstat(f.fileno()).st_size
        if size > limit:
            raise TooLarge(size, limit)
        # read what the file says it holds (a buffer of the limit's size would be reserved up front), then
        # on up to the limit when it holds more (it grew, or it is a device or pipe reporting no size)
        data = f.read(size + 1)
        if len(data) > size:
            data += f.read(limit + 1 - len(data))
    if len(data) > limit:
        raise TooLarge(len(data), limit, exact=False)
    return data


def atomic_write(path: Path, write: Callable[[BinaryIO], object]) -> None:
    """``path`` made to hold what ``write`` writes, whole: written to a temporary file in its folder and
    renamed over it (mode 0644); on any failure the temporary file is removed and ``path`` is untouched."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
