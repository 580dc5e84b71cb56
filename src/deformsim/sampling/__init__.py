"""Everything random about a sample, drawn in pure Python (no Blender).

A *sample* is one scene state (object deformation, openings, label, lighting) seen by every camera, so
it yields one image per camera. ``sample_params(i, seed, ...)`` depends only on ``(seed, i)``: samples can
be drawn in any order, by any worker, and a resumed run draws the same ones. The package holds the parameter
records (:mod:`~.params`, serialised by :mod:`~.records`), the lookup tables (:mod:`~.tables`), the photo folder
reads (:mod:`~.photos`), the draws (:mod:`~.sample`, :mod:`~.draws`), the named random streams that sampling and
compositing draw from (:mod:`~.streams`) and the registry of render features (:mod:`~.features`).
"""

from deformsim.sampling.draws import draw_appearance, draw_framing, draw_prints, draw_shape, draw_source
from deformsim.sampling.params import (
    AppearanceParams,
    CameraParams,
    CanDesign,
    LightParams,
    MaterialParams,
    PrintParams,
    SampleParams,
    ShapeParams,
    SurfaceParams,
)
from deformsim.sampling.photos import artwork_photos, surface_photos
from deformsim.sampling.sample import allowed_families, label_for, sample_params
from deformsim.sampling.tables import BRAND_WORDS, CAN_SIZES, CUT_SIDES, LIGHT_KINDS, SURFACE_COLOURS

__all__ = [
    "BRAND_WORDS", "CAN_SIZES", "CUT_SIDES", "LIGHT_KINDS", "SURFACE_COLOURS", "AppearanceParams", "CameraParams",
    "CanDesign", "LightParams", "MaterialParams", "PrintParams", "SampleParams", "ShapeParams", "SurfaceParams",
    "allowed_families", "artwork_photos", "draw_appearance", "draw_framing", "draw_prints", "draw_shape", "draw_source",
    "label_for", "sample_params", "surface_photos",
]
