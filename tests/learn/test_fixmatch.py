"""Self-training the networks on weak and strong views of unlabelled photos (``deformsim adapt --method fixmatch``,
``adamatch``): the photos' labels are never read, a seed fixes the model, the renders keep it right on the renders,
and what the method cannot take is refused in one line before any work."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from deformsim.cli.app import app
from deformsim.errors import UserError
from deformsim.learn.adapt_file import AdaptFile
from deformsim.learn.adapt_stage import adapt_model
from deformsim.learn.adapter import NETWORKS, AdaptRecipe
from deformsim.learn.fixmatch import MatchRecipe, Thresholds, adamatch, class_confusion
from deformsim.learn.predict import load
from deformsim.records import read_record
from tests.learn.blobs import make_blobs

pytestmark = pytest.mark.torch


@pytest.fixture(scope="module")
def unlabelled(tmp_path_factory):
    """12 + 12 photos (blobs of another seed) in class folders, and the same flattened under neutral names."""
    root = tmp_path_factory.mktemp("unlabelled")
    table = make_blobs(root / "sorted", 12, seed=21)
    (root / "flat").mkdir()
    for k, path in enumerate(sorted(table["path"], key=lambda p: Path(p).name)):
        shutil.copy(path, root / "flat" / f"photo{k:03d}.png")
    return root / "sorted", root / "flat", table


def renders_of(blobs) -> Path:
    return Path(blobs["path"].iloc[0]).parents[1]


def test_self_training_never_reads_labels_and_a_seed_fixes_it(trained, blobs, unlabelled, tmp_path):
    """The self-trained networks are the same to the bit whether the photos sit in class folders or one flat folder
    under other names, and when adapted twice."""
    sorted_dir, flat_dir, _ = unlabelled
    recipe = AdaptRecipe(method="fixmatch", steps=20)
    outs = [adapt_model(trained, folder, tmp_path / name, recipe, progress=False, data=renders_of(blobs)).model_path
            for name, folder in (("a", sorted_dir), ("b", flat_dir), ("c", flat_dir))]
    states = [torch.load(o, weights_only=True) for o in outs]
    for key, value in states[0]["state_dict"].items():
        assert all(torch.equal(value, s["state_dict"][key]) for s in states[1:]), key
    before = torch.load(trained, weights_only=True)["state_dict"]
    assert any(not torch.equal(before[k], v) for k, v in states[0]["state_dict"].items())  # the networks moved
    assert "adapter" not in states[0] and len(states[0]["adapted_unlabelled"]) == 24


def test_the_renders_keep_the_model_right_on_them(trained, blobs, unlabelled, tmp_path):
    """However wrong its pseudo-labels, the renders mixed into every step keep the model judging them as before."""
    paths, y = list(blobs["path"]), blobs["y"].to_numpy()
    before = ((load(trained, progress=False).predict_proba(paths) >= 0.5) == y).mean()
    for method in NETWORKS:
        result = adapt_model(trained, unlabelled[1], tmp_path / method, AdaptRecipe(method=method, steps=20), progress=False,
                             data=renders_of(blobs))
        after = ((load(result.model_path, progress=False).predict_proba(paths) >= 0.5) == y).mean()
        assert after >= min(before, 0.9) - 0.05, (method, before, after)
        assert read_record(tmp_path / method / "adapt.json", AdaptFile).folders.data == str(renders_of(blobs))


def test_what_self_training_cannot_take_is_one_line_before_any_work(trained, blobs, unlabelled, photos, tmp_path):
    root, _ = photos
    flat = unlabelled[1]
    fixmatch = AdaptRecipe(method="fixmatch", steps=20)
    cases = [(dict(photos=flat, recipe=fixmatch), "^adapt method fixmatch needs --data: "),
             (dict(photos=flat, recipe=fixmatch, data=renders_of(blobs), labelled=root), "takes no --labelled"),
             (dict(photos=None, recipe=fixmatch, data=renders_of(blobs)), "needs photos"),
             (dict(photos=flat, recipe=AdaptRecipe(), data=renders_of(blobs)), "go with the methods fixmatch, adamatch, mcc"),
             (dict(photos=flat, recipe=fixmatch, data=renders_of(blobs), variant="backgrounds"), "generated dataset")]
    for kwargs, message in cases:
        with pytest.raises(UserError, match=message):
            adapt_model(trained, kwargs.pop("photos"), tmp_path / "out", kwargs.pop("recipe"), progress=False, **kwargs)
        assert not (tmp_path / "out").exists()
    few = tmp_path / "few"
    few.mkdir()
    for path in sorted(flat.glob("*.png"))[:5]:
        shutil.copy(path, few / path.name)
    with pytest.raises(UserError, match="5 distinct photo"):
        adapt_model(trained, few, tmp_path / "out", fixmatch, progress=False, data=renders_of(blobs))
    with pytest.raises(UserError, match="fixmatch steps"):
        MatchRecipe(steps=0)


def test_cli_adapt_self_trains_with_the_renders(trained, blobs, unlabelled, tmp_path):
    done = CliRunner().invoke(app, ["adapt", str(trained), "--photos", str(unlabelled[1]), "--out", str(tmp_path / "m"),
                                    "--method", "adamatch", "--steps", "20", "--data", str(renders_of(blobs)),
                                    "--no-progress"])
    assert done.exit_code == 0, done.output
    assert "adapted on 24 photos (0 labelled)" in done.output
    assert read_record(tmp_path / "m" / "adapt.json", AdaptFile).recipe.method == "adamatch"


def test_freematch_thresholds_do_not_starve_the_rare_class():
    """Photos mostly judged deformed: the intact class's threshold falls below the deformed one's, so the few
    intact pseudo-labels still count."""
    thresholds = Thresholds(momentum=0.5)
    p = torch.tensor([0.95] * 9 + [0.2])
    for _ in range(20):
        thresholds.update(p)
    per_class = thresholds.classes / thresholds.classes.max() * thresholds.confidence
    assert per_class[0] < per_class[1]
    assert thresholds.mask(p).tolist() == [1.0] * 10


def test_adamatch_aligns_the_photos_to_the_renders_class_balance():
    p_s = torch.tensor([0.99, 0.01] * 8)  # renders: balanced and sure
    p = torch.tensor([0.9] * 12 + [0.2] * 4)  # photos: mostly judged deformed
    aligned, mask, weight, level = adamatch(p_s, p, 0.9, 0.0)
    assert torch.stack([1 - aligned, aligned], 1).mean(0)[1] < torch.stack([1 - p, p], 1).mean(0)[1]
    assert level == pytest.approx(0.9 * 0.99) and weight == 0.0
    assert np.array_equal(mask.numpy(), (torch.maximum(aligned, 1 - aligned) >= level).float().numpy())


def test_class_confusion_is_lowest_for_sure_judgements_of_both_classes():
    sure = class_confusion(torch.tensor([8.0, -8.0] * 8))
    unsure = class_confusion(torch.tensor([0.3, -0.2] * 8))
    assert 0 <= sure < 0.1 < 0.4 < unsure  # logits 8 at temperature 2.5 still leave 4 % across
    z = torch.tensor([0.3, -0.2] * 8, requires_grad=True)
    class_confusion(z).backward()
    assert (z.grad[0] < 0) and (z.grad[1] > 0)  # minimising it pushes each photo further toward its side


def test_cdan_reverses_the_discriminators_gradient_more_as_training_goes_on():
    """The networks receive the domain loss's gradient reversed, scaled by a coefficient warming up from 0 to 1."""
    from deformsim.learn.fixmatch import GradientReversal, warm_up

    x = torch.ones(3, requires_grad=True)
    (GradientReversal.apply(x, 0.5) * torch.tensor([1.0, 2.0, 3.0])).sum().backward()
    assert x.grad.tolist() == [-0.5, -1.0, -1.5]
    assert warm_up(0) == 0 and 0 < warm_up(0.1) < warm_up(0.5) < warm_up(1) <= 1 and warm_up(1) > 0.99
