"""The render-feature registry: each declaration is complete, and the refusals' estimate counts what each active
feature costs (no Blender)."""

import importlib.util
import re

import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import RENDER_KINDS
from deformsim.errors import UserError
from deformsim.generate.refusals import check_plan, render_seconds
from deformsim.sampling.features import FEATURES, extra_renders, png_bytes
from deformsim.sampling.params import SampleParams


@pytest.mark.parametrize("f", FEATURES, ids=lambda f: f.name)
def test_each_declaration_is_complete(f):
    module, _, cls = f.blender.partition(":")
    assert module.startswith("deformsim.blender.") and cls and importlib.util.find_spec(module) is not None
    assert (f.draw is None) == (f.stream is None) == (f.field == "")  # a draw has its stream and its field
    assert not f.field or f.field in SampleParams.__dataclass_fields__
    assert f.renders in (0, 1) and (f.renders == 0 or len(f.kinds) == 1)  # an extra render writes its one kind
    assert not set(f.kinds) & set(RENDER_KINDS)
    assert f.on(load_config("quick")) == (f.name == "dense")  # quick turns on dense maps only


def test_names_and_kinds_are_unique():
    names, kinds = [f.name for f in FEATURES], [k for f in FEATURES for k in f.kinds]
    assert len(set(names)) == len(names) and len(set(kinds)) == len(kinds)


def _estimate(overrides: dict) -> tuple[float, float]:
    """(hours, GB) the --yes refusal names for 1,000,000 images of ``overrides``."""
    with pytest.raises(UserError) as exc:
        check_plan(load_config("quick", {"generate.n": 1_000_000, **overrides}), yes=False)
    hours, gb = re.search(r"about ([\d,]+) hours .* and ([\d,]+) GB", str(exc.value)).groups()
    return float(hours.replace(",", "")), float(gb.replace(",", ""))


def test_the_estimate_adds_each_active_features_renders_and_images():
    plain = {"render.dense": False}
    scenes = {**plain, "render.shadow": True, "render.surface": {}}
    assert extra_renders(load_config("quick", scenes)) == 2 and png_bytes(load_config("quick", plain)) == 0
    assert render_seconds(load_config("quick", scenes)) == 3 * render_seconds(load_config("quick", plain))
    (h0, gb0), (h2, gb2) = _estimate(plain), _estimate(scenes)
    assert h2 / h0 == pytest.approx(3, rel=0.01) and gb2 / gb0 == pytest.approx(5 / 3, rel=0.01)
    assert _estimate({})[1] > gb0  # dense maps: disk, no render
