"""NaN and infinite vertex coordinates in a mesh file are found without Blender (whose importers drop them)."""

from __future__ import annotations

import struct
import time

import numpy as np
import pytest

from deformsim.errors import UserError
from deformsim.spec.mesh_numbers import nonfinite_vertices
from deformsim.spec.model import check_mesh_file


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


def _sparse(path, size: int, head: bytes = b""):
    with open(path, "wb") as f:
        f.write(head)
        f.truncate(size)  # a hole: no disk used, nothing to read but zeros
    return path


def test_a_huge_sparse_stl_is_refused_before_it_is_read(tmp_path):
    from typer.testing import CliRunner

    from deformsim.cli.app import app
    from tests.util import CARTON_SPEC

    big = _sparse(tmp_path / "big.stl", 3 << 30)
    t0 = time.perf_counter()
    res = CliRunner().invoke(app, ["spec", "check", str(CARTON_SPEC), "--object", str(big)])
    assert res.exit_code in (1, 2) and "is 3,072 MiB: more than the 1,024 MiB a .stl part may be" in res.output, res.output
    assert time.perf_counter() - t0 < 5  # reading it took 20 s


@pytest.mark.parametrize("head, size, needle", [
    (b"\0" * 80 + struct.pack("<I", 3), 200 << 20, "its header counts 3 triangles, 234 bytes, but the file holds 209,715,200"),
    (b"\0" * 80 + struct.pack("<I", 0), 84, "has no faces"),
    (b"\0" * 40, 40, "shorter than a binary STL's header"),
], ids=["count", "none", "short"])
def test_an_stl_whose_size_its_header_does_not_give_is_one_line(tmp_path, head, size, needle):
    path = _sparse(tmp_path / "part.stl", size, head)
    with pytest.raises(UserError, match=needle):
        check_mesh_file(path)


def test_a_valid_binary_or_ascii_stl_passes_the_size_checks(tmp_path):
    (tmp_path / "b.stl").write_bytes(binary_stl((0, 1, 0)))
    (tmp_path / "a.stl").write_bytes(b"solid x\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n")
    for name in ("a.stl", "b.stl"):
        assert check_mesh_file(tmp_path / name) == tmp_path / name


@pytest.mark.parametrize("name", ["big.obj", "big.ply", "big.glb", "big.fbx", "big.gltf"])
def test_every_mesh_format_has_a_size_bound(tmp_path, name):
    path = _sparse(tmp_path / name, (1 << 30) + 1)
    with pytest.raises(UserError, match="MiB a .* part may be"):
        check_mesh_file(path)
