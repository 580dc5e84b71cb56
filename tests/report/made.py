"""Hand-made contents of a report's metrics.json, shaped as run_experiments writes them (no training)."""

from __future__ import annotations

from deformsim.config import TrainConfig
from deformsim.evaluate.metrics import compute_metrics

HISTORY = [{"epoch": 1, "loss": 0.7, "acc": 0.55, "seconds": 1.0}, {"epoch": 2, "loss": 0.4, "acc": 0.8, "seconds": 1.0}]


def experiment(y: list[int], prob: list[float], model: str, paths: list[str] | None = None,
               train_seconds: float = 2.0) -> dict:
    """A test that ran: a model (file ``model``, relative to the report) whose P(deformed) of images labelled ``y``
    was ``prob``."""
    paths = paths or [f"/photos/{i}.png" for i in range(len(y))]
    return {
        "train": {"n": 40, "n_deformed": 20, "n_samples": 10},
        "test": {"n": len(y), "n_deformed": int(sum(y))},
        "model": model, "weights": "offline", "history": HISTORY,
        "train_seconds": train_seconds, "predict_seconds": 0.5,
        "metrics": compute_metrics(y, prob, 0.5),
        "predictions": [{"path": p, "y": a, "prob": b} for p, a, b in zip(paths, y, prob)],
    }


def metrics_file(variants: dict, **fields) -> dict:
    """A metrics.json's content with these ``variants`` ({name: {"n_images", "split", "real", ...}})."""
    return {"settings": TrainConfig(weights="offline").model_dump(mode="json"), "variants": variants, **fields}
