"""The twin folder's layout (ARCHITECTURE.md, Contract 2): the one place in the backend naming its files
and folders, relative to the folder.

The TypeScript side names the same ones in ``packages/core/src/twin-layout.ts`` (``TWIN_FILES``,
``TWIN_FOLDERS``); ``tests/test_twin_layout.py`` fails when the two differ. ``TWIN_FILES`` and
``TWIN_FOLDERS`` use the TypeScript keys.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Final

#: Thing Description (TD 1.1)
TD: Final = "td.json"
#: the manifest: robot (URDF, SRDF, end-effector link, base pose), scene, generator
MANIFEST: Final = "twin.json"
#: self-contained URDF, mesh filenames relative to the folder
URDF: Final = "robot.urdf"
#: the robot's SRDF (present when generated with one)
SRDF: Final = "robot.srdf"
#: the scene used (obstacles and other robots)
SCENE: Final = "scene.json"
#: the labelled point cloud
POINT_CLOUD: Final = "workspace.csv"
#: the workspace surface (binary STL)
SURFACE: Final = "workspace.stl"
#: the WorkspaceSummary
SUMMARY: Final = "workspace.json"
#: the reachability map
REACHABILITY: Final = "reachability.csv"
#: the active calibration (written by serve's calibrate)
CALIBRATION: Final = "calibration.json"
#: the Thing Model every TD links with ``rel: "type"``
THING_MODEL: Final = "robot-arm.tm.json"

#: meshes copied from the robot's source (the URDF's relative mesh filenames point here)
MESHES_DIR: Final = "meshes"
#: the scene's mesh obstacles, below ``MESHES_DIR``
SCENE_MESHES_DIR: Final = "meshes/scene"
#: cached convex parts of concave collision meshes, one folder per mesh key
COLLISION_DIR: Final = "collision"
#: the scene's other robots, one exported folder each (``robots/<id>/robot.urdf``, its meshes and parts)
SCENE_ROBOTS_DIR: Final = "robots"

TWIN_FILES: Final[Mapping[str, str]] = MappingProxyType({
    "td": TD,
    "manifest": MANIFEST,
    "urdf": URDF,
    "srdf": SRDF,
    "scene": SCENE,
    "pointCloud": POINT_CLOUD,
    "surface": SURFACE,
    "summary": SUMMARY,
    "reachability": REACHABILITY,
    "calibration": CALIBRATION,
    "thingModel": THING_MODEL,
})

TWIN_FOLDERS: Final[Mapping[str, str]] = MappingProxyType({
    "meshes": MESHES_DIR,
    "sceneMeshes": SCENE_MESHES_DIR,
    "collision": COLLISION_DIR,
    "sceneRobots": SCENE_ROBOTS_DIR,
})
