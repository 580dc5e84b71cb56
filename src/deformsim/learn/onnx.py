"""ONNX export of a trained model.

The graph takes ``image``: float32 (N, 3, S, S) RGB in 0-1 (resized to the training size S, no
normalisation: it is inside the graph) and outputs ``p_deformed``: (N,) probabilities, or for the other
``train.target`` s ``max_disp_mm`` (N,), ``p_family`` (N, K) or ``p_region`` (N, s, s). The training
threshold, classes, target, output names, image size and weights source are stored as ONNX metadata. An
ensemble's mean (of its members and of its backbones' models, ``train.ensemble_backbones``) and test-time flips
(``train.tta_flip``) are inside the graph, and so is the adapter of a model adapted to photos (``deformsim adapt``);
a test-time crop (``train.crop``) is not: the metadata names it, to apply
before the graph.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import torch
from torch import nn

from deformsim.atomic import atomic_path
from deformsim.errors import ResourceError, UserError
from deformsim.learn.checkpoint import read_checkpoint, restore, restore_mixture
from deformsim.learn.models import DeformNet, Ensemble, members
from deformsim.outputs import DISK_FULL, check_file_target

OUTPUT = {"label": "p_deformed", "severity": "max_disp_mm", "family": "p_family", "localise": "p_region"}


class _Probabilities(nn.Module):
    def __init__(self, models: list[DeformNet | Ensemble], flip: bool, target: str, adapter: dict | None = None):
        super().__init__()
        self.models, self.flip, self.target = nn.ModuleList(models), flip, target
        self.adapter = adapter is not None
        if adapter is not None:  # deformsim.learn.adapter.Adapter.apply, in the graph
            for name in ("mean", "scale", "coef"):
                self.register_buffer(name, torch.tensor(adapter[name] or [0.0], dtype=torch.float32))
            self.anchor, self.shift, self.bias, self.probe = (adapter["anchor"], adapter["shift"], adapter["bias"],
                                                              bool(adapter["coef"]))

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        outs = [self._one(model, image) for model in self.models]
        p = outs[0] if len(outs) == 1 else torch.stack(outs).mean(0)
        if not self.adapter:
            return p
        z = self.anchor * torch.logit(p, eps=1e-6) + self.shift
        if self.probe:  # each backbone's pooled features of the plain image, the mean over its members
            feats = torch.cat([torch.stack([m.pooled_raw(model.stem(image)) for m in members(model)]).mean(0)
                               for model in self.models], 1)
            z = z + ((feats - self.mean) / self.scale) @ self.coef + self.bias
        return torch.sigmoid(z)

    def _one(self, model: DeformNet | Ensemble, image: torch.Tensor) -> torch.Tensor:
        out = model.predict(image)
        if not self.flip:
            return out
        mirrored = model.predict(image.flip(-1))
        return (out + (mirrored.flip(-1) if self.target == "localise" else mirrored)) / 2


def to_onnx(model_path: str | Path, onnx_path: str | Path) -> Path:
    """Write the model at ``model_path`` (model.pt or its folder) to ``onnx_path``; returns the path.

    The output path is checked before the model is read; a failed write (a full disk) is one :class:`UserError`.
    """
    onnx_path = check_file_target(onnx_path, "--onnx", [model_path])
    ckpt, path = read_checkpoint(model_path)
    model, cfg = restore(ckpt, path)
    models = [model] + [m for m, _ in restore_mixture(ckpt, path)]
    try:
        _export(models, cfg, ckpt, onnx_path)
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise ResourceError(f"cannot write {onnx_path}: {exc.strerror}: free some disk space and export again") from None
        raise UserError(f"cannot write {onnx_path}: {exc.strerror or exc}") from None
    return onnx_path


def _export(models: list[DeformNet | Ensemble], cfg, ckpt: dict, onnx_path: Path) -> None:
    import onnx

    example = torch.zeros(1, 3, cfg.image_size, cfg.image_size)
    output = OUTPUT[cfg.target]
    with atomic_path(onnx_path) as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the TorchScript exporter's deprecation notice
        graph = _Probabilities(models, cfg.tta_flip, cfg.target, ckpt.get("adapter"))
        torch.onnx.export(graph, (example,), str(tmp), dynamo=False, opset_version=17,
                          input_names=["image"], output_names=[output],
                          dynamic_axes={"image": {0: "batch"}, output: {0: "batch"}})
        proto = onnx.load(str(tmp))
        meta = {"classes": ",".join(ckpt.get("classes", [])), "threshold": str(cfg.threshold),
                "image_size": str(cfg.image_size), "backbone": "+".join([cfg.backbone, *cfg.ensemble_backbones]),
                "weights": " + ".join([ckpt.get("weights", ""), *(m.get("weights", "") for m in ckpt.get("mixture", []))]),
                "target": cfg.target, "outputs": ",".join(ckpt.get("outputs", ["deformed"])),
                "ensemble": str(cfg.ensemble), "tta_flip": str(cfg.tta_flip).lower(), "crop": cfg.crop,
                "input": "RGB float32 in [0, 1], NCHW, resized to image_size x image_size"}
        for k, v in meta.items():
            proto.metadata_props.add(key=k, value=v)
        onnx.save(proto, str(tmp))
