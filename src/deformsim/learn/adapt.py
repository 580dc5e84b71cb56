"""Unsupervised domain adaptation from unlabelled photos of real parts (their labels are never read).

- ``adabn`` (Li et al., AdaBN): the pooled features pass a BatchNorm without affine parameters
  (``train.feature_norm``); its statistics, estimated on the synthetic training images, are replaced by those
  of the real photos, so both domains enter the head centred and scaled alike.
- ``selftrain``: AdaBN, then the photos the adapted model classifies most surely (probability beyond
  ``train.pseudo_confidence``, as many of each predicted class) join training with those predictions as
  labels for ``train.adapt_epochs`` epochs; the statistics are re-estimated on the photos at the end.
"""

from __future__ import annotations

import torch
from torch import nn

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.models import DeformNet
from deformsim.log import get_logger

log = get_logger(__name__)


@torch.no_grad()
def set_feature_stats(model: DeformNet, stems: torch.Tensor, batch_size: int) -> None:
    """Set the feature BatchNorm's statistics to the exact mean and variance of ``stems``' pooled features."""
    if not isinstance(model.norm, nn.BatchNorm1d):
        raise UserError("domain adaptation needs train.feature_norm: true")
    was_training = model.training
    model.eval()
    feats = torch.cat([model.pooled_raw(b) for b in stems.split(batch_size)])
    model.norm.running_mean.copy_(feats.mean(0))
    model.norm.running_var.copy_(feats.var(0, unbiased=len(feats) > 1))
    model.train(was_training)


@torch.no_grad()
def pseudo_labels(model: DeformNet, stems: torch.Tensor, cfg: TrainConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """Row indices and labels of the most surely classified photos, balanced between the predicted classes."""
    model.eval()
    p = torch.cat([torch.sigmoid(model.tail(b)) for b in stems.split(cfg.batch_size)])
    sure_pos = torch.nonzero(p >= cfg.pseudo_confidence).flatten()
    sure_neg = torch.nonzero(p <= 1 - cfg.pseudo_confidence).flatten()
    n = min(len(sure_pos), len(sure_neg))
    pos = sure_pos[torch.argsort(p[sure_pos], descending=True)[:n]]
    neg = sure_neg[torch.argsort(p[sure_neg])[:n]]
    rows = torch.cat([pos, neg])
    return rows, torch.cat([torch.ones(n), torch.zeros(n)]).to(p.device)
