"""The registry of optional render features (:class:`deformsim.blender.feature.Feature`), in the order their hooks
run: it is the order of the Blender operations per sample and of the manifest columns, so a new feature goes last."""

from __future__ import annotations

from deformsim.blender.feature import Feature, RenderContext
from deformsim.blender.motion.drop import Drop
from deformsim.blender.passes.dense import Dense
from deformsim.blender.scene.lights import AreaLights
from deformsim.blender.scene.shadow import Shadow
from deformsim.blender.scene.surface import Surface

FEATURES: tuple[type[Feature], ...] = (AreaLights, Drop, Dense, Shadow, Surface)


def set_up(ctx: RenderContext) -> list[Feature]:
    """Set up every feature ``ctx.cfg`` turns on, once per worker."""
    return [feature(ctx) for feature in FEATURES if feature.on(ctx.cfg)]
