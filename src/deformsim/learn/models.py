"""The paper's classifier: a frozen ImageNet backbone with a trainable last layer or block and a head.

``DeformNet.forward`` takes 0-1 RGB images (N, 3, S, S), turns them grey with ``grey`` (Rec. 709 luma in all three
channels), applies the backbone's normalisation and returns **logits** of P(deformed) (training uses BCEWithLogits);
``proba`` applies the sigmoid, and the ONNX export outputs probabilities. The backbone is split at ``cut``: ``stem``
(frozen, always in eval mode, so its outputs can be cached) and ``tail`` (the last conv layer / block, trained; with
``finetune="none"`` the whole backbone is the stem and only the head trains). The
head is the paper's three fully connected layers or a linear probe; with ``feature_norm`` the pooled features pass a
BatchNorm without affine parameters, whose statistics can be re-estimated on another domain (AdaBN,
:mod:`deformsim.learn.adapt`).

Other ``target`` s (:mod:`deformsim.learn.targets`) freeze the whole backbone and train only a head on it:
``severity`` regresses the maximum displacement in mm (``tail`` returns mm), ``family`` gives one logit per
deformation family, ``localise`` a region logit map (:class:`deformsim.learn.heads.RegionHead` on the stem's map).
``predict`` gives what the model is for: P(deformed), mm, family probabilities or a region probability map.
"""

from __future__ import annotations

import torch
from torch import nn

from deformsim.config import TrainConfig
from deformsim.learn.backbones import BACKBONES
from deformsim.learn.heads import POOL_WIDTH, GlobalPool, RegionHead, region_size, vector_head
from deformsim.learn.weights import resolve

LUMA = torch.tensor([0.2126, 0.7152, 0.0722]).view(1, 3, 1, 1)  # Rec. 709 weights of R, G, B


class DeformNet(nn.Module):
    def __init__(self, backbone: str, hidden: tuple[int, int], dropout: float, finetune: str = "last_conv",
                 head: str = "mlp", feature_norm: bool = False, target: str = "label", outputs: int = 1,
                 image_size: int = 224, pool: str = "avg", grey: bool = False):
        super().__init__()
        self.backbone = backbone
        self.grey = grey
        self.target = target
        bb = BACKBONES[backbone]
        self.features = bb.features()
        self.cut, stem_width = (len(self.features), bb.width) if finetune == "none" else bb.cuts[finetune]
        self.register_buffer("mean", torch.tensor(bb.mean, dtype=torch.float32).view(1, 3, 1, 1))
        self.register_buffer("std", torch.tensor(bb.std, dtype=torch.float32).view(1, 3, 1, 1))
        self.pool = GlobalPool(pool)
        self.width = width = bb.width * POOL_WIDTH[pool]  # of the pooled features (:meth:`embed`'s "pooled")
        self.norm = nn.BatchNorm1d(width, affine=False) if feature_norm else nn.Identity()
        if target == "localise":
            self.head = RegionHead(stem_width, region_size(image_size))
        else:
            self.head = vector_head(width, hidden, dropout, head, outputs)
        if target == "severity":  # mean and standard deviation of the training targets (mm)
            self.register_buffer("scale", torch.tensor([0.0, 1.0]))
        for p in self.frozen_parameters():
            p.requires_grad_(False)

    @property
    def frozen(self) -> nn.Sequential:
        """The frozen backbone layers: the stem, or all of them for a head-only target."""
        return self.features[: self.cut] if self.target == "label" else self.features

    def frozen_parameters(self):
        return (p for m in self.frozen for p in m.parameters())

    def train(self, mode: bool = True) -> "DeformNet":
        super().train(mode)
        self.frozen.eval()  # frozen BatchNorm statistics stay as loaded
        return self

    def stem(self, x: torch.Tensor) -> torch.Tensor:
        """Frozen part: 0-1 RGB images to the activations entering the first trainable layer (computed channels-last
        where the backbone runs faster so, and returned in the default layout)."""
        if self.grey:
            x = (x * LUMA.to(x)).sum(1, keepdim=True).expand_as(x)
        x = (x - self.mean) / self.std
        if BACKBONES[self.backbone].channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        return self.features[: self.cut](x).contiguous()

    def pooled_raw(self, z: torch.Tensor) -> torch.Tensor:
        """From stem activations to the pooled output of the trainable backbone layers (N, width)."""
        return self.pool(self.features[self.cut :](z))

    def embed(self, z: torch.Tensor, layer: str = "penultimate") -> torch.Tensor:
        """From stem activations to pooled (normalised) backbone features (``pooled``) or the last hidden layer."""
        pooled = self.norm(self.pooled_raw(z))
        return pooled if layer == "pooled" else self.head[:-1](pooled)

    def head_input(self, z: torch.Tensor) -> torch.Tensor:
        """Head-only targets: what the head reads, from frozen layers only (the stem map, or pooled features)."""
        return z if self.target == "localise" else self.pooled_raw(z)

    def from_input(self, h: torch.Tensor) -> torch.Tensor:
        """Head-only targets: head input to mm (severity) or logits (family: N x K; localise: N x s x s)."""
        if self.target == "localise":
            return self.head(h)
        out = self.head(self.norm(h))
        return out.squeeze(1) * self.scale[1] + self.scale[0] if self.target == "severity" else out

    def tail(self, z: torch.Tensor) -> torch.Tensor:
        """Trainable part: stem activations to logits (N,), or to :meth:`from_input`'s output."""
        if self.target != "label":
            return self.from_input(self.head_input(z))
        return self.head(self.norm(self.pooled_raw(z))).squeeze(1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.tail(self.stem(x))

    def proba(self, x: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self(x))

    def outputs(self, z: torch.Tensor) -> torch.Tensor:
        """Stem activations to the prediction: probabilities, or mm for severity."""
        out = self.tail(z)
        return out if self.target == "severity" else torch.sigmoid(out)

    def predict(self, x: torch.Tensor) -> torch.Tensor:
        return self.outputs(self.stem(x))


LOGIT_EPS = 1e-6  # an ensemble's mean probability is clamped to [eps, 1 - eps] before its logit


class Ensemble(nn.Module):
    """``train.ensemble`` DeformNets of one config, trained with consecutive seeds, that share the frozen stem (one
    cache of stem activations serves all): predictions are the mean of their probabilities (``tail`` returns its
    clamped logit), ``embed`` is the first member's."""

    def __init__(self, members: list[DeformNet]):
        super().__init__()
        first = members[0]
        for m in members[1:]:
            for i in range(first.cut):
                m.features[i] = first.features[i]
        self.members = nn.ModuleList(members)
        self.backbone, self.target, self.cut, self.grey = first.backbone, first.target, first.cut, first.grey

    @property
    def features(self) -> nn.Sequential:
        return self.members[0].features

    @property
    def mean(self) -> torch.Tensor:
        return self.members[0].mean

    def stem(self, x: torch.Tensor) -> torch.Tensor:
        return self.members[0].stem(x)

    def outputs(self, z: torch.Tensor) -> torch.Tensor:
        return torch.stack([m.outputs(z) for m in self.members]).mean(0)

    def tail(self, z: torch.Tensor) -> torch.Tensor:
        # clamped: a member's float32 sigmoid reaches exactly 1, whose logit would make the loss NaN
        return torch.logit(self.outputs(z), eps=LOGIT_EPS)

    def embed(self, z: torch.Tensor, layer: str = "penultimate") -> torch.Tensor:
        return self.members[0].embed(z, layer)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.tail(self.stem(x))

    def predict(self, x: torch.Tensor) -> torch.Tensor:
        return self.outputs(self.stem(x))


def members(model: DeformNet | Ensemble) -> list[DeformNet]:
    """The networks of a model: an ensemble's members, or the model itself."""
    return list(model.members) if isinstance(model, Ensemble) else [model]


def build(cfg: TrainConfig, load_weights: bool = True, outputs: int = 1) -> tuple[DeformNet | Ensemble, str]:
    """The model for ``cfg`` (member k's random init seeded by cfg.seed + k) with its backbone weights and their
    source: a :class:`DeformNet`, or an :class:`Ensemble` of ``cfg.ensemble`` of them.

    ``load_weights=False`` skips resolving pretrained weights (when a saved state dict follows); ``outputs``:
    the number of families of a ``family`` model.
    """
    nets = []
    for k in range(cfg.ensemble):
        torch.manual_seed(cfg.seed + k)
        nets.append(DeformNet(cfg.backbone, cfg.hidden, cfg.dropout, cfg.finetune, cfg.head, cfg.feature_norm,
                              cfg.target, outputs, cfg.image_size, cfg.pool, cfg.grey))
    desc = "loaded from a saved model"
    if load_weights:
        state, desc = resolve(cfg.backbone, cfg.weights)
        if state is not None:
            for net in nets:
                net.features.load_state_dict(state)
    return (nets[0] if len(nets) == 1 else Ensemble(nets)), desc
