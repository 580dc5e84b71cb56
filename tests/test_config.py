"""Config validation: one clear line naming the bad value, before any work."""


import pytest

from deformsim.config import list_presets, load_config
from deformsim.errors import UserError


def test_presets_load_and_paper_has_the_papers_settings():
    assert {"quick", "paper"} <= set(list_presets())
    paper = load_config("paper")
    assert paper.generate.n == 6000 and paper.render.resolution == 512
    assert (paper.train.lr, paper.train.batch_size, paper.train.epochs) == (1e-3, 32, 15)


def test_overrides_apply_and_none_is_ignored():
    cfg = load_config("quick", {"generate.n": 16, "render.resolution": 96, "render.samples": None})
    assert (cfg.generate.n, cfg.render.resolution, cfg.render.samples) == (16, 96, load_config().render.samples)


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


def test_scene_kinds_are_the_layouts_in_render_order():
    from deformsim.config import RenderConfig
    from deformsim.dataset.layout import SCENE_KINDS

    assert RenderConfig().scene_kinds == ()
    assert RenderConfig(shadow=True, surface={}).scene_kinds == SCENE_KINDS
    assert RenderConfig(surface={"kinds": ["cloth"]}).scene_kinds == ("surface",)


@pytest.mark.parametrize(
    "overrides, line",
    [
        ({"camera.polar": [70, 50]}, "--polar [70, 50]: invalid camera.polar: polar range [70.0, 50.0] is empty (min > max)"),
        ({"camera.azimuth_quadrants": [[0, 10], [-400, 10]]}, "--azimuth_quadrants [[0, 10], [-400, 10]]: invalid "
         "camera.azimuth_quadrants.1: azimuth_quadrants range [-400.0, 10.0] goes below -360"),
        ({"render.surface": {"scale": [2, 1]}},
         "--surface {'scale': [2, 1]}: invalid render.surface.scale: scale range [2.0, 1.0] is empty (min > max)"),
        ({"render.look": "Punchy"}, "--look Punchy: render.look Punchy needs view_transform AgX (got Standard)"),
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
