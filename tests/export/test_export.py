"""Exports: ImageFolder, COCO (checked with pycocotools) and anomalib's Folder layout, from small dense datasets."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pandas as pd
import pytest
import yaml
from PIL import Image
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO

from deformsim.composite.stage import composite
from deformsim.config import CompositeConfig
from deformsim.dataset.dense import read_mask
from deformsim.errors import UserError
from deformsim.export import export_data
from deformsim.export.files import place
from tests.fake_dense import make_dense_dataset


@pytest.fixture(scope="module")
def dense(tmp_path_factory):
    """A dense dataset with a framed and flipped composite ('framed', the default variant)."""
    root = make_dense_dataset(tmp_path_factory.mktemp("dense") / "data")
    cfg = CompositeConfig(matte="alpha", object_fill=(0.8, 0.8), flip_part=0.5, workers=1)
    composite(root, cfg, "framed", seed=1, progress=False)
    return root


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    """A dataset without dense maps, with a framed composite."""
    root = make_dense_dataset(tmp_path_factory.mktemp("plain") / "data", dense=False)
    composite(root, CompositeConfig(matte="alpha", object_fill=(0.8, 0.8), workers=1), "framed", seed=1, progress=False)
    return root


def _variant(root, name="framed"):
    return pd.read_parquet(root / "variants" / name / "manifest.parquet").set_index("id")


def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_imagefolder_classes_and_links(dense, tmp_path):
    res = export_data(dense, tmp_path / "if", "imagefolder", progress=False)
    out = tmp_path / "if"
    assert res.variant == "framed" and res.summary["classes"] == {"deformed": 4, "intact": 4}
    for iid, row in _variant(dense).iterrows():
        label = "deformed" if iid[5] in "13" else "intact"
        exported = out / label / f"{iid}.png"
        assert os.path.samefile(exported, dense / row["image"])  # hard-linked, same filesystem
    labels = pd.read_csv(out / "labels.csv")
    assert len(labels) == 8 and (labels["y"] == labels["label"].eq("deformed")).all()
    assert labels["visible_disp_mm"].max() == pytest.approx(3.0)
    assert (dense / "variants" / "framed" / "images" / "000000_c0.png").is_file()  # linked, never moved


@pytest.mark.torch
def test_imagefolder_loads_with_torchvision(dense, tmp_path):
    from torchvision.datasets import ImageFolder

    export_data(dense, tmp_path / "if", "imagefolder", variant="green", progress=False)
    ds = ImageFolder(str(tmp_path / "if"))
    assert ds.classes == ["deformed", "intact"] and len(ds) == 8
    assert sum(1 for _, c in ds.samples if c == ds.class_to_idx["deformed"]) == 4


def test_place_copies_when_it_cannot_link(tmp_path, monkeypatch):
    src = tmp_path / "a.png"
    src.write_bytes(b"x")

    def refuse(*_):
        raise OSError(18, "Invalid cross-device link")

    monkeypatch.setattr(os, "link", refuse)
    assert place(src, tmp_path / "sub" / "b.png") is False
    assert (tmp_path / "sub" / "b.png").read_bytes() == b"x" and src.is_file()


@pytest.mark.parametrize("variant", ["framed", "black"])
def test_coco_validates_with_pycocotools(dense, tmp_path, variant):
    out = tmp_path / "coco"
    res = export_data(dense, out, "coco", variant=variant, progress=False)
    coco = COCO(str(out / "annotations" / "instances.json"))
    assert {c["name"] for c in coco.loadCats(coco.getCatIds())} == {"intact", "deformed"}
    assert len(coco.getImgIds()) == 8 and len(coco.getAnnIds()) == 7 == res.summary["annotations"]  # one part unseen
    table = _variant(dense) if variant == "framed" else pd.read_parquet(dense / "manifest.parquet").set_index("id")
    for img in coco.loadImgs(coco.getImgIds()):
        row = table.loc[img["deformsim_id"]]
        with Image.open(out / img["file_name"]) as im:
            assert im.size == (img["width"], img["height"])
        anns = coco.loadAnns(coco.getAnnIds(imgIds=img["id"]))
        truth = read_mask(dense / row["mask"])
        if not truth.any():
            assert anns == []
            continue
        (ann,) = anns
        decoded = coco.annToMask(ann).astype(bool)
        assert (decoded & truth).sum() / (decoded | truth).sum() == 1.0
        assert ann["area"] == mask_utils.area(ann["segmentation"]) == truth.sum()
        assert ann["bbox"] == [row["bbox_x0"], row["bbox_y0"], row["bbox_x1"] - row["bbox_x0"],
                               row["bbox_y1"] - row["bbox_y0"]]
        assert coco.loadCats(ann["category_id"])[0]["name"] == ann["attributes"]["label"]
        assert ann["attributes"]["deformed"] == (ann["attributes"]["label"] == "deformed")
        assert ann["attributes"]["visible_disp_mm"] == pytest.approx(row["visible_disp_mm"])
        assert ann["attributes"]["families"] == (["crush"] if ann["attributes"]["deformed"] else [])


def test_coco_without_dense_maps(plain, tmp_path):
    export_data(plain, tmp_path / "coco", "coco", variant="black", progress=False)
    coco = COCO(str(tmp_path / "coco" / "annotations" / "instances.json"))
    img = coco.loadImgs(coco.getImgIds())[0]
    with Image.open(plain / "images" / "rgba" / f"{img['deformsim_id']}.png") as im:
        alpha = np.asarray(im.getchannel("A")) >= 128
    assert np.array_equal(coco.annToMask(coco.loadAnns(coco.getAnnIds(imgIds=img["id"]))[0]).astype(bool), alpha)
    with pytest.raises(UserError, match="render.dense") as err:
        export_data(plain, tmp_path / "coco2", "coco", variant="framed", progress=False)
    assert "\n" not in str(err.value) and not (tmp_path / "coco2").exists()


def test_anomalib_folder_layout(dense, tmp_path):
    out = tmp_path / "ano"
    export_data(dense, out, "anomalib", progress=False)
    args = yaml.safe_load((out / "folder.yaml").read_text())
    assert args["class_path"] == "anomalib.data.Folder"
    a = args["init_args"]
    assert a["root"] == str(out.resolve())
    good, test_good, bad, masks = (out / a[k] for k in ("normal_dir", "normal_test_dir", "abnormal_dir", "mask_dir"))
    v = _variant(dense)
    assert sorted(p.stem for p in bad.iterdir()) == sorted(v.index[v.index.str[5].isin(["1", "3"])])
    # masks: same file names as the abnormal images, binary 0/255, the same size, the variant's region maps
    assert sorted(p.name for p in masks.iterdir()) == sorted(p.name for p in bad.iterdir())
    for p in masks.iterdir():
        m = np.asarray(Image.open(p))
        assert set(np.unique(m)) <= {0, 255} and m.shape == np.asarray(Image.open(bad / p.name)).shape[:2]
        assert np.array_equal(m >= 128, read_mask(dense / v.loc[p.stem, "region"]))
    assert any(np.asarray(Image.open(p)).any() for p in masks.iterdir())
    # the normal images: all intact ones, the cameras of one scene on one side
    train, held = {p.stem for p in good.iterdir()}, {p.stem for p in test_good.iterdir()}
    assert train | held == {"000000_c0", "000000_c1", "000002_c0", "000002_c1"} and train and held
    assert not {i[:6] for i in train} & {i[:6] for i in held}
    assert "Folder(" in (out / "README.txt").read_text()


def test_anomalib_without_dense_maps_has_no_masks(plain, tmp_path):
    export_data(plain, tmp_path / "ano", "anomalib", progress=False)
    args = yaml.safe_load((tmp_path / "ano" / "folder.yaml").read_text())["init_args"]
    assert "mask_dir" not in args and not (tmp_path / "ano" / "ground_truth").exists()
    assert "No masks" in (tmp_path / "ano" / "README.txt").read_text()
    assert len(list((tmp_path / "ano" / "test" / "deformed").iterdir())) == 4


def test_out_is_claimed_before_work_and_replaced_whole(dense, tmp_path):
    out = tmp_path / "exp"
    export_data(dense, out, "imagefolder", progress=False)
    before = _files(out)
    with pytest.raises(UserError, match="--overwrite"):
        export_data(dense, out, "coco", progress=False)
    assert _files(out) == before
    export_data(dense, out, "coco", overwrite=True, progress=False)
    assert "intact" not in {p.name for p in out.iterdir()} and (out / "annotations" / "instances.json").is_file()
    assert json.loads((out / "export.json").read_text())["format"] == "coco"
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep")
    with pytest.raises(UserError, match="never"):
        export_data(dense, other, "coco", overwrite=True, progress=False)
    assert (other / "notes.txt").read_text() == "keep"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging folder left


@pytest.mark.parametrize("call, match", [
    (dict(fmt="yolo"), "'yolo'"),
    (dict(fmt="coco", variant="nope"), "'nope'"),
    (dict(fmt="coco", out="inside"), "lies inside the dataset"),
])
def test_bad_input_is_one_line(dense, tmp_path, call, match):
    out = dense / "x" if call.pop("out", None) else tmp_path / "o"
    with pytest.raises(UserError, match=match) as err:
        export_data(dense, out, call.pop("fmt"), progress=False, **call)
    assert "\n" not in str(err.value) and not out.exists()


def test_engine_exports(dense, tmp_path):
    from deformsim import Engine

    res = Engine().export_data(dense, tmp_path / "e", "imagefolder", variant="black")
    assert res.summary["images"] == 8 and len(list((tmp_path / "e" / "intact").iterdir())) == 4


@pytest.mark.parametrize("case", ["absolute", "dotdot", "symlink", "not-an-image", "fifo"])
def test_every_file_read_is_an_image_inside_the_dataset(tmp_path, case):
    root = make_dense_dataset(tmp_path / "data", n_samples=2, cameras=1)
    outside = tmp_path / "secret.png"
    shutil.copyfile(root / "images" / "black" / "000000_c0.png", outside)  # an image, so only its place is wrong
    manifest = pd.read_parquet(root / "manifest.parquet")
    target = root / "images" / "black" / "000001_c0.png"
    if case == "absolute":
        manifest.loc[1, "black"] = str(outside)
    elif case == "dotdot":
        manifest.loc[1, "black"] = "images/../../secret.png"
    elif case == "symlink":
        target.unlink()
        target.symlink_to(outside)
    elif case == "not-an-image":
        target.write_text("not a picture")
    else:
        target.unlink()
        os.mkfifo(target)  # reading it would hang
    manifest.to_parquet(root / "manifest.parquet")
    needle = {"not-an-image": "does not open as an image", "fifo": "is not a file"}.get(case, "lies outside the dataset")
    for fmt in ("imagefolder", "anomalib"):
        with pytest.raises(UserError, match=f"row 000001_c0.*{needle}") as err:
            export_data(root, tmp_path / "out", fmt, variant="black", progress=False)
        assert "\n" not in str(err.value) and not (tmp_path / "out").exists()


def test_a_symlink_inside_the_dataset_is_followed(tmp_path):
    root = make_dense_dataset(tmp_path / "data", n_samples=2, cameras=1)
    link = root / "images" / "black" / "000001_c0.png"
    link.unlink()
    link.symlink_to(root / "images" / "green" / "000001_c0.png")
    export_data(root, tmp_path / "out", "imagefolder", variant="black", progress=False)
    assert os.path.samefile(tmp_path / "out" / "deformed" / "000001_c0.png", root / "images" / "green" / "000001_c0.png")


def test_the_readme_says_the_export_hard_links_and_copy_makes_it_independent(dense, tmp_path):
    linked = export_data(dense, tmp_path / "linked", "anomalib", progress=False)
    assert linked.summary["linked"] == 8
    assert "hard links to the dataset's own files: editing one in place changes the dataset" in \
        (tmp_path / "linked" / "README.txt").read_text()
    res = export_data(dense, tmp_path / "copy", "anomalib", progress=False, copy=True)
    assert res.summary["linked"] == 0 and json.loads((tmp_path / "copy" / "export.json").read_text())["copy"] is True
    assert "Every file here is a copy" in (tmp_path / "copy" / "README.txt").read_text()
    for exported in (tmp_path / "copy").rglob("*.png"):
        original = dense / "variants" / "framed" / "images" / exported.name
        if "ground_truth" not in exported.parts:
            assert not os.path.samefile(exported, original) and exported.read_bytes() == original.read_bytes()
        assert os.stat(exported).st_nlink == 1  # masks too: nothing shared with the dataset


def test_overwrite_never_replaces_a_dataset(dense, tmp_path):
    other = tmp_path / "other"
    shutil.copytree(dense, other)
    (other / "inputs.json").write_text(json.dumps({"kind": "dataset", "inputs": {}}))
    before = _files(other)
    with pytest.raises(UserError, match="OUT .*other holds a deformsim dataset, not an export"):
        export_data(dense, other, "coco", overwrite=True, progress=False)
    assert _files(other) == before
