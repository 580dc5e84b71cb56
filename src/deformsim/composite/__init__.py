"""Chroma-key matting and compositing onto photo or procedural backgrounds (``deformsim composite``)."""

from deformsim.composite.backgrounds import BackgroundWarning, fit, procedural, scan_backgrounds
from deformsim.composite.matte import alpha_matte, binary_iou, chroma_matte, inrange_matte
from deformsim.composite.stage import composite, default_name, stable_int

__all__ = [
    "BackgroundWarning",
    "alpha_matte",
    "binary_iou",
    "chroma_matte",
    "composite",
    "default_name",
    "fit",
    "inrange_matte",
    "procedural",
    "scan_backgrounds",
    "stable_int",
]
