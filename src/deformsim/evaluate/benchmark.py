"""The sim-to-real benchmark: real-photo metrics as mean and standard deviation over seeds.

One run trains on synthetic images only and is tested twice: on the synthetic images held out of its
training (grouped by scene) and on a folder of labelled real photos. By default a run first sets aside a test split
of the renders and trains on the rest; with ``Plan.whole`` it trains on every render, as ``deformsim run`` trains its
model for the real photos, and its synthetic scores are those of the renders its training held out for validation
(out of bag for a ``train.ensemble``). Runs differ in the dataset's
generate seed (``data_seeds``), in which background photo lands behind which render (``composite_seeds``)
and in the training seed (``train_seeds``); the rendered ``black`` variant has no background draw. The real
labels are read only to score predictions: training, its validation split and the 0.5 threshold never see
them. Unlabelled photos given as ``adapt`` may adapt the model (whatever their folders, no label is read).
Beside the runs' mean the results hold each draw's ensemble of its training seeds and, given a ``baseline``
benchmark, the paired differences to it (:mod:`deformsim.evaluate.paired`).
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.evaluate.paired import METRICS as REAL_METRICS
from deformsim.evaluate.results import Aggregate, Baseline, ResultsFile, Run, read_results
from deformsim.log import get_logger
from deformsim.records import made

log = get_logger(__name__)

RENDERED = ("black", "green")  # variants without a background draw


@dataclass(frozen=True)
class Plan:
    """How many draws of each random source the benchmark averages over."""

    data_seeds: int = 1
    composite_seeds: int = 3
    train_seeds: int = 3
    variants: tuple[str, ...] = ("black", "backgrounds")
    whole: bool = False  # train on every render (synthetic scores: its validation renders), not on a split of them

    def __post_init__(self) -> None:
        for name in ("data_seeds", "composite_seeds", "train_seeds"):
            if getattr(self, name) < 1:
                raise UserError(f"benchmark {name} must be at least 1, got {getattr(self, name)}")
        if not self.variants:
            raise UserError("benchmark needs at least one variant")


def _stats(values: list[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof=1; 0 for a single value)."""
    a = np.asarray(values, dtype=float)
    return float(a.mean()), float(a.std(ddof=1)) if len(a) > 1 else 0.0


def aggregate(runs: list[Run]) -> dict[str, Aggregate]:
    """Per variant: ``n_runs`` and ``<metric>_mean`` / ``<metric>_std`` of the real metrics and of
    ``synthetic_accuracy`` / ``synthetic_f1`` over its runs."""
    out: dict[str, Aggregate] = {}
    for variant in dict.fromkeys(r.variant for r in runs):
        mine = [r for r in runs if r.variant == variant]
        row: dict = {"n_runs": len(mine)}
        for k in (*REAL_METRICS, "synthetic_accuracy", "synthetic_f1"):
            row[f"{k}_mean"], row[f"{k}_std"] = _stats([r.value(k) for r in mine])
        out[variant] = Aggregate(**row)
    return out


def run_record(key: tuple, model, y: np.ndarray, prob: np.ndarray, threshold: float, synthetic: dict) -> Run:
    """One run as ``results.json`` holds it: its variant and seeds (``key``, as :func:`deformsim.evaluate.paired.run_key`
    gives them), its model, the real metrics and predictions ``prob`` at ``threshold``, and its synthetic accuracy and
    F1."""
    from deformsim.evaluate.metrics import compute_metrics

    real = compute_metrics(y, prob, threshold)
    variant, data_seed, composite_seed, train_seed = key
    return Run.model_validate(
        {"variant": variant, "data_seed": data_seed, "composite_seed": composite_seed, "train_seed": train_seed,
         "model": model, "real": {k: real[k] for k in REAL_METRICS} | {"confusion": real["confusion"]["matrix"]},
         "synthetic": {k: synthetic[k] for k in ("accuracy", "f1")}, "real_predictions": [float(p) for p in prob]},
        strict=False)


def _synthetic(held: dict, predictor, table, test_df, threshold: float) -> dict:
    """A run's synthetic scores: on its held-out test split, or (``test_df`` None: trained on every render) on the
    renders its training ``held`` out, by the probabilities ``fit`` returned (out of bag for an ensemble)."""
    from deformsim.evaluate.metrics import compute_metrics

    if test_df is not None:
        return compute_metrics(test_df["y"].to_numpy(), predictor.predict_proba(list(test_df["path"])), threshold)
    y = table.set_index("id").loc[held["ids"], "y"].to_numpy()
    return compute_metrics(y, np.asarray(held["p_deformed"]), threshold)


def _draws(variant: str, plan: Plan) -> range:
    return range(1) if variant in RENDERED else range(plan.composite_seeds)


def run_benchmark(cfg: Config, out: Path, real: Path, plan: Plan = Plan(), adapt: Path | None = None,
                  datasets: Path | None = None, progress: bool = True, baseline: Path | None = None) -> ResultsFile:
    """Generate (or reuse), composite, train and test every run of ``plan``; write ``out/results.json`` and
    ``out/report.html``. ``baseline``: another benchmark's results to compare with, run by run.

    Datasets live in ``datasets`` (default ``out``), named by their settings, so benchmarks of other training or
    compositing settings reuse the renders; composited variants are named by their settings too.
    """
    from deformsim.dataset.real import real_table
    from deformsim.dataset.tables import drop_unseen
    from deformsim.dataset.variants import variant_table
    from deformsim.evaluate.experiments import grouped_split
    from deformsim.evaluate.paired import check_same_photos, compare, ensembles
    from deformsim.generate.identity import data_name
    from deformsim.generate.stage import generate, prepare
    from deformsim.identity import digest
    from deformsim.learn.finetune import check_unseen
    from deformsim.learn.predict import load
    from deformsim.learn.train import fit
    from deformsim.report.benchmark import write_benchmark_report

    t_start = time.perf_counter()
    out = Path(out)
    real_df = real_table(real)
    base = read_results(baseline) if baseline is not None else None
    if base is not None:
        check_same_photos(list(real_df["path"]), list(real_df["y"]), base)
    photo_variants = [v for v in plan.variants if v not in (*RENDERED, "procedural")]
    if photo_variants and cfg.composite.backgrounds is None:
        raise UserError(f"variants {', '.join(photo_variants)} need composite.backgrounds (a photo folder)")
    store = Path(datasets or out)
    folders = []
    for d in range(plan.data_seeds):
        cfg_d = cfg.model_copy(deep=True)
        cfg_d.generate.seed = cfg.generate.seed + d
        folder = store / data_name(cfg_d)
        folders.append((cfg_d, folder, prepare(cfg_d, folder)))  # every input check before any work

    runs: list[Run] = []
    total = sum(len(_draws(v, plan)) for v in plan.variants) * plan.data_seeds * plan.train_seeds
    for cfg_d, folder, prepared in folders:
        log.info("dataset seed %d: %s", cfg_d.generate.seed, folder)
        generate(cfg_d, folder, progress=progress, prepared=prepared)
        for variant in plan.variants:
            for c in _draws(variant, plan):
                name = variant
                if variant not in RENDERED:
                    comp = cfg.composite if variant != "procedural" else cfg.composite.model_copy(update={"backgrounds": None})
                    name = f"{variant}-{digest(comp.model_dump(mode='json'))[:8]}-seed{c}"
                    _composite_once(folder, comp, name, c, progress)
                table = drop_unseen(variant_table(folder, name), cfg.train.min_region, name)
                for k in range(plan.train_seeds):
                    train_cfg = cfg.train.model_copy(update={"seed": cfg.train.seed + k})
                    log.info("run %d/%d: %s, data seed %d, background seed %s, train seed %d",
                             len(runs) + 1, total, variant, cfg_d.generate.seed, c if variant not in RENDERED else "-",
                             train_cfg.seed)
                    train_df, test_df = (table, None) if plan.whole else grouped_split(table, train_cfg.split,
                                                                                       train_cfg.seed)
                    model_dir = out / "models" / f"{folder.name}-{name}-train{train_cfg.seed}"
                    if model_dir.exists():
                        shutil.rmtree(model_dir)  # the benchmark's own output: retrained from scratch
                    trained = fit(train_df, train_cfg, model_dir, progress=progress, adapt=adapt)
                    predictor = load(model_dir)
                    check_unseen(model_dir, real_df["path"])
                    synth = _synthetic(trained.held_out, predictor, table, test_df, train_cfg.threshold)
                    prob = predictor.predict_proba(list(real_df["path"]))
                    key = (variant, cfg_d.generate.seed, c if variant not in RENDERED else None, train_cfg.seed)
                    runs.append(run_record(key, str(model_dir), real_df["y"].to_numpy(), prob, train_cfg.threshold,
                                           synth))
    share = float(real_df["y"].mean())
    results = made(ResultsFile, {
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "real_dir": str(Path(real).resolve()),
        "real_images": len(real_df),
        "real_paths": list(real_df["path"]),
        "real_labels": [int(v) for v in real_df["y"]],  # for scoring and the reliability diagram only
        "majority_baseline": max(share, 1 - share),
        "plan": {"data_seeds": plan.data_seeds, "composite_seeds": plan.composite_seeds,
                 "train_seeds": plan.train_seeds, "variants": list(plan.variants), "whole": plan.whole},
        "adapt": str(adapt) if adapt is not None else None,
        "settings": cfg.model_dump(mode="json"),
        "variants": aggregate(runs),
        "runs": runs,
    })
    results.ensembles = ensembles(results)
    if base is not None:
        results.baseline = Baseline(results=str(Path(baseline).resolve()), comparison=compare(results, base))
    results.seconds = time.perf_counter() - t_start
    results.write(out / "results.json")
    write_benchmark_report(results, out)
    return results


def _composite_once(folder: Path, comp, name: str, seed: int, progress: bool) -> None:
    """Composite the variant unless it exists with the same settings and holds every image of the dataset (then its
    images keep their cached features); one made before the dataset grew is made again."""
    from deformsim.composite.stage import SETTINGS_FILE, composite, variant_settings
    from deformsim.dataset.variants import is_current

    stamp = folder / "variants" / name / SETTINGS_FILE
    if _read_stamp(stamp) == variant_settings(name, seed, comp) and is_current(folder, name):
        return
    composite(folder, comp, name, seed, progress=progress)


def _read_stamp(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):  # missing, or cut short by a kill: composited again
        return None
