"""A few labelled photos stacked on a trained model: the residual is kept only where cross-validation inside the
photos says it helps, never when each shooting session holds one class, and the adapted model refuses to be scored
on the photos it learnt from."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.dataset.groups import photo_date, photo_groups
from deformsim.errors import UserError
from deformsim.learn.adapt_file import AdaptFile
from deformsim.learn.adapt_stage import adapt_model
from deformsim.learn.adapter import AdaptRecipe, sigmoid
from deformsim.learn.predict import load
from deformsim.learn.stack import fit_stack, folds_of
from deformsim.records import read_record

pytestmark = pytest.mark.torch


def _photos(rng, n):
    """Features of n photos of each class and a synthetic model that also leans on feature 1 (the light, say,
    which went with the damage in the renders but not in real photos), and the labels."""
    y = np.repeat([0, 1], n)
    x = rng.normal(size=(2 * n, 6))
    x[:, 0] += np.where(y == 1, 1.5, -1.5)
    return x, sigmoid(3.0 * (x[:, 0] - 1.2 * x[:, 1])), y


def test_a_residual_corrects_what_the_renders_got_wrong_and_is_kept_only_then():
    rng = np.random.default_rng(0)
    x, p, y = _photos(rng, 30)
    adapter, choice = fit_stack(p, x, y, ["one day"] * len(y))
    xt, pt, yt = _photos(rng, 300)  # unseen photos of the same parts
    before, after = ((pt >= 0.5) == yt).mean(), ((adapter.apply(pt, xt) >= 0.5) == yt).mean()
    assert choice.l2 is not None and choice.folds == 5 and choice.losses["none"] > min(choice.losses.values())
    assert before < 0.88 and after > before + 0.05, (before, after)
    noise = rng.normal(size=x.shape)  # features that say nothing of the class: a residual could only fit noise
    adapter, choice = fit_stack(p, noise, y, ["one day"] * len(y))
    assert choice.l2 is None and not adapter.coef
    np.testing.assert_allclose(adapter.apply(p, noise), np.clip(p, 1e-6, 1 - 1e-6), atol=1e-9)


def test_sessions_that_each_hold_one_class_keep_the_synthetic_model():
    rng = np.random.default_rng(1)
    x, p, y = _photos(rng, 10)
    x[:, 2] += np.where(y == 1, 3.0, -3.0)  # the day's light: it separates the classes of these photos only
    days = np.where(y == 1, "2022-07-09", "2022-06-24").tolist()
    adapter, choice = fit_stack(p, x, y, days)
    assert choice.l2 is None and "holds one class" in choice.reason
    np.testing.assert_allclose(adapter.apply(p, x), np.clip(p, 1e-6, 1 - 1e-6), atol=1e-9)
    mixed = [f"day{i % 3}" for i in range(len(y))]  # three sessions, each with both classes
    held, reason = folds_of(y, mixed)
    assert not reason and [sorted(set(np.asarray(mixed)[h])) for h in held] == [["day0"], ["day1"], ["day2"]]
    assert folds_of(np.repeat([0, 1], [6, 4]), ["d"] * 10)[1] == ("cross-validation needs 5 labelled photos of each "
                                                                  "class (5 folds)")
    with pytest.raises(UserError, match="both classes"):
        fit_stack(p[:5], x[:5], y[:5], ["d"] * 5)


def test_a_few_photos_whose_classes_follow_the_light_keep_the_synthetic_model():
    """A biased sample: each class's photos shot in another light, which the features show more strongly than the
    damage. With fewer than 5 photos a class no residual is fitted, so the light cannot be learnt as the damage;
    from 5 a class, cross-validation has its 5 folds."""
    rng = np.random.default_rng(4)
    x, p, y = _photos(rng, 8)
    x[:, 3] += np.where(y == 1, 4.0, -4.0)
    for n in (2, 4):
        rows = np.concatenate([np.flatnonzero(y == 0)[:n], np.flatnonzero(y == 1)[:n]])
        adapter, choice = fit_stack(p[rows], x[rows], y[rows], ["undated"] * len(rows))
        assert choice.l2 is None and choice.reason.startswith("cross-validation needs 5") and not adapter.coef
    assert fit_stack(p, x, y, ["undated"] * len(y))[1].folds == 5


def test_a_photo_s_session_comes_from_exif_its_name_or_a_file(tmp_path):
    named = tmp_path / "IMG_20220709_173654_1.jpg"
    Image.new("RGB", (8, 8)).save(named)
    exif = Image.Exif()
    exif.get_ifd(0x8769)[36867] = "2023:01:02 10:11:12"
    shot = tmp_path / "IMG_20220709_180000.jpg"  # EXIF wins over the name
    Image.new("RGB", (8, 8)).save(shot, exif=exif)
    plain = tmp_path / "metal10.jpg"
    Image.new("RGB", (8, 8)).save(plain)
    assert [photo_date(p) for p in (named, shot, plain)] == ["2022-07-09", "2023-01-02", "undated"]
    table = tmp_path / "groups.csv"
    table.write_text("path,group\nmetal10.jpg,line 2\n")
    assert photo_groups([str(named), str(plain)], str(table)) == ["2022-07-09", "line 2"]
    assert photo_groups([str(named), str(plain)], "none") == ["all", "all"]
    table.write_text("path,group\nmetal10.jpg\n")
    with pytest.raises(UserError, match="line 2: expected 'path,group'"):
        photo_groups([str(plain)], str(table))
    with pytest.raises(UserError, match="--groups file not found"):
        photo_groups([str(plain)], str(tmp_path / "missing.csv"))


def test_adapting_on_labelled_photos_records_them_and_refuses_scoring_on_them(trained, photos, tmp_path):
    from deformsim.api import Engine

    root, table = photos
    result = adapt_model(trained, None, tmp_path / "m2", AdaptRecipe(method="stack"), labelled=root, progress=False)
    assert result.labelled == result.photos == 12 and result.choice is not None
    adapted = load(result.model_path, progress=False)
    assert adapted.adapter.method == "stack" and adapted.adapter.anchor == 1.0
    with pytest.raises(UserError, match="learnt from the labels of 12 of these images"):
        Engine("quick").evaluate(result.model_path, real=root)
    renamed = tmp_path / "renamed"
    for label in ("intact", "deformed"):
        shutil.copytree(root / label, renamed / label / "batch 1")
    again = adapt_model(trained, None, tmp_path / "m3", AdaptRecipe(method="stack"), labelled=renamed, progress=False)
    assert (tmp_path / "m3" / "model.pt").read_bytes() == (tmp_path / "m2" / "model.pt").read_bytes()
    assert again.choice == result.choice
    for kwargs, message in (({}, "adapt needs photos"), ({"recipe": AdaptRecipe(method="stack"), "photos": root},
                                                          "give them with --labelled")):
        with pytest.raises(UserError, match=message):
            adapt_model(trained, kwargs.get("photos"), tmp_path / "bad", kwargs.get("recipe", AdaptRecipe()),
                        progress=False)
        assert not (tmp_path / "bad").exists()


def test_cli_adapt_labelled_says_what_cross_validation_chose(trained, photos, tmp_path):
    root, _ = photos
    done = CliRunner().invoke(app, ["adapt", str(trained), "--labelled", str(root), "--photos", str(root), "--out",
                                    str(tmp_path / "m2"), "--no-progress"])
    assert done.exit_code == 0, done.output
    assert "adapted on 12 photos (12 labelled)" in done.output  # the labelled copies count once, as labelled
    assert "cross-validation over" in done.output or "kept the synthetic model" in done.output
    written = read_record(tmp_path / "m2" / "adapt.json", AdaptFile)
    assert (written.labelled, written.recipe.method, written.choice is not None) == (12, "stack", True)
