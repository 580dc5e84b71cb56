"""The paper's Table II: for each training variant, a held-out synthetic test and a sim-to-real test.

(a) *split*: a seeded split of the variant's images, stratified by label and grouped by ``sample`` (the
views of one scene state never straddle train and test); train on one part, test on the other.
(b) *real* (with a real folder): train on all of the variant's images, test on the real photographs.
Models go to ``OUT/models/<variant>_{split,full}/``; everything measured goes to ``OUT/metrics.json``; Grad-CAM
heatmaps of the real-test models over real photos go to ``OUT/gradcam/<variant>/<n>.png``. A dataset with dense
labels also gets the severity, family and localise heads (:mod:`deformsim.evaluate.dense_experiments`).
"""

from __future__ import annotations

import io
import json
import os
import shutil
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from deformsim.atomic import write_bytes, write_json
from deformsim.config import TrainConfig
from deformsim.dataset.images import open_rgb
from deformsim.dataset.real import real_table
from deformsim.dataset.tables import drop_unseen, split
from deformsim.dataset.variants import list_variants, variant_table
from deformsim.errors import UserError
from deformsim.evaluate.dense_experiments import plan as plan_dense
from deformsim.evaluate.dense_experiments import run_dense
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.metrics_file import Evaluation, Heatmap, MetricsFile, Prediction
from deformsim.evaluate.results import ResultsFile
from deformsim.log import get_logger
from deformsim.records import made
from deformsim.version import __version__

log = get_logger(__name__)

EXAMPLES_PER_CLASS = 3
LOW_SYNTHETIC = 0.75  # held-out synthetic accuracy below which the model has not learned the renders
GRADCAM_MAX = 24  # real photos with a heatmap per model
GRADCAM_SIZE = 224  # longest side of a heatmap image, pixels


def grouped_split(table: pd.DataFrame, train_fraction: float, seed: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Split ``table`` into (train, test) by whole samples, keeping each label's share of samples.

    Uses :func:`deformsim.dataset.tables.split` (each label keeps its share, at least one sample on each side).
    Raises :class:`UserError` when a label has fewer than two samples or a sample's views
    disagree on the label.
    """
    labels = table.groupby("sample")["y"].agg(["min", "max"])
    mixed = labels.index[labels["min"] != labels["max"]]
    if len(mixed):
        raise UserError(f"sample {mixed[0]} has views with different labels")
    for y in (0, 1):
        n = int((labels["min"] == y).sum())
        if n < 2:
            raise UserError(f"a split needs at least 2 samples of each class, got {n} with y={y}")
    train, test = split(table, train_fraction, seed)
    return table.iloc[train].reset_index(drop=True), table.iloc[test].reset_index(drop=True)


def _counts(df: pd.DataFrame) -> dict:
    out = {"n": len(df), "n_deformed": int(df["y"].sum())}
    if "sample" in df:
        out["n_samples"] = int(df["sample"].nunique())
    return out


def _rel(path: Path, root: Path) -> str:
    return os.path.relpath(path, root)


def _train_and_test(train_df, test_df, cfg: TrainConfig, model_dir: Path, out_dir: Path, progress: bool) -> dict:
    from deformsim.learn import predict, train
    from deformsim.learn.finetune import check_unseen

    result = train.fit(train_df, cfg, model_dir, progress=progress)
    check_unseen(result.model_path, test_df["path"])
    t0 = time.perf_counter()
    prob = predict.load(result.model_path).predict_proba(list(test_df["path"]))
    predict_seconds = time.perf_counter() - t0
    return {
        "train": _counts(train_df),
        "test": _counts(test_df),
        "model": _rel(Path(result.model_path), out_dir),
        "weights": result.weights,
        "history": result.history,
        "train_seconds": result.seconds,
        "predict_seconds": predict_seconds,
        "metrics": compute_metrics(test_df["y"].to_numpy(), prob, cfg.threshold),
        "predictions": [
            {"path": p, "y": int(y), "prob": float(q)} for p, y, q in zip(test_df["path"], test_df["y"], prob)
        ],
    }


def _examples(table: pd.DataFrame, rng: np.random.Generator) -> list[dict]:
    out = []
    for y in (0, 1):
        rows = table[table["y"] == y]
        pick = rng.choice(len(rows), size=min(EXAMPLES_PER_CLASS, len(rows)), replace=False)
        out += [{"path": rows["path"].iloc[i], "y": y} for i in sorted(pick)]
    return out


def review_order(predictions: list[Prediction], threshold: float) -> list[int]:
    """Indices of ``predictions`` to review: the misclassified (most confident first), then the others (least
    confident first); ties keep their order."""
    def key(i: int) -> tuple[int, float]:
        p = predictions[i]
        margin = abs(p.prob - threshold)
        return (0, -margin) if (p.prob >= threshold) != bool(p.y) else (1, margin)

    return sorted(range(len(predictions)), key=key)


def gradcam_images(predictor, predictions: list[Prediction], threshold: float, out_dir: Path,
                   folder: str) -> list[Heatmap]:
    """Grad-CAM overlays of the first :data:`GRADCAM_MAX` photos in :func:`review_order`, written as
    ``out_dir/folder/<n>.png``; returns their predictions, each with its ``image`` relative to ``out_dir``."""
    from PIL import Image

    from deformsim.learn.crops import crop
    from deformsim.learn.gradcam import overlay

    chosen = [predictions[i] for i in review_order(predictions, threshold)[:GRADCAM_MAX]]
    cams = predictor.gradcam([p.path for p in chosen])
    out = []
    for n, (p, cam) in enumerate(zip(chosen, cams)):
        photo = crop(open_rgb(p.path), predictor.cfg.crop)  # what the model saw
        photo.thumbnail((GRADCAM_SIZE, GRADCAM_SIZE))
        buf = io.BytesIO()
        Image.fromarray(overlay(np.asarray(photo), cam)).save(buf, format="PNG")
        name = f"{folder}/{n}.png"
        write_bytes(out_dir / name, buf.getvalue())
        out.append(Heatmap(**p.model_dump(), image=name))
    return out


def _load_tables(data_root: Path, cfg: TrainConfig) -> tuple[dict[str, pd.DataFrame], list[str]]:
    available = list_variants(data_root)
    chosen = [v for v in cfg.variants if v in available]
    if not chosen:
        raise UserError(f"none of the variants {cfg.variants} is in {data_root} (have: {', '.join(available)})")
    tables = {v: drop_unseen(variant_table(data_root, v), cfg.min_region, f"variant '{v}'") for v in chosen}
    for v, t in tables.items():
        if t["y"].nunique() < 2:
            raise UserError(f"variant '{v}' has only {t['label'].iloc[0]} images: training needs both classes")
        missing = [p for p in t["path"] if not os.path.isfile(p)]
        if missing:
            raise UserError(f"variant '{v}': {len(missing)} images are missing, e.g. {missing[0]}")
    return tables, [v for v in cfg.variants if v not in available]


def _record(path: Path) -> dict | None:
    """A JSON or YAML mapping the report only shows; None when it is missing or unreadable."""
    try:
        value = yaml.safe_load(path.read_text()) if path.is_file() else None
    except (OSError, ValueError, yaml.YAMLError):
        return None
    return value if isinstance(value, dict) else None


def provenance(data_root: Path, variants: list[str]) -> dict:
    """What the dataset was made from: its config, its inputs' digests and each variant's compositing settings."""
    from deformsim.composite.stage import SETTINGS_FILE
    from deformsim.dataset.layout import Layout

    layout = Layout(data_root)
    composite = {v: s for v in variants if (s := _record(layout.variant_dir(v) / SETTINGS_FILE)) is not None}
    return {"config": _record(layout.config), "inputs": _record(layout.inputs), "composite": composite}


def _summary(entry: dict) -> dict:
    keys = ("accuracy", "f1", "precision", "recall")
    return {
        part: ({k: entry[part]["metrics"][k] for k in keys} if entry.get(part, {}).get("metrics") else None)
        for part in ("split", "real")
    }


def low_synthetic_line(variant: str, accuracy: float, what: str = "held-out synthetic accuracy") -> str | None:
    """A warning when ``accuracy`` on held-out renders is below :data:`LOW_SYNTHETIC`: a model that cannot tell the
    renders apart has learned nothing its real-photo figures could show; None otherwise."""
    if accuracy >= LOW_SYNTHETIC:
        return None
    return (f"variant {variant}: {what} {accuracy:.2f} is below {LOW_SYNTHETIC:g}: the model does not tell the renders "
            "apart, so its real-photo figures mean little; check that the deformations show (deformsim show, "
            "deformsim spec check --config), then render more or larger images or train longer")


def low_synthetic_runs(results: ResultsFile) -> list[str]:
    """:func:`low_synthetic_line` of each variant of a benchmark's ``results`` whose mean held-out synthetic accuracy
    is too low to read its real figures."""
    lines = (low_synthetic_line(v, s.synthetic_accuracy_mean, "mean held-out synthetic accuracy")
             for v, s in results.variants.items())
    return [line for line in lines if line]


def low_synthetic(metrics: MetricsFile) -> list[str]:
    """:func:`low_synthetic_line` of every variant of a report's ``metrics`` that has one."""
    lines = (low_synthetic_line(v, split.metrics.accuracy) for v, entry in metrics.variants.items()
             if (split := entry.ran("split")) is not None)
    return [line for line in lines if line]


def run_experiments(
    data_root: str | Path, cfg: TrainConfig, out_dir: str | Path, real_dir: str | Path | None = None,
    progress: bool = True,
) -> MetricsFile:
    """Run Table II for every variant of ``cfg.variants`` present in ``data_root``; write ``metrics.json``."""
    from deformsim.evaluate import pca
    from deformsim.learn import predict

    t_start = time.perf_counter()
    data_root, out_dir = Path(data_root), Path(out_dir)
    tables, missing = _load_tables(data_root, cfg)
    dense = plan_dense(data_root, tables, cfg)
    real = real_table(real_dir) if real_dir is not None else None
    rng = np.random.default_rng(cfg.seed)

    variants: dict[str, dict] = {}
    for v, table in tables.items():
        entry: dict = {"n_images": len(table), "n_samples": int(table["sample"].nunique()),
                       "examples": _examples(table, rng)}
        try:
            train_df, test_df = grouped_split(table, cfg.split, cfg.seed)
        except UserError as exc:
            entry["split"] = {"skipped": str(exc)}
        else:
            _log(progress, f"{v}: training on {len(train_df)} images, testing on {len(test_df)} held out")
            model_dir = out_dir / "models" / f"{v}_split"
            entry["split"] = _train_and_test(train_df, test_df, cfg, model_dir, out_dir, progress)
            write_json(model_dir / "split.json", {"train": list(train_df["id"]), "test": list(test_df["id"])})
        if real is not None:
            _log(progress, f"{v}: training on all {len(table)} images, testing on {len(real)} real")
            entry["real"] = _train_and_test(table, real, cfg, out_dir / "models" / f"{v}_full", out_dir, progress)
        entry["summary"] = _summary(entry)
        variants[v] = entry

    _log(progress, "PCA plots of the domains")
    domains = {f"synthetic {v}": t for v, t in tables.items()}
    if real is not None:
        domains["real"] = real
    plots = {"pca_pixels": "pca_pixels.png", "pca_features": {}}
    write_bytes(out_dir / plots["pca_pixels"], pca.pixel_pca_png(domains, seed=cfg.seed))
    shutil.rmtree(out_dir / "gradcam", ignore_errors=True)  # heatmaps of an earlier run
    for v, entry in variants.items():
        part = entry.get("real") or entry["split"]
        if "model" not in part:
            continue
        name = f"pca_features_{v}.png"
        predictor = predict.load(out_dir / part["model"])
        write_bytes(out_dir / name, pca.feature_pca_png(predictor, domains, title=f"model trained on {v}",
                                                        seed=cfg.seed))
        plots["pca_features"][v] = name
        if "real" in entry:
            _log(progress, f"{v}: Grad-CAM heatmaps of real photos")
            predictions = [Prediction(**p) for p in part["predictions"]]
            part["gradcam"] = [h.model_dump() for h in gradcam_images(predictor, predictions, cfg.threshold, out_dir,
                                                                      f"gradcam/{v}")]

    if dense is not None:
        _log(progress, f"{dense[0]}: dense-label heads (severity, family, localise)")
        dense = run_dense(*dense, cfg, out_dir, real, progress, grouped_split)
    metrics = {
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "data_root": str(data_root.resolve()),
        "real_dir": str(Path(real_dir).resolve()) if real_dir is not None else None,
        "real": _counts(real) if real is not None else None,
        "settings": cfg.model_dump(mode="json"),
        "version": __version__,
        "data": provenance(data_root, list(tables)),
        "missing_variants": missing,
        "variants": variants,
        "plots": plots,
        "seconds": time.perf_counter() - t_start,
    }
    if dense is not None:
        metrics["dense"] = dense
    metrics = made(MetricsFile, metrics)
    metrics.write(out_dir / "metrics.json")
    for line in low_synthetic(metrics):
        log.warning(line)
    return metrics


def _log(progress: bool, message: str) -> None:
    if progress:
        log.info(message)


def evaluate_model(
    model: str | Path, data_root: str | Path | None = None, variant: str | None = None,
    real_dir: str | Path | None = None, threshold: float | None = None,
) -> Evaluation:
    """Metrics and predictions of a trained model on a synthetic variant (``data_root`` + ``variant``) or a real
    folder.

    A model trained on a split (its folder holds ``split.json``) is tested on that split's held-out images
    only; the deformed images whose damage it was trained not to see (``train.min_region``) are left out.
    ``threshold`` defaults to the model's training threshold.
    """
    from deformsim.learn import predict
    from deformsim.learn.finetune import check_unseen

    if (real_dir is None) == (data_root is None):
        raise UserError("give either a real folder or a dataset and a variant to evaluate on")
    if data_root is not None and not variant:
        raise UserError(f"which variant of {data_root}? (have: {', '.join(list_variants(data_root))})")
    if threshold is not None and not 0 < threshold < 1:
        raise UserError(f"threshold must lie in (0, 1), got {threshold}")
    predictor = predict.load(model)
    held_out = False
    if real_dir is not None:
        table, test = real_table(real_dir), str(real_dir)
    else:
        test = f"{data_root} / {variant}"
        table = drop_unseen(variant_table(data_root, variant), predictor.cfg.min_region, test)
        split_file = predictor.path.parent / "split.json"
        if split_file.is_file():
            table = table[table["id"].isin(json.loads(split_file.read_text())["test"])].reset_index(drop=True)
            held_out = True
    check_unseen(predictor.path, table["path"])
    prob = predictor.predict_proba(list(table["path"]))
    threshold = predictor.cfg.threshold if threshold is None else threshold
    return made(Evaluation, {
        "model": str(model), "test": test, "n_images": len(table), "held_out": held_out,
        "metrics": compute_metrics(table["y"].to_numpy(), prob, threshold),
        "predictions": [{"path": p, "y": int(y), "prob": float(q)} for p, y, q in zip(table["path"], table["y"], prob)],
    })
