"""The adaptation benchmark (``deformsim bench adapt``): a trained model adapted to unlabelled real photos, scored on
labelled ones against the same model unadapted, paired on the same photos.

Two protocols, both reading the folder's labels for scoring only:

- ``transductive``: adapted on every photo of the folder (labels unread), scored on the same photos;
- ``inductive``: the photos split into ``folds`` by content (a seeded permutation of their sha256-ordered list, copies
  counted once); each fold scored by the model adapted on the other folds, so no photo is scored by a model that saw it.

Per method and protocol: accuracy, F1, precision, recall and AUC, and each one's paired difference to the unadapted
model with a 95 % bootstrap interval over the photos (:func:`deformsim.evaluate.paired._interval`).
"""

from __future__ import annotations

import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from deformsim.atomic import write_json
from deformsim.errors import UserError
from deformsim.learn.adapter import METHODS, MIN_PHOTOS, AdaptRecipe, fit_adapter
from deformsim.log import get_logger

log = get_logger(__name__)

PROTOCOLS = ("transductive", "inductive")


def _folds(n: int, folds: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % folds


def run_adaptation(model: Path, real: Path, out: Path, methods: tuple[str, ...] = METHODS, folds: int = 2,
                   recipe: AdaptRecipe = AdaptRecipe(), seed: int = 0, progress: bool = True) -> dict:
    """Every method under both protocols on the labelled photos of ``real``; written to ``out/adapt.json``."""
    from deformsim.evaluate.fewshot import _table
    from deformsim.evaluate.metrics import compute_metrics
    from deformsim.evaluate.paired import _interval
    from deformsim.learn.adapt_stage import check_adaptable
    from deformsim.learn.predict import load
    from deformsim.outputs import check_folder_target

    start = time.perf_counter()
    out = check_folder_target(out, "--out")
    for method in methods:
        replace(recipe, method=method)  # one line for an unknown method, before any work
    if not 2 <= folds <= 20:
        raise UserError(f"--folds must lie in [2, 20], got {folds}")
    table = _table(real).sort_values("digest").reset_index(drop=True)
    if len(table) < folds * MIN_PHOTOS:
        raise UserError(f"{real} holds {len(table)} distinct photos: {folds} folds of at least {MIN_PHOTOS} needs "
                        f"{folds * MIN_PHOTOS}")
    predictor = load(model, progress)
    check_adaptable(predictor)
    paths, y = list(table["path"]), table["y"].to_numpy()
    threshold = predictor.cfg.threshold
    p0 = predictor.synthetic_outputs(paths)
    features = predictor.adapter_features(paths) if "probe" in methods else None
    fold = _folds(len(paths), folds, seed)
    rng = np.random.default_rng(seed)
    rows = {"unadapted": {"metrics": compute_metrics(y, p0, threshold), "predictions": p0.tolist()}}
    for method in methods:
        r = replace(recipe, method=method)
        for protocol in PROTOCOLS:
            if protocol == "transductive":
                adapter = fit_adapter(p0, features, r)
                p = adapter.apply(p0, features)
                prior = [adapter.prior]
            else:
                p, prior = np.empty(len(paths)), []
                for f in range(folds):
                    test, train = fold == f, fold != f
                    adapter = fit_adapter(p0[train], None if features is None else features[train], r)
                    p[test] = adapter.apply(p0[test], None if features is None else features[test])
                    prior.append(adapter.prior)
            paired = _interval(p[None], p0[None], y, threshold, rng)
            rows[f"{method} {protocol}"] = {"metrics": compute_metrics(y, p, threshold), "paired": paired,
                                            "prior": prior, "predictions": p.tolist()}
            log.info("%s %s: accuracy %.3f (%+.1f points, %+.1f to %+.1f)", method, protocol,
                     rows[f"{method} {protocol}"]["metrics"]["accuracy"], 100 * paired["accuracy"]["diff"],
                     100 * paired["accuracy"]["low"], 100 * paired["accuracy"]["high"])
    result = {"model": str(model), "real": str(real), "photos": len(paths), "folds": folds, "seed": seed,
              "recipe": asdict(recipe), "true_share": float(y.mean()), "labels": y.tolist(),
              "paths": [str(p) for p in paths], "rows": rows, "seconds": time.perf_counter() - start}
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "adapt.json", result)
    return result
