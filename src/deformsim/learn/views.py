"""A photo's views as a model's frozen stem sees them: its plain image and augmented views, each through the stem
once (for :mod:`deformsim.learn.finetune` and :mod:`deformsim.learn.fixmatch`)."""

from __future__ import annotations

import torch

from deformsim.learn.models import DeformNet


def photo_views(model: DeformNet, paths: list[str], size: int, views: int, seed: int, batch_size: int,
                progress: bool = False, crop: str = "none", augment=None) -> torch.Tensor:
    """Stem activations (1 + views, N, C, H, W) of each photo as the model's test-time ``crop`` shows it: its plain
    image (cached), then views augmented by ``augment`` (default :func:`deformsim.learn.data.augmenter`; drawn from
    torch's RNG seeded by ``seed``, the caller's RNG left as it was)."""
    from deformsim.learn.data import ImageSet, augmenter
    from deformsim.learn.features import cached_stem, pass_size

    out = [cached_stem(model, paths, size, batch_size, progress, crop)]
    if views:
        images = ImageSet(paths, size, crop=crop)
        plain = [images[i] for i in range(len(paths))]
        augment = augment or augmenter(size)
        was_training = model.training
        model.eval()
        with torch.random.fork_rng(devices=[]), torch.inference_mode():
            torch.manual_seed(seed)
            for _ in range(views):
                x = torch.stack([augment(im) for im in plain])
                out.append(torch.cat([model.stem(b.to(model.mean.device)).cpu()
                                      for b in x.split(pass_size(model, size, batch_size))]))
        model.train(was_training)
    return torch.stack(out)
