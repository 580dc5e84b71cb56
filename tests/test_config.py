"""Config validation: one clear line naming the bad value, before any work."""


import pytest

from deformsim.config import list_presets, load_config
from deformsim.errors import UserError


def test_presets_load_and_paper_has_the_papers_settings():
    assert {"quick", "paper"} <= set(list_presets())
    paper = load_config("paper")
    assert paper.generate.n == 6000 and paper.render.resolution == 512
    assert (paper.train.lr, paper.train.batch_size, paper.train.epochs) == (1e-3, 32, 15)


def test_overrides_apply_and_none_sets_null(tmp_path):
    config = tmp_path / "config.yaml"
    config.write_text("camera:\n  fill: [0.3, 0.6]\n")
    cfg = load_config(config, {"generate.n": 16, "render.resolution": 96, "camera.fill": None})
    assert (cfg.generate.n, cfg.render.resolution, cfg.camera.fill) == (16, 96, None)
    assert load_config(config).camera.fill == (0.3, 0.6)


@pytest.mark.parametrize(
    "overrides, needle",
    [
        ({"render.resolution": 0}, "render.resolution"),
        ({"camera.polar": [70, 50]}, "camera.polar"),
        ({"generate.n": 10}, "multiple of the 4 cameras"),
        ({"deform.families": [4, 2]}, "deform.families"),
        ({"render.adaptive_threshold": 0}, "render.adaptive_threshold"),
        ({"render.max_bounces": -1}, "render.max_bounces"),
        ({"render.clamp_indirect": -2}, "render.clamp_indirect"),
        ({"render.denoise_prefilter": "slow"}, "render.denoise_prefilter"),
        ({"render.denoise_input": "rgb_normal"}, "render.denoise_input"),
        ({"render.tile_size": 4}, "render.tile_size"),
        ({"render.region_visible": {"turn_deg": 90}}, "render.region_visible.turn_deg"),
        ({"render.region_visible": {"across_px": 0}}, "render.region_visible.across_px"),
        ({"render.dense": False, "render.region_visible": {}}, "render.region_visible needs render.dense: true"),
        ({"render.surface": {"part_colour": False}, "composite.surface": 0.5},
         "render.surface.part_colour: false needs composite.surface: 1"),
        ({"object.shapes": {"round": True, "scale": [[0.9, 1.2], [1, 1], [1, 1]]}}, "object.shapes.round takes y's"),
    ],
)
def test_bad_values_are_named(overrides, needle):
    with pytest.raises(UserError, match=needle.replace(".", r"\.")):
        load_config("quick", overrides)


def test_missing_and_corrupt_config_files(tmp_path):
    with pytest.raises(UserError, match="not found"):
        load_config(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("render: [1, 2\n")
    with pytest.raises(UserError, match="not valid YAML"):
        load_config(bad)


@pytest.mark.parametrize(
    "overrides, needle",
    [
        ({"camera.fill": [0, 0.5]}, "camera.fill"),
        ({"camera.fill": [0.5, 1.2]}, "camera.fill"),
        ({"camera.fill": [0.8, 0.5]}, "camera.fill"),
        ({"camera.offset": 0.6}, "camera.offset"),
        ({"camera.offset": -0.1}, "camera.offset"),
        ({"camera.partial": 1.5}, "camera.partial"),
        ({"camera.lens_mm": [85, 35]}, "camera.lens_mm"),
        ({"camera.lens_mm": [1, 35]}, "camera.lens_mm"),
        ({"camera.lens_mm": 0.5}, "camera.lens_mm"),
        ({"camera.fstop": [0, 8]}, "camera.fstop"),
        ({"camera.fstop": [8, 2]}, "camera.fstop"),
    ],
)
def test_bad_camera_framing_is_named(overrides, needle):
    with pytest.raises(UserError, match=needle.replace(".", r"\.")) as exc:
        load_config("quick", overrides)
    assert "\n" not in str(exc.value)


def test_camera_framing_is_off_by_default_and_lens_takes_a_range():
    cam = load_config("paper").camera
    assert (cam.fill, cam.offset, cam.partial, cam.fstop, cam.lens_mm, cam.framing) == (None, 0, 0, None, 50.0, False)
    cam = load_config("quick", {"camera.lens_mm": [35, 85]}).camera
    assert cam.lens_mm == (35.0, 85.0) and cam.lens_fixed == 60.0 and cam.framing


@pytest.mark.parametrize(
    "overrides, line",
    [
        ({"camera.polar": [70, 50]}, "--polar [70, 50]: invalid camera.polar: polar range [70.0, 50.0] is empty (min > max)"),
        ({"camera.azimuth_quadrants": [[0, 10], [-400, 10]]}, "--azimuth_quadrants [[0, 10], [-400, 10]]: invalid "
         "camera.azimuth_quadrants.1: azimuth_quadrants range [-400.0, 10.0] goes below -360"),
        ({"render.surface": {"scale": [2, 1]}},
         "--surface {'scale': [2, 1]}: invalid render.surface.scale: scale range [2.0, 1.0] is empty (min > max)"),
        ({"render.look": "Punchy"}, "--look Punchy: render.look Punchy needs view_transform AgX (got Standard)"),
        ({"render.world_map": 2}, "--world_map 2: render.world_map 2 is below Cycles' least map width, 4 "
         "(0 = automatic)"),
    ],
)
def test_a_bad_value_inside_an_override_is_named_by_its_flag(overrides, line):
    flags = {k: "--" + k.rsplit(".", 1)[-1] for k in overrides}
    with pytest.raises(UserError) as exc:
        load_config("quick", overrides, flags)
    assert str(exc.value) == line


def test_a_bad_value_in_a_file_is_named_by_the_file(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("lighting:\n  area_lights:\n    count: [3, 1]\n")
    with pytest.raises(UserError) as exc:
        load_config(path)
    assert str(exc.value) == f"{path}: invalid lighting.area_lights.count: count range [3, 1] is empty (min > max) " \
        "(got [3, 1])"


def _number_fields():
    """Every leaf field of the config that holds numbers: (dotted key, its kind in words)."""
    from deformsim.config import Config
    from deformsim.config_reference import fields, sections

    for key, model in [("", Config), *sections()]:
        for f in fields(model, key):
            if f.section is None and any(w in f.kind for w in ("number", "integer", "[min, max]")):
                yield f.key, f.kind


def _values(kind: str, bad: float) -> object:
    """A value of a field of ``kind`` that holds ``bad``."""
    if kind.startswith("list of [min, max]"):
        return [[0, bad]]
    if kind.startswith("[min, max]"):
        return [0, bad] if bad > 0 or bad != bad else [bad, 0]
    if kind.startswith("["):  # a fixed tuple of numbers
        return [bad] * kind.count("integer")
    return bad


NUMBER_FIELDS = sorted(_number_fields())


@pytest.mark.parametrize("key, kind", NUMBER_FIELDS, ids=[k for k, _ in NUMBER_FIELDS])
def test_every_number_field_refuses_nan_infinity_and_absurd_values(key, kind):
    """NaN and infinity in any float (alone or in a range) and values beyond any real run's, in any number field,
    are one line naming the key."""
    floats = "integer" not in kind or "number" in kind
    for bad in ([float("nan"), float("inf"), -float("inf")] if floats else []) + [10**30, -(10**30)]:
        with pytest.raises(UserError) as exc:
            load_config("quick", {key: _values(kind, bad)})
        line = str(exc.value)
        assert key in line and "\n" not in line and len(line) < 300, (bad, line)


@pytest.mark.parametrize("seed", [-1, 2**63, 2**64 + 1, 2**200])
@pytest.mark.parametrize("key", ["generate.seed", "train.seed"])
def test_seeds_stay_within_int64_and_numpy(key, seed):
    with pytest.raises(UserError, match=key.replace(".", r"\.")):
        load_config("quick", {key: seed})
    assert load_config("quick", {key: 2**63 - 1})


def test_nan_lens_and_fill_are_named_in_one_line(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("camera:\n  lens_mm: .nan\n")
    with pytest.raises(UserError) as exc:
        load_config(path)
    assert str(exc.value) == f"{path}: invalid camera.lens_mm: Input should be a finite number (got nan)"
    path.write_text("camera:\n  fill: [.nan, 0.5]\n")
    with pytest.raises(UserError, match=r"invalid camera\.fill\.0: Input should be a finite number") as exc:
        load_config(path)
    path.write_text("camera:\n  lens_mm: [35, .inf]\n")
    with pytest.raises(UserError, match=r"invalid camera\.lens_mm\.1: Input should be a finite number"):
        load_config(path)


def test_error_lines_never_print_huge_values(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("render:\n  look: [" + ", ".join(["lol"] * 50_000) + "]\n")
    with pytest.raises(UserError) as exc:
        load_config(path)
    assert "invalid render.look" in str(exc.value) and str(exc.value).count("lol") <= 6 and len(str(exc.value)) < 500
    with pytest.raises(UserError) as exc:
        load_config("quick", {"render.look": "x" * 10**6}, {"render.look": "--look"})
    assert str(exc.value).startswith("--look xxx") and len(str(exc.value)) < 400
    for overrides in ({"generate.n": 10**5000}, {"lighting.area_lights.count": [0, 10**5000]},
                      {"deform.families": [1, 10**400]}):
        with pytest.raises(UserError) as exc:
            load_config("quick", overrides)
        assert next(iter(overrides)) in str(exc.value) and len(str(exc.value)) < 300


def test_an_override_under_a_value_that_is_no_mapping_names_that_value(tmp_path):
    path = tmp_path / "c.yaml"
    path.write_text("generate: 5\n")
    with pytest.raises(UserError, match=r"invalid generate: Input should be .*dictionary"):
        load_config(path, {"generate.n": 8})


def test_the_quick_preset_trains_two_backbones_and_yields_them_to_a_backbone_or_dense_target_given():
    cfg = load_config("quick")
    assert (cfg.train.backbone, cfg.train.ensemble_backbones, cfg.train.ensemble) == ("vgg16", ["efficientnet_lite0"], 3)
    for given in ({"train.target": "severity"}, {"train.target": "localise", "train.ensemble": 1}):
        dense = load_config("quick", given)
        assert (dense.train.target, dense.train.ensemble, dense.train.ensemble_backbones) == (given["train.target"], 1, [])
    assert cfg.train.for_target("family").model_dump() == dense.train.model_copy(update={"target": "family"}).model_dump()
    assert cfg.train.for_target("label") == cfg.train
    with pytest.raises(UserError, match="train.ensemble applies to train.target label, not severity"):
        load_config("quick", {"train.target": "severity", "train.ensemble": 2})
    lite = load_config("quick", {"train.backbone": "efficientnet_lite0"}).train  # the backbone named, three seeds
    assert (lite.backbone, lite.ensemble_backbones, lite.ensemble) == ("efficientnet_lite0", [], 3)
    both = load_config("quick", {"train.backbone": "mobilenet_v2", "train.ensemble_backbones": ["vgg16"]}).train
    assert (both.backbone, both.ensemble_backbones) == ("mobilenet_v2", ["vgg16"])
