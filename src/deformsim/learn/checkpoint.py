"""A trained model's file, ``model.pt``: the state dict, training config, weights source, classes, history, split.

A model of another ``train.target`` than ``label`` also records ``outputs``: the names of what it predicts
(its families, ``max_disp_mm`` or ``region``), from which :func:`restore` rebuilds its head.
"""

from __future__ import annotations

from pathlib import Path

import torch

from deformsim.atomic import atomic_path
from deformsim.config import TrainConfig
from deformsim.dataset.images import CLASSES
from deformsim.errors import UserError
from deformsim.learn.models import DeformNet, build

MODEL_FILE = "model.pt"


def save(path: Path, model: DeformNet, cfg: TrainConfig, weights: str, history: list[dict], split: dict,
         outputs: list[str] | None = None) -> None:
    """Write ``path`` atomically; ``split`` holds the ``train`` and ``val`` image ids."""
    ckpt = {"state_dict": {k: v.cpu() for k, v in model.state_dict().items()}, "config": cfg.model_dump(mode="json"),
            "weights": weights, "classes": list(CLASSES), "history": history, "split": split}
    if outputs is not None:
        ckpt["outputs"] = list(outputs)
    with atomic_path(path) as tmp:
        torch.save(ckpt, tmp)


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
    """The saved model in eval mode and its training config."""
    cfg = TrainConfig.model_validate(ckpt["config"])
    model, _ = build(cfg, load_weights=False, outputs=len(ckpt.get("outputs") or [None]))
    try:
        model.load_state_dict(ckpt["state_dict"])
    except RuntimeError as exc:  # a state dict of another head or backbone than its config says
        raise UserError(f"the model does not match its saved config: {str(exc).splitlines()[0]}") from None
    return model.eval(), cfg
