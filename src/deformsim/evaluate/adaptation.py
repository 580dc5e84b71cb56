"""The adaptation benchmark (``deformsim bench adapt``): a trained model adapted to unlabelled real photos, scored on
labelled ones against the same model unadapted, paired on the same photos.

Two protocols, both reading the folder's labels for scoring only:

- ``transductive``: adapted on every photo of the folder (labels unread), scored on the same photos;
- ``inductive``: the photos split into ``folds`` by content (a seeded permutation of their sha256-ordered list, copies
  counted once); each fold scored by the model adapted on the other folds, so no photo is scored by a model that saw it.

With ``ks``, k labelled photos of each class are drawn at random and the rest scored; ``biased`` draws them as a
biased sample does instead: each class's k photos from a different lighting (the intact ones from the warmer half of
the folder and the deformed ones from the cooler half, or the reverse in every other draw; from the
photos' pixels; :mod:`deformsim.evaluate.draws`), which a model fitted on them can mistake for the damage. With
``ns``, each method is adapted on n unlabelled photos drawn at random, under both protocols: how many photos it needs.

Several models (one per render draw, say) are pooled: per method and protocol, accuracy, F1 and AUC as mean and
standard deviation over the models, and the paired difference of each metric to the unadapted models with a 95 %
bootstrap interval over the models and the photos (:func:`deformsim.evaluate.paired.paired_differences`).
"""

from __future__ import annotations

import time
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

from deformsim.errors import UserError
from deformsim.evaluate.adaptation_file import AdaptBenchFile
from deformsim.evaluate.draws import Drawing, drawing
from deformsim.learn.adapter import MIN_PHOTOS, UNLABELLED, AdaptRecipe, fit_adapter
from deformsim.log import get_logger
from deformsim.records import made

log = get_logger(__name__)

PROTOCOLS = ("transductive", "inductive")
KSHOT = ("labelled probe", "probe, the rest unlabelled", "stacked")  # the k-photo curves beside the unadapted model


def content_folds(n: int, folds: int, seed: int) -> np.ndarray:
    """A fold number for each of ``n`` photos (sorted by content), drawn by ``seed``."""
    return np.random.default_rng(seed).permutation(n) % folds


def _fit_apply(p0: np.ndarray, features: np.ndarray | None, recipe: AdaptRecipe, rows: np.ndarray,
               scored: np.ndarray) -> tuple[np.ndarray, float]:
    """The adapter fitted on the photos ``rows``: its probabilities of the photos ``scored``, and its prior."""
    adapter = fit_adapter(p0[rows], None if features is None else features[rows], recipe)
    return adapter.apply(p0[scored], None if features is None else features[scored]), adapter.prior


def adapted_probabilities(p0: np.ndarray, features: np.ndarray | None, fold: np.ndarray, recipe: AdaptRecipe,
                          protocol: str) -> tuple[np.ndarray, list[float]]:
    """The photos' adapted probabilities under ``protocol`` and the priors estimated on the way."""
    if protocol == "transductive":
        adapter = fit_adapter(p0, features, recipe)
        return adapter.apply(p0, features), [adapter.prior]
    p, priors = np.empty(len(p0)), []
    for f in np.unique(fold):
        p[fold == f], prior = _fit_apply(p0, features, recipe, fold != f, fold == f)
        priors.append(prior)
    return p, priors


def _row(y: np.ndarray, probs: np.ndarray, threshold: float) -> dict:
    """Metrics of each model's predictions (rows of ``probs``) and their mean and standard deviation."""
    from deformsim.evaluate.metrics import compute_metrics

    each = [compute_metrics(y, p, threshold) for p in probs]
    row = {"models": each}
    for key in ("accuracy", "f1", "auc"):
        values = [m[key] for m in each if m[key] is not None]
        row[key] = float(np.mean(values)) if values else None
        row[f"{key}_std"] = float(np.std(values)) if values else None
    return row


def _kshot(p0: np.ndarray, features: np.ndarray, y: np.ndarray, groups: list[str], chosen: np.ndarray,
           rest: np.ndarray, recipe: AdaptRecipe, threshold: float) -> dict[str, float]:
    """Accuracy on the photos ``rest`` with the labelled photos ``chosen``: the model unadapted, a probe fitted on
    the chosen photos' labels alone, the probe fitted on them and the rest unlabelled (transductive), and the model
    stacked with a residual fitted on them (:mod:`deformsim.learn.stack`, their sessions ``groups``)."""
    from deformsim.learn.adapter import fit_logistic
    from deformsim.learn.stack import fit_stack

    labels = np.full(len(y), -1)
    labels[chosen] = y[chosen]
    x = (features - features.mean(0)) / (features.std(0) + 1e-6)  # the photos' pixels, not their labels
    coef, bias = fit_logistic(x[chosen], y[chosen].astype(float), np.ones(len(chosen)), recipe.l2)
    both = fit_adapter(p0, features, recipe, labels)
    stacked = fit_stack(p0[chosen], features[chosen], y[chosen], [groups[i] for i in chosen])[0]
    scored = {"unadapted": p0[rest], KSHOT[0]: 1 / (1 + np.exp(-(x[rest] @ coef + bias))),
              KSHOT[1]: both.apply(p0[rest], features[rest]), KSHOT[2]: stacked.apply(p0[rest], features[rest])}
    return {name: float(((p >= threshold) == (y[rest] == 1)).mean()) for name, p in scored.items()}


def kshot_curves(base: list[np.ndarray], features: list[np.ndarray], y: np.ndarray, groups: list[str], ks: list[int],
                 draws: int, recipe: AdaptRecipe, threshold: float, seed: int,
                 sampling: Drawing | None = None) -> list[dict]:
    """Per k and curve: mean accuracy over the models and draws, its standard deviation, and the mean paired
    difference to the unadapted model on the same photos with a 95 % bootstrap interval over the runs. The k photos
    are drawn as ``sampling`` draws them (default: at random)."""
    from deformsim.evaluate.fewshot import mean_interval

    sampling = sampling or Drawing(y)
    rows = []
    for k in ks:
        runs = [_kshot(p0, f, y, groups, *sampling.rows(k, d, np.random.default_rng([seed, k, d])), recipe,
                       threshold)
                for p0, f in zip(base, features) for d in range(draws)]
        for name in ("unadapted", *KSHOT):
            acc = [r[name] for r in runs]
            row = {"k": k, "curve": name, "runs": len(runs), "accuracy": float(np.mean(acc)),
                   "accuracy_std": float(np.std(acc))}
            if name != "unadapted":
                row["paired"], row["paired_interval"] = mean_interval([r[name] - r["unadapted"] for r in runs], seed)
            rows.append(row)
    return rows


def unlabelled_curves(base: list[np.ndarray], features: list[np.ndarray | None], y: np.ndarray, fold: np.ndarray,
                      ns: list[int], draws: int, recipes: dict[str, AdaptRecipe], threshold: float,
                      seed: int) -> list[dict]:
    """Per n, method and protocol: the accuracy of each model adapted on n unlabelled photos drawn at random
    (``draws`` draws per model, the same photos for every method), mean and standard deviation over the runs, the
    unadapted model's on the same photos, and the mean paired difference with a 95 % bootstrap interval over the
    runs. Transductive: adapted on the n photos and scored on them; inductive: for each fold, adapted on n photos of
    the other folds and scored on the fold."""
    from deformsim.evaluate.fewshot import mean_interval

    rows = []
    for n in ns:
        for method, recipe in recipes.items():
            for protocol in PROTOCOLS:
                runs = []
                for p0, f in zip(base, features):
                    for d in range(draws):
                        rng = np.random.default_rng([seed, n, d])
                        if protocol == "transductive":
                            scored = rng.choice(len(y), n, replace=False)
                            p = _fit_apply(p0, f, recipe, scored, scored)[0]
                        else:
                            scored, p = np.arange(len(y)), np.empty(len(y))
                            for g in np.unique(fold):
                                pick = rng.choice(np.flatnonzero(fold != g), n, replace=False)
                                p[fold == g] = _fit_apply(p0, f, recipe, pick, fold == g)[0]
                        truth = y[scored] == 1
                        runs.append((float(((p >= threshold) == truth).mean()),
                                     float(((p0[scored] >= threshold) == truth).mean())))
                acc = np.array(runs)
                paired, interval = mean_interval(list(acc[:, 0] - acc[:, 1]), seed)
                rows.append({"n": n, "curve": f"{method} {protocol}", "runs": len(runs),
                             "accuracy": float(acc[:, 0].mean()), "accuracy_std": float(acc[:, 0].std()),
                             "unadapted": float(acc[:, 1].mean()), "paired": paired, "paired_interval": interval})
    return rows


def run_adaptation(models: list[Path], real: Path, out: Path, methods: tuple[str, ...] = UNLABELLED, folds: int = 2,
                   recipe: AdaptRecipe = AdaptRecipe(), seed: int = 0, progress: bool = True, ks: list[int] = (),
                   draws: int = 5, groups: str = "date", biased: bool = False, ns: list[int] = ()) -> AdaptBenchFile:
    """Every unlabelled method under both protocols on the labelled photos of ``real``, for each of ``models`` (e.g.
    one per render draw), pooled; with ``ks``, the k-photo curves (:func:`kshot_curves`, ``draws`` draws of the k
    photos per model; the shooting sessions ``groups``: ``date``, ``none`` or a CSV file, see
    :mod:`deformsim.dataset.groups`; ``biased``: each class's k photos from a different lighting); with ``ns``, the
    curves over n unlabelled photos (:func:`unlabelled_curves`, ``draws`` draws per model); written to
    ``out/adapt.json`` and returned."""
    from deformsim.dataset.groups import photo_groups
    from deformsim.evaluate.fewshot import unique_photos
    from deformsim.evaluate.paired import paired_differences
    from deformsim.learn.adapt_stage import check_adaptable
    from deformsim.learn.predict import load
    from deformsim.outputs import check_folder_target

    start = time.perf_counter()
    out = check_folder_target(out, "--out")
    recipes = {method: replace(recipe, method=method) for method in methods}  # one line for an unknown method
    if labelled := [m for m in methods if m not in UNLABELLED]:
        raise UserError(f"--methods {labelled[0]} needs labelled photos: the k-photo curves (--k) measure it")
    if not 2 <= folds <= 20:
        raise UserError(f"--folds must lie in [2, 20], got {folds}")
    if not 1 <= draws <= 1000:
        raise UserError(f"--draws must lie in [1, 1000], got {draws}")
    table = unique_photos(real).sort_values("digest").reset_index(drop=True)
    fewest = int(min(table["y"].sum(), (1 - table["y"]).sum()))
    if ks and max(ks) >= fewest:
        raise UserError(f"--k {max(ks)}: {real} holds {fewest} photos of its smaller class; k must leave one to score")
    if biased and not ks:
        raise UserError("--biased draws the k labelled photos: give --k too")
    sampling = drawing(table["y"].to_numpy(), list(table["path"]), ks, biased, real)  # before any model is read
    if len(table) < folds * MIN_PHOTOS:
        raise UserError(f"{real} holds {len(table)} distinct photos: {folds} folds of at least {MIN_PHOTOS} needs "
                        f"{folds * MIN_PHOTOS}")
    fold = content_folds(len(table), folds, seed)
    pool = len(table) - int(np.bincount(fold).max())  # the fewest photos an inductive fold leaves to adapt on
    if ns and (ns[0] < MIN_PHOTOS or ns[-1] > pool):
        raise UserError(f"--n {ns[0] if ns[0] < MIN_PHOTOS else ns[-1]}: adapting needs at least {MIN_PHOTOS} photos, "
                        f"and {folds} folds of {len(table)} photos leave {pool} to adapt on")
    predictors = [load(m, progress) for m in models]
    for predictor in predictors:
        check_adaptable(predictor)
    paths, y = list(table["path"]), table["y"].to_numpy()
    sessions = photo_groups(paths, groups)
    threshold = predictors[0].cfg.threshold
    base, adapted, priors, feats = [], {}, {}, []
    for predictor in predictors:
        p0, features = predictor.outputs_and_features(paths, bool(ks) or any(r.probe for r in recipes.values()))
        base.append(p0)
        feats.append(features)
        for method, r in recipes.items():
            for protocol in PROTOCOLS:
                p, prior = adapted_probabilities(p0, features, fold, r, protocol)
                adapted.setdefault(f"{method} {protocol}", []).append(p)
                priors.setdefault(f"{method} {protocol}", []).append(prior)
    rng = np.random.default_rng(seed)
    unadapted = np.array(base)
    rows = {"unadapted": {**_row(y, unadapted, threshold), "predictions": unadapted.tolist()}}
    for name, probs in adapted.items():
        probs = np.array(probs)
        paired = {k: d.model_dump() for k, d in paired_differences(probs, unadapted, y, threshold, rng).items()}
        rows[name] = {**_row(y, probs, threshold), "paired": paired,
                      "prior": priors[name], "predictions": probs.tolist()}
        acc = rows[name]["paired"]["accuracy"]
        log.info("%s: accuracy %.3f (%+.1f points, %+.1f to %+.1f)", name, rows[name]["accuracy"], 100 * acc["diff"],
                 100 * acc["low"], 100 * acc["high"])
    kshot = kshot_curves(base, feats, y, sessions, [k for k in ks if k > 0], draws, recipe, threshold, seed, sampling)
    unlabelled = unlabelled_curves(base, feats, y, fold, list(ns), draws, recipes, threshold, seed)
    result = made(AdaptBenchFile, {
        "models": [str(m) for m in models], "real": str(real), "photos": len(paths), "folds": folds, "seed": seed,
        "recipe": asdict(recipe), "true_share": float(y.mean()), "labels": y.tolist(), "groups": groups,
        "biased": biased, "sessions": sessions, "paths": [str(p) for p in paths], "rows": rows, "kshot": kshot,
        "unlabelled": unlabelled,
        "draws": draws, "seconds": time.perf_counter() - start})
    out.mkdir(parents=True, exist_ok=True)
    result.write(out / "adapt.json")
    return result
