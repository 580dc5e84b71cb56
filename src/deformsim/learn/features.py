"""Cache of the frozen stem's outputs: the frozen layers run once per image set instead of once per epoch.

A cache file holds the fp16 activations entering the first trainable layer for a list of images. Its key
hashes the frozen weights themselves, the backbone, the image size and each image's identity (resolved
path, size, modification time), so a changed image or different weights make a new file.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import torch
from tqdm import tqdm

from deformsim.atomic import atomic_path
from deformsim.learn.data import ImageSet
from deformsim.learn.models import DeformNet
from deformsim.learn.weights import cache_dir


def _image_identity(path: str) -> str:
    st = os.stat(path)
    return f"{Path(path).resolve()}|{st.st_size}|{st.st_mtime_ns}"


def cache_key(model: DeformNet, paths: list[str], size: int) -> str:
    h = hashlib.sha256(f"{model.backbone}|cut={model.cut}|size={size}".encode())
    for name, t in model.features[: model.cut].state_dict().items():
        h.update(name.encode())
        h.update(t.detach().cpu().contiguous().numpy().tobytes())
    for p in paths:
        h.update(_image_identity(p).encode())
    return h.hexdigest()


def run_stem(model: DeformNet, paths: list[str], size: int, batch_size: int, progress: bool = False) -> torch.Tensor:
    """Frozen-stem activations (float32) of ``paths``, computed in eval mode without gradients."""
    loader = torch.utils.data.DataLoader(ImageSet(paths, size), batch_size=batch_size)
    device = model.mean.device
    was_training = model.training
    model.eval()
    out = []
    with torch.inference_mode():
        for x in tqdm(loader, desc="frozen layers", unit="batch", disable=not progress, leave=False):
            out.append(model.stem(x.to(device)).cpu())
    model.train(was_training)
    return torch.cat(out)


def cached_stem(model: DeformNet, paths: list[str], size: int, batch_size: int, progress: bool = False) -> tuple[torch.Tensor, bool]:
    """Stem activations (fp16) from the cache or computed and stored; the flag says whether it was a hit."""
    key = cache_key(model, paths, size)
    path = cache_dir() / "features" / f"{model.backbone}-{size}-{key[:24]}.pt"
    if path.is_file():
        try:
            return torch.load(path, map_location="cpu", weights_only=True), True
        except (RuntimeError, OSError, EOFError):
            pass  # an unreadable cache is recomputed
    feats = run_stem(model, paths, size, batch_size, progress).half()
    with atomic_path(path) as tmp:
        torch.save(feats, tmp)
    return feats, False
