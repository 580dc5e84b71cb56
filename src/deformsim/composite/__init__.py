"""Chroma-key matting and compositing onto photo or procedural backgrounds (``deformsim composite``)."""
