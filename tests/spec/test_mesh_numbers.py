"""NaN and infinite vertex coordinates in a mesh file are found without Blender (whose importers drop them)."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from deformsim.spec.mesh_numbers import nonfinite_vertices


def binary_stl(vertex: tuple[float, float, float]) -> bytes:
    tri = struct.pack("<3f", 0, 0, 1) + struct.pack("<3f", 0, 0, 0) + struct.pack("<3f", 1, 0, 0)
    return b"\0" * 80 + struct.pack("<I", 1) + tri + struct.pack("<3f", *vertex) + b"\0\0"


@pytest.mark.parametrize("name, content, bad", [
    ("a.stl", binary_stl((0, 1, 0)), False),
    ("b.stl", binary_stl((0, np.nan, 0)), True),
    ("c.stl", binary_stl((np.inf, 1, 0)), True),
    ("d.stl", b"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 NaN 0\n", True),
    ("e.stl", b"solid x\n facet normal 0 0 inf\n  outer loop\n   vertex 0 0 0\n   vertex 1.5e+001 0 0\n", False),
    ("f.obj", b"# inf\nv 0 0 0\nv 1 2 3\nvn 0 0 1\nf 1 2 1\n", False),
    ("g.obj", b"v 0 0 0\nv 1 -inf 3\n", True),
    ("h.obj", b"v 0 0 0\nv 1 2e39 3\n", True),  # infinite as float32
    ("i.ply", b"ply\nformat ascii 1.0\ncomment inf\nelement vertex 1\nproperty float x\nend_header\n0 0 0\n", False),
    ("j.ply", b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0 nan 0\n", True),
    ("k.glb", b"glTF nan", False),  # not read here
])
def test_nonfinite_vertices_are_found(tmp_path, name, content, bad):
    path = tmp_path / name
    path.write_bytes(content)
    assert nonfinite_vertices(path) is bad
