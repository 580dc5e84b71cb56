"""`deformsim run` end to end, for the built-in can and for a user mesh; spec and mesh validation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import UserError
from deformsim.pipeline import run
from tests.util import CARTON_SPEC, cli

# 2 intact + 2 deformed scene states (a split needs two of each), 1 epoch at 64 px.
E2E = {"generate.n": 16, "render.resolution": 64, "render.samples": 4, "generate.seed": 5, "train.epochs": 1,
       "train.image_size": 64, "train.weights": "offline", "composite.variants": ["black", "backgrounds"]}


def real_folder(data: Path, root: Path) -> Path:
    """A stand-in 'real' folder laid out as intact/ and deformed/ (green renders: another domain)."""
    df = read_manifest(data)
    for row in df.itertuples():
        target = root / row.label / f"{row.id}.png"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((data / row.green).read_bytes())
    return root


@pytest.mark.blender
def test_run_on_the_builtin_can_makes_a_report_and_skips_what_is_done(tmp_path):
    cfg = load_config("quick", E2E)
    first = run(cfg, tmp_path / "run", progress=False)
    real = real_folder(first.data, tmp_path / "real")
    result = run(cfg, tmp_path / "run", real=real, progress=False)
    assert result.skipped == ["generate", "composite:procedural"]
    assert list(result.seconds)[0] == "report: training" and list(result.seconds)[-1] == "report: testing, plots and the page"
    metrics = json.loads((tmp_path / "run" / "report" / "metrics.json").read_text())
    best = max(("black", "procedural"), key=lambda v: metrics["variants"][v]["real"]["metrics"]["accuracy"])
    linked = tmp_path / "run" / "report" / metrics["variants"][best]["real"]["model"]
    assert result.model == tmp_path / "run" / "model"  # the headline model, hard-linked: no second copy
    assert (result.model / "model.pt").stat().st_ino == linked.stat().st_ino
    assert set(metrics["variants"]) == {"black", "procedural"}
    acc = metrics["variants"]["black"]["real"]["metrics"]["accuracy"]
    assert f"{100 * acc:.1f}%" in result.report.read_text()
    again = run(cfg, tmp_path / "run", real=real, progress=False)
    assert again.skipped == ["generate", "composite:procedural", "report"] and not again.seconds
    changed = run(load_config("quick", {**E2E, "train.epochs": 2}), tmp_path / "run", real=real, progress=False)
    assert changed.skipped == ["generate", "composite:procedural"]
    adapted = run(load_config("quick", {**E2E, "train.epochs": 2}), tmp_path / "run", real=real, progress=False,
                  unlabelled=real)  # the model adapts to the photos last, their labels unread
    assert adapted.skipped == ["generate", "composite:procedural", "report"] and list(adapted.seconds) == ["adapt"]
    assert adapted.adapted == tmp_path / "run" / "model-adapted"
    assert "adapter" in torch.load(adapted.adapted / "model.pt", weights_only=True)


@pytest.mark.blender
def test_run_on_a_user_mesh(tmp_path, carton):
    cfg = load_config("quick", {**E2E, "object.mesh": carton, "object.spec": CARTON_SPEC})
    result = run(cfg, tmp_path / "run", progress=False)
    assert result.report.is_file()
    df = read_manifest(result.data)
    assert len(df) == 16 and "key_squashed_top" in df.columns
    assert np.allclose(df.camera_scale, 0.215 / 0.122, rtol=0.01)  # cameras back off with the part's size
    cover = [np.asarray(Image.open(result.data / p))[..., 3].mean() / 255 for p in df.rgba]
    assert 0.02 < min(cover) and max(cover) < 0.8  # the part is in frame, and not cropped to fill it


@pytest.mark.parametrize("change, needle", [
    (("op: dent", "op: poke"), "unknown operation 'poke'"),
    (("ops: [{op: twist, angle: 35}]", "ops: []"), "keys 'twisted'.ops: key has no operations"),
    (("roughness: [0.3, 0.6]", "roughness: [0.6, 0.3]"), "roughness range [0.6, 0.3] is empty"),
    (("roughness: [0.3, 0.6]", "roughness: [-0.2, 0.6]"), "roughness range [-0.2, 0.6] is negative"),
])
def test_bad_specs_fail_before_rendering(tmp_path, carton, change, needle):
    spec = tmp_path / "spec.yaml"
    spec.write_text(CARTON_SPEC.read_text().replace(*change))
    for args in (["spec", "check", str(spec)],
                 ["run", "--object", str(carton), "--spec", str(spec), "--out", str(tmp_path / "out")]):
        proc = cli(*args)
        assert proc.returncode == 2 and needle in " ".join(proc.stderr.split()), proc.stderr
        assert len(proc.stderr.strip().splitlines()) <= 2 and "Traceback" not in proc.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.blender
def test_unknown_family_is_named(carton, tmp_path):
    cfg = load_config("quick", {**E2E, "object.mesh": carton, "object.spec": CARTON_SPEC,
                                "deform.use_families": ["crush", "crumple"]})
    with pytest.raises(UserError, match="unknown family 'crumple'"):
        run(cfg, tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.blender
@pytest.mark.parametrize("name, content, needle", [
    ("missing.stl", None, "mesh file not found"),
    ("empty.stl", b"", "is empty"),
    ("noise.stl", bytes(range(256)) * 3, "not a valid STL"),
    ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"),
    ("part.step", b"ISO-10303-21;", "unsupported format"),
])
def test_bad_meshes_fail_before_rendering(tmp_path, name, content, needle):
    mesh = tmp_path / name
    if content is not None:
        mesh.write_bytes(content)
    proc = cli("run", "--object", str(mesh), "--spec", str(CARTON_SPEC), "--out", str(tmp_path / "out"))
    assert proc.returncode == 2 and needle in proc.stderr and name in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()


@pytest.fixture
def no_work(monkeypatch):
    """Fail the test if a run gets past its checks."""
    import deformsim.pipeline as pipeline

    def started(*_, **__):
        raise AssertionError("the run started its work")

    monkeypatch.setattr(pipeline, "prepare", started)


def test_run_never_writes_into_another_output_nor_replaces_an_input(tmp_path, no_work):
    data = tmp_path / "data"
    (data / "samples").mkdir(parents=True)
    (data / "inputs.json").write_text(json.dumps({"kind": "dataset", "inputs": {}}))
    cfg = load_config("quick", E2E)
    with pytest.raises(UserError, match="holds a deformsim dataset, not a run"):
        run(cfg, data, progress=False)
    real = tmp_path / "run" / "report" / "real"
    (real / "intact").mkdir(parents=True)
    with pytest.raises(UserError, match="the run's report folder .*report contains the real photos"):
        run(cfg, tmp_path / "run", real=real, progress=False)
    photos = tmp_path / "photos"
    photos.mkdir()
    with pytest.raises(UserError, match="--out .*lies inside the backgrounds folder"):
        run(load_config("quick", {**E2E, "composite.backgrounds": str(photos)}), photos / "run", progress=False)
    assert sorted(p.name for p in data.iterdir()) == ["inputs.json", "samples"] and not any(photos.iterdir())


def test_unlabelled_photos_are_checked_before_any_work(tmp_path, no_work):
    from PIL import Image

    few = tmp_path / "few"
    few.mkdir()
    for k in range(3):
        Image.new("RGB", (8, 8), (k, 0, 0)).save(few / f"{k}.png")
    cfg = load_config("quick", E2E)
    with pytest.raises(UserError, match="--unlabelled .*few holds 3 distinct photo"):
        run(cfg, tmp_path / "run", unlabelled=few, progress=False)
    with pytest.raises(UserError, match="--unlabelled folder not found"):
        run(cfg, tmp_path / "run", unlabelled=tmp_path / "nope", progress=False)
    with pytest.raises(UserError, match="the run's adapted model .*contains the unlabelled photos"):
        run(cfg, tmp_path / "run", unlabelled=tmp_path / "run" / "model-adapted" / "photos", progress=False)
    assert not (tmp_path / "run").exists()


def test_a_run_is_never_written_inside_a_folder_of_photos_it_reads(tmp_path, no_work):
    from PIL import Image

    textures = tmp_path / "textures"
    textures.mkdir()
    Image.new("RGB", (8, 8), (90, 60, 30)).save(textures / "wood.png")
    cfg = load_config("quick", {**E2E, "render.surface": {"kinds": ["photo"], "photos": str(textures)}})
    with pytest.raises(UserError, match="--out .*textures/run is or lies inside the surface photo folder"):
        run(cfg, textures / "run", progress=False)
    assert [p.name for p in textures.iterdir()] == ["wood.png"]
