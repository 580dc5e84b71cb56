"""The paper's classifier: a frozen ImageNet backbone with a trainable last layer or block and a head.

``DeformNet.forward`` takes 0-1 RGB images (N, 3, S, S), applies torchvision's normalisation and returns
**logits** of P(deformed) (training uses BCEWithLogits); ``proba`` applies the sigmoid, and the ONNX export
outputs probabilities. The backbone is split at ``cut``: ``stem`` (frozen, always in eval mode, so its
outputs can be cached) and ``tail`` (the last conv layer / block, trained). The head is the paper's three
fully connected layers or a linear probe; with ``feature_norm`` the pooled features pass a BatchNorm without
affine parameters, whose statistics can be re-estimated on another domain (AdaBN, :mod:`deformsim.learn.adapt`).
"""

from __future__ import annotations

import torch
from torch import nn

from deformsim.config import TrainConfig
from deformsim.learn.backbones import CUTS, WIDTH, backbone_features
from deformsim.learn.weights import TORCH_MEAN, TORCH_STD, resolve


class DeformNet(nn.Module):
    def __init__(self, backbone: str, hidden: tuple[int, int], dropout: float, finetune: str = "last_conv",
                 head: str = "mlp", feature_norm: bool = False):
        super().__init__()
        self.backbone = backbone
        self.features = backbone_features(backbone)
        self.cut = CUTS[backbone][finetune]
        self.register_buffer("mean", torch.tensor(TORCH_MEAN, dtype=torch.float32).view(1, 3, 1, 1))
        self.register_buffer("std", torch.tensor(TORCH_STD, dtype=torch.float32).view(1, 3, 1, 1))
        self.pool = nn.AdaptiveAvgPool2d(1)
        width = WIDTH[backbone]
        self.norm = nn.BatchNorm1d(width, affine=False) if feature_norm else nn.Identity()
        if head == "mlp":
            h0, h1 = hidden
            self.head = nn.Sequential(
                nn.Flatten(),
                nn.Linear(width, h0), nn.ReLU(inplace=True), nn.Dropout(dropout),
                nn.Linear(h0, h1), nn.ReLU(inplace=True), nn.Dropout(dropout),
                nn.Linear(h1, 1),
            )
        else:
            self.head = nn.Sequential(nn.Flatten(), nn.Dropout(dropout), nn.Linear(width, 1))
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

    def pooled_raw(self, z: torch.Tensor) -> torch.Tensor:
        """From stem activations to the pooled output of the trainable backbone layers (N, width)."""
        return self.pool(self.features[self.cut :](z)).flatten(1)

    def embed(self, z: torch.Tensor, layer: str = "penultimate") -> torch.Tensor:
        """From stem activations to pooled (normalised) backbone features (``pooled``) or the last hidden layer."""
        pooled = self.norm(self.pooled_raw(z))
        return pooled if layer == "pooled" else self.head[:-1](pooled)

    def tail(self, z: torch.Tensor) -> torch.Tensor:
        """Trainable part: stem activations to logits (N,)."""
        return self.head(self.norm(self.pooled_raw(z))).squeeze(1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.tail(self.stem(x))

    def proba(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self(x))


def build(cfg: TrainConfig, load_weights: bool = True) -> tuple[DeformNet, str]:
    """The model for ``cfg`` (random init seeded by cfg.seed) with its backbone weights and their source.

    ``load_weights=False`` skips resolving pretrained weights (when a saved state dict follows).
    """
    torch.manual_seed(cfg.seed)
    model = DeformNet(cfg.backbone, cfg.hidden, cfg.dropout, cfg.finetune, cfg.head, cfg.feature_norm)
    if not load_weights:
        return model, "loaded from a saved model"
    state, desc = resolve(cfg.backbone, cfg.weights)
    if state is not None:
        model.features.load_state_dict(state)
    return model, desc
