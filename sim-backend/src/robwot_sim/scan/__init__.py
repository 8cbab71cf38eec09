"""The scene from a scan: point clouds read (``clouds.py``), the robots' own points removed, support planes
and objects found (``segment.py``), each object covered by a shape (``shapes.py``), a scene written."""
