"""`deformsim generate` end to end: tiny renders through real Blender workers."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import RENDER_KINDS, Layout
from deformsim.dataset.manifest import read_manifest, stable_view
from deformsim.errors import UserError
from deformsim.generate.stage import generate
from tests.util import ROOT, TINY, child_pids


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "deformsim.cli", *args]


def env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT / "src")}


def tiny_args(out: Path, n: int = 8) -> list[str]:
    return ["generate", "--out", str(out), "--n", str(n), "--resolution", "64", "--samples", "4", "--seed", "3",
            "--no-progress"]


def assert_same_dataset(a: Path, b: Path) -> None:
    ma, mb = read_manifest(a), read_manifest(b)
    pd.testing.assert_frame_equal(stable_view(ma), stable_view(mb))
    for row in ma.itertuples():
        for kind in RENDER_KINDS:
            assert (a / getattr(row, kind)).read_bytes() == (b / getattr(row, kind)).read_bytes(), (row.id, kind)


def test_tiny_dataset_is_balanced_labelled_and_complete(tiny_dataset):
    df = read_manifest(tiny_dataset)
    assert len(df) == 8 and (df.label == "intact").sum() == 4 and (df.label == "deformed").sum() == 4
    assert df.id.is_unique and set(df.camera) == {0, 1, 2, 3}
    for col in ("key_crush_top", "disp_crinkle_fine", "tab", "seal", "hdri", "hdri_rotation", "cam_azimuth",
                "cam_polar", "cam_radius", "render_seconds", "seed", "families"):
        assert col in df.columns, col
    assert (df.render_seconds > 0).all()
    deformed = df[df.label == "deformed"]
    key_cols = [c for c in df.columns if c.startswith("key_")]
    assert (deformed[key_cols].sum(axis=1) > 0.6).all()
    assert (df[df.label == "intact"][key_cols].to_numpy() == 0).all()
    for row in df.itertuples():
        rgba = np.asarray(Image.open(tiny_dataset / row.rgba))
        assert rgba.shape == (64, 64, 4)
        assert rgba[..., 3].max() == 255 and rgba[0, 0, 3] == 0  # object opaque, corner background
        black = np.asarray(Image.open(tiny_dataset / row.black))
        assert black.shape == (64, 64, 3) and black[0, 0].tolist() == [0, 0, 0]
        green = np.asarray(Image.open(tiny_dataset / row.green))
        assert green[0, 0].tolist() == [0, 255, 0]
    layout = Layout(tiny_dataset)
    assert layout.preview.is_file() and layout.config.is_file()
    assert "bpy" in json.loads(layout.versions.read_text())


def test_one_worker_and_a_second_run_give_the_same_dataset(tiny_dataset, tmp_path):
    cfg = load_config("quick", {**TINY, "generate.workers": 1})  # the fixture ran with 2 (the default here)
    generate(cfg, tmp_path / "again", progress=False)
    assert_same_dataset(tiny_dataset, tmp_path / "again")


@pytest.mark.blender
def test_cli_writes_16_images_and_flags_override_the_config(tmp_path):
    out = tmp_path / "cli"
    args = tiny_args(out, 16)
    args[args.index("64")] = "96"
    run = subprocess.run(cli(*args, "--config", "configs/quick.yaml"), cwd=ROOT, env=env(),
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-2000:]
    df = read_manifest(out)
    assert len(df) == 16 and (df.label == "intact").sum() == 8
    assert Image.open(out / df.rgba[0]).size == (96, 96)
    assert "16 images" in run.stdout


def _wait_for(predicate, timeout: float = 300) -> None:
    t0 = time.time()
    while not predicate():
        if time.time() - t0 > timeout:
            raise TimeoutError
        time.sleep(0.1)


def test_killed_run_resumes_to_the_uninterrupted_result(tiny_dataset, tmp_path):
    out = tmp_path / "resumed"
    proc = subprocess.Popen(cli(*tiny_args(out)), cwd=ROOT, env=env(), start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _wait_for(lambda: (out / "samples" / "000000.json").exists() or proc.poll() is not None)
    os.killpg(proc.pid, signal.SIGKILL)  # the whole run, workers included
    proc.wait()
    assert not (out / "manifest.parquet").exists()
    leftovers = list((out / "images").rglob(".*tmp*"))
    rerun = subprocess.run(cli(*tiny_args(out)), cwd=ROOT, env=env(), capture_output=True, text=True, timeout=900)
    assert rerun.returncode == 0, rerun.stderr[-2000:]
    assert not any(p.exists() for p in leftovers)
    assert_same_dataset(tiny_dataset, out)


@pytest.mark.blender
def test_worker_killed_mid_run_has_its_sample_retried(tmp_path):
    out = tmp_path / "crash"
    # 8 samples: when the first is written, the others are still ahead of the workers however loaded the machine
    proc = subprocess.Popen(cli(*tiny_args(out, 32)), cwd=ROOT, env=env(), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    _wait_for(lambda: (out / "samples" / "000000.json").exists())
    workers = child_pids(proc.pid)
    assert workers, "no worker process found"
    for pid in workers:
        os.kill(pid, signal.SIGKILL)
    output, _ = proc.communicate(timeout=900)
    assert proc.returncode == 0, output[-2000:]
    assert len(read_manifest(out)) == 32
    assert "retrying" in output


def test_changed_settings_on_an_existing_folder_fail_and_keep_it(tiny_dataset):
    before = {p: p.stat().st_mtime_ns for p in tiny_dataset.rglob("*") if p.is_file()}
    with pytest.raises(UserError, match="render.resolution"):
        generate(load_config("quick", {**TINY, "render.resolution": 96}), tiny_dataset, progress=False)
    after = {p: p.stat().st_mtime_ns for p in tiny_dataset.rglob("*") if p.is_file()}
    assert before == after


def test_bad_input_fails_before_any_output(tmp_path):
    out = tmp_path / "never"
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "broken.jpg").write_bytes(b"\xff\xd8 not a jpeg")
    for overrides, needle in [({"object.mesh": tmp_path / "missing.stl"}, "not found"),
                              ({"lighting.hdri_dir": tmp_path}, "no .exr or .hdr"),
                              ({"render.surface": {"kinds": ["photo"], "photos": str(tmp_path / "none")}},
                               "render.surface.photos: .* is not a folder"),
                              ({"render.surface": {"kinds": ["photo"], "photos": str(tmp_path / "bad")}},
                               "render.surface.photos: cannot read image .*broken.jpg"),
                              ({"render.appearance": {"photos": str(tmp_path / "none")}},
                               "render.appearance.photos: .* is not a folder"),
                              ({"render.appearance": {"photos": str(tmp_path / "bad")}},
                               "render.appearance.photos: cannot read image .*broken.jpg")]:
        with pytest.raises(UserError, match=needle):
            generate(load_config("quick", {**TINY, **overrides}), out, progress=False)
    assert not out.exists()
    no_sim = tmp_path / "spec.yaml"
    no_sim.write_text("name: plain\nbuiltin: can\nfamilies: [{name: f, keys: [{name: k, ops: [{op: twist, angle: 9}]}]}]\n")
    with pytest.raises(UserError, match="spec 'plain' declares no simulation scenarios"):
        generate(load_config("quick", {**TINY, "object.spec": no_sim, "deform.sources.bank": 1}), out, progress=False)
    assert not out.exists()
    run = subprocess.run(cli(*tiny_args(out), "--object", str(tmp_path / "part.stl")), cwd=ROOT, env=env(),
                         capture_output=True, text=True)
    assert run.returncode == 2 and "mesh file not found" in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_ray_cluster_renders_the_same_dataset(tiny_dataset, tmp_path):
    ray = pytest.importorskip("ray", reason="Ray is not installed (pip install 'deformsim[ray]')")
    try:
        ray.init(address="local", _node_ip_address="127.0.0.1", num_cpus=2, include_dashboard=False,
                 log_to_driver=False)
    except Exception as exc:  # pragma: no cover - depends on the machine
        pytest.skip(f"Ray could not start a local cluster on 127.0.0.1: {exc}")
    try:
        generate(load_config("quick", {**TINY, "generate.backend": "ray", "generate.workers": 2}),
                 tmp_path / "ray", progress=False)
        generate(load_config("quick", {**TINY, "generate.backend": "ray", "generate.gather": True}),
                 tmp_path / "gather", progress=False)
    finally:
        ray.shutdown()
    assert_same_dataset(tiny_dataset, tmp_path / "ray")
    assert_same_dataset(tiny_dataset, tmp_path / "gather")


def write_stl(path: Path, vertices: np.ndarray, triangles: list[tuple[int, int, int]]) -> Path:
    """A binary STL of ``triangles`` (indices into ``vertices``, metres)."""
    import struct

    data = bytearray(b"\0" * 80 + struct.pack("<I", len(triangles)))
    for tri in triangles:
        data += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *vertices[i]) for i in tri) + b"\0\0"
    path.write_bytes(bytes(data))
    return path


SQUARE = np.array([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]])
CUBE = np.array([[x, y, z] for x in (0, 0.1) for y in (0, 0.1) for z in (0, 0.1)])  # index 4x + 2y + z
CUBE_FACES = [t for a, b, c, d in [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
              for t in ((a, b, c), (a, c, d))]


@pytest.mark.blender
@pytest.mark.parametrize("name, vertices, faces, needle", [
    ("triangle", SQUARE, [(0, 1, 2)], "has 3 vertices: a part needs a solid shape"),
    ("flat", SQUARE, [(0, 1, 2), (0, 2, 3)], "is flat"),
])
def test_spec_check_refuses_the_meshes_generate_refuses(tmp_path, name, vertices, faces, needle):
    """`spec check` passed one triangle and a flat mesh that `generate` then rejected: both run
    the same part checks, so both refuse them in one line, before any output."""
    mesh = write_stl(tmp_path / f"{name}.stl", vertices, faces)
    spec = ROOT / "examples" / "carton" / "spec.yaml"
    check = subprocess.run(cli("spec", "check", str(spec), "--object", str(mesh)), cwd=ROOT, env=env(),
                           capture_output=True, text=True)
    out = tmp_path / "out"
    gen = subprocess.run(cli(*tiny_args(out), "--object", str(mesh), "--spec", str(spec)), cwd=ROOT, env=env(),
                         capture_output=True, text=True)
    for proc in (check, gen):
        assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert check.stderr.split("error:")[-1] == gen.stderr.split("error:")[-1]
    assert not out.exists()


@pytest.mark.blender
def test_a_mesh_with_nan_vertices_is_refused(tmp_path):
    """An STL with NaN vertices (which Blender's importer drops, with the faces on them) is refused by spec check
    and generate in one line, before any output."""
    vertices = CUBE.astype(float)
    vertices[7] = np.nan
    mesh = write_stl(tmp_path / "nan.stl", vertices, CUBE_FACES)
    spec = ROOT / "examples" / "carton" / "spec.yaml"
    out = tmp_path / "out"
    for args in (("spec", "check", str(spec), "--object", str(mesh)),
                 (*tiny_args(out), "--object", str(mesh), "--spec", str(spec))):
        proc = subprocess.run(cli(*args), cwd=ROOT, env=env(), capture_output=True, text=True)
        assert proc.returncode == 2 and "vertex coordinates that are NaN or infinite" in proc.stderr, proc.stderr
    assert not out.exists()
