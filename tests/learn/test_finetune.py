"""Fine-tuning with labelled real photos: predictions move toward their labels, and the adapted model refuses to be
scored on any of them (by content), while a folder it cannot adapt on fails with one line before any work."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.errors import UserError
from deformsim.evaluate.experiments import evaluate_model
from deformsim.identity import file_digest
from deformsim.learn.checkpoint import read_checkpoint
from deformsim.learn.finetune import Recipe, finetune
from deformsim.learn.predict import load
from tests.learn.blobs import make_blobs

pytestmark = pytest.mark.torch

FAST = Recipe(part="head", steps=60, lr=1e-3, views=1)


def _gap(model, table) -> float:
    """Mean distance of P(deformed) from the label."""
    return float(np.abs(load(model).predict_proba(list(table["path"])) - table["y"].to_numpy()).mean())


def test_finetune_moves_predictions_toward_the_labels_of_its_photos(trained, photos, tmp_path):
    root, table = photos
    result = finetune(trained, root, tmp_path / "ft", FAST, progress=False)
    assert _gap(result.model_path, table) < _gap(trained, table) - 0.05
    assert result.photos == 12 and result.loss[1] < result.loss[0]
    ckpt, _ = read_checkpoint(result.model_path)
    assert ckpt["adapted_on"] == sorted(file_digest(p) for p in table["path"])


def test_finetune_of_the_tail_with_synthetic_images_mixed_in(trained, photos, blobs, tmp_path):
    root, table = photos
    result = finetune(trained, root, tmp_path / "ft", Recipe(steps=3, views=1), data=blobs["path"].iloc[0].rsplit(
        "/", 2)[0], progress=False)
    before, after = (read_checkpoint(m)[0]["state_dict"] for m in (trained, result.model_path))
    changed = {k.split(".")[0] for k in before if not torch.equal(before[k], after[k])}
    assert changed == {"features", "head"} and result.synthetic == len(blobs)


def test_an_adapted_model_refuses_to_be_scored_on_its_photos_even_renamed(trained, photos, tmp_path):
    root, table = photos
    model = finetune(trained, root, tmp_path / "ft", FAST, progress=False).model_path
    with pytest.raises(UserError, match="learnt from the labels of 12 of these images"):
        evaluate_model(model, real_dir=root)
    other = make_blobs(tmp_path / "other", 3, seed=12)
    assert evaluate_model(model, real_dir=tmp_path / "other").n_images == len(other)
    shutil.copy(table["path"].iloc[0], tmp_path / "other" / "intact" / "renamed.png")
    res = CliRunner().invoke(app, ["evaluate", str(model), "--real", str(tmp_path / "other")])
    assert res.exit_code == 2
    errors = [line for line in res.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "learnt from the labels of 1 of these images" in errors[0] and "renamed.png" in errors[0]


@pytest.mark.parametrize("case", ["missing", "empty", "one class", "no images"])
def test_finetune_refuses_a_folder_it_cannot_adapt_on_before_any_work(case, trained, tmp_path):
    real = tmp_path / "real"
    if case != "missing":
        real.mkdir()
    if case == "one class":
        make_blobs(tmp_path / "one", 2)
        shutil.copytree(tmp_path / "one" / "intact", real / "intact")
    if case == "no images":
        (real / "intact").mkdir()
        (real / "deformed").mkdir()
    with pytest.raises(UserError, match=str(real)) as err:
        finetune(trained, real, tmp_path / "out", FAST, progress=False)
    assert "\n" not in str(err.value) and not (tmp_path / "out").exists()


def test_finetune_keeps_its_inputs_apart_from_its_output(trained, photos):
    with pytest.raises(UserError, match="is the model|contains the model"):
        finetune(trained, photos[0], trained.parent, FAST, progress=False)


def test_a_model_with_a_bad_adapted_on_list_is_refused(trained, tmp_path):
    ckpt = torch.load(trained, weights_only=True)
    ckpt["adapted_on"] = ["not a digest"]
    torch.save(ckpt, tmp_path / "model.pt")
    with pytest.raises(UserError, match="adapted_on"):
        read_checkpoint(tmp_path / "model.pt")


def test_a_negative_or_huge_seed_is_refused_like_generate_seed():
    """`finetune --seed -1` was accepted where `generate.seed=-1` is refused."""
    for seed in (-1, 2**63):
        with pytest.raises(UserError, match=rf"^--seed {seed}: a seed is a whole number from 0 to"):
            Recipe(seed=seed)
    assert Recipe(seed=2**63 - 1).seed == 2**63 - 1


def test_finetune_then_adapts_to_unlabelled_photos_whose_labels_it_never_reads(trained, photos, tmp_path):
    """`finetune --real DIR --unlabelled DIR2`: the fine-tuned model adapted to DIR2 as `adapt --photos` does, the
    labelled photos counted once (as labelled); flattening DIR2's class folders changes nothing."""
    root, table = photos
    unlabelled = make_blobs(tmp_path / "u", 5, seed=13)
    shutil.copy(table["path"].iloc[0], tmp_path / "u" / "intact" / "a-labelled-photo.png")
    res = CliRunner().invoke(app, ["finetune", str(trained), "--real", str(root), "--unlabelled", str(tmp_path / "u"),
                                   "--out", str(tmp_path / "ft"), "--part", "head", "--steps", "20", "--views", "1",
                                   "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "adapted on 12 photos, then to 10 unlabelled photos in" in res.output
    ckpt, _ = read_checkpoint(tmp_path / "ft")
    assert ckpt["adapter"]["method"] == "probe"
    assert ckpt["adapted_unlabelled"] == sorted(file_digest(p) for p in unlabelled["path"])
    assert ckpt["adapted_on"] == sorted(file_digest(p) for p in table["path"])
    flat = tmp_path / "flat"
    flat.mkdir()
    for p in (tmp_path / "u").rglob("*.png"):
        shutil.copy(p, flat / f"{p.parent.name}-{p.name}")
    again = finetune(trained, root, tmp_path / "ft2", Recipe(part="head", steps=20, views=1), progress=False,
                     unlabelled=flat)
    assert again.unlabelled == 10
    assert read_checkpoint(again.model_path)[0]["adapter"] == ckpt["adapter"]


def test_finetune_refuses_too_few_unlabelled_photos_before_any_work(trained, photos, tmp_path):
    make_blobs(tmp_path / "u", 2, seed=13)
    with pytest.raises(UserError, match=r"^--unlabelled .*u holds 4 distinct photo\(s\): adapting needs at least 8$"):
        finetune(trained, photos[0], tmp_path / "out", FAST, progress=False, unlabelled=tmp_path / "u")
    assert not (tmp_path / "out").exists()


def test_an_adapted_model_is_refused_rather_than_losing_its_adapter(trained, photos, tmp_path):
    unlabelled = tmp_path / "u"
    make_blobs(unlabelled, 5, seed=13)
    adapted = finetune(trained, photos[0], tmp_path / "ft", FAST, progress=False, unlabelled=unlabelled).model_path
    with pytest.raises(UserError, match=r"is adapted already: fine-tune the model it was made from$"):
        finetune(adapted, photos[0], tmp_path / "again", FAST, progress=False)
    assert not (tmp_path / "again").exists()


def test_finetune_mixes_in_the_variant_the_model_was_trained_on(tiny_dataset, photos, tmp_path):
    """--data without --variant: the renders of the variant the model learnt (as deformsim adapt reads them)."""
    import json

    from deformsim.config import TrainConfig
    from deformsim.learn.stage import train_model

    cfg = TrainConfig(weights="offline", image_size=32, epochs=1, batch_size=4)
    model = train_model(tiny_dataset, cfg, tmp_path / "m", variant="green", progress=False).model_path
    root, _ = photos
    finetune(model, root, tmp_path / "ft", FAST, data=tiny_dataset, progress=False)
    finetune(model, root, tmp_path / "ft-green", FAST, data=tiny_dataset, variant="green", progress=False)
    finetune(model, root, tmp_path / "ft-black", FAST, data=tiny_dataset, variant="black", progress=False)
    losses = {p: json.loads((tmp_path / p / "finetune.json").read_text())["losses"] for p in ("ft", "ft-green", "ft-black")}
    assert losses["ft"] == losses["ft-green"] != losses["ft-black"]


def test_the_renders_mixed_in_leave_out_what_the_model_was_trained_not_to_see(dent_out_of_view, tmp_path):
    """train.min_region: a deformed render whose damage does not show is no deformed image for fine-tuning or
    adapting either (its label would teach the model to call intact-looking parts deformed)."""
    from deformsim.config import TrainConfig
    from deformsim.dataset.variants import variant_table
    from deformsim.learn.stage import model_renders

    data, hidden = dent_out_of_view
    every = set(variant_table(data, "black")["id"])
    kept = model_renders(data, "black", tmp_path / "model.pt", TrainConfig(min_region=0.02))
    assert set(kept["id"]) == every - {hidden}
    assert set(model_renders(data, "black", tmp_path / "model.pt", TrainConfig())["id"]) == every
