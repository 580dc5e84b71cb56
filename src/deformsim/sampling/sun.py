"""``lighting.sun``: a hard directional key light per sample, as the driver sees it: its drawn record, its draw and
its declaration in the render-feature registry (its Blender side: :mod:`deformsim.blender.scene.sun`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from deformsim.sampling.feature import Given, RenderFeature
from deformsim.sampling.records import Record
from deformsim.sampling.streams import Stream


@dataclass(frozen=True)
class SunParams(Record):
    """The sample's sun: where its light comes from, how strong, hard and warm it is (strength 0: not lit)."""

    azimuth: float  # degrees about +Z from +X
    elevation: float  # degrees above the horizon
    strength: float  # irradiance (W/m2); 0 when the sample is outside lighting.sun.share
    angle: float  # angular diameter (degrees): the softness of its shadows' edges
    temperature: float  # colour temperature in kelvin


def draw_sun(rng: np.random.Generator, g: Given) -> SunParams:
    """Every value is drawn for every sample, lit or not, so ``share`` moves no other value."""
    s = g.cfg.lighting.sun
    lit = rng.uniform() < s.share
    azimuth, elevation = float(rng.uniform(0, 360)), float(rng.uniform(*s.elevation))
    strength, angle = float(rng.uniform(*s.strength)), float(rng.uniform(*s.angle))
    return SunParams(azimuth=azimuth, elevation=elevation, strength=strength if lit else 0.0, angle=angle,
                     temperature=float(rng.uniform(*s.temperature)))


SUN = RenderFeature(
    name="sun", section="lighting.sun", on=lambda cfg: cfg.lighting.sun is not None,
    blender="deformsim.blender.scene.sun:Sun", field="sun",
    stream=Stream(("index",), (10,), "the sample's sun: direction, strength, softness, colour (lighting.sun)"),
    draw=draw_sun, columns=lambda s: {f"sun_{k}": v for k, v in s.to_dict().items()} if s is not None else {},
)
