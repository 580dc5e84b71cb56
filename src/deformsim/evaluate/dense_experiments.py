"""The report's dense-label part: severity, family and localise heads on one training variant.

On a dataset with dense labels the three heads of :mod:`deformsim.learn.targets` train on the training part of
the label experiments' grouped split of one variant (the first composited variant of ``train.variants`` whose
manifest carries its own aligned maps, else ``black``) and are measured on its held-out part
(:mod:`deformsim.evaluate.dense`). They reuse the cached stem activations, so they cost little. Localisation
heatmaps of up to :data:`HEATMAPS` real photos, evenly spread over the folder (their labels are only shown),
go to ``OUT/dense/real_<n>.png``, the severity scatter plot to ``OUT/dense/severity.png``. Models go to
``OUT/models/<variant>_<target>/``.
"""

from __future__ import annotations

import io
import shutil
import time
from pathlib import Path

import numpy as np
import pandas as pd

from deformsim.atomic import write_bytes
from deformsim.config import TrainConfig
from deformsim.dataset.images import open_rgb
from deformsim.dataset.variants import has_own_maps, variant_table
from deformsim.errors import UserError
from deformsim.evaluate.dense import family_metrics, region_metrics, severity_metrics

TARGETS = ("severity", "family", "localise")
HEATMAPS = 6
HEATMAP_SIZE = 200  # longest side of the photo in a heatmap pair, pixels


def plan(data_root: Path, tables: dict[str, pd.DataFrame], cfg: TrainConfig) -> tuple[str, pd.DataFrame] | None:
    """The variant and table (absolute map paths) the dense heads train on; None when the dataset is not dense.

    Checked before any training: a dense dataset whose labels are unusable stops with one line.
    """
    from deformsim.learn.targets import check_target

    first = next(iter(tables.values()))
    if "region" not in first.columns:
        return None
    composited = [v for v in tables if has_own_maps(data_root, v)]
    variant = composited[0] if composited else "black"
    table = tables[variant] if variant in tables else variant_table(data_root, variant)
    for target in TARGETS:
        check_target(table, cfg.for_target(target))
    return variant, table


def _pair_png(path: str, heat: np.ndarray) -> bytes:
    """The photo and its heatmap overlay side by side."""
    from PIL import Image

    from deformsim.learn.gradcam import overlay

    photo = open_rgb(path)
    photo.thumbnail((HEATMAP_SIZE, HEATMAP_SIZE))
    a = np.asarray(photo)
    buf = io.BytesIO()
    Image.fromarray(np.concatenate([a, np.full((a.shape[0], 6, 3), 255, np.uint8), overlay(a, heat)], 1)).save(buf, "PNG")
    return buf.getvalue()


def _heatmaps(predictor, real: pd.DataFrame, out_dir: Path) -> list[dict]:
    picks = np.unique(np.linspace(0, len(real) - 1, min(HEATMAPS, len(real))).round().astype(int))
    rows = real.iloc[picks]
    maps = predictor.predict_outputs(list(rows["path"]))
    out = []
    for n, ((_, r), heat) in enumerate(zip(rows.iterrows(), maps)):
        name = f"dense/real_{n}.png"
        write_bytes(out_dir / name, _pair_png(r["path"], heat))
        out.append({"path": r["path"], "y": int(r["y"]), "image": name,
                    "region_fraction": float((heat >= predictor.cfg.threshold).mean()), "peak": float(heat.max())})
    return out


def _measure(target: str, predictor, train_df: pd.DataFrame, test_df: pd.DataFrame, out_dir: Path) -> dict:
    from deformsim.learn.targets import family_columns, region_masks
    from deformsim.report.figures import scatter_png

    out = predictor.predict_outputs(list(test_df["path"]))
    thr = predictor.cfg.threshold
    if target == "severity":
        true = test_df["max_disp_mm"].to_numpy(float)
        write_bytes(out_dir / "dense" / "severity.png", scatter_png(true, out, "max displacement (mm)"))
        return {"metrics": severity_metrics(true, out, float(train_df["max_disp_mm"].mean())),
                "plot": "dense/severity.png"}
    if target == "family":
        return {"metrics": family_metrics(test_df[family_columns(test_df)].to_numpy(), out, predictor.outputs, thr)}
    truth = region_masks(list(test_df["region"]), out.shape[-1]).numpy() >= 0.5
    return {"metrics": region_metrics(truth, out, thr)}


def run_dense(variant: str, table: pd.DataFrame, cfg: TrainConfig, out_dir: Path, real: pd.DataFrame | None,
              progress: bool, grouped_split) -> dict:
    """Train and measure the three heads on ``table`` (from :func:`plan`), split by ``grouped_split`` (the label
    experiments' split function); what the report shows of them."""
    from deformsim.learn import predict, train

    t0 = time.perf_counter()
    shutil.rmtree(out_dir / "dense", ignore_errors=True)
    entry: dict = {"variant": variant}
    try:
        train_df, test_df = grouped_split(table, cfg.split, cfg.seed)
    except UserError as exc:
        return {**entry, "skipped": str(exc)}
    entry.update({"n_train": len(train_df), "n_test": len(test_df), "heads": {}})
    for target in TARGETS:
        tcfg = cfg.for_target(target)
        result = train.fit(train_df, tcfg, out_dir / "models" / f"{variant}_{target}", progress=progress)
        predictor = predict.load(result.model_path)
        head = {"model": str(result.model_path.relative_to(out_dir)), "train_seconds": result.seconds,
                "outputs": predictor.outputs, **_measure(target, predictor, train_df, test_df, out_dir)}
        if target == "localise" and real is not None and len(real):
            head["real_heatmaps"] = _heatmaps(predictor, real, out_dir)
        entry["heads"][target] = head
    entry["seconds"] = time.perf_counter() - t0
    return entry
