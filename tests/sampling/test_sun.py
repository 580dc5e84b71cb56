"""``lighting.sun``, the render feature added through the registry alone: off by default, its own stream, its
manifest columns, its share and ranges, its identity (no Blender)."""

import dataclasses
import json

import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import rows_for
from deformsim.dataset.rendered import Rendered
from deformsim.errors import UserError
from deformsim.generate.identity import data_name
from deformsim.generate.refusals import render_seconds
from deformsim.sampling import SampleParams, sample_params
from deformsim.spec.model import load_spec

HDRIS = ["city", "studio"]
SUN = {"lighting.sun": {"share": 0.5, "strength": [2, 3], "elevation": [30, 40], "angle": [1, 2]}}
SPEC = load_spec()


def test_the_sun_is_off_by_default_and_moves_no_other_draw_when_on():
    off, on = load_config("quick"), load_config("quick", SUN)
    for i in range(20):
        a, b = sample_params(i, 3, off, SPEC, HDRIS), sample_params(i, 3, on, SPEC, HDRIS)
        assert a.sun is None and "sun" not in a.to_dict()  # records without the sun as they were
        assert b.sun is not None and dataclasses.replace(b, sun=None) == a
        assert SampleParams.from_dict(json.loads(json.dumps(b.to_dict()))) == b  # as the worker receives it


def test_the_sun_lights_its_share_of_samples_within_its_ranges():
    suns = [sample_params(i, 5, load_config("quick", SUN), SPEC, HDRIS).sun for i in range(200)]
    lit = [s for s in suns if s.strength > 0]
    assert 0.4 < len(lit) / len(suns) < 0.6
    assert all(2 <= s.strength <= 3 and 30 <= s.elevation <= 40 and 1 <= s.angle <= 2 for s in lit)
    assert all(0 <= s.azimuth < 360 for s in suns) and len({round(s.azimuth) for s in suns}) > 100


def test_the_manifest_records_the_sun_only_when_on(tmp_path):
    rendered = Rendered(index=0, render_seconds=[0.1] * 4)
    p = sample_params(0, 5, load_config("quick", SUN), SPEC, HDRIS)
    row = rows_for(p, Layout(tmp_path), rendered)[0]
    assert (row["sun_azimuth"], row["sun_strength"], row["sun_angle"]) == (p.sun.azimuth, p.sun.strength, p.sun.angle)
    plain = rows_for(sample_params(0, 5, load_config("quick"), SPEC, HDRIS), Layout(tmp_path), rendered)[0]
    assert not any(k.startswith("sun_") for k in plain)


def test_the_sun_changes_the_datasets_identity_but_not_its_render_time():
    off, on = load_config("quick"), load_config("quick", SUN)
    assert data_name(on, SPEC) != data_name(off, SPEC)
    assert render_seconds(on) == render_seconds(off)  # one light more, no extra render


@pytest.mark.parametrize("bad", [{"share": 1.5}, {"strength": [3, 1]}, {"elevation": [10, 100]}, {"angle": [-1, 2]}])
def test_bad_sun_settings_give_one_line(bad):
    with pytest.raises(UserError) as exc:
        load_config("quick", {"lighting.sun": bad})
    assert "lighting.sun" in str(exc.value) and "\n" not in str(exc.value)
