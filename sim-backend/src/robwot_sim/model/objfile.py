"""The one OBJ writer: vertices and triangles, 1-based indices, nine significant digits."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt


def write_obj(path: Path, vertices: npt.NDArray[np.float64], faces: npt.NDArray[Any] | list[Any]) -> None:
    """Writes ``vertices`` [n, 3] and triangles ``faces`` [m, 3] (0-based indices) to ``path`` as OBJ."""
    lines = [f"v {a:.9g} {b:.9g} {c:.9g}\n" for a, b, c in np.asarray(vertices, dtype=np.float64)]
    lines += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in np.asarray(faces, dtype=np.int64)]
    path.write_text("".join(lines))
