"""The networks trained on unlabelled photos beside the renders (``deformsim adapt --method fixmatch|adamatch|mcc``).

Each step draws a batch of renders with their labels and a batch of photos, and adds a loss on the photos to the
renders' cross-entropy:

- ``fixmatch`` (Sohn et al. 2020) with FreeMatch's thresholds (Wang et al. 2023): a photo's plain image (the weak
  view) gives a pseudo-label, the class the model predicts, without a gradient; one of its strongly augmented views
  (:func:`strong_augmenter`) is trained toward that label when the model's confidence on the plain image clears its
  class's threshold. The global threshold is an exponential moving average (EMA) of the model's mean confidence on
  the photos, starting at 1/2; each class's is the global one scaled by the EMA of that class's mean probability over
  its maximum, so the class the photos rarely show is not starved.
- ``adamatch`` (Berthelot et al. 2022, FixMatch for domain shift): the photos' probabilities aligned to the renders'
  class balance, the threshold a share of the model's mean confidence on the renders, the photos' loss warmed up.
- ``mcc`` (Minimum Class Confusion, Jin et al. 2020): no pseudo-label; the strong views' predictions are pushed
  apart from the other class (:func:`class_confusion`).
- ``cdan`` (Conditional Domain Adversarial Network, Long et al. 2018, as thuml's library builds it): a domain
  discriminator (:class:`Discriminator`) learns to tell renders from photos by their pooled features conditioned on
  the predicted class (their outer product); its gradient reaches the networks reversed (:class:`GradientReversal`),
  warmed up over the steps, so that the features it cannot tell apart are what the networks learn.

What trains is the networks' trainable part, as ``deformsim finetune`` trains it (:mod:`deformsim.learn.finetune`,
``part="tail"``): the stem stays frozen and each photo's views pass it once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import torch
from torch import nn

from deformsim.errors import UserError
from deformsim.learn.adapter import NETWORKS
from deformsim.learn.device import adam
from deformsim.learn.models import DeformNet
from deformsim.log import get_logger
from deformsim.schema import MAX_SEED, shown

log = get_logger(__name__)
PSEUDO_LABELS = ("fixmatch", "adamatch")  # the methods that train the photos toward pseudo-labels


@dataclass(frozen=True)
class MatchRecipe:
    """How the networks train on unlabelled photos beside the renders: the method, steps, learning rate, batch sizes,
    views, the photos' loss weight and each method's own setting."""

    steps: int = 200
    lr: float = 1e-4
    batch_size: int = 16  # renders per step
    ratio: int = 2  # photos per step for each render (FixMatch's mu)
    views: int = 4  # strong views per photo
    weight: float = 1.0  # the photos' loss beside the renders' (FixMatch's lambda_u)
    momentum: float = 0.99  # the thresholds' EMA (fixmatch)
    method: str = "fixmatch"  # fixmatch, adamatch, mcc or cdan (the module's docstring)
    relative: float = 0.9  # adamatch: the threshold is this share of the renders' mean confidence
    seed: int = 0

    def __post_init__(self) -> None:
        for name, low, high in (("steps", 1, 100_000), ("batch_size", 1, 4096), ("ratio", 1, 64),
                                ("views", 1, 64)):
            if not low <= getattr(self, name) <= high:
                raise UserError(f"fixmatch {name} must lie in [{low}, {high}], got {getattr(self, name)}")
        if not 0 < self.lr <= 1:
            raise UserError(f"fixmatch lr must lie in (0, 1], got {self.lr}")
        if not 0 <= self.weight <= 100:
            raise UserError(f"fixmatch weight must lie in [0, 100], got {self.weight}")
        if self.method not in NETWORKS:
            raise UserError(f"the networks' adapt method must be one of {', '.join(NETWORKS)}, got {self.method!r}")
        if not 0 < self.relative <= 1:
            raise UserError(f"fixmatch relative must lie in (0, 1], got {self.relative}")
        if not 0 <= self.momentum < 1:
            raise UserError(f"fixmatch momentum must lie in [0, 1), got {self.momentum}")
        if not (isinstance(self.seed, int) and 0 <= self.seed <= MAX_SEED):
            raise UserError(f"--seed {shown(self.seed)}: a seed is a whole number from 0 to {MAX_SEED}")


def strong_augmenter(size: int):
    """FixMatch's strong view: :func:`deformsim.learn.data.augmenter`'s crop, flip, jitter, blur and noise, then
    RandAugment (2 operations at magnitude 9) and a random erasure (Cutout). Draws from torch's global RNG."""
    from torchvision.transforms import v2

    from deformsim.learn.data import augmenter

    return v2.Compose([augmenter(size), v2.RandAugment(num_ops=2, magnitude=9),
                       v2.RandomErasing(p=1.0, scale=(0.02, 0.15), value=0.5)])


class Thresholds:
    """FreeMatch's self-adaptive thresholds for two classes (intact, deformed)."""

    def __init__(self, momentum: float):
        self.momentum = momentum
        self.confidence = torch.tensor(0.5)
        self.classes = torch.full((2,), 0.5)

    def update(self, p: torch.Tensor) -> None:
        """Fold in a batch's P(deformed) ``p`` of the photos' weak views."""
        m = self.momentum
        self.confidence = m * self.confidence + (1 - m) * torch.maximum(p, 1 - p).mean()
        self.classes = m * self.classes + (1 - m) * torch.stack([1 - p, p], 1).mean(0)

    def mask(self, p: torch.Tensor) -> torch.Tensor:
        """1 where the weak view's confidence clears its predicted class's threshold, else 0."""
        per_class = self.classes / self.classes.max() * self.confidence
        return (torch.maximum(p, 1 - p) >= per_class[(p >= 0.5).long()]).float()


def adamatch(p_s: torch.Tensor, p: torch.Tensor, relative: float, progress: float) -> tuple:
    """AdaMatch's (Berthelot et al. 2022) pseudo-labels of a batch: the photos' P(deformed) ``p`` aligned to the
    renders' class distribution (batch means of ``p_s``, the renders' P(deformed)), the mask of those whose
    confidence clears ``relative`` times the renders' mean confidence, the photos' loss weight, warmed up over the
    first half of training (``progress`` from 0 to 1), and that threshold."""
    source, target = torch.stack([1 - p_s, p_s], 1).mean(0), torch.stack([1 - p, p], 1).mean(0)
    aligned = torch.stack([1 - p, p], 1) * source / target
    p = aligned[:, 1] / aligned.sum(1)
    level = relative * torch.maximum(p_s, 1 - p_s).mean().item()
    return p, (torch.maximum(p, 1 - p) >= level).float(), 0.5 - math.cos(min(math.pi, 2 * math.pi * progress)) / 2, level


def class_confusion(logits: torch.Tensor, temperature: float = 2.5) -> torch.Tensor:
    """Minimum Class Confusion (Jin et al. 2020, as thuml's Transfer-Learning-Library computes it) of a batch of
    photos' logits of P(deformed): the share of probability mass the batch puts across the two classes, each photo
    weighted by its certainty."""
    z = logits / temperature
    p = torch.stack([torch.sigmoid(-z), torch.sigmoid(z)], 1)
    entropy = -(p * torch.log(p + 1e-5)).sum(1).detach()
    weight = 1 + torch.exp(-entropy)
    weight = (len(p) * weight / weight.sum()).unsqueeze(1)
    confusion = (p * weight).T @ p
    confusion = confusion / confusion.sum(1)
    return (confusion.sum() - confusion.trace()) / 2


class GradientReversal(torch.autograd.Function):
    """Identity forward; the gradient times ``-coefficient`` backward (Ganin and Lempitsky 2015)."""

    @staticmethod
    def forward(ctx, x: torch.Tensor, coefficient: float) -> torch.Tensor:
        ctx.coefficient = coefficient
        return x.view_as(x)

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple:
        return -ctx.coefficient * grad, None


class Discriminator(nn.Sequential):
    """CDAN's domain discriminator: the outer product of pooled features (N, width) and class probabilities (N, 2),
    through two hidden layers, to the logit of "photo" (thuml's ``DomainDiscriminator``, narrower)."""

    def __init__(self, width: int, hidden: int = 256):
        super().__init__(nn.Linear(2 * width, hidden), nn.BatchNorm1d(hidden), nn.ReLU(),
                         nn.Linear(hidden, hidden), nn.BatchNorm1d(hidden), nn.ReLU(), nn.Linear(hidden, 1))

    def domain_logits(self, features: torch.Tensor, logits: torch.Tensor, coefficient: float) -> torch.Tensor:
        p = torch.sigmoid(logits).detach().unsqueeze(1)
        joint = (torch.cat([1 - p, p], 1).unsqueeze(2) * features.unsqueeze(1)).flatten(1)
        return self(GradientReversal.apply(joint, coefficient)).squeeze(1)


def warm_up(progress: float) -> float:
    """The reversed gradient's coefficient, 0 at the start to 1 (thuml's warm start: 2 / (1 + exp(-10 p)) - 1)."""
    return 2 / (1 + math.exp(-10 * progress)) - 1


def self_train(model: DeformNet, weak: torch.Tensor, strong: torch.Tensor,
               renders: tuple[torch.Tensor, torch.Tensor], recipe: MatchRecipe) -> list[dict]:
    """Train ``model``'s trainable part in place on the renders' stems and labels ``renders`` and the photos' stems:
    ``weak`` (N, ...) of their plain images and ``strong`` (views, N, ...) of their strong views. Per step: the
    loss, the share of photos whose pseudo-label counted, and the threshold (FreeMatch's global one)."""
    if model.target != "label":
        raise UserError(f"self-training needs a model of train.target label, not {model.target}")
    device = model.mean.device
    opt_params = [p for p in model.parameters() if p.requires_grad]
    order = torch.Generator().manual_seed(recipe.seed)
    thresholds = Thresholds(recipe.momentum)
    x_s, y_s = renders[0], renders[1].float()
    trace = []
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(recipe.seed)  # the head's dropout and the discriminator's initial weights draw from here
        critic = None
        if recipe.method == "cdan":
            critic = Discriminator(model.width).to(device)
        opt = adam(opt_params + ([] if critic is None else list(critic.parameters())), recipe.lr)
        for step in range(recipe.steps):
            s = torch.randint(len(y_s), (recipe.batch_size,), generator=order)
            u = torch.randint(weak.shape[0], (recipe.batch_size * recipe.ratio,), generator=order)
            v = torch.randint(strong.shape[0], (len(u),), generator=order)
            model.eval()
            mask, weight, level = torch.ones(len(u)), 1.0, 0.0  # every photo counts fully (mcc, cdan)
            if recipe.method in PSEUDO_LABELS:  # the pseudo-labels' pass
                with torch.no_grad():
                    p_s, p = torch.sigmoid(model.tail(torch.cat([x_s[s], weak[u]]).to(device))).cpu().split(
                        [len(s), len(u)])
            if recipe.method == "adamatch":
                p, mask, weight, level = adamatch(p_s, p, recipe.relative, step / recipe.steps)
            elif recipe.method == "fixmatch":
                thresholds.update(p)
                mask, weight, level = thresholds.mask(p), 1.0, thresholds.confidence.item()
            model.head.train()
            features = model.embed(torch.cat([x_s[s], strong[v, u]]).to(device), "pooled")
            logits = model.head(features).squeeze(1).cpu()
            loss_s = nn.functional.binary_cross_entropy_with_logits(logits[: len(s)], y_s[s])
            if recipe.method == "mcc":
                loss_u = class_confusion(logits[len(s):])
            elif recipe.method == "cdan":
                critic.train()
                domain = critic.domain_logits(features, logits.to(device), warm_up(step / recipe.steps)).cpu()
                photo = torch.cat([torch.zeros(len(s)), torch.ones(len(u))])
                loss_u = nn.functional.binary_cross_entropy_with_logits(domain, photo)
            else:
                loss_u = (nn.functional.binary_cross_entropy_with_logits(logits[len(s):], (p >= 0.5).float(),
                                                                         reduction="none") * mask).mean()
            loss = loss_s + recipe.weight * weight * loss_u
            opt.zero_grad()
            loss.backward()
            opt.step()
            trace.append({"loss": loss.item(), "mask": mask.mean().item(), "threshold": level})
    model.eval()
    return trace


def self_trained(ckpt: dict, path: Path, photos: list[str], renders, recipe: MatchRecipe,
                 progress: bool = False) -> dict:
    """The saved model ``ckpt`` (read from ``path``) with each of its networks (every ensemble member of every
    backbone, member k seeded ``recipe.seed + k``) trained on ``photos`` beside the ``renders`` (a table of path and
    y); its history, split and labelled photos kept (the caller records the unlabelled ones)."""
    from deformsim.learn import checkpoint
    from deformsim.learn.device import pick_device
    from deformsim.learn.features import cached_stem
    from deformsim.learn.models import members
    from deformsim.learn.views import photo_views

    cfg = checkpoint.saved_config(ckpt, path)
    device = pick_device(cfg.device)
    y = torch.tensor(renders["y"].to_numpy())
    nets = [checkpoint.restore(ckpt, path), *checkpoint.restore_mixture(ckpt, path)]
    for net, net_cfg in nets:
        net.to(device)
        size, batch = net_cfg.image_size, net_cfg.batch_size
        views = photo_views(net, photos, size, recipe.views, recipe.seed, batch, progress, net_cfg.crop,
                            strong_augmenter(size))
        stems = cached_stem(net, list(renders["path"]), size, batch, progress)
        for k, member in enumerate(members(net)):
            trace = self_train(member, views[0], views[1:], (stems, y), replace(recipe, seed=recipe.seed + k))
            late = trace[len(trace) // 2:]
            counted = "" if recipe.method not in PSEUDO_LABELS else (
                f"; in the last half of the steps {100 * sum(t['mask'] for t in late) / len(late):.0f} % of the photos' "
                f"pseudo-labels counted (threshold {trace[-1]['threshold']:.3f} at the end)")
            log.info("%s member %d trained on the photos (%s): loss %.3f -> %.3f%s", net.backbone, k, recipe.method,
                     trace[0]["loss"], trace[-1]["loss"], counted)
    mixture = [(m, c, e.get("weights", "")) for (m, c), e in zip(nets[1:], ckpt.get("mixture", []))]
    return checkpoint.contents(nets[0][0], cfg, ckpt.get("weights", ""), ckpt.get("history", []),
                               ckpt.get("split", {}), adapted_on=ckpt.get("adapted_on"), mixture=mixture)
