"""Loading a trained model and applying it to image files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.data import ImageSet
from deformsim.learn.features import cached_stem
from deformsim.learn.models import DeformNet, build
from deformsim.learn.train import MODEL_FILE, pick_device, set_threads

LAYERS = ("penultimate", "pooled")
CHUNK = 512  # images whose cached stem activations are held in memory at once


def read_checkpoint(model_path: str | Path) -> tuple[dict, Path]:
    """The saved dict of ``model.pt`` (or of a folder holding it) and its path."""
    path = Path(model_path)
    if path.is_dir():
        path = path / MODEL_FILE
    if not path.is_file():
        raise UserError(f"no trained model at {model_path} (expected {MODEL_FILE}; run deformsim train)")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt or foreign files
        raise UserError(f"{path} is not a deformsim model: {exc}") from None
    if not isinstance(ckpt, dict) or "state_dict" not in ckpt or "config" not in ckpt:
        raise UserError(f"{path} is not a deformsim model (no state_dict/config)")
    return ckpt, path


def restore(ckpt: dict) -> tuple[DeformNet, TrainConfig]:
    cfg = TrainConfig.model_validate(ckpt["config"])
    model, _ = build(cfg, load_weights=False)
    model.load_state_dict(ckpt["state_dict"])
    return model.eval(), cfg


class Predictor:
    """A trained model in eval mode; ``cfg.image_size`` and ``cfg.threshold`` come from training."""

    def __init__(self, ckpt: dict, path: Path):
        self.model, self.cfg = restore(ckpt)
        self.device = pick_device(self.cfg.device)
        self.model.to(self.device)
        self.path = path
        self.weights: str = ckpt.get("weights", "")
        self.classes: list[str] = ckpt.get("classes", ["intact", "deformed"])
        self.history: list[dict] = ckpt.get("history", [])
        self.split: dict = ckpt.get("split", {})

    def _stems(self, paths):
        """Batches of stem activations (float32 on the device): cached per image unless ``cache_features`` is off."""
        paths, bs = [str(p) for p in paths], self.cfg.batch_size
        if not self.cfg.cache_features:
            for x in torch.utils.data.DataLoader(ImageSet(paths, self.cfg.image_size), batch_size=bs):
                yield self.model.stem(x.to(self.device))
            return
        for i in range(0, len(paths), CHUNK):  # bounded memory on large folders
            for z in cached_stem(self.model, paths[i : i + CHUNK], self.cfg.image_size, bs).split(bs):
                yield z.to(self.device)

    @torch.inference_mode()
    def predict_proba(self, paths: list[str | Path]) -> np.ndarray:
        """P(deformed) per image, float64 (N,)."""
        out = [torch.sigmoid(self.model.tail(z)).cpu() for z in self._stems(paths)]
        return torch.cat(out).double().numpy() if out else np.zeros(0)

    def predict(self, paths: list[str | Path]) -> tuple[np.ndarray, list[str]]:
        """Probabilities and class names at the training threshold."""
        p = self.predict_proba(paths)
        return p, [self.classes[int(v >= self.cfg.threshold)] for v in p]

    @torch.inference_mode()
    def features(self, paths: list[str | Path], layer: str = "penultimate") -> np.ndarray:
        """Per-image embeddings (N, D): the last hidden layer (``penultimate``) or pooled backbone features."""
        if layer not in LAYERS:
            raise UserError(f"unknown feature layer '{layer}' (choose from {', '.join(LAYERS)})")
        out = [self.model.embed(z, layer).cpu() for z in self._stems(paths)]
        return torch.cat(out).numpy() if out else np.zeros((0, 0), np.float32)


def load(model_path: str | Path) -> Predictor:
    """A :class:`Predictor` for ``model.pt`` or the folder that holds it."""
    set_threads()
    ckpt, path = read_checkpoint(model_path)
    return Predictor(ckpt, path)
