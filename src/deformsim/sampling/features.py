"""The registry of optional render features (:class:`~deformsim.sampling.feature.RenderFeature`), in the order their
Blender hooks run per sample: a new feature goes last. Sampling draws, the manifest writes, the refusals count and
the worker sets up what the registry lists."""

from __future__ import annotations

import json
from typing import Any

from deformsim.config import Config
from deformsim.dataset.layout import DENSE_KINDS, SHADOW_KIND, SURFACE_KIND
from deformsim.sampling import streams
from deformsim.sampling.draws import draw_drop, draw_lights, draw_surface
from deformsim.sampling.feature import Given, RenderFeature
from deformsim.sampling.photos import surface_photos
from deformsim.sampling.streams import Stream
from deformsim.sampling.sun import SUN
from deformsim.spec.model import Spec

AREA_LIGHTS = RenderFeature(
    name="lights", section="lighting.area_lights", on=lambda cfg: cfg.lighting.area_lights.count[1] > 0,
    blender="deformsim.blender.scene.lights:AreaLights", field="lights",
    stream=Stream(("index",), (3,), "the sample's area lights (lighting.area_lights)"),
    draw=lambda rng, g: draw_lights(rng, g.cfg, g.cameras), off=(),
    columns=lambda lights: {"lights": json.dumps([lp.__dict__ for lp in lights], sort_keys=True)},
)
DROP = RenderFeature(
    name="drop", section="pose.mode", on=lambda cfg: cfg.pose.mode == "drop", blender="deformsim.blender.motion.drop:Drop",
    field="drop_rotation", stream=Stream(("index",), (2,), "the start orientation of pose.mode drop"),
    draw=lambda rng, g: draw_drop(rng, g.cfg.pose.drop_upright), off=(),
    columns=lambda q: {f"drop_q{a}": v for a, v in zip("wxyz", q)},
)
DENSE = RenderFeature(
    name="dense", section="render.dense", on=lambda cfg: cfg.render.dense, blender="deformsim.blender.passes.dense:Dense",
    kinds=DENSE_KINDS, png_bytes=1.5,
)
SHADOW = RenderFeature(
    name="shadow", section="render.shadow", on=lambda cfg: cfg.render.shadow,
    blender="deformsim.blender.scene.shadow:Shadow", kinds=(SHADOW_KIND,), renders=1,
)
SURFACE = RenderFeature(
    name="surface", section="render.surface", on=lambda cfg: cfg.render.surface is not None,
    blender="deformsim.blender.scene.surface:Surface", field="surface",
    stream=Stream(("index",), (4,), "the ground the part rests on (render.surface)"),
    draw=lambda rng, g: draw_surface(rng, g.cfg, g.listing),
    columns=lambda s: {"surface_params": json.dumps(s.__dict__, sort_keys=True)} if s is not None else {},
    kinds=(SURFACE_KIND,), renders=1,
    listing=lambda cfg: surface_photos(cfg.render.surface.photos) if "photo" in cfg.render.surface.kinds else None,
)

FEATURES: tuple[RenderFeature, ...] = (AREA_LIGHTS, DROP, DENSE, SHADOW, SURFACE, SUN)

# Every named stream: sampling's and compositing's, and the features' (tests/sampling/test_streams.py: none draw alike).
STREAMS: dict[str, Stream] = {**streams.STREAMS, **{f.name: f.stream for f in FEATURES if f.stream is not None}}


def active(cfg: Config) -> list[RenderFeature]:
    """The features ``cfg`` turns on, in the registry's order."""
    return [f for f in FEATURES if f.on(cfg)]


def listings(cfg: Config) -> dict[str, list[str] | None]:
    """The input files each active feature's draw picks from, by feature name: listed once per run."""
    return {f.name: f.listing(cfg) for f in active(cfg) if f.listing is not None}


def draw_features(index: int, seed: int, cfg: Config, spec: Spec, cameras: tuple,
                  listed: dict[str, list[str] | None] | None = None) -> dict[str, Any]:
    """Every feature's drawn value for sample ``index`` (off ones their off value), by its SampleParams field;
    ``listed``: :func:`listings` of ``cfg`` (listed here when None)."""
    listed = listings(cfg) if listed is None else listed
    return {f.field: f.value(index, seed, Given(cfg, spec, cameras, listed.get(f.name)))
            for f in FEATURES if f.field}


def feature_columns(p) -> dict:
    """The manifest columns of sample ``p``'s (:class:`~deformsim.sampling.SampleParams`) feature draws."""
    return {k: v for f in FEATURES if f.columns is not None for k, v in f.columns(getattr(p, f.field)).items()}


def extra_renders(cfg: Config) -> int:
    """The Cycles renders per image ``cfg``'s features add to the one of ``rgba``."""
    return sum(f.renders for f in active(cfg))


def png_bytes(cfg: Config) -> float:
    """Bytes per pixel of the images ``cfg``'s features write without an extra render."""
    return sum(f.png_bytes for f in active(cfg))
