"""docs/configuration.md is written from the config's field descriptions, and is current."""

from __future__ import annotations

from deformsim.config import Config
from deformsim.config_reference import fields, main, markdown, sections
from deformsim.identity import NEVER
from tests.util import ROOT

REGENERATE = ".venv/bin/python -m deformsim.config_reference"


def test_the_committed_reference_is_current():
    committed = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")
    assert committed == markdown(), f"docs/configuration.md is stale: run `{REGENERATE}` in the checkout's root"


def test_every_field_is_described():
    missing = [f.key for _, model in [("", Config), *sections()] for f in fields(model, _) if not f.description]
    assert not missing, f"fields without Field(description=...): {', '.join(missing)}"


def test_the_walk_gives_keys_types_defaults_and_rules():
    assert [key for key, _ in sections()] == [
        "object", "object.shapes", "camera", "pose", "lighting", "lighting.area_lights", "lighting.sun", "deform",
        "deform.sources", "render", "render.region_visible", "render.surface", "render.appearance", "generate",
        "composite", "composite.effects", "train"]
    camera = {f.key: f for f in fields(type(Config().camera), "camera")}
    assert camera["camera.fill"].kind == "[min, max] (0 < min ≤ max ≤ 1) or null" and camera["camera.fill"].default is None
    assert camera["camera.polar"].kind == "[min, max] (0 ≤ min ≤ max ≤ 180)"
    assert camera["camera.polar"].default == [50.0, 70.0]
    assert camera["camera.lens_mm"].kind == "number or [min, max] (above 1, at most 2000)"
    render = {f.key: f for f in fields(type(Config().render), "render")}
    assert render["render.resolution"].kind == "integer (16 ≤ x ≤ 4096)"
    assert render["render.surface"].section is not None and render["render.surface"].kind == "section or null"
    assert {f.key for f in fields(Config) if f.rule == NEVER} == {"composite", "train"}


def test_main_writes_the_reference(tmp_path):
    main([str(tmp_path / "configuration.md")])
    assert (tmp_path / "configuration.md").read_text(encoding="utf-8") == markdown()


def test_every_number_field_states_its_range():
    """The reference gives every number an upper bound."""
    for key, model in [("", Config), *sections()]:
        for f in fields(model, key):
            if f.section is None and any(w in f.kind for w in ("number", "integer", "[min, max]")):
                assert any(b in f.kind for b in ("≤ max ≤", "x ≤", "x <", "at most")), (f.key, f.kind)
