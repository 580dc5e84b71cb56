"""Per-image cache of the frozen stem's outputs: each image goes through the frozen layers once.

Every model built from the same backbone weights shares its frozen stem, so the cache is keyed per image:
``cache_dir()/features/<backbone>-<size>[-<crop>][-flip]-<stem hash>/<image hash>.pt`` holds one image's
activations entering the first trainable layer (of the image as the test-time crop and mirror show it), in float32
so cached predictions equal uncached ones (and the ONNX export) to 1e-5. The stem hash covers the frozen weights
themselves, ``grey`` and the stem's memory layout (channels-last rounds differently); the image hash the image file's
bytes (sha256) and the version of the image loader, so a rewritten image (even one copied over another with the same
size and time), other weights or another decoding make new files, and identical images share one. Training,
prediction and PCA features of every run read the same files.
An entry that is not a finite float32 tensor of the stem's shape is computed again and replaced.

Memory is bounded whatever ``image_size``: images go through the frozen layers in passes of at most
:data:`PASS_BUDGET` bytes of activations (:func:`pass_size`, from the stem's activations at that size), so a 1024-pixel
VGG-16 takes one image per pass where a 224-pixel one takes most of a batch.
"""

from __future__ import annotations

import copy
import hashlib
from pathlib import Path
from weakref import WeakKeyDictionary

import torch

from deformsim.dataset.images import LOADER_VERSION
from deformsim.errors import UserError
from deformsim.identity import file_digest
from deformsim.learn import checkpoint
from deformsim.learn.backbones import BACKBONES
from deformsim.learn.data import ImageSet
from deformsim.learn.models import DeformNet
from deformsim.log import progress_bar
from deformsim.outputs import cache_dir

_STEM_HASHES: WeakKeyDictionary = WeakKeyDictionary()  # model -> (weight versions, hash)
_STEM_SHAPES: dict[tuple[str, int, int], tuple[int, ...]] = {}  # (backbone, cut, size) -> activation shape
_IMAGE_BYTES: dict[tuple[str, int, int], int] = {}  # (backbone, cut, size) -> bytes one image takes in the stem
PASS_BUDGET = 512 << 20  # bytes of activations one pass through the frozen layers may hold


def stem_hash(model: DeformNet) -> str:
    """sha256 of the backbone name, the cut, ``grey``, the stem's layout and the frozen weights; recomputed only when those
    tensors change."""
    state = model.features[: model.cut].state_dict()
    versions = tuple((t.data_ptr(), t._version) for t in state.values())
    memo = _STEM_HASHES.get(model)
    if memo is not None and memo[0] == versions:
        return memo[1]
    layout = "|channels_last" if BACKBONES[model.backbone].channels_last else ""
    h = hashlib.sha256(f"{model.backbone}|cut={model.cut}{'|grey' if model.grey else ''}{layout}".encode())
    for name, t in state.items():
        h.update(name.encode())
        h.update(t.detach().cpu().contiguous().numpy().tobytes())
    _STEM_HASHES[model] = (versions, h.hexdigest())
    return h.hexdigest()


def _image_identity(path: str) -> str:
    """The image's content (not its path or times) and how it is decoded."""
    try:
        return f"loader{LOADER_VERSION}|{file_digest(path)}"
    except OSError as exc:
        raise UserError(f"cannot read image {path}: {exc.strerror}") from None


def cache_key(model: DeformNet, paths: list[str], size: int, crop: str = "none", flip: bool = False) -> list[str]:
    """Cache file names (relative to ``cache_dir()/features``) of the stem activations of ``paths`` at ``size``."""
    view = ("" if crop == "none" else f"-{crop}") + ("-flip" if flip else "")
    folder = f"{model.backbone}-{size}{view}-{stem_hash(model)[:24]}"
    return [f"{folder}/{hashlib.sha256(_image_identity(str(p)).encode()).hexdigest()[:32]}.pt" for p in paths]


def image_bytes(model: DeformNet, size: int) -> int:
    """Bytes one image takes going through the frozen layers at ``size``, measured once on the meta device (no
    memory): the image twice (as read and normalised), and the most any top-level layer holds at once, taken as its
    input and every activation inside it (a block keeps its inner activations until it returns)."""
    key = (model.backbone, model.cut, size)
    if key not in _IMAGE_BYTES:
        stem = copy.deepcopy(model.features[: model.cut]).to("meta").eval()
        held: list[int] = []

        def nbytes(t) -> int:
            return t.numel() * t.element_size() if isinstance(t, torch.Tensor) else 0

        def enter(module, inputs) -> None:
            held.append(sum(map(nbytes, inputs)))

        def leaf(module, inputs, output) -> None:
            held[-1] += nbytes(output)

        for block in stem.children():
            block.register_forward_pre_hook(enter)
            for m in block.modules():
                if not list(m.children()):
                    m.register_forward_hook(leaf)
        with torch.no_grad():
            stem(torch.empty(1, 3, size, size, device="meta"))
        _IMAGE_BYTES[key] = 2 * 3 * size * size * 4 + max(held)
    return _IMAGE_BYTES[key]


def pass_size(model: DeformNet, size: int, batch_size: int) -> int:
    """Images per pass through the frozen layers: ``batch_size``, or fewer (at least one) to hold at most
    :data:`PASS_BUDGET` bytes of activations at ``size``."""
    return max(1, min(batch_size, PASS_BUDGET // image_bytes(model, size)))


def run_stem(model: DeformNet, paths: list[str], size: int, batch_size: int, progress: bool = False,
             crop: str = "none", flip: bool = False) -> torch.Tensor:
    """Frozen-stem activations (float32) of ``paths``, computed in eval mode without gradients, in passes of at most
    ``batch_size`` images that fit :data:`PASS_BUDGET`."""
    loader = torch.utils.data.DataLoader(ImageSet(paths, size, crop=crop, flip=flip),
                                         batch_size=pass_size(model, size, batch_size))
    device = model.mean.device
    was_training = model.training
    model.eval()
    out = []
    with torch.inference_mode(), progress_bar(len(loader), "images", progress) as bar:
        for x in loader:
            out.append(model.stem(x.to(device)).cpu())
            bar.update()
    model.train(was_training)
    return torch.cat(out)


def fill(models: list[DeformNet], paths: list[str], size: int, batch_size: int, progress: bool = False) -> None:
    """Cache the stem activations of ``paths`` (as :func:`cached_stem` does) of several models (backbones) at once:
    each image the cache lacks for one of them is decoded once for all."""
    root = cache_dir() / "features"
    todo = []  # (model, {path: cache file}) of the files not there yet
    for model in models:
        files = dict(zip(map(str, paths), (root / k for k in cache_key(model, paths, size))))
        todo.append((model, {p: f for p, f in files.items() if not f.is_file()}))
    need = list(dict.fromkeys(p for _, missing in todo for p in missing))
    if not need:
        return
    per_pass = min(pass_size(m, size, batch_size) for m, _ in todo)
    loader = torch.utils.data.DataLoader(ImageSet(need, size), batch_size=per_pass)
    modes = [m.training for m, _ in todo]
    for m, _ in todo:
        m.eval()
    with torch.inference_mode(), progress_bar(len(loader), "images", progress) as bar:
        for start, x in zip(range(0, len(need), per_pass), loader):
            batch = need[start:start + per_pass]
            for model, missing in todo:
                rows = [i for i, p in enumerate(batch) if p in missing]
                if rows:
                    feats = model.stem(x[rows].to(model.mean.device)).cpu()
                    for i, t in zip(rows, feats):
                        checkpoint.write(missing[batch[i]], t.clone())  # a view would save the whole batch's storage
            bar.update()
    for (m, _), mode in zip(todo, modes):
        m.train(mode)


def stem_shape(model: DeformNet, size: int) -> tuple[int, ...]:
    """The shape (C, H, W) of one image's stem activations at ``size``."""
    key = (model.backbone, model.cut, size)
    if key not in _STEM_SHAPES:
        was_training = model.training
        model.eval()
        with torch.inference_mode():
            _STEM_SHAPES[key] = tuple(model.stem(torch.zeros(1, 3, size, size, device=model.mean.device)).shape[1:])
        model.train(was_training)
    return _STEM_SHAPES[key]


def _load(path: Path, shape: tuple[int, ...]) -> torch.Tensor | None:
    """The cached activations in ``path``, or None when there are none of ``shape`` (float32, finite) to trust."""
    try:
        t = torch.load(path, map_location="cpu", weights_only=True)
    except Exception:  # not cached yet, or truncated or foreign (torch raises several types): recomputed
        return None
    ok = isinstance(t, torch.Tensor) and tuple(t.shape) == shape and t.dtype == torch.float32
    return t if ok and bool(torch.isfinite(t).all()) else None


def cached_stem(model: DeformNet, paths: list[str], size: int, batch_size: int, progress: bool = False,
                crop: str = "none", flip: bool = False) -> torch.Tensor:
    """Stem activations (float32, N x C x H x W) of ``paths`` (test-time ``crop`` and ``flip`` as
    :func:`deformsim.learn.data.load_image`): cached images are read, only the others computed and stored."""
    if not paths:
        raise ValueError("cached_stem needs at least one image")
    root = cache_dir() / "features"
    files = [root / k for k in cache_key(model, paths, size, crop, flip)]
    shape = stem_shape(model, size)
    found = {f: _load(f, shape) for f in dict.fromkeys(files)}
    missing = [f for f, t in found.items() if t is None]
    if missing:
        path_of = dict(zip(files, map(str, paths)))
        feats = run_stem(model, [path_of[f] for f in missing], size, batch_size, progress, crop, flip)
        for f, t in zip(missing, feats):
            t = t.clone()  # a view would save the whole batch's storage
            checkpoint.write(f, t)
            found[f] = t
        del feats, t  # before the stack: two copies at most
    return torch.stack([found[f] for f in files])
