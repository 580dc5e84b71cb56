"""The condition-assessment model (torch): backbones and weights, model, feature cache, training, checkpoint,
prediction, ONNX export.

Modules import torch, except :mod:`~deformsim.learn.backbones` (the registry the config reads its names from);
the CLI imports them inside its commands only.
"""
