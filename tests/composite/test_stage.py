"""The composite stage and command: variants, determinism, bad backgrounds, atomic output."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext

import cv2
import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from deformsim.cli.composite import register
from deformsim.composite.backgrounds import BackgroundWarning
from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.variants import list_variants, variant_table
from deformsim.errors import UserError
from tests.fake_dense import make_dense_dataset
from tests.util import ROOT, child_pids, cli, dead_tag


def _photos(tmp_path, backgrounds_dir, n=3):
    folder = tmp_path / "bg"
    (folder / "nested").mkdir(parents=True)
    srcs = sorted(backgrounds_dir.glob("*.jpg"))[:n]
    for i, p in enumerate(srcs):
        shutil.copy(p, (folder / "nested" if i % 2 else folder) / p.name)
    return folder


def _snapshot(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_procedural_variant_is_readable_and_counted(dataset):
    made = composite(dataset, CompositeConfig(), None, seed=0, progress=False)
    variant = made.folder
    assert variant == dataset / "variants" / "procedural"
    iou = pd.read_parquet(variant / "manifest.parquet")["matte_iou"].dropna().tolist()
    assert (made.images, made.surfaces, made.matte_iou) == (8, 0, iou) and len(iou) == 8
    assert "procedural" in list_variants(dataset)
    table = variant_table(dataset, "procedural")
    assert len(table) == 8 and set(table["y"]) == {0, 1}
    assert table["background"].str.startswith("procedural:").all()
    assert all(os.path.isfile(p) for p in table["path"])
    assert not list((dataset / "variants").glob(".staging*"))


def test_same_seed_same_composites_any_workers(dataset):
    one = composite(dataset, CompositeConfig(workers=1), "a", seed=5, progress=False).folder
    two = composite(dataset, CompositeConfig(workers=2), "b", seed=5, progress=False).folder
    other = composite(dataset, CompositeConfig(workers=1), "c", seed=6, progress=False).folder
    a, b, c = (pd.read_parquet(v / "manifest.parquet") for v in (one, two, other))
    cols = ["id", "background", "bg_x", "bg_y", "bg_scale", "bg_flip"]
    pd.testing.assert_frame_equal(a[cols], b[cols])
    assert _snapshot(one / "images") == _snapshot(two / "images")
    assert not a["background"].equals(c["background"])


def test_photo_backgrounds_recorded(dataset, tmp_path, backgrounds_dir):
    folder = _photos(tmp_path, backgrounds_dir)
    cfg = CompositeConfig(backgrounds=folder, scale_jitter=(1.0, 1.5))
    variant = composite(dataset, cfg, None, seed=2, progress=False).folder
    assert variant.name == "backgrounds"
    df = pd.read_parquet(variant / "manifest.parquet")
    names = {str(p.relative_to(folder)) for p in folder.rglob("*.jpg")}
    assert set(df["background"]) <= names and any("nested/" in n for n in df["background"])
    assert df["bg_scale"].between(1.0, 1.5).all() and df["bg_x"].between(0, 1).all()
    assert df["bg_flip"].dtype == bool


def test_corrupt_backgrounds_skipped_and_named(dataset, tmp_path):
    folder = tmp_path / "bg"
    folder.mkdir()
    rng = np.random.default_rng(0)
    cv2.imwrite(str(folder / "good.png"), rng.integers(0, 255, (120, 160, 3), dtype=np.uint8))
    (folder / "garbage.jpg").write_bytes(b"not an image")
    _, jpg = cv2.imencode(".jpg", rng.integers(0, 255, (300, 400, 3), dtype=np.uint8))
    (folder / "truncated.jpg").write_bytes(jpg.tobytes()[: len(jpg) // 3])
    (folder / "notes.txt").write_text("ignored")
    with pytest.warns(BackgroundWarning) as record:
        variant = composite(dataset, CompositeConfig(backgrounds=folder), "bad", seed=0, progress=False).folder
    messages = " ".join(str(w.message) for w in record)
    assert "garbage.jpg" in messages and "truncated.jpg" in messages and "notes.txt" not in messages
    assert set(pd.read_parquet(variant / "manifest.parquet")["background"]) == {"good.png"}


@pytest.mark.parametrize("make", ["missing", "empty", "only_bad"])
def test_bad_folder_fails_before_work(dataset, tmp_path, make):
    existing = composite(dataset, CompositeConfig(), "backgrounds", seed=0, progress=False).folder
    before = _snapshot(existing)
    folder = tmp_path / "bg"
    if make != "missing":
        folder.mkdir()
    if make == "only_bad":
        (folder / "x.jpg").write_bytes(b"junk")
    with pytest.warns(BackgroundWarning) if make == "only_bad" else nullcontext():
        with pytest.raises(UserError) as err:
            composite(dataset, CompositeConfig(backgrounds=folder), None, seed=0, progress=False)
    assert "\n" not in str(err.value) and str(folder) in str(err.value)
    assert _snapshot(existing) == before


def test_failed_run_keeps_existing_variant(dataset):
    existing = composite(dataset, CompositeConfig(), "procedural", seed=0, progress=False).folder
    before = _snapshot(existing)
    victim = sorted((dataset / "images" / "green").glob("*.png"))[-1]
    victim.write_bytes(b"broken png")
    with pytest.raises(UserError, match=victim.name):
        composite(dataset, CompositeConfig(workers=2), "procedural", seed=9, progress=False)
    assert _snapshot(existing) == before
    assert not list((dataset / "variants").glob(".staging*"))


def test_bad_variant_name(dataset):
    with pytest.raises(UserError, match="variant name"):
        composite(dataset, CompositeConfig(), "../x", seed=0, progress=False)
    with pytest.raises(UserError, match="variant name"):
        composite(dataset, CompositeConfig(), "green", seed=0, progress=False)


def test_cli(dataset, tmp_path, backgrounds_dir):
    app = typer.Typer()
    register(app)
    app.command("noop")(lambda: None)  # keep `composite` a subcommand
    runner = CliRunner()
    folder = _photos(tmp_path, backgrounds_dir, 2)
    res = runner.invoke(app, ["composite", str(dataset), "--backgrounds", str(folder), "--seed", "3",
                              "--workers", "1", "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "8 composites" in res.output and (dataset / "variants" / "backgrounds" / "manifest.parquet").is_file()
    iou = pd.read_parquet(dataset / "variants" / "backgrounds" / "manifest.parquet")["matte_iou"]
    assert f"matte IoU vs exact alpha: mean {iou.mean():.4f}, min {iou.min():.4f}" in " ".join(res.output.split())
    res = runner.invoke(app, ["composite", str(dataset), "--matte", "alpha", "--name", "exact", "--no-progress"])
    assert res.exit_code == 0, res.output
    assert pd.read_parquet(dataset / "variants" / "exact" / "manifest.parquet")["matte"].eq("alpha").all()
    res = runner.invoke(app, ["composite", str(dataset), "--backgrounds", str(tmp_path / "nope")])
    assert res.exit_code == 2 and "background folder not found" in res.output



def test_balanced_photos_use_each_photo_equally_behind_each_class():
    from collections import Counter

    from deformsim.composite.stage import balanced_photos

    ids = [f"{i:06d}_c{c}" for i in range(50) for c in range(4)]
    labels = [i % 2 for i in range(50) for _ in range(4)]
    first = balanced_photos(ids, labels, 7, seed=3)
    assert set(first) == set(ids)
    for y in (0, 1):
        counts = Counter(first[i] for i, label in zip(ids, labels) if label == y)
        assert set(counts) == set(range(7)) and max(counts.values()) - min(counts.values()) <= 1
    assert first == balanced_photos(list(reversed(ids)), list(reversed(labels)), 7, seed=3)  # order-free
    assert first != balanced_photos(ids, labels, 7, seed=4)


def test_framing_and_effects_are_seeded_recorded_and_fill_the_frame(dataset):
    from deformsim.composite.framing import object_box
    from deformsim.config import CameraEffects

    cfg = CompositeConfig(matte="alpha", object_fill=(0.8, 0.8), fill_offset=0.0, effects=CameraEffects(), workers=1)
    one = composite(dataset, cfg, "framed", seed=2, progress=False).folder
    two = composite(dataset, cfg.model_copy(update={"workers": 2}), "framed2", seed=2, progress=False).folder
    assert _snapshot(one / "images") == _snapshot(two / "images")
    df = pd.read_parquet(one / "manifest.parquet")
    assert {"frame_fill", "frame_side", "fx_exposure", "fx_noise", "fx_jpeg_quality"} <= set(df.columns)
    plain = composite(dataset, CompositeConfig(matte="alpha", object_fill=(0.8, 0.8), fill_offset=0.0), "f3",
                      seed=2, progress=False).folder
    rgba = cv2.imread(str(dataset / "images" / "rgba" / "000000_c0.png"), cv2.IMREAD_UNCHANGED)
    before = object_box(rgba[..., 3] / 255.0)
    size = rgba.shape[0]
    row = pd.read_parquet(plain / "manifest.parquet").iloc[0]
    # the object's longer side now fills 80 % of the frame, unless the render could not be cropped that far
    side = max(before[2] - before[0], before[3] - before[1])
    assert row["frame_side"] == pytest.approx(min(side / 0.8, size), abs=1e-6)


def _fake_dataset(root, n_samples, size):
    return make_dense_dataset(root, n_samples=n_samples, cameras=2, size=size, dense=False)


def test_a_failing_command_exits_with_its_code_every_time(tmp_path):
    """pyarrow's thread pool, once started by a read, could abort the interpreter at exit (134) after the error line."""
    data = _fake_dataset(tmp_path / "data", 2, 32)
    args = ("composite", str(data), "--backgrounds", str(tmp_path / "nonexistent"), "--no-progress")
    with ThreadPoolExecutor(4) as pool:  # side by side: a loaded machine is where the abort showed
        runs = list(pool.map(lambda _: cli(*args), range(12)))
    assert [r.returncode for r in runs] == [2] * 12, [r.stderr[-300:] for r in runs if r.returncode != 2]
    assert all(r.stderr.startswith("error: background folder not found") for r in runs)


def _alive(pid: int) -> bool:
    try:
        return open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads child processes from /proc")
def test_kill_9_ends_the_workers_and_the_next_run_removes_the_staging_folder(tmp_path):
    data = _fake_dataset(tmp_path / "data", 60, 256)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.Popen([sys.executable, "-m", "deformsim.cli", "composite", str(data), "--workers", "2",
                             "--no-progress"], cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(workers) < 2 and proc.poll() is None and time.monotonic() < deadline:
            workers = child_pids(proc.pid)
            time.sleep(0.02)
        assert len(workers) == 2 and proc.poll() is None, "the run ended before its workers were seen"
        time.sleep(0.3)  # mid-run: the workers are compositing
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        deadline = time.monotonic() + 10
        while any(map(_alive, workers)) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not [pid for pid in workers if _alive(pid)], "workers outlived their killed parent"
    finally:
        proc.kill()
        for pid in workers:  # a survivor of an old build: ours to end
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)
    left = sorted(p.name for p in (data / "variants").iterdir())
    assert [n for n in left if n.startswith(".procedural.staging-")], left  # what the killed run left
    composite(data, CompositeConfig(workers=1), None, seed=0, progress=False)
    assert sorted(p.name for p in (data / "variants").iterdir()) == ["procedural"]
    assert len(variant_table(data, "procedural")) == 120


def test_a_staging_folder_is_never_taken_for_a_variant(dataset):
    """What a run killed just before its swap left beside the variant (its manifest written) is no variant, and
    the next run removes it."""
    composite(dataset, CompositeConfig(workers=1), "comp", seed=0, progress=False)
    variants = dataset / "variants"
    left = variants / f".comp.staging-{dead_tag()}-1a2b3c4d"  # the owner tag of a process that has ended
    shutil.copytree(variants / "comp", left)
    assert list_variants(dataset) == ["black", "green", "comp"]
    composite(dataset, CompositeConfig(workers=1), "comp", seed=1, progress=False)
    assert sorted(p.name for p in variants.iterdir()) == ["comp"]


@pytest.mark.parametrize("balance", [False, True])
def test_paired_twins_share_each_images_composite_draws(dataset, tmp_path, balance):
    """generate.paired: an intact image is composited with its deformed twin's background, framing and camera
    effects (manifest column ``pair``), balanced backgrounds too; without the column each image draws its own."""
    photos, rng = tmp_path / "photos", np.random.default_rng(0)
    photos.mkdir()
    for i in range(6):
        cv2.imwrite(str(photos / f"p{i}.png"), rng.integers(0, 256, (80, 120, 3), dtype=np.uint8))
    cfg = CompositeConfig(backgrounds=photos, effects={}, object_fill=(0.5, 0.9), balance_backgrounds=balance)
    cols = ["background", "bg_x", "bg_y", "bg_scale", "bg_flip", "fx_exposure", "fx_noise"]

    def twins(variant):
        df = pd.read_parquet(variant / "manifest.parquet").set_index("id")
        ids = [i for i in df.index if i.startswith("000001_")]
        return df.loc[ids, cols].reset_index(drop=True), df.loc[[i.replace("000001", "000000") for i in ids],
                                                                   cols].reset_index(drop=True)

    intact, damaged = twins(composite(dataset, cfg, "own", seed=4, progress=False).folder)
    assert not intact.equals(damaged)
    manifest = dataset / "manifest.parquet"
    df = pd.read_parquet(manifest)
    assert sorted(df.groupby("sample")["y"].first()) == [0, 1]  # sample 0 and its intact twin, sample 1
    df.assign(pair=0).to_parquet(manifest, index=False)
    intact, damaged = twins(composite(dataset, cfg, "paired", seed=4, progress=False).folder)
    pd.testing.assert_frame_equal(intact, damaged)
