"""bench adapt --biased: each class's k labelled photos from a different lighting, so that a model fitted on them can
take the light for the damage; the lighting split comes from the photos' pixels."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from deformsim.errors import UserError
from deformsim.evaluate.adaptation import kshot_curves, run_adaptation
from deformsim.evaluate.draws import Drawing, biased_draw, check_biased, warm_half
from deformsim.learn.adapter import AdaptRecipe


def test_warm_half_splits_the_photos_by_their_colour_at_the_median(tmp_path):
    paths = []
    for i, (r, b) in enumerate([(200, 90), (120, 120), (90, 200), (180, 100), (100, 170), (140, 130)]):
        paths.append(str(tmp_path / f"{i}.jpg"))
        Image.new("RGB", (300, 200), (r, 110, b)).save(paths[-1])
    assert warm_half(paths).tolist() == [True, False, False, True, False, True]


def test_a_photo_that_cannot_be_read_is_named_in_one_line(tmp_path):
    (tmp_path / "broken.jpg").write_bytes(b"not a jpeg")
    with pytest.raises(UserError, match="broken.jpg") as err:
        warm_half([str(tmp_path / "broken.jpg")])
    assert "\n" not in str(err.value)


def test_a_biased_draw_takes_each_class_from_its_own_lighting_and_scores_the_rest():
    y = np.repeat([0, 1], 20)
    warm = np.tile([True, False], 20)
    for intact_warm in (True, False):
        chosen, rest = biased_draw(y, 4, warm, intact_warm, np.random.default_rng(3))
        assert len(chosen) == 8 and set(chosen).isdisjoint(rest) and len(chosen) + len(rest) == 40
        assert (warm[chosen[y[chosen] == 0]] == intact_warm).all()
        assert (warm[chosen[y[chosen] == 1]] != intact_warm).all()
    again = biased_draw(y, 4, warm, True, np.random.default_rng(3))[0]
    assert again.tolist() == biased_draw(y, 4, warm, True, np.random.default_rng(3))[0].tolist()


def test_a_probe_fitted_on_a_biased_sample_learns_the_light_and_falls_below_the_model():
    """Features where the light is the strongest direction and the damage a weaker one the model already reads: on
    labelled photos whose class follows the light, a probe on them alone falls far below the unadapted model, which
    is what the biased mode is there to show."""
    rng = np.random.default_rng(0)
    y = np.repeat([0, 1], 40)
    warm = rng.permutation(np.tile([True, False], 40))
    features = np.column_stack([4.0 * warm + rng.normal(0, 0.3, 80), 1.0 * y + rng.normal(0, 0.5, 80),
                                rng.normal(size=(80, 3))])
    p0 = np.clip(0.2 + 0.6 * y + rng.normal(0, 0.1, 80), 0.01, 0.99)
    rows = kshot_curves([p0], [features], y, ["undated"] * 80, [5], 4, AdaptRecipe(), 0.5, 0, Drawing(y, warm))
    by = {r["curve"]: r for r in rows}
    assert by["unadapted"]["accuracy"] > 0.95
    assert by["labelled probe"]["accuracy"] < 0.8 and by["labelled probe"]["paired_interval"][1] < 0


def test_a_biased_draw_short_of_photos_on_one_side_is_refused_naming_it(tmp_path):
    y = np.repeat([0, 1], 10)
    warm = np.array([True] * 8 + [False] * 2 + [True, False] * 5)
    with pytest.raises(UserError, match=r"^--biased --k 2: real holds 2 cool-lit intact photos; the biased draw needs 2 "
                                        r"and one left to score$"):
        check_biased(y, warm, 2, "real")
    check_biased(y, warm, 1, "real")


def test_biased_without_k_is_refused_before_any_work(tmp_path):
    real = tmp_path / "real"
    for c in ("intact", "deformed"):
        (real / c).mkdir(parents=True)
        for i in range(10):
            Image.new("RGB", (32, 32), (10 * i, 50, 100)).save(real / c / f"{i}.png")
    with pytest.raises(UserError, match=r"^--biased draws the k labelled photos: give --k too$"):
        run_adaptation([tmp_path / "no-model"], real, tmp_path / "out", biased=True)
    assert not (tmp_path / "out").exists()
