"""Area lights and view transforms on the pure side: config checks, drawing, the record (no Blender)."""

import dataclasses
import json

import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import rows_for
from deformsim.dataset.rendered import Rendered
from deformsim.errors import UserError
from deformsim.identity import digest
from deformsim.sampling import LIGHT_KINDS, LightParams, SampleParams, sample_params
from deformsim.spec.model import load_spec

HDRIS = ["city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"]
LIGHTS = {"lighting.area_lights.count": [1, 3], "lighting.area_lights.power": [100, 200]}
# The fields SampleParams had before poses and lights, drawn by the default config (seed 4, samples 0-49) at the
# commit that added area lights: the digest of their to_dict()s.
BEFORE = "563d11289aa6"
OLD_FIELDS = ("index", "seed", "label", "families", "keys", "displacement", "seal", "tab", "hdri", "hdri_rotation",
              "hdri_strength", "cameras", "design", "material", "extent", "pose_tilt", "pose_axis", "bank",
              "bank_amount")


@pytest.fixture(scope="module")
def spec():
    return load_spec()


def test_default_draws_are_unchanged(spec):
    cfg = load_config("quick")
    ps = [sample_params(i, 4, cfg, spec, HDRIS) for i in range(50)]
    assert all(p.lights == () for p in ps)
    assert digest([{k: v for k, v in p.to_dict().items() if k in OLD_FIELDS} for p in ps]) == BEFORE


def test_lights_draw_from_their_own_stream(spec):
    off, on = load_config("quick"), load_config("quick", LIGHTS)
    for i in range(100):
        a, b = sample_params(i, 3, off, spec, HDRIS), sample_params(i, 3, on, spec, HDRIS)
        assert dataclasses.replace(b, lights=()) == a
        assert 1 <= len(b.lights) <= 3


def test_light_draws_respect_the_config(spec):
    cfg = load_config("quick", {**LIGHTS, "lighting.area_lights.temperature": [5000, 6000]})
    kinds = set()
    for i in range(300):
        p = sample_params(i, 9, cfg, spec, HDRIS)
        for lp in p.lights:
            kinds.add(lp.kind)
            g = LIGHT_KINDS[lp.kind]
            assert g["size"][0] <= lp.size <= g["size"][1] and 0 <= lp.azimuth < 360
            assert 5000 <= lp.temperature <= 6000
            assert 100 * lp.distance**2 <= lp.power <= 200 * lp.distance**2 + 1e-9
            if lp.kind == "ring":  # just behind one of the cameras, on its axis
                cam = min(p.cameras, key=lambda c: abs((c.azimuth - lp.azimuth + 180) % 360 - 180))
                assert abs((cam.azimuth - lp.azimuth + 180) % 360 - 180) <= 4 + 1e-9
                assert abs(lp.elevation - (90 - cam.polar)) <= 4 + 1e-9
                assert cam.radius < lp.distance <= 1.2 * cam.radius
            else:
                assert g["distance"][0] <= lp.distance <= g["distance"][1]
                assert g["elevation"][0] <= lp.elevation <= g["elevation"][1]
    assert kinds == {"softbox", "ring", "window"}
    only = load_config("quick", {**LIGHTS, "lighting.area_lights.kinds": ["window"]})
    assert {lp.kind for i in range(50) for lp in sample_params(i, 1, only, spec, HDRIS).lights} == {"window"}


def test_overhead_panels_hang_above_the_part_and_leave_the_default_draws(spec):
    cfg = load_config("quick", {**LIGHTS, "lighting.area_lights.kinds": ["overhead"]})
    lights = [lp for i in range(50) for lp in sample_params(i, 1, cfg, spec, HDRIS).lights]
    assert lights and {lp.kind for lp in lights} == {"overhead"}
    assert all(lp.elevation >= 75 and lp.size >= 0.6 for lp in lights)  # a large panel nearly straight above
    default = load_config("quick", LIGHTS)
    assert "overhead" not in default.lighting.area_lights.kinds
    assert {lp.kind for i in range(100) for lp in sample_params(i, 1, default, spec, HDRIS).lights} == {
        "softbox", "ring", "window"}


def test_lights_are_deterministic_and_round_trip(spec, tmp_path):
    cfg = load_config("quick", LIGHTS)
    a = [sample_params(i, 7, cfg, spec, HDRIS) for i in range(20)]
    assert a == [sample_params(i, 7, cfg, spec, HDRIS) for i in reversed(range(20))][::-1]
    assert [p.lights for p in a] != [sample_params(i, 8, cfg, spec, HDRIS).lights for i in range(20)]
    for p in a:
        back = SampleParams.from_dict(json.loads(json.dumps(p.to_dict())))
        assert back == p and all(isinstance(lp, LightParams) for lp in back.lights)
    rows = rows_for(a[0], Layout(tmp_path), Rendered(a[0].index, [0.0] * 4))
    assert [LightParams(**d) for d in json.loads(rows[0]["lights"])] == list(a[0].lights)
    assert SampleParams.from_dict({k: v for k, v in a[0].to_dict().items() if k != "lights"}).lights == ()


def test_config_checks():
    for bad, match in (({"lighting.area_lights.count": [2, 1]}, "count"),
                       ({"lighting.area_lights.kinds": []}, "kinds"),
                       ({"lighting.area_lights.kinds": ["spot"]}, "kinds"),
                       ({"lighting.area_lights.power": [-1, 2]}, "power"),
                       ({"render.view_transform": "Raw"}, "view_transform"),
                       ({"render.look": "Punchy"}, "Punchy")):
        with pytest.raises(UserError, match=match):
            load_config("quick", bad)
    cfg = load_config("quick", {"render.view_transform": "AgX", "render.look": "Punchy"})
    assert cfg.render.view_transform == "AgX"
    assert load_config("quick").render.view_transform == "Standard"
