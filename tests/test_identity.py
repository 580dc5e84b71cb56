"""Identity by content: datasets and stage stamps follow the bytes of their inputs and the settings that count.

No Blender: the mesh probe is faked, renders come from fake workers (tests/generate/fakes.py), and the
composite and report stages are replaced by fakes that write only their outputs.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from deformsim.config import Config, load_config
from deformsim.errors import UserError
from deformsim.generate import stage as gen_stage
from deformsim.generate.identity import data_name, data_settings
from deformsim.identity import NEVER, WHEN_SET, digest, file_digest, files_digest, folder_digest, rule_of, when
from deformsim.pipeline import run
from tests.generate.fakes import use_fakes
from tests.util import CARTON_SPEC

COLOUR = "color: [[0.55, 0.55, 0.55], [0.98, 0.98, 0.98]]"


def copy_keeping_times(src: Path, dst: Path) -> None:
    """``cp -p src dst``: dst gets src's bytes and src's modification time."""
    shutil.copyfile(src, dst)
    shutil.copystat(src, dst)


def same_size_pair(tmp_path: Path) -> tuple[Path, Path]:
    a, b = tmp_path / "a.bin", tmp_path / "b.bin"
    a.write_bytes(b"A" * 64)
    b.write_bytes(b"B" * 64)
    os.utime(b, ns=(a.stat().st_atime_ns, a.stat().st_mtime_ns))
    return a, b


def test_digests_follow_bytes_not_size_or_time(tmp_path):
    a, b = same_size_pair(tmp_path)
    before, folder_before = file_digest(a), folder_digest(tmp_path)
    copy_keeping_times(b, a)  # same size, same mtime, other bytes
    assert a.stat().st_mtime_ns == b.stat().st_mtime_ns
    assert file_digest(a) == file_digest(b) != before
    assert folder_digest(tmp_path) != folder_before
    assert files_digest([a], tmp_path) != files_digest([b], tmp_path)  # names count too


# digest(data_settings(cfg)) of configs whose datasets exist: a rule on a field must not move any of them. They were
# rendered before 0.3.3, with Cycles' automatic importance map (the presets set render.world_map 2048 since).
AUTOMATIC_MAP = {"render.world_map": 0}
PINNED = [
    ("quick", {}, "2f3e63a5dbff"),
    ("paper", {}, "081f1b29cd7a"),
    ("quick", {"generate.workers": 3, "generate.n": 16, "generate.backend": "ray", "generate.address": "auto",
      "generate.gather": True, "generate.preview": 0, "generate.recycle_every": 5, "generate.max_retries": 0,
      "pose.drop_frames": 50, "pose.drop_height": 1.0, "composite.matte": "alpha", "train.epochs": 2},
     "2f3e63a5dbff"),
    ("quick", {"pose.mode": "drop"}, "c8195c3c78c2"),
    ("quick", {"pose.mode": "drop", "pose.drop_upright": 0.5, "pose.drop_frames": 100}, "8fa97c0d1365"),
    ("quick", {"camera.fill": [0.4, 0.8], "camera.offset": 0.2, "camera.partial": 0.2, "camera.fstop": [2, 8],
      "camera.lens_mm": [35, 85]}, "ef7086c02c89"),
    ("quick", {"camera.offset": 0.1}, "91ea725540ab"),
    ("quick", {"render.surface": {}}, "29fde8ee8e70"),
    ("quick", {"render.surface": {"kinds": ["cloth"], "scale": [1, 2]}}, "18f7751a133f"),
    ("quick", {"render.shadow": True, "render.dense": False, "render.creases": True}, "c18cc702ca18"),
    ("quick", {"render.threads": 2}, "d7151776a845"),
    ("quick", {"generate.seed": 7, "generate.intact_fraction": 0.3}, "9fe6db05441a"),
    ("quick", {"lighting.area_lights.count": [1, 2], "lighting.area_lights.kinds": ["ring"]}, "7ceab64c5c5c"),
    ("quick", {"deform.sources.bank": 1, "deform.sources.lattice": 0}, "4b914d230383"),
    ("quick", {"render.adaptive": True, "render.view_transform": "AgX", "render.look": "Punchy"}, "60c8ff527a2a"),
    ("quick", {"render.region_visible": {"across_px": 3}}, "43f3bc1ebaf8"),
]


@pytest.mark.parametrize("preset, overrides, pinned", PINNED, ids=[",".join(o) or p for p, o, _ in PINNED])
def test_existing_datasets_keep_their_identity(preset, overrides, pinned):
    assert digest(data_settings(load_config(preset, {**AUTOMATIC_MAP, **overrides}))) == pinned


def test_the_presets_map_makes_new_datasets():
    """A preset's renders with the 2048 map differ from the automatic map's: its datasets are new ones, so a folder
    rendered before is refused, never resumed with other pixels."""
    for preset, _, before in PINNED[:2]:
        now = digest(data_settings(load_config(preset)))
        assert now != before and digest(data_settings(load_config(preset, AUTOMATIC_MAP))) == before


def test_the_rules_sit_on_the_fields():
    assert rule_of(Config, "composite") == rule_of(Config, "train") == NEVER
    assert rule_of(type(Config().generate), "workers") == NEVER
    assert rule_of(type(Config().camera), "fill") == WHEN_SET
    assert rule_of(type(Config().pose), "drop_frames") == when(mode="drop")
    settings = data_settings(load_config("quick"))
    assert list(settings) == ["object", "camera", "pose", "lighting", "deform", "render", "generate"]
    assert settings["generate"] == {"seed": 0, "intact_fraction": 0.5} and settings["pose"] == {"tilt": [0.0, 90.0]}
    assert "fill" not in settings["camera"] and "surface" not in settings["render"]
    assert data_settings(load_config("quick", {"camera.fill": [0.4, 0.8]}))["camera"]["fill"] == [0.4, 0.8]


@pytest.fixture
def part(tmp_path) -> tuple[Path, Path]:
    """A mesh file (never read: the probe is faked) and a copy of the carton spec."""
    mesh, spec = tmp_path / "part.stl", tmp_path / "runspec.yaml"
    mesh.write_bytes(b"solid part\n" + b"\0" * 200)
    spec.write_text(CARTON_SPEC.read_text())
    return mesh, spec


def test_dataset_name_follows_mesh_and_spec_contents(part):
    mesh, spec = part
    cfg = load_config("quick", {"object.mesh": mesh, "object.spec": spec})
    first = data_name(cfg)
    spec.write_text(spec.read_text() + "\n# a comment changes nothing rendered\n")
    assert data_name(cfg) == first
    spec.write_text(spec.read_text().replace(COLOUR, "color: [[0.1, 0.1, 0.1], [0.98, 0.98, 0.98]]"))
    second = data_name(cfg)
    assert second != first
    mesh.write_bytes(b"solid wider part\n" + b"\1" * 200)
    assert data_name(cfg) not in (first, second)


def test_the_same_files_by_other_paths_name_the_same_dataset(part, tmp_path, monkeypatch):
    mesh, spec = part
    first = data_name(load_config("quick", {"object.mesh": mesh, "object.spec": spec}))
    monkeypatch.chdir(tmp_path)  # relative paths to the same files
    assert data_name(load_config("quick", {"object.mesh": mesh.name, "object.spec": spec.name})) == first
    moved = tmp_path / "moved"
    moved.mkdir()
    shutil.copytree(tmp_path, moved / "project", ignore=shutil.ignore_patterns("moved"))
    assert data_name(load_config("quick", {"object.mesh": moved / "project" / mesh.name,
                                           "object.spec": moved / "project" / spec.name})) == first
    assert list(Config(render={"surface": {}, "appearance": {}}).input_paths()) == [
        "mesh", "spec", "HDRI folder", "surface photo folder", "artwork photo folder"]  # every input read by content


@pytest.fixture
def fake_stages(monkeypatch):
    """Stages that write only their outputs; the list of stages each call ran."""
    from deformsim.composite import stage as comp_stage
    from deformsim.evaluate import experiments
    from deformsim.report import html

    calls: list[str] = []
    real_generate = gen_stage.generate

    def generate(*args, **kwargs):
        calls.append("generate")
        return real_generate(*args, **kwargs)

    def composite(data, cfg, name, seed, progress=True):
        calls.append(f"composite:{name}")
        (data / "variants" / name).mkdir(parents=True, exist_ok=True)
        (data / "variants" / name / "manifest.parquet").write_text("fake")

    def run_experiments(data, cfg, out, real_dir=None, progress=True):
        calls.append("report")
        (Path(out) / "models").mkdir(parents=True)
        return {}

    def write_report(metrics, out):
        (Path(out) / "report.html").write_text("report")
        return Path(out) / "report.html"

    use_fakes(monkeypatch)
    monkeypatch.setattr(gen_stage, "generate", generate)
    monkeypatch.setattr(comp_stage, "composite", composite)
    monkeypatch.setattr(experiments, "run_experiments", run_experiments)
    monkeypatch.setattr(html, "write_report", write_report)
    return calls


def test_run_redoes_what_depends_on_an_edited_input(tmp_path, part, fake_stages):
    mesh, spec = part
    real = tmp_path / "real"
    for name in ("intact/a.bmp", "intact/b.bmp", "deformed/c.bmp"):
        (real / name).parent.mkdir(parents=True, exist_ok=True)
        (real / name).write_bytes(name.encode() * 20)
    cfg = load_config("quick", {"object.mesh": mesh, "object.spec": spec, "generate.n": 8})
    out = tmp_path / "run"
    first = run(cfg, out, real=real, progress=False)
    assert fake_stages == ["generate", "composite:procedural", "report"]
    again = run(cfg, out, real=real, progress=False)
    assert again.skipped == ["generate", "composite:procedural", "report"]

    spec.write_text(spec.read_text().replace(COLOUR, "color: [[0.1, 0.1, 0.1], [0.98, 0.98, 0.98]]"))
    edited = run(cfg, out, real=real, progress=False)
    assert edited.skipped == [] and edited.data != first.data  # a new dataset, never a mix

    copy_keeping_times(real / "intact" / "b.bmp", real / "intact" / "a.bmp")  # same size and time
    photos = run(cfg, out, real=real, progress=False)
    assert photos.skipped == ["generate", "composite:procedural"] and "report" in photos.seconds

    mesh.write_bytes(b"solid wider part\n" + b"\1" * 200)
    remeshed = run(cfg, out, real=real, progress=False)
    assert remeshed.skipped == [] and remeshed.data not in (first.data, edited.data)
    assert sorted(p.name for p in out.iterdir() if p.name.startswith("data-")) == sorted(
        {first.data.name, edited.data.name, remeshed.data.name})
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []  # no staging left


def test_run_redoes_composite_when_a_background_photo_changes(tmp_path, fake_stages):
    photos = tmp_path / "photos"
    photos.mkdir()
    (photos / "a.jpg").write_bytes(b"a" * 100)
    (photos / "b.jpg").write_bytes(b"b" * 100)
    cfg = load_config("quick", {"composite.backgrounds": photos, "composite.variants": ["black", "backgrounds"]})
    run(cfg, tmp_path / "run", progress=False)
    copy_keeping_times(photos / "b.jpg", photos / "a.jpg")
    again = run(cfg, tmp_path / "run", progress=False)
    assert again.skipped == ["generate"] and "composite:backgrounds" in again.seconds


def test_run_redoes_generate_when_an_artwork_photo_changes_and_never_replaces_the_folder(tmp_path, fake_stages):
    from PIL import Image

    photos = tmp_path / "art"
    photos.mkdir()
    for name, colour in (("a.png", (200, 30, 30)), ("b.png", (30, 30, 200))):
        Image.new("RGB", (8, 8), colour).save(photos / name)
    cfg = load_config("quick", {"render.appearance": {"photos": photos}, "generate.n": 8})
    first = run(cfg, tmp_path / "run", progress=False)
    shutil.copyfile(photos / "b.png", photos / "a.png")
    again = run(cfg, tmp_path / "run", progress=False)
    assert again.skipped == [] and again.data != first.data  # a new dataset from the new artwork
    inside = load_config("quick", {"render.appearance": {"photos": tmp_path / "run" / "report" / "art"}})
    shutil.copytree(photos, tmp_path / "run" / "report" / "art")
    with pytest.raises(UserError, match="the run's report folder .*report contains the artwork photo folder"):
        run(inside, tmp_path / "run", progress=False)
