"""Reading an input file whole, or refusing it: never a prefix of it.

Every file the backend reads from outside (URDF, SRDF, xacro includes, YAML, launch files, package.xml,
scenes, meshes, convex-part manifests) goes through `read_whole` with the size limit of its kind. A file
above the limit is refused before it is read, and one that turns out longer while it is read (it grew,
or it is a device or a pipe reporting no size) is refused too: no reader ever parses the first part of
a file as if it were all of it (a cut YAML drops the joints past the cut; a cut XML reads as malformed
at a line that is not wrong). The reader turns `TooLarge` into its own error naming the file.
"""

from __future__ import annotations

import os
from pathlib import Path


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
