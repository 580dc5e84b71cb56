"""The condition-assessment model (torch): backbones and weights, model, feature cache, training, checkpoint,
prediction, ONNX export.

Modules import torch, except :mod:`~deformsim.learn.backbones` (the registry the config reads its names from),
:mod:`~deformsim.learn.crops`, :mod:`~deformsim.learn.model_input` and :mod:`~deformsim.learn.onnx_predict` (an
exported model, with onnxruntime); the CLI imports them inside its commands only.
"""
