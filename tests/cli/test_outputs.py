"""Outputs are never silently replaced or mixed, and every output path is checked before any work.

Covered: train/report --out and --overwrite (never onto another kind of output, nor onto their own inputs); export,
evaluate, predict and spec preview targets (a folder, a file in the way, an unwritable place); the --real folder
rule. A small "generated" dataset is made from the blob images (no Blender).
"""

from __future__ import annotations

import json
import os
import shutil
import time
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from deformsim.cli.app import app

pytestmark = pytest.mark.torch

TRAIN = ["--epochs", "1", "--weights", "none", "--no-progress"]


def invoke(*args: str):
    return CliRunner().invoke(app, [str(a) for a in args])


def one_line_error(res, code: int = 2) -> str:
    text = res.output.strip()
    assert res.exit_code == code, res.output
    assert "Traceback" not in text and len(text.splitlines()) == 1 and text.startswith("error:"), text
    return text


@pytest.fixture(scope="module")
def dataset(blobs, tmp_path_factory) -> Path:
    """A generated-dataset layout over the blob images: 12 samples (6 per class) of one camera."""
    root = tmp_path_factory.mktemp("blobdata") / "data"
    rows = []
    for i, r in enumerate(pd.concat([blobs[blobs.y == 0].head(6), blobs[blobs.y == 1].head(6)]).itertuples()):
        iid = f"{i:06d}_c0"
        for kind in ("rgba", "black", "green"):
            (root / "images" / kind).mkdir(parents=True, exist_ok=True)
            (root / "images" / kind / f"{iid}.png").write_bytes(Path(r.path).read_bytes())
        rows.append({"id": iid, "sample": i, "camera": 0, "label": r.label, "y": r.y,
                     **{k: f"images/{k}/{iid}.png" for k in ("rgba", "black", "green")}})
    pd.DataFrame(rows).to_parquet(root / "manifest.parquet")
    (root / "samples").mkdir()
    (root / "config.yaml").write_text("generate: {n: 12}\n")
    (root / "inputs.json").write_text(json.dumps({"kind": "dataset", "inputs": {}}))  # as generate records it
    return root


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def config(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "c.yaml"
    path.write_text("train: {image_size: 64, batch_size: 8}\n")
    return path


@pytest.fixture(scope="module")
def model(dataset, config, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("model") / "m"
    res = invoke("train", dataset, "--variant", "black", "--out", out, "--config", config, *TRAIN)
    assert res.exit_code == 0, res.output
    return out


@pytest.fixture(scope="module")
def real(blobs, tmp_path_factory) -> Path:
    """Photos in intact/ and deformed/, one of them in a subfolder of intact/."""
    root = tmp_path_factory.mktemp("real")
    for r in pd.concat([blobs[blobs.y == 0].tail(3), blobs[blobs.y == 1].tail(2)]).itertuples():
        (root / r.label).mkdir(exist_ok=True)
        (root / r.label / Path(r.path).name).write_bytes(Path(r.path).read_bytes())
    (root / "intact" / "unsure").mkdir()
    sorted((root / "intact").glob("*.png"))[0].rename(root / "intact" / "unsure" / "x.png")
    return root


def test_train_refuses_a_model_with_other_settings_and_overwrite_replaces_it_whole(dataset, config, tmp_path):
    out = tmp_path / "m"
    assert invoke("train", dataset, "--variant", "black", "--out", out, "--config", config, *TRAIN).exit_code == 0
    # the same command again: the same settings, so the model is replaced
    assert invoke("train", dataset, "--variant", "black", "--out", out, "--config", config, *TRAIN).exit_code == 0
    first = (out / "model.pt").read_bytes()
    res = invoke("train", dataset, "--variant", "green", "--out", out, "--config", config, *TRAIN)
    assert "other settings (inputs.variant: 'black' there, 'green' now)" in one_line_error(res)
    assert "--overwrite" in res.output and (out / "model.pt").read_bytes() == first
    (out / "stale.txt").write_text("from the old model")
    res = invoke("train", dataset, "--variant", "green", "--out", out, "--config", config, "--overwrite", *TRAIN)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["inputs.json", "model.pt", "train.json"]
    assert json.loads((out / "inputs.json").read_text())["inputs"]["variant"] == "green"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m"]  # no staging or old copy left beside it


def test_train_refuses_a_file_and_a_foreign_folder(dataset, config, tmp_path):
    (tmp_path / "file").write_text("x")
    assert "is a file" in one_line_error(invoke("train", dataset, "--out", tmp_path / "file", "--config", config))
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    for extra in ([], ["--overwrite"]):
        res = invoke("train", dataset, "--out", tmp_path / "mine", "--config", config, *extra, *TRAIN)
        assert "holds files but no deformsim model" in one_line_error(res)
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


def test_report_refuses_other_settings_and_overwrite_leaves_nothing_stale(dataset, config, tmp_path):
    out = tmp_path / "rep"
    res = invoke("report", dataset, "--out", out, "--config", config, "--variants", "black,green", *TRAIN)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (out / "models").iterdir()) == ["black_split", "green_split"]
    res = invoke("report", dataset, "--out", out, "--config", config, "--variants", "black", *TRAIN)
    assert "holds a report made with other settings (settings.variants" in one_line_error(res)
    res = invoke("report", dataset, "--out", out, "--config", config, "--variants", "black", "--overwrite", *TRAIN)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (out / "models").iterdir()) == ["black_split"]
    assert "pca_features_green.png" not in {p.name for p in out.iterdir()}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]
    (tmp_path / "file").write_text("x")
    assert "is a file" in one_line_error(invoke("report", dataset, "--out", tmp_path / "file", *TRAIN))


def test_overwrite_never_replaces_a_dataset_nor_an_input(dataset, config, tmp_path):
    copy = tmp_path / "D2"
    shutil.copytree(dataset, copy)
    before = _files(copy)
    for command in (["train", dataset, "--variant", "black"], ["report", dataset]):
        for extra in (["--overwrite"], []):
            res = invoke(*command, "--out", copy, "--config", config, *extra, *TRAIN)
            kind = command[0].replace("train", "model")
            assert f"holds a deformsim dataset, not a {kind}" in one_line_error(res), command + extra
    assert _files(copy) == before
    res = invoke("train", copy, "--variant", "black", "--out", copy, "--overwrite", "--config", config, *TRAIN)
    assert "is the training data" in one_line_error(res)
    res = invoke("report", copy, "--out", tmp_path, "--overwrite", "--config", config, *TRAIN)
    assert "contains the dataset" in one_line_error(res)
    assert _files(copy) == before


def test_export_checks_its_path_before_reading_the_model(model, tmp_path):
    (tmp_path / "file").write_text("x")
    (tmp_path / "dir").mkdir()
    cases = {tmp_path / "dir": "is a folder", tmp_path / "file" / "m.onnx": "is a file, not a folder",
             Path("/sys/m.onnx"): "cannot write in /sys"}
    for target, needle in cases.items():
        t0 = time.perf_counter()
        assert needle in one_line_error(invoke("export", tmp_path / "no-model", "--onnx", target))
        assert time.perf_counter() - t0 < 5
    assert invoke("export", model, "--onnx", tmp_path / "sub" / "m.onnx").exit_code == 0


def test_evaluate_and_predict_check_their_outputs_first(model, real, tmp_path):
    res = invoke("evaluate", model, "--real", real, "-o", tmp_path)
    assert "is a folder" in one_line_error(res)
    res = invoke("predict", model, real, "--csv", tmp_path)
    assert "is a folder" in one_line_error(res)


def test_spec_preview_checks_out_before_rendering(tmp_path):
    (tmp_path / "file").write_text("x")
    t0 = time.perf_counter()
    res = invoke("spec", "preview", "--out", tmp_path / "file" / "keys.png")
    assert "is a file, not a folder" in one_line_error(res)
    assert time.perf_counter() - t0 < 5  # no Blender started


def test_the_real_folder_rule_is_stated_and_what_was_found_is_listed(model, real):
    for command in (["evaluate"], ["report"], ["run"]):
        help_text = " ".join(invoke(*command, "--help").output.replace("│", " ").split())
        assert "subfolders included" in help_text, command
    res = invoke("evaluate", model, "--real", real)
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "3 intact (intact/ 2, intact/unsure/ 1), 2 deformed (deformed/ 2)" in text


def test_show_never_writes_over_its_own_dataset(dataset, tmp_path):
    """`show DATA --out DATA/manifest.parquet` overwrote its input: the dataset was unreadable after."""
    copy = shutil.copytree(dataset, tmp_path / "data")
    before = _files(copy)
    for target in (copy / "manifest.parquet", copy / "images" / "black" / "000000_c0.png", copy / "new.png"):
        res = invoke("show", copy, "--variant", "black", "--out", target, "--count", "2")
        assert f"lies inside the deformsim dataset {copy}" in one_line_error(res)
    assert _files(copy) == before
    assert invoke("show", copy, "--variant", "black", "--out", tmp_path / "sheet.png", "--count", "2").exit_code == 0


def test_export_and_predict_never_write_into_another_output(dataset, model, real, config, tmp_path):
    """`export --onnx` and `predict --csv` overwrote another model's model.pt or a dataset's manifest.parquet."""
    other = tmp_path / "other"
    assert invoke("train", dataset, "--variant", "black", "--out", other, "--config", config, *TRAIN).exit_code == 0
    data = shutil.copytree(dataset, tmp_path / "data")
    kept = {other: _files(other), data: _files(data), model: _files(model)}
    for target, kind in ((other / "model.pt", "model"), (data / "manifest.parquet", "dataset"),
                         (model / "train.json", "model"), (data / "images" / "sub" / "x.onnx", "dataset")):
        assert f"lies inside the deformsim {kind}" in one_line_error(invoke("export", model, "--onnx", target))
        csv = target.with_suffix(".csv") if target.suffix == ".onnx" else target
        assert f"lies inside the deformsim {kind}" in one_line_error(invoke("predict", model, real, "--csv", csv))
        assert "lies inside the deformsim" in one_line_error(invoke("evaluate", model, "--real", real, "-o", csv))
    assert {k: _files(k) for k in kept} == kept


@pytest.mark.parametrize("command", ["train", "report"])
def test_an_output_inside_a_dataset_is_refused(dataset, config, tmp_path, command):
    """`train DATA --out DATA/mymodel` and `report DATA --out DATA/rep` were accepted; `generate --overwrite` of
    DATA then removed them."""
    data = shutil.copytree(dataset, tmp_path / "data")
    before = _files(data)
    argv = {"train": ["train", data, "--variant", "black"], "report": ["report", data, "--variants", "black"]}[command]
    for out in (data / "mine", data / "variants" / "x" / "mine"):
        res = invoke(*argv, "--out", out, "--config", config, *TRAIN)
        assert f"lies inside the deformsim dataset {data}" in one_line_error(res)
    assert _files(data) == before


def test_finetune_into_its_own_model_is_refused(model, real, tmp_path):
    copy = shutil.copytree(model, tmp_path / "m")
    before = _files(copy)
    res = invoke("finetune", copy, "--real", real, "--out", copy / "sub", "--steps", "1", "--no-progress")
    *notes, error = res.output.strip().splitlines()  # after the note naming the photos found
    assert res.exit_code == 2 and all(n.startswith("real photos in") for n in notes), res.output
    assert error.startswith("error:") and f"lies inside the deformsim model {copy}" in error
    assert _files(copy) == before


def test_report_by_default_goes_beside_the_dataset(dataset, config, tmp_path):
    data = shutil.copytree(dataset, tmp_path / "data")
    res = invoke("report", data, "--variants", "black", "--config", config, *TRAIN)
    assert res.exit_code == 0, res.output
    assert (tmp_path / "data-report" / "report.html").is_file() and not (data / "report").exists()


def test_a_folder_holding_another_output_is_never_replaced(dataset, model, config, tmp_path):
    """A model nested in a model (made by an older deformsim) went with its parent on --overwrite."""
    outer = shutil.copytree(model, tmp_path / "m")
    inner = shutil.copytree(model, outer / "inner")
    before = _files(outer)
    for extra in ([], ["--overwrite"]):
        res = invoke("train", dataset, "--variant", "black", "--out", outer, "--config", config, *extra, *TRAIN)
        assert f"holds the deformsim model {inner}, which replacing it would remove" in one_line_error(res)
    assert _files(outer) == before


def _odd_named(real: Path, tmp_path: Path) -> tuple[Path, str]:
    """A copy of ``real`` with one photo named with a byte that is not UTF-8 (``bad\\xffname.png``)."""
    copy = shutil.copytree(real, tmp_path / "odd")
    photo = sorted((copy / "deformed").glob("*.png"))[0]
    name = os.fsdecode(b"bad\xffname.png")
    photo.rename(photo.parent / name)
    return copy, name


def test_a_photo_name_that_is_not_utf8_is_written_as_it_can_be(dataset, model, real, config, tmp_path):
    """predict --csv, finetune --real and report --real stopped with UnicodeEncodeError (evaluate coped)."""
    odd, name = _odd_named(real, tmp_path)
    res = invoke("predict", model, odd, "--csv", tmp_path / "p.csv")
    assert res.exit_code == 0, res.output
    assert "bad\\xffname.png" in (tmp_path / "p.csv").read_text()
    res = invoke("finetune", model, "--real", odd, "--out", tmp_path / "ft", "--steps", "1", "--views", "0",
                 "--no-progress")
    assert res.exit_code == 0, res.output
    res = invoke("report", dataset, "--out", tmp_path / "rep", "--real", odd, "--variants", "black", "--config", config,
                 *TRAIN)
    assert res.exit_code == 0, res.output
    assert "bad\\xffname.png" in (tmp_path / "rep" / "report.html").read_text()
