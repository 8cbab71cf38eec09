"""The backend and the TypeScript packages name the twin folder's files alike: ``robwot_sim/twin_layout.py``
holds exactly the entries of the object literals in ``packages/core/src/twin-layout.ts``."""

from __future__ import annotations

import re
from pathlib import Path

from robwot_sim import twin_layout

TS_LAYOUT = Path(__file__).resolve().parents[2] / "packages" / "core" / "src" / "twin-layout.ts"


def ts_object(text: str, name: str) -> dict[str, str]:
    """The ``key: "value"`` entries of ``export const <name> = Object.freeze({...} as const)``."""
    match = re.search(rf"export const {name} = Object\.freeze\(\{{(.*?)\}} as const\);", text, re.DOTALL)
    assert match is not None, f"{TS_LAYOUT}: no `export const {name} = Object.freeze({{...}} as const);`"
    body = re.sub(r"/\*.*?\*/|//[^\n]*", "", match.group(1), flags=re.DOTALL)
    entries = [e.strip() for e in body.split(",") if e.strip()]
    out: dict[str, str] = {}
    for entry in entries:
        m = re.fullmatch(r'(\w+):\s*"([^"\\]*)"', entry)
        assert m is not None, f"{TS_LAYOUT}: {name} entry {entry!r} is not `key: \"string\"`"
        assert m.group(1) not in out, f"{TS_LAYOUT}: {name}.{m.group(1)} given twice"
        out[m.group(1)] = m.group(2)
    return out


def test_files_match_the_typescript_layout() -> None:
    ts = ts_object(TS_LAYOUT.read_text(encoding="utf-8"), "TWIN_FILES")
    assert "td" in ts and "thingModel" in ts
    assert dict(twin_layout.TWIN_FILES) == ts


def test_folders_match_the_typescript_layout() -> None:
    ts = ts_object(TS_LAYOUT.read_text(encoding="utf-8"), "TWIN_FOLDERS")
    assert "meshes" in ts and "collision" in ts
    assert dict(twin_layout.TWIN_FOLDERS) == ts


def test_every_constant_is_in_the_mappings() -> None:
    """Each module constant is reachable through TWIN_FILES / TWIN_FOLDERS, so the comparison covers it."""
    constants = {v for k, v in vars(twin_layout).items() if k.isupper() and isinstance(v, str)}
    assert constants == set(twin_layout.TWIN_FILES.values()) | set(twin_layout.TWIN_FOLDERS.values())
    assert len(set(twin_layout.TWIN_FILES.values())) == len(twin_layout.TWIN_FILES)
