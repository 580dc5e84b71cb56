"""Prediction with an exported model (``deformsim predict model.onnx``): onnxruntime and numpy, no torch.

What an inspection station deploys: the file :mod:`deformsim.learn.onnx` writes. Each image is read as the torch
model reads it (:func:`~deformsim.learn.model_input.model_input` with the test-time crop and image size the file's
metadata names); test-time flips and ensembles are inside the graph.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deformsim.errors import UserError
from deformsim.learn.model_input import model_input

BATCH = 32  # images per run of the graph
NEEDED = ("image_size", "threshold", "classes", "target", "outputs")  # metadata every export carries


@dataclass(frozen=True)
class OnnxSettings:
    """What the export's metadata says of its training: the input size, the test-time crop, the threshold."""

    image_size: int
    threshold: float
    crop: str
    target: str


class Labels:
    """P(deformed) and class names from ``predict_outputs``, for a predictor with ``path``, ``target``, ``classes``
    and ``cfg.threshold``: :class:`OnnxPredictor` and :class:`deformsim.learn.predict.Predictor`."""

    def _needs(self, target: str) -> None:
        if self.target != target:
            raise UserError(f"{self.path} predicts train.target {self.target}, not {target}")

    def predict_proba(self, paths: list[str | Path]) -> np.ndarray:
        """P(deformed) per image, float64 (N,)."""
        self._needs("label")
        return self.predict_outputs(paths)

    def predict(self, paths: list[str | Path], threshold: float | None = None) -> tuple[np.ndarray, list[str]]:
        """Probabilities and class names at ``threshold`` (default: the training threshold)."""
        p = self.predict_proba(paths)
        cut = self.cfg.threshold if threshold is None else threshold
        return p, [self.classes[int(v >= cut)] for v in p]


class OnnxPredictor(Labels):
    """An exported model with the interface of :class:`deformsim.learn.predict.Predictor`'s predictions."""

    def __init__(self, path: str | Path):
        import onnxruntime as ort

        path = Path(path)
        if not path.is_file():
            raise UserError(f"no ONNX model at {path}")
        try:
            self.session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime's own errors: a file that is not a model
            raise UserError(f"{path} is not an ONNX model ({str(exc).splitlines()[0][:200]})") from None
        meta = self.session.get_modelmeta().custom_metadata_map
        if missing := [key for key in NEEDED if key not in meta]:
            raise UserError(f"{path} is not a model deformsim exported (its metadata has no {', '.join(missing)})")
        self.path = path
        self.cfg = OnnxSettings(int(meta["image_size"]), float(meta["threshold"]), meta.get("crop", "none"), meta["target"])
        self.target = self.cfg.target
        self.classes = meta["classes"].split(",")
        self.outputs = meta["outputs"].split(",")

    def predict_outputs(self, paths: list[str | Path]) -> np.ndarray:
        """What the model predicts, float64, as :meth:`Predictor.predict_outputs` returns it."""
        size, crop = self.cfg.image_size, self.cfg.crop
        name = self.session.get_inputs()[0].name
        out = [self.session.run(None, {name: np.stack([model_input(p, size, crop) for p in paths[i : i + BATCH]])})[0]
               for i in range(0, len(paths), BATCH)]
        return np.concatenate(out).astype(np.float64) if out else np.zeros(0)
