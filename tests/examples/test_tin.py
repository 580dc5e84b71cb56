"""The food-tin example (examples/tin): its mesh, what each spec key does to it, and its config end to end."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.generate.visibility import invisible_keys, lattice_displacement
from deformsim.spec.lattice_ops import key_points, rest_lattice
from deformsim.spec.model import load_spec

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "tin"
SPEC, CONFIG = EXAMPLE / "spec.yaml", EXAMPLE / "config.yaml"
SIZE = (0.073, 0.073, 0.110)  # m: the default tin


def make_tin(out: Path, *args: str) -> np.ndarray:
    """Run make_tin.py; the STL's triangles (k, 3, 3) in mm."""
    subprocess.run([sys.executable, str(EXAMPLE / "make_tin.py"), str(out), *args], check=True, capture_output=True)
    raw = out.read_bytes()
    n = int(np.frombuffer(raw, "<u4", 1, 80)[0])
    rec = np.frombuffer(raw, [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")], n, 84)
    assert len(raw) == 84 + 50 * n
    return rec["v"].astype(np.float64)


def test_the_mesh_is_written_into_a_folder_that_does_not_exist_yet(tmp_path):
    out = tmp_path / "runs" / "tin" / "tin.stl"  # the docs' first command on a fresh checkout
    assert len(make_tin(out, "--segments", "16")) > 0 and [p.name for p in out.parent.iterdir()] == ["tin.stl"]


@pytest.fixture(scope="module")
def tin(tmp_path_factory) -> np.ndarray:
    return make_tin(tmp_path_factory.mktemp("tin") / "tin.stl", "--segments", "48")  # coarse around: a faster check


def edges_and_volume(tris: np.ndarray) -> tuple[dict, float]:
    """Each directed edge's count (vertices welded by their float32 coordinates) and the signed volume."""
    _, ids = np.unique(tris.astype(np.float32).reshape(-1, 3), axis=0, return_inverse=True)
    faces = ids.reshape(-1, 3)
    assert (faces[:, 0] != faces[:, 1]).all() and (faces[:, 1] != faces[:, 2]).all() and (faces[:, 0] != faces[:, 2]).all()
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    keys, counts = np.unique(directed, axis=0, return_counts=True)
    volume = np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])).sum() / 6
    return dict(zip(map(tuple, keys), counts)), float(volume)


@pytest.mark.parametrize("args, size", [((), (73, 73, 110)), (("--diameter", "99", "--height", "119"), (99, 99, 119)),
                                        (("--ends", "flat"), (73, 73, 110))])
def test_the_tin_is_watertight_outward_and_the_stated_size(tmp_path, args, size):
    tris = make_tin(tmp_path / "tin.stl", *args)
    edges, volume = edges_and_volume(tris)
    # every edge is shared by exactly two faces, which run along it in opposite directions: closed and oriented
    assert all(c == 1 for c in edges.values())
    assert all((b, a) in edges for a, b in edges)
    pts = tris.reshape(-1, 3)
    assert np.allclose(pts.max(0) - pts.min(0), size, atol=1.0) and abs(pts[:, 2].min()) < 1e-6
    assert 0.8 * np.pi * (size[0] / 2) ** 2 * size[2] < volume < np.pi * (size[0] / 2) ** 2 * size[2]  # faces outward


def test_the_tin_has_beads_seams_and_recessed_ends(tin):
    pts = tin.reshape(-1, 3)
    r, z = np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2]
    wall = (z > 20) & (z < 90) & (r > 30)
    assert r[wall].max() - r[wall].min() > 0.7  # beads rolled in
    assert r.max() - r[(z > 10) & (z < 100)].max() > 0.8  # the seams stand out past the body
    centre = r < 5
    assert z[centre].min() > 2 and z[centre].max() < 108  # end panels recessed behind the seams


def test_flat_ends_have_a_flat_centre_and_their_rings_near_the_seam(tmp_path):
    """`--ends flat`: the panel is level across its middle half and ridged only in its outer third."""
    pts = make_tin(tmp_path / "tin.stl", "--ends", "flat", "--segments", "48").reshape(-1, 3)
    r, z = np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2]
    bottom = z < 5
    assert np.ptp(z[bottom & (r < 14)]) < 0.01 and np.ptp(z[bottom & (r > 18) & (r < 27)]) > 0.3
    default = make_tin(tmp_path / "rings.stl", "--segments", "48").reshape(-1, 3)
    assert np.ptp(default[(default[:, 2] < 5) & (np.hypot(default[:, 0], default[:, 1]) < 14), 2]) > 0.3


def moved(spec, tin_mm: np.ndarray, key: str) -> tuple[np.ndarray, np.ndarray]:
    """The tin's vertices (m, lattice centred) and each one's displacement (m) by ``key`` at full weight, through the
    spec's lattice as Blender's B-spline lattice moves them."""
    pts = np.unique(tin_mm.reshape(-1, 3), axis=0) / 1000
    lo, hi = pts.min(0), pts.max(0)
    size = (hi - lo) * (1 + 2 * spec.lattice.margin)
    centred = pts - (lo + hi) / 2
    ops = next(k.ops for f in spec.families for k in f.keys if k.name == key)
    rest = rest_lattice(spec.lattice.points)
    field = key_points(rest, [(op.op, op.params) for op in ops]) - rest
    return centred, lattice_displacement(field, spec.lattice.points, centred / size) * size


def test_the_ends_region_takes_the_end_panels_and_leaves_the_side_wall(tin):
    """The spec's lacquered ends: every face whose centre is on the end panels (inside the seams), none of the wall."""
    from deformsim.spec.lattice_ops import select_vertices

    (ends,) = load_spec(SPEC).material.regions
    centres, normals = tin.mean(1), np.cross(tin[:, 1] - tin[:, 0], tin[:, 2] - tin[:, 0])
    chosen = select_vertices(centres, normals, min_normal_angle=ends.where.min_normal_angle)
    radius = np.hypot(centres[:, 0], centres[:, 1])
    panel = radius < 0.7 * radius.max()
    wall = (centres[:, 2] > 15) & (centres[:, 2] < 95)  # the beaded wall, seams and their plain bands left out
    assert chosen[panel].mean() > 0.95 and not chosen[wall].any()


def test_each_key_deforms_the_tin_where_it_says(tin):
    spec = load_spec(SPEC)
    for name, (azimuth, at) in {"dent_finger": (40, 0.38), "dent_thumb": (60, 0.62), "dent_fist": (25, 0.5),
                                "rim_dent_top": (40, 0.98), "rim_dent_bottom": (20, 0.02)}.items():
        p, d = moved(spec, tin, name)
        i = np.linalg.norm(d, axis=1).argmax()
        az = np.degrees(np.arctan2(p[i, 1], p[i, 0])) % 360
        assert abs((az - azimuth + 180) % 360 - 180) < 25, name  # deepest where the key says, on that side
        assert abs(p[i, 2] / 0.110 + 0.5 - at) < 0.12, name
        assert np.dot(d[i, :2], p[i, :2]) < 0, name  # pushed in
        far = np.dot(p[:, :2], [np.cos(np.radians(azimuth)), np.sin(np.radians(azimuth))]) < -0.02
        assert np.linalg.norm(d[far], axis=1).max() < 0.1 * np.linalg.norm(d[i]), name  # the far side stays
    p, d = moved(spec, tin, "dent_finger")
    assert 0.004 < np.linalg.norm(d, axis=1).max() < 0.012  # a finger-deep dent at full weight (4-12 mm)
    p, d = moved(spec, tin, "end_crushed")
    top = p[:, 2] > 0.05
    assert d[top, 2].mean() < -0.005 and abs(d[p[:, 2] < -0.05, 2]).max() < 0.001  # the top end down, the bottom not
    for name in ("beads_buckled", "wall_panelled"):
        p, d = moved(spec, tin, name)
        i = np.linalg.norm(d, axis=1).argmax()
        assert abs(p[i, 2]) < 0.03, name  # the wall's middle band, where the beads are
    p, d = moved(spec, tin, "rim_bent")
    assert np.linalg.norm(d[p[:, 2] > 0.04], axis=1).max() > 0.003 and np.linalg.norm(d[p[:, 2] < 0.02], axis=1).max() < 1e-4


def test_the_keys_show_at_the_examples_render_size_and_not_at_64_px():
    spec = load_spec(SPEC)
    assert invisible_keys(load_config(CONFIG), spec, SIZE) is None
    small = invisible_keys(load_config(CONFIG, {"render.resolution": 64, "deform.families": [3, 5]}), spec, SIZE)
    assert small is not None and "'beads_buckled'" in small and "64 px renders" in small


def test_the_config_stands_tins_upright_with_side_and_top_views():
    cfg = load_config(CONFIG)
    assert cfg.pose.tilt == (0.0, 0.0) and cfg.render.surface is not None and cfg.composite.surface == 1.0
    polars = cfg.camera.polars
    assert sum(hi <= 15 for _, hi in polars) == 1 and sum(lo >= 60 for lo, _ in polars) == 3
    assert cfg.render.resolution >= 192 and set(cfg.lighting.hdris) <= {"interior", "studio"}


def test_the_config_trains_the_quick_presets_model():
    ours, quick = load_config(CONFIG).train, load_config("quick").train
    assert (ours.backbone, ours.ensemble_backbones, ours.ensemble) == (quick.backbone, quick.ensemble_backbones,
                                                                        quick.ensemble)


@pytest.mark.blender
def test_the_example_runs_end_to_end(tmp_path):
    from deformsim.dataset.manifest import read_manifest
    from deformsim.pipeline import run

    mesh = tmp_path / "tin.stl"
    make_tin(mesh, "--segments", "48")
    cfg = load_config(CONFIG, {"generate.n": 16, "render.resolution": 48, "render.samples": 4, "train.epochs": 1,
                               "train.image_size": 48, "train.weights": "offline", "object.mesh": mesh,
                               "object.spec": SPEC, "generate.seed": 3})
    result = run(cfg, tmp_path / "run", progress=False)
    assert result.report.is_file()
    df = read_manifest(result.data)
    assert len(df) == 16 and df.surface.notna().all() and (df.pose_tilt == 0).all()
    top = df[df.camera == 3]
    assert (top.cam_polar < 10).all() and (df[df.camera < 3].cam_polar > 70).all()
    twins = df.groupby(["pair", "camera"])  # each dented tin and its intact twin: one scene, two labels
    assert (twins.y.nunique() == 2).all() and (twins.cam_azimuth.nunique() == 1).all()
    assert (twins.surface_params.nunique() == 1).all() and (twins.material.nunique() == 1).all()
