"""Shape families (object.shapes) and printed appearance (render.appearance): draws from streams of their own,
deterministic per seed, recorded in the manifest, off by default. Pure: no Blender."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PIL import Image

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import rows_for
from deformsim.dataset.rendered import Rendered
from deformsim.errors import UserError
from deformsim.generate.identity import data_name, input_digests
from deformsim.sampling import CAN_SIZES, sample_params
from deformsim.spec.model import load_spec

HDRIS = ["city", "studio"]
ON = {"object.shapes": {}, "render.appearance": {}}


@pytest.fixture(scope="module")
def spec():
    return load_spec()


def test_off_by_default_and_on_moves_no_other_draw(spec):
    off, on = load_config("quick"), load_config("quick", ON)
    for i in range(20):
        a, b = sample_params(i, 4, off, spec, HDRIS), sample_params(i, 4, on, spec, HDRIS)
        assert a.shape is None and a.appearance is None
        assert "shape" not in a.to_dict() and "appearance" not in a.to_dict(), "records of old runs stay as they were"
        assert dataclasses.replace(b, shape=None, appearance=None) == a
        assert b.shape is not None and b.appearance is not None


def test_draws_are_deterministic_per_seed_and_vary_per_sample(spec):
    cfg = load_config("quick", ON)
    first = [sample_params(i, 7, cfg, spec, HDRIS) for i in range(30)]
    again = [sample_params(i, 7, cfg, spec, HDRIS) for i in range(30)]
    other = [sample_params(i, 8, cfg, spec, HDRIS) for i in range(30)]
    assert first == again
    assert [p.shape for p in first] != [p.shape for p in other]
    assert len({p.appearance.seed for p in first}) == 30
    assert {p.appearance.style for p in first} <= {"designer", "bare"}
    for p in first:
        assert type(p).from_dict(p.to_dict()) == p


def test_named_sizes_and_continuous_blends(spec):
    exact = load_config("quick", {"object.shapes": {"sizes": ["slim250", "tall568"], "continuous": 0.0}})
    shapes = [sample_params(i, 1, exact, spec, HDRIS).shape for i in range(40)]
    assert {s.size for s in shapes} == {"slim250", "tall568"}
    for s in shapes:
        assert (s.diameter, s.height) == (CAN_SIZES[s.size]["diameter"], CAN_SIZES[s.size]["height"])
    blend = load_config("quick", {"object.shapes": {"continuous": 1.0, "neck": [0.8, 1.2]}})
    shapes = [sample_params(i, 1, blend, spec, HDRIS).shape for i in range(60)]
    mixed = [s for s in shapes if "~" in s.size]
    assert len(mixed) > 40, "pairs of one size drawn twice stay that size"
    for s in mixed:
        a, b = (CAN_SIZES[n] for n in s.size.split("~"))
        assert min(a["height"], b["height"]) <= s.height <= max(a["height"], b["height"])
        assert min(a["diameter"], b["diameter"]) <= s.diameter <= max(a["diameter"], b["diameter"])
    assert min(s.neck for s in shapes) < 0.9 and max(s.neck for s in shapes) > 1.0


def test_round_parts_take_one_factor_across(spec):
    scale = [[0.8, 1.3], [0.8, 1.3], [0.7, 1.1]]
    free = load_config("quick", {"object.shapes": {"scale": scale}})
    round_ = load_config("quick", {"object.shapes": {"scale": scale, "round": True}})
    pairs = [(sample_params(i, 3, free, spec, HDRIS).shape, sample_params(i, 3, round_, spec, HDRIS).shape)
             for i in range(20)]
    assert all(r.scale[0] == r.scale[1] for _, r in pairs), "a round part stays round"
    assert any(f.scale[0] != f.scale[1] for f, _ in pairs)
    assert all((f.scale[0], f.scale[2]) == (r.scale[0], r.scale[2]) for f, r in pairs), "no other draw moves"


def test_manifest_records_the_drawn_shape_and_appearance(spec, tmp_path):
    cfg = load_config("quick", ON)
    p = sample_params(3, 2, cfg, spec, HDRIS)
    rendered = Rendered(index=3, render_seconds=[0.1] * 4, kinds=(), sample_columns={}, image_columns=[])
    rows = rows_for(p, Layout(tmp_path), rendered)
    assert rows[0]["shape_size"] == p.shape.size and rows[0]["shape_height_mm"] == p.shape.height
    assert rows[0]["shape_scale_z"] == p.shape.scale[2] and rows[0]["shape_bulge"] == p.shape.bulge
    assert rows[0]["appearance_style"] == p.appearance.style
    assert rows[0]["appearance_gloss"] == p.appearance.gloss
    plain = rows_for(sample_params(3, 2, load_config("quick"), spec, HDRIS), Layout(tmp_path), rendered)
    assert not any(k.startswith(("shape_", "appearance_")) for k in plain[0]), "manifests without them as they were"


def test_identity_covers_the_settings_and_the_artwork_photos(spec, tmp_path):
    base = load_config("quick")
    names = {data_name(base, spec)}
    names.add(data_name(load_config("quick", {"object.shapes": {}}), spec))
    names.add(data_name(load_config("quick", {"object.shapes": {"sizes": ["slim250"]}}), spec))
    names.add(data_name(load_config("quick", {"render.appearance": {}}), spec))
    photos = tmp_path / "art"
    photos.mkdir()
    Image.fromarray(np.full((8, 8, 3), 90, np.uint8)).save(photos / "a.png")
    cfg = load_config("quick", {"render.appearance": {"photos": str(photos)}})
    names.add(data_name(cfg, spec))
    assert "artwork" in input_digests(cfg, spec)
    Image.fromarray(np.full((8, 8, 3), 91, np.uint8)).save(photos / "a.png")
    names.add(data_name(cfg, spec))
    assert len(names) == 6
    assert "artwork" not in input_digests(base, spec)


def test_photos_are_drawn_for_the_can_and_a_mesh(tmp_path):
    for name in ("b.png", "a.jpg"):
        Image.fromarray(np.full((8, 8, 3), 50, np.uint8)).save(tmp_path / name)
    cfg = load_config("quick", {"render.appearance": {"photos": str(tmp_path), "photo_share": 1.0}})
    looks = [sample_params(i, 0, cfg, load_spec(), HDRIS).appearance for i in range(10)]
    assert {a.style for a in looks} == {"photo"}
    assert {a.photo for a in looks} == {str(tmp_path / "a.jpg"), str(tmp_path / "b.png")}
    assert all(0 <= a.crop[0] <= 1 and 1 <= a.crop[2] <= 2 for a in looks)


@pytest.mark.parametrize("overrides, words", [
    ({"object.shapes": {"sizes": ["huge"]}}, "object.shapes"),
    ({"object.shapes": {"scale": [[1, 1], [0, 1], [1, 1]]}}, "object.shapes.scale"),
    ({"object.shapes": {"taper": [-2, 0]}}, "object.shapes.taper"),
    ({"object.shapes": {"continuous": 1.5}}, "object.shapes"),
    ({"render.appearance": {"gloss": [0.2, 3]}}, "render.appearance.gloss"),
    ({"render.appearance": {"metallic_share": -1}}, "render.appearance"),
])
def test_bad_values_give_one_line(overrides, words):
    with pytest.raises(UserError) as exc:
        load_config("quick", overrides)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_a_missing_or_empty_photo_folder_gives_one_line(spec, tmp_path):
    for folder in (tmp_path / "missing", tmp_path):
        cfg = load_config("quick", {"render.appearance": {"photos": str(folder)}})
        with pytest.raises(UserError) as exc:
            input_digests(cfg, spec)
        assert "render.appearance.photos" in str(exc.value) and "\n" not in str(exc.value)


def test_a_surface_value_range_sets_the_grounds_brightness_and_moves_nothing_else(spec):
    base = {"render.surface": {"kinds": ["concrete"]}}
    own = [sample_params(i, 3, load_config("quick", base), spec, HDRIS).surface for i in range(40)]
    darker = load_config("quick", {"render.surface": {"kinds": ["concrete"], "value": [0.1, 0.2]}})
    dark = [sample_params(i, 3, darker, spec, HDRIS).surface for i in range(40)]
    assert all(0.1 <= d.value <= 0.2 for d in dark) and max(o.value for o in own) > 0.4
    assert [dataclasses.replace(d, value=0) for d in dark] == [dataclasses.replace(o, value=0) for o in own]
    with pytest.raises(Exception, match="value"):
        load_config("quick", {"render.surface": {"kinds": ["concrete"], "value": [0.5, 1.5]}})


def test_material_regions_draw_from_their_own_stream_within_their_ranges(tmp_path):
    from deformsim.spec.model import Spec

    spec = {"name": "tin", "families": [{"name": "f", "keys": [{"name": "k", "ops": [{"op": "compress", "amount": 0.1}]}]}],
            "material": {"color": [[0.7, 0.7, 0.7], [0.9, 0.9, 0.9]]}}
    plain = Spec.model_validate(spec)
    spec["material"]["regions"] = [{"name": "ends", "where": {"min_normal_angle": 60},
                                    "color": [[0.2, 0.2, 0.2], [0.3, 0.3, 0.3]], "roughness": [0.4, 0.5]}]
    regions = Spec.model_validate(spec)
    cfg = load_config("quick")
    for i in range(20):
        a, b = sample_params(i, 2, cfg, plain, HDRIS), sample_params(i, 2, cfg, regions, HDRIS)
        assert "regions" not in a.material.to_dict(), "records of specs without regions stay as they were"
        assert dataclasses.replace(b, material=dataclasses.replace(b.material, regions=())) == a
        (ends,) = b.material.regions
        assert all(0.2 <= c <= 0.3 for c in ends.color) and 0.4 <= ends.roughness <= 0.5
        assert type(b).from_dict(b.to_dict()) == b and b == sample_params(i, 2, cfg, regions, HDRIS)
    assert len({sample_params(i, 2, cfg, regions, HDRIS).material.regions for i in range(20)}) == 20


def test_a_blended_colour_range_stays_on_its_line_and_moves_nothing_else():
    from deformsim.spec.model import Spec

    spec = {"name": "tin", "families": [{"name": "f", "keys": [{"name": "k", "ops": [{"op": "compress", "amount": 0.1}]}]}],
            "material": {"color": [[0.6, 0.6, 0.62], [0.8, 0.8, 0.84]]}}
    channels = Spec.model_validate(spec)
    spec["material"]["color_draw"] = "blend"
    blend = Spec.model_validate(spec)
    cfg = load_config("quick")
    tints = []
    for i in range(20):
        a, b = sample_params(i, 2, cfg, channels, HDRIS), sample_params(i, 2, cfg, blend, HDRIS)
        r, g, bl = b.material.color
        assert r == pytest.approx(g) and bl == pytest.approx(0.62 + (r - 0.6) * 1.1) and 0.6 <= r <= 0.8
        assert dataclasses.replace(b, material=a.material) == a and b.material.roughness == a.material.roughness
        tints.append(np.ptp(a.material.color[:2]))
    assert max(tints) > 0.05, "drawn channel by channel, a range of greys gives tints"


def test_printed_marks_draw_from_their_own_stream_by_share_ink_and_style():
    from deformsim.spec.model import Spec

    spec = {"name": "tin", "families": [{"name": "f", "keys": [{"name": "k", "ops": [{"op": "compress", "amount": 0.1}]}]}],
            "material": {"regions": [{"name": "ends", "where": {"min_normal_angle": 60}}]}}
    plain = Spec.model_validate(spec)
    spec["material"]["regions"][0]["print"] = {"share": 0.5, "styles": ["ring", "dots"],
                                               "inks": [[[0, 0.3, 0], [0.1, 0.5, 0.1]], [[0.5, 0, 0], [0.6, 0, 0]]]}
    printed = Spec.model_validate(spec)
    cfg = load_config("quick")
    marks = []
    for i in range(40):
        a, b = sample_params(i, 2, cfg, plain, HDRIS), sample_params(i, 2, cfg, printed, HDRIS)
        assert "print" not in a.material.regions[0].to_dict(), "records of unprinted specs stay as they were"
        (ends,) = b.material.regions
        assert b.material.print is None and dataclasses.replace(ends, print=None) == a.material.regions[0]
        assert dataclasses.replace(b, material=a.material) == a, "printing moves no other draw"
        assert type(b).from_dict(b.to_dict()) == b and b == sample_params(i, 2, cfg, printed, HDRIS)
        marks.append(ends.print)
    shown = [m for m in marks if m is not None]
    assert 10 <= len(shown) <= 30, "about half the samples printed (share 0.5)"
    assert {m.style for m in shown} == {"ring", "dots"} and len({m.seed for m in shown}) == len(shown)
    greens = [m.ink for m in shown if m.ink[1] > 0]
    assert 0 < len(greens) < len(shown), "each printed sample draws one of the ink ranges"
    assert all(0 <= r <= 0.1 and 0.3 <= g <= 0.5 and 0 <= bl <= 0.1 for r, g, bl in greens)
    assert all(0.5 <= m.ink[0] <= 0.6 for m in shown if m.ink[1] == 0)
