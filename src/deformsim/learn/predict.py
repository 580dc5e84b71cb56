"""Loading a trained model and applying it to image files."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import torch

from deformsim.dataset.images import CLASSES
from deformsim.errors import UserError
from deformsim.learn.adapter import Adapter
from deformsim.learn.checkpoint import read_checkpoint, restore
from deformsim.learn.data import ImageSet
from deformsim.learn.device import pick_device, set_threads
from deformsim.learn.features import cached_stem, pass_size, stem_shape
from deformsim.learn.models import members
from deformsim.learn.onnx_predict import Labels
from deformsim.log import progress_bar

LAYERS = ("penultimate", "pooled")
CHUNK = 512  # images whose cached stem activations are held in memory at once, at most
HELD_BUDGET = 64 << 20  # bytes of stem activations held at once (twice while they are stacked)


class Predictor(Labels):
    """A trained model in eval mode; ``cfg.image_size`` and ``cfg.threshold`` come from training, and so do the
    test-time options: ``cfg.crop`` crops each image before it is classified, ``cfg.tta_flip`` averages each
    prediction with its mirror image's (a region map mirrored back first). A model with ``train.ensemble_backbones``
    predicts the mean of its backbones' models (``others``, each with its own frozen layers and cache) and averages
    their Grad-CAM maps; its embeddings are the first backbone's.

    ``progress``: a progress bar while images go through the frozen layers (None: when stderr is a terminal).
    """

    def __init__(self, ckpt: dict, path: Path, progress: bool | None = None):
        self.model, self.cfg = restore(ckpt, path)
        self.others = [Predictor(entry, path, progress) for entry in ckpt.get("mixture", [])]
        self.device = pick_device(self.cfg.device)
        self.model.to(self.device)
        self.path = path
        self.weights: str = ckpt.get("weights", "")
        self.classes: list[str] = ckpt.get("classes", list(CLASSES))
        self.history: list[dict] = ckpt.get("history", [])
        self.split: dict = ckpt.get("split", {})
        self.target: str = self.cfg.target
        self.outputs: list[str] = ckpt.get("outputs", ["deformed"])
        self.progress = progress
        self.adapter = Adapter.from_dict(ckpt["adapter"], str(path)) if "adapter" in ckpt else None

    @property
    def _show_progress(self) -> bool:
        return self.progress if self.progress is not None else sys.stderr.isatty()

    def _stems(self, paths, flip: bool = False):
        """Batches of stem activations (float32 on the device) of the images as the model's test-time crop and
        ``flip`` show them: cached per image unless ``cache_features`` is off."""
        paths, bs, crop, size = [str(p) for p in paths], self.cfg.batch_size, self.cfg.crop, self.cfg.image_size
        if not self.cfg.cache_features:
            loader = torch.utils.data.DataLoader(ImageSet(paths, size, crop=crop, flip=flip),
                                                 batch_size=pass_size(self.model, size, bs))
            with progress_bar(len(loader), "images", self._show_progress) as bar:
                for x in loader:
                    yield self.model.stem(x.to(self.device))
                    bar.update()
            return
        held = 4 * math.prod(stem_shape(self.model, size))
        chunk = max(1, min(CHUNK, HELD_BUDGET // held))  # bounded memory on large folders and large images
        for i in range(0, len(paths), chunk):
            stems = cached_stem(self.model, paths[i : i + chunk], size, bs, self._show_progress, crop, flip)
            for z in stems.split(bs):
                yield z.to(self.device)

    def predict_outputs(self, paths: list[str | Path]) -> np.ndarray:
        """What the model predicts, float64: P(deformed) (N,) (adapted to the user's photos when the model was,
        :mod:`deformsim.learn.adapter`), severity in mm (N,), family probabilities (N, K, in the order of
        ``outputs``) or region probability maps (N, s, s)."""
        if self.adapter is None:
            return self.synthetic_outputs(paths)
        out, features = self.outputs_and_features(paths, bool(self.adapter.coef))
        return self.adapter.apply(out, features) if len(out) else out

    def synthetic_outputs(self, paths: list[str | Path]) -> np.ndarray:
        """:meth:`predict_outputs` of the model as trained on renders (before any adapter)."""
        return self.outputs_and_features(paths, False)[0]

    @torch.inference_mode()
    def outputs_and_features(self, paths: list[str | Path], features: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """:meth:`synthetic_outputs` and, with ``features``, what an adapter's probe reads (N, D): each backbone's
        pooled features of the plain image, the mean over an ensemble's members, side by side; one pass of the
        images through each backbone's frozen layers."""
        if not paths:
            return np.zeros(0), np.zeros((0, 0)) if features else None
        views, pooled, nets = [], [], members(self.model)
        for flip in (False, True) if self.cfg.tta_flip else (False,):
            outs = []
            for z in self._stems(paths, flip):
                outs.append(self.model.outputs(z).cpu())
                if features and not flip:
                    pooled.append(torch.stack([m.pooled_raw(z) for m in nets]).mean(0).cpu())
            out = torch.cat(outs).double()
            views.append(out.flip(-1) if flip and self.target == "localise" else out)
        own = torch.stack(views).mean(0).numpy()
        feats = [torch.cat(pooled).double().numpy()] if features else []
        if self.others:
            rest = [other.outputs_and_features(paths, features) for other in self.others]
            own = np.mean([own] + [r[0] for r in rest], axis=0)
            feats += [r[1] for r in rest if r[1] is not None]
        return own, np.concatenate(feats, 1) if features else None

    def gradcam(self, paths: list[str | Path]) -> np.ndarray:
        """Grad-CAM heatmaps (N, h, w) in [0, 1] of P(deformed) (:mod:`deformsim.learn.gradcam`); a mixture's are
        the mean of its backbones' maps, each resized to the finest of them."""
        from deformsim.learn.gradcam import gradcam

        maps = [np.concatenate([gradcam(p.model, z) for z in p._stems(paths)]) for p in [self, *self.others]]
        if not self.others:
            return maps[0]
        side = max(m.shape[-1] for m in maps)
        resized = [torch.nn.functional.interpolate(torch.from_numpy(m)[:, None], size=(side, side), mode="bilinear",
                                                   align_corners=False)[:, 0].numpy() for m in maps]
        return np.mean(resized, axis=0)

    @torch.inference_mode()
    def features(self, paths: list[str | Path], layer: str = "penultimate") -> np.ndarray:
        """Per-image embeddings (N, D): the last hidden layer (``penultimate``) or pooled backbone features."""
        if layer not in LAYERS:
            raise UserError(f"unknown feature layer '{layer}' (choose from {', '.join(LAYERS)})")
        if self.target == "localise" and layer == "penultimate":
            raise UserError("a localise model has no penultimate layer (use pooled features)")
        out = [self.model.embed(z, layer).cpu() for z in self._stems(paths)]
        return torch.cat(out).numpy() if out else np.zeros((0, 0), np.float32)


def load(model_path: str | Path, progress: bool | None = None) -> Predictor:
    """A :class:`Predictor` for ``model.pt`` or the folder that holds it (``progress``: see :class:`Predictor`)."""
    set_threads()
    ckpt, path = read_checkpoint(model_path)
    return Predictor(ckpt, path, progress)
