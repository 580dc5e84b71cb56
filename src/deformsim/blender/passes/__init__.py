"""Render passes: one sample's images (render) and its dense ground truth (dense)."""
