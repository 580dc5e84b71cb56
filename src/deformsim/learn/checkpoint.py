"""A trained model's file, ``model.pt``: the state dict, training config, weights source, classes, history, split.

A model of another ``train.target`` than ``label`` also records ``outputs``: the names of what it predicts
(its families, ``max_disp_mm`` or ``region``), from which :func:`restore` rebuilds its head. A model adapted to
unlabelled photos holds its ``adapter`` (:mod:`deformsim.learn.adapter`) and the sha256 of those photos
(``adapted_unlabelled``). A model trained with ``train.ensemble_backbones`` holds each further backbone's model in
``mixture`` (its state dict, config and weights source), checked as the first is; :func:`restore` gives the first,
:func:`restore_mixture` the others.
"""

from __future__ import annotations

import re
from pathlib import Path

import torch
from pydantic import ValidationError

from deformsim.atomic import atomic_path
from deformsim.config import TrainConfig
from deformsim.dataset.images import CLASSES
from deformsim.errors import ResourceError, UserError
from deformsim.learn.backbones import BACKBONES
from deformsim.learn.models import DeformNet, build
from deformsim.schema import clip, first_error, shown

MODEL_FILE = "model.pt"
_SHA256 = re.compile("[0-9a-f]{64}")
MAX_OUTPUTS = 1024  # what a model of train.target family may predict: one output per deformation family


def _entry(model: DeformNet, cfg: TrainConfig, weights: str) -> dict:
    return {"state_dict": {k: v.cpu() for k, v in model.state_dict().items()}, "config": cfg.model_dump(mode="json"),
            "weights": weights}


def contents(model: DeformNet, cfg: TrainConfig, weights: str, history: list[dict], split: dict,
             outputs: list[str] | None = None, adapted_on: list[str] | None = None,
             mixture: list[tuple[DeformNet, TrainConfig, str]] = ()) -> dict:
    """What :func:`save` writes: ``split`` holds the ``train`` and ``val`` image ids, ``adapted_on`` the sha256 of
    each real photo a fine-tuned model was adapted on (:mod:`deformsim.learn.finetune`), ``mixture`` the further
    backbones' models, configs and weights sources."""
    ckpt = _entry(model, cfg, weights) | {"classes": list(CLASSES), "history": history, "split": split}
    if mixture:
        ckpt["mixture"] = [_entry(*m) for m in mixture]
    if outputs is not None:
        ckpt["outputs"] = list(outputs)
    if adapted_on is not None:
        ckpt["adapted_on"] = list(adapted_on)
    return ckpt


def save(path: Path, *args, **kwargs) -> None:
    """Write the model's :func:`contents` (the same arguments) to ``path`` atomically."""
    write(path, contents(*args, **kwargs))


def write(path: Path, obj) -> None:
    """``torch.save`` to ``path`` atomically; a failed write (torch raises RuntimeError, not OSError, when the disk
    fills) is a :class:`ResourceError` naming the file. The file is ours to close, so a failure frees its space."""
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        try:
            torch.save(obj, f)
        except RuntimeError as exc:  # "[enforce fail at inline_container.cc:672] . unexpected pos 576 vs 534"
            reason = (str(exc).strip().splitlines() or [""])[0].rpartition("] ")[2].strip(" .")[:120] or "failed"
            raise ResourceError(f"cannot write {path} (torch: {reason}): is the disk full? Free some disk space, "
                                "then rerun the same command") from None


def _elsewhere(folder: Path) -> str:
    """Where the model is when ``folder`` is a run or a report folder rather than a model's."""
    from deformsim.report.headline import RUN_MODEL, headline_model

    if (folder / RUN_MODEL / MODEL_FILE).is_file():
        return f"a run folder: its model is {folder / RUN_MODEL}"
    report = headline_model(folder)
    if report is not None:
        return f"a report folder: the model of its headline test is {report}"
    return f"expected {MODEL_FILE}; run deformsim train"


def read_checkpoint(model_path: str | Path) -> tuple[dict, Path]:
    """The saved dict of ``model.pt`` (or of a folder holding it) and its path, checked as :func:`restore` will use
    it: a valid training config, finite weights, and at most :data:`MAX_OUTPUTS` outputs; one line naming the file
    otherwise."""
    path = Path(model_path)
    if path.is_dir():
        path = path / MODEL_FILE
    if not path.is_file():
        raise UserError(f"no trained model at {model_path} ({_elsewhere(Path(model_path))})")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt or foreign files
        raise UserError(f"{path} is not a deformsim model: {clip(str(exc), 160)}") from None
    cfg = _check_model(ckpt, path)
    mixture = ckpt.get("mixture", [])
    if not isinstance(mixture, list):
        raise UserError(f"{path} is not a deformsim model: its mixture is not a list of models")
    backbones = []
    for k, entry in enumerate(mixture):
        other = _check_model(entry, f"{path} (mixture model {k + 1})")
        if other != cfg.model_copy(update={"backbone": other.backbone, "ensemble_backbones": []}):
            raise UserError(f"{path} is not a deformsim model: its mixture model {k + 1} was trained otherwise than "
                            "the first (their configs differ in more than the backbone)")
        backbones.append(other.backbone)
    if backbones != cfg.ensemble_backbones:
        raise UserError(f"{path} is not a deformsim model: its mixture holds other backbones than its "
                        f"train.ensemble_backbones ({', '.join(cfg.ensemble_backbones) or 'none'})")
    outputs = ckpt.get("outputs")
    if outputs is not None and not (isinstance(outputs, list) and 0 < len(outputs) <= MAX_OUTPUTS
                                    and all(isinstance(o, str) for o in outputs)):
        raise UserError(f"{path} is not a deformsim model: its outputs are not 1 to {MAX_OUTPUTS} names")
    for key in ("adapted_on", "adapted_unlabelled"):
        digests = ckpt.get(key, [])
        if not (isinstance(digests, list) and all(isinstance(d, str) and _SHA256.fullmatch(d) for d in digests)):
            raise UserError(f"{path} is not a deformsim model: its {key} is not a list of sha256 digests")
    if "adapter" in ckpt:
        from deformsim.learn.adapter import Adapter

        Adapter.from_dict(ckpt["adapter"], str(path))
    classes = ckpt.get("classes", list(CLASSES))
    if not (isinstance(classes, list) and len(classes) == 2 and all(isinstance(c, str) for c in classes)):
        raise UserError(f"{path} is not a deformsim model: its classes are not two names")
    return ckpt, path


def _check_model(entry, path: Path | str) -> TrainConfig:
    """``entry``'s training config; one line naming ``path`` unless it is valid and the state dict holds finite
    tensors."""
    if not isinstance(entry, dict) or not isinstance(entry.get("state_dict"), dict) or "config" not in entry:
        raise UserError(f"{path} is not a deformsim model (no state_dict/config)")
    cfg = saved_config(entry, path)
    for name, tensor in entry["state_dict"].items():
        if not isinstance(tensor, torch.Tensor):
            raise UserError(f"{path} is not a deformsim model: state_dict entry {shown(name, 60)} is no tensor")
        if tensor.is_floating_point() and not torch.isfinite(tensor).all():
            raise UserError(f"{path} holds non-finite weights (NaN or infinity) in {shown(name, 60)}: train it again")
    _check_buffers(entry["state_dict"], cfg, path)
    return cfg


def _check_buffers(state: dict, cfg: TrainConfig, path: Path | str) -> None:
    """One line naming ``path`` unless the fixed buffers are what training wrote: the input normalisation is the
    backbone's, every BatchNorm variance at least 0, a severity scale's spread above 0 (else predictions are NaN)."""
    bb = BACKBONES[cfg.backbone]
    for name, value in (("mean", bb.mean), ("std", bb.std)):
        t = state.get(name)
        if t is not None and not (t.numel() == 3 and torch.allclose(t.flatten().double(), torch.tensor(value).double())):
            raise UserError(f"{path} is not a deformsim model: its input {name} {shown(t.flatten().tolist(), 60)} is not "
                            f"{cfg.backbone}'s {list(value)}")
    for name, t in state.items():
        if name.endswith("running_var") and (t < 0).any():
            raise UserError(f"{path} is not a deformsim model: {shown(name, 60)} holds a negative variance")
    scale = state.get("scale")
    if scale is not None and not (scale.numel() == 2 and scale[1] > 0):
        raise UserError(f"{path} is not a deformsim model: its severity scale {shown(scale.tolist(), 60)} has no spread")


def saved_config(ckpt: dict, path: Path | str = "the model") -> TrainConfig:
    """The training config saved in ``ckpt``, validated as a config file is (the same ranges), or one line naming
    ``path`` and the bad value."""
    data = ckpt.get("config")
    if not isinstance(data, dict):
        raise UserError(f"{path} is not a deformsim model: its config is no mapping")
    try:
        return TrainConfig.model_validate(data)
    except ValidationError as exc:
        loc, msg, value = first_error(exc, data)
        where = ".".join(str(p) for p in loc)
        raise UserError(f"{path}: its saved config is invalid: train.{where}: {msg} (got {shown(value)})") from None


def restore(ckpt: dict, path: Path | str = "the model") -> tuple[DeformNet, TrainConfig]:
    """The saved model (of a dict that :func:`read_checkpoint` checked) in eval mode and its training config;
    ``path`` names the file in errors."""
    cfg = saved_config(ckpt, path)
    with torch.device("meta"):  # no random initialisation of weights the saved ones replace
        model, _ = build(cfg, load_weights=False, outputs=len(ckpt.get("outputs") or [None]))
    try:
        model.load_state_dict(ckpt["state_dict"], assign=True)
    except RuntimeError as exc:  # a state dict of another head or backbone than its config says
        raise UserError(f"{path} does not match its saved config: {clip(str(exc).splitlines()[0], 160)}") from None
    return model.eval(), cfg


def restore_mixture(ckpt: dict, path: Path | str = "the model") -> list[tuple[DeformNet, TrainConfig]]:
    """The further backbones' models of a ``train.ensemble_backbones`` model (none for others), as :func:`restore`
    gives the first."""
    return [restore(entry, f"{path} (mixture model {k + 1})") for k, entry in enumerate(ckpt.get("mixture", []))]
