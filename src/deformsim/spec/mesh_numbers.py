"""The numbers of a mesh file, read without Blender, before Blender reads it: its size against a bound per format and,
for binary STL, its triangle count against its size (a huge or sparse file is refused at once, not read); and its
vertex coordinates, since Blender's importers drop a vertex whose coordinates are NaN or infinite, with the faces on
it, without a word, so such a part would render with holes."""

from __future__ import annotations

import mmap
import re
from pathlib import Path

import numpy as np

from deformsim.errors import UserError

MAX_BYTES = {".stl": 1 << 30, ".obj": 1 << 30, ".ply": 1 << 30, ".glb": 1 << 30, ".gltf": 1 << 28, ".fbx": 1 << 30}
STL_HEADER = 84  # bytes: 80 of header, then the triangle count (uint32)
STL_TRIANGLE = 50  # bytes per triangle: a normal, three vertices (float32) and two spare bytes

_NONFINITE = rb"(?:nan|inf|e\+?0*(?:39|[4-9]\d|[1-9]\d{2,}))"  # NaN or infinite, also as float32 (exponent 39 up)
_LINES = {".obj": re.compile(rb"(?im)^[ \t]*v[ \t][^\n]*?" + _NONFINITE),
          ".stl": re.compile(rb"(?im)^[ \t]*vertex[ \t][^\n]*?" + _NONFINITE)}
_PLY_BODY = re.compile(rb"(?i)" + _NONFINITE)


def check_size(path: Path) -> None:
    """One line, before anything is read past its first bytes, when ``path`` is larger than its format's bound
    (:data:`MAX_BYTES`), or is an STL that is neither a binary one whose size its triangle count gives (84 + 50 per
    triangle) nor ASCII text starting ``solid``, or a binary STL of no triangles."""
    suffix, size = path.suffix.lower(), path.stat().st_size
    if size > MAX_BYTES.get(suffix, size):
        raise UserError(f"mesh {path} is {size / 2**20:,.0f} MiB: more than the {MAX_BYTES[suffix] >> 20:,} MiB a "
                        f"{suffix} part may be (simplify it)")
    if suffix != ".stl":
        return
    with open(path, "rb") as f:
        head = f.read(512)
    count = int.from_bytes(head[80:STL_HEADER], "little") if len(head) >= STL_HEADER else None
    if count is not None and size == STL_HEADER + STL_TRIANGLE * count:
        if count == 0:
            raise UserError(f"mesh {path} has no faces (a binary STL of 0 triangles)")
        return
    if head.lstrip().startswith(b"solid"):
        return  # ASCII
    counted = f"its header counts {count} triangles, {STL_HEADER + STL_TRIANGLE * count:,} bytes" if count is not None \
        else "it is shorter than a binary STL's header"
    raise UserError(f"mesh {path} is not a valid STL: not ASCII (starting 'solid'), and as binary STL {counted}, "
                    f"but the file holds {size:,}")


def nonfinite_vertices(path: Path) -> bool:
    """Whether a vertex coordinate of ``path`` is NaN or infinite, in the formats read here: STL (binary and
    ASCII), OBJ and ASCII PLY; False for the others (glTF, FBX, binary PLY), which are not read. The file is mapped,
    not read into memory."""
    suffix = path.suffix.lower()
    if suffix not in (".stl", ".obj", ".ply") or path.stat().st_size == 0:
        return False
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as raw:
        return _nonfinite(raw, suffix)


def _nonfinite(raw: mmap.mmap, suffix: str) -> bool:
    if suffix == ".stl" and len(raw) >= STL_HEADER:
        count = int.from_bytes(raw[80:STL_HEADER], "little")
        if len(raw) == STL_HEADER + STL_TRIANGLE * count:  # binary
            rows = np.frombuffer(raw, np.dtype([("n", "<f4", 3), ("v", "<f4", 9), ("a", "<u2")]), count, STL_HEADER)
            finite = bool(np.isfinite(rows["v"]).all())
            del rows  # the map closes only when no array views it
            return not finite
    if suffix in _LINES:
        return _LINES[suffix].search(raw) is not None
    if suffix == ".ply" and raw[:3] == b"ply" and b"format ascii" in raw[:200]:
        end = raw.find(b"end_header")
        return end >= 0 and _PLY_BODY.search(raw, end + len(b"end_header")) is not None
    return False
