"""The vertex numbers of a mesh file, read without Blender: Blender's importers drop a vertex whose coordinates are
NaN or infinite, with the faces on it, without a word, so such a part would render with holes."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

_NONFINITE = rb"(?:nan|inf|e\+?0*(?:39|[4-9]\d|[1-9]\d{2,}))"  # NaN or infinite, also as float32 (exponent 39 up)
_LINES = {".obj": re.compile(rb"(?im)^[ \t]*v[ \t][^\n]*?" + _NONFINITE),
          ".stl": re.compile(rb"(?im)^[ \t]*vertex[ \t][^\n]*?" + _NONFINITE)}
_PLY_BODY = re.compile(rb"(?i)" + _NONFINITE)


def nonfinite_vertices(path: Path) -> bool:
    """Whether a vertex coordinate of ``path`` is NaN or infinite, in the formats read here: STL (binary and
    ASCII), OBJ and ASCII PLY; False for the others (glTF, FBX, binary PLY), which are not read."""
    suffix = path.suffix.lower()
    raw = path.read_bytes() if suffix in (".stl", ".obj", ".ply") else b""
    if suffix == ".stl" and len(raw) >= 84:
        count = int.from_bytes(raw[80:84], "little")
        if len(raw) == 84 + 50 * count:  # binary: per triangle a normal, three vertices and two spare bytes
            rows = np.frombuffer(raw, np.dtype([("n", "<f4", 3), ("v", "<f4", 9), ("a", "<u2")]), count, 84)
            return not np.isfinite(rows["v"]).all()
    if suffix in _LINES:
        return _LINES[suffix].search(raw) is not None
    if suffix == ".ply" and raw.startswith(b"ply") and b"format ascii" in raw[:200]:
        end = raw.find(b"end_header")
        return end >= 0 and _PLY_BODY.search(raw, end + len(b"end_header")) is not None
    return False
