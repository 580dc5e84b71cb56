"""The paper's classifier: a frozen ImageNet backbone with a trainable last block and a 3-layer head.

``DeformNet.forward`` takes 0-1 RGB images (N, 3, S, S), applies torchvision's normalisation and returns
**logits** of P(deformed) (training uses BCEWithLogits); ``proba`` applies the sigmoid, and the ONNX export
outputs probabilities. The backbone is split at ``cut``: ``stem`` (frozen, always in eval mode, so its
outputs can be cached) and ``tail`` (the last conv layer / block, trained).
"""

from __future__ import annotations

import torch
from torch import nn

from deformsim.config import TrainConfig
from deformsim.learn.weights import TORCH_MEAN, TORCH_STD, resolve

# Index of the first trainable module in ``features``: vgg16 features[28] is the last conv (512->512),
# mobilenet_v2 features[18] is the last block (1x1 conv 320->1280 + BN + ReLU6).
CUT = {"vgg16": 28, "mobilenet_v2": 18}
WIDTH = {"vgg16": 512, "mobilenet_v2": 1280}


def backbone_features(name: str) -> nn.Sequential:
    """torchvision's randomly initialised ``features`` (VGG-16 without building its 120M-parameter classifier)."""
    from torchvision import models

    if name == "mobilenet_v2":
        return models.mobilenet_v2(weights=None).features
    features = models.vgg.make_layers(models.vgg.cfgs["D"])
    for m in features.modules():
        if isinstance(m, nn.Conv2d):  # as torchvision's VGG initialises its convolutions
            nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            nn.init.zeros_(m.bias)
    return features


class DeformNet(nn.Module):
    def __init__(self, backbone: str, hidden: tuple[int, int], dropout: float):
        super().__init__()
        self.backbone = backbone
        self.features = backbone_features(backbone)
        self.cut = CUT[backbone]
        self.register_buffer("mean", torch.tensor(TORCH_MEAN, dtype=torch.float32).view(1, 3, 1, 1))
        self.register_buffer("std", torch.tensor(TORCH_STD, dtype=torch.float32).view(1, 3, 1, 1))
        self.pool = nn.AdaptiveAvgPool2d(1)
        h0, h1 = hidden
        self.head = nn.Sequential(
            nn.Flatten(),
            nn.Linear(WIDTH[backbone], h0), nn.ReLU(inplace=True), nn.Dropout(dropout),
            nn.Linear(h0, h1), nn.ReLU(inplace=True), nn.Dropout(dropout),
            nn.Linear(h1, 1),
        )
        for p in self.frozen_parameters():
            p.requires_grad_(False)

    def frozen_parameters(self):
        return (p for m in self.features[: self.cut] for p in m.parameters())

    def train(self, mode: bool = True) -> "DeformNet":
        super().train(mode)
        self.features[: self.cut].eval()  # frozen BatchNorm statistics stay as loaded
        return self

    def stem(self, x: torch.Tensor) -> torch.Tensor:
        """Frozen part: 0-1 RGB images to the activations entering the first trainable layer."""
        return self.features[: self.cut]((x - self.mean) / self.std)

    def embed(self, z: torch.Tensor, layer: str = "penultimate") -> torch.Tensor:
        """From stem activations to pooled backbone features (``pooled``) or the last hidden layer."""
        pooled = self.pool(self.features[self.cut :](z)).flatten(1)
        return pooled if layer == "pooled" else self.head[:-1](pooled)

    def tail(self, z: torch.Tensor) -> torch.Tensor:
        """Trainable part: stem activations to logits (N,)."""
        return self.head(self.pool(self.features[self.cut :](z))).squeeze(1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.tail(self.stem(x))

    def proba(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self(x))


def build(cfg: TrainConfig, load_weights: bool = True) -> tuple[DeformNet, str]:
    """The model for ``cfg`` (random init seeded by cfg.seed) with its backbone weights and their source.

    ``load_weights=False`` skips resolving pretrained weights (when a saved state dict follows).
    """
    torch.manual_seed(cfg.seed)
    model = DeformNet(cfg.backbone, cfg.hidden, cfg.dropout)
    if not load_weights:
        return model, "loaded from a saved model"
    state, desc = resolve(cfg.backbone, cfg.weights)
    if state is not None:
        model.features.load_state_dict(state)
    return model, desc
