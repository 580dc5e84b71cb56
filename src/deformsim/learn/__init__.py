"""The condition-assessment model (torch): weights, model, feature cache, training, prediction, ONNX export.

Modules import torch; the CLI imports them inside its commands only.
"""
