"""The Blender side of the registry of optional render features (:data:`deformsim.sampling.features.FEATURES`): each
declaration names its :class:`~deformsim.blender.feature.Feature` class, set up here in the registry's order (the
order of the Blender operations per sample, so a new feature goes last)."""

from __future__ import annotations

from importlib import import_module

from deformsim.blender.feature import Feature, RenderContext
from deformsim.sampling.feature import RenderFeature
from deformsim.sampling.features import FEATURES as DECLARED
from deformsim.sampling.features import active


def blender_class(f: RenderFeature) -> type[Feature]:
    """The Blender side ``f`` names ("module:Class")."""
    module, name = f.blender.split(":")
    return getattr(import_module(module), name)


FEATURES: tuple[type[Feature], ...] = tuple(blender_class(f) for f in DECLARED)


def set_up(ctx: RenderContext) -> list[Feature]:
    """Set up every feature ``ctx.cfg`` turns on, once per worker."""
    return [blender_class(f)(ctx) for f in active(ctx.cfg)]
