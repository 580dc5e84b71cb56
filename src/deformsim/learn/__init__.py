"""The condition-assessment model (torch): backbones and weights, model, feature cache, training, checkpoint,
prediction, ONNX export.

Modules import torch; the CLI imports them inside its commands only.
"""
