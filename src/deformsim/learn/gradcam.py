"""Grad-CAM (Selvaraju et al.): where in an image the evidence for "deformed" lies, for the report.

The map is taken at the last spatial activation of the trainable backbone layers (before a final max pool; the
frozen network's output when only the head trains):
each channel weighted by the mean gradient of the logit over it, summed, rectified and scaled to [0, 1].
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from deformsim.learn.models import DeformNet, Ensemble, members


def gradcam(model: DeformNet | Ensemble, stems: torch.Tensor) -> np.ndarray:
    """Heatmaps (N, h, w) in [0, 1] of P(deformed) for stem activations ``stems`` (N, C, H, W); an ensemble's is
    the mean of its members'."""
    return np.mean([_gradcam(net, stems) for net in members(model)], axis=0)


def _gradcam(model: DeformNet, stems: torch.Tensor) -> np.ndarray:
    model.eval()
    layers = list(model.features[model.cut :])
    split = len(layers) - 1 if layers and isinstance(layers[-1], nn.MaxPool2d) else len(layers)
    maps = []
    for z in stems.split(16):
        with torch.enable_grad():
            act = z.detach()
            for m in layers[:split]:
                act = m(act)
            act.requires_grad_(True)
            rest = act
            for m in layers[split:]:
                rest = m(rest)
            logit = model.head(model.norm(model.pool(rest))).squeeze(1)
            (grad,) = torch.autograd.grad(logit.sum(), act)
        cam = torch.relu((grad.mean(dim=(2, 3), keepdim=True) * act).sum(1)).detach()
        peak = cam.flatten(1).max(1).values.clamp_min(1e-12)[:, None, None]
        maps.append((cam / peak).cpu())
    return torch.cat(maps).numpy()


def overlay(image: np.ndarray, cam: np.ndarray, alpha: float = 0.45) -> np.ndarray:
    """``image`` (H, W, 3 uint8) with ``cam`` resized over it in a red-yellow colour map."""
    import cv2

    h, w = image.shape[:2]
    heat = cv2.resize(cam.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    colour = cv2.cvtColor(cv2.applyColorMap((heat * 255).astype(np.uint8), cv2.COLORMAP_JET), cv2.COLOR_BGR2RGB)
    out = image.astype(np.float32) * (1 - alpha * heat[..., None]) + colour * (alpha * heat[..., None])
    return out.clip(0, 255).astype(np.uint8)
