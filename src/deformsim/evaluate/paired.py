"""What the sim-to-real benchmark adds to its runs: the ensemble of each draw's training seeds, the photos most often
judged wrong, and the paired difference to a baseline benchmark on the same photos.

Two benchmarks are compared run by run: a run of one pairs with the run of the other with the same variant and
data, background and training seeds (when the baseline trained on other variants, runs pair by seeds alone).
Per metric the difference is the mean over pairs of (run - baseline run) on the same photos; its 95 % interval
is the percentile bootstrap that resamples the photos and the pairs, both with replacement, so it holds the
spread of the photos and of the seeds. A row beats the baseline in a metric when its interval excludes zero.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from deformsim.errors import UserError
from deformsim.evaluate.metrics import resample_blocks, roc_auc
from deformsim.evaluate.results import Comparison, Difference, Ensemble, ResultsFile, Run

METRICS = ("accuracy", "f1", "precision", "recall", "auc")
BOOTSTRAP = 2000


def scores(prob: np.ndarray, y: np.ndarray, threshold: float) -> dict[str, np.ndarray]:
    """Per row of ``prob`` (runs x photos): accuracy, F1, precision, recall (a 0/0 ratio is 0, as in
    :func:`deformsim.evaluate.metrics.compute_metrics`) and the area under the ROC curve (NaN without both classes)."""
    pred = prob >= threshold
    pos = y.astype(bool)
    tp, fp = (pred & pos).sum(-1), (pred & ~pos).sum(-1)
    fn = (~pred & pos).sum(-1)

    def ratio(num, den):
        return np.where(den > 0, num / np.maximum(den, 1), 0.0)

    return {"accuracy": (pred == pos).mean(-1), "f1": ratio(2 * tp, 2 * tp + fp + fn),
            "precision": ratio(tp, tp + fp), "recall": ratio(tp, tp + fn), "auc": roc_auc(prob, pos)}


def _draw(run: Run) -> tuple:
    return run.data_seed, run.composite_seed


def run_key(run: Run) -> tuple:
    """What a run pairs by: its variant, data and background seed, and training seed."""
    return run.variant, *_draw(run), run.train_seed


def ensembles(results: ResultsFile) -> dict[str, Ensemble]:
    """Per variant: the metrics of each draw's ensemble (the mean probability over its training seeds) as mean ±
    std over the draws, with ``n_draws`` and ``members`` (training seeds per draw)."""
    y = np.asarray(results.real_labels)
    out = {}
    for variant, groups in draw_groups(results.runs).items():
        prob = np.stack([np.mean([r.real_predictions for r in runs], axis=0) for runs in groups.values()])
        s = scores(prob, y, results.threshold)
        row = {"n_draws": len(groups), "members": min(len(runs) for runs in groups.values())}
        for k in METRICS:
            row[f"{k}_mean"] = float(s[k].mean())
            row[f"{k}_std"] = float(s[k].std(ddof=1)) if len(groups) > 1 else 0.0
        out[variant] = Ensemble(**row)
    return out


def often_wrong(results: ResultsFile) -> dict[str, list[dict]]:
    """Per variant: every real photo that one of its runs judged wrong, as ``path``, ``name`` (class folder and file
    name), ``y``, ``wrong`` (how many runs did) of ``runs`` and ``prob`` (its mean P(deformed) over them); most often
    wrong first, then the furthest wrong on average."""
    y = np.asarray(results.real_labels, dtype=bool)
    out = {}
    for variant, groups in draw_groups(results.runs).items():
        prob = np.array([r.real_predictions for runs in groups.values() for r in runs])
        wrong, mean = ((prob >= results.threshold) != y).sum(axis=0), prob.mean(axis=0)
        off = np.where(y, -mean, mean)  # the mean leaning to the wrong class
        order = sorted(np.flatnonzero(wrong), key=lambda i: (-wrong[i], -off[i]))
        paths = [results.real_paths[i] for i in order]
        out[variant] = [{"path": p, "name": _name(p), "y": int(y[i]), "wrong": int(wrong[i]), "runs": len(prob),
                         "prob": float(mean[i])} for p, i in zip(paths, order)]
    return out


def draw_groups(runs: list[Run]) -> dict[str, dict[tuple, list[Run]]]:
    """``runs`` by variant, then by draw (data and background seed)."""
    out: dict[str, dict[tuple, list[Run]]] = {}
    for r in runs:
        out.setdefault(r.variant, {}).setdefault(_draw(r), []).append(r)
    return out


def _name(path: str) -> str:
    """A scored photo by class folder and file name."""
    return f"{Path(path).parent.name}/{Path(path).name}"


def _photos(paths: list[str], labels: list[int]) -> list[tuple[str, int]]:
    """The scored photos by class folder and file name, with their labels."""
    return [(_name(p), int(y)) for p, y in zip(paths, labels)]


def check_same_photos(paths: list[str], labels: list[int], baseline: ResultsFile) -> None:
    """One line unless the photos ``paths`` with ``labels`` are those ``baseline`` was scored on (class folder, file
    name, label, order)."""
    if _photos(paths, labels) != _photos(baseline.real_paths, baseline.real_labels):
        raise UserError("the baseline was scored on other photos (or labels) than these results: compare runs on the "
                        "same --real folder")


def _pairs(results: ResultsFile, baseline: ResultsFile, variant: str) -> list[tuple[Run, Run]]:
    same_variant = baseline.of(variant)
    pool = same_variant or baseline.runs
    key = run_key if same_variant else (lambda r: (*_draw(r), r.train_seed))
    base = {key(b): b for b in pool}
    return [(r, base[key(r)]) for r in results.of(variant) if key(r) in base]


def paired_differences(new: np.ndarray, base: np.ndarray, y: np.ndarray, threshold: float,
                       rng: np.random.Generator) -> dict[str, Difference]:
    """Observed mean difference per metric and its bootstrap interval over photos and pairs (rows of new/base); the
    resamples are scored in blocks of bounded size (:func:`~deformsim.evaluate.metrics.resample_blocks`)."""
    observed = {k: float((scores(new, y, threshold)[k] - scores(base, y, threshold)[k]).mean()) for k in METRICS}
    boot: dict[str, list] = {k: [] for k in METRICS}
    n_pairs, n_photos = new.shape
    for block in resample_blocks(BOOTSTRAP, n_pairs * n_photos):
        draws = [(rng.integers(0, n_pairs, n_pairs) if n_pairs > 1 else np.zeros(1, dtype=int),
                  rng.integers(0, n_photos, n_photos)) for _ in range(block)]
        rows, cols = np.stack([r for r, _ in draws])[:, :, None], np.stack([c for _, c in draws])
        labels = y[cols][:, None, :]
        s_new, s_base = scores(new[rows, cols[:, None, :]], labels, threshold), scores(base[rows, cols[:, None, :]],
                                                                                       labels, threshold)
        for k in METRICS:
            boot[k].append((s_new[k] - s_base[k]).mean(-1))
    out = {}
    for k in METRICS:
        lo, hi = np.nanpercentile(np.concatenate(boot[k]), [2.5, 97.5])  # NaN: a resample of the photos that lacks a class
        out[k] = Difference(diff=observed[k], low=float(lo), high=float(hi), clears=bool(lo > 0 or hi < 0))
    return out


def compare(results: ResultsFile, baseline: ResultsFile, seed: int = 0) -> dict[str, Comparison]:
    """Per variant of ``results``: its paired differences to ``baseline`` (:func:`paired_differences` per metric): run against
    run (``runs``), each draw's ensemble against the baseline's (``ensemble``), and each draw's ensemble against the
    baseline's single runs of that draw (``ensemble_vs_single``; against itself: what ensembling adds). One line when
    the two were not scored on the same photos or no run pairs."""
    check_same_photos(results.real_paths, results.real_labels, baseline)
    y, threshold = np.asarray(results.real_labels), results.threshold
    rng = np.random.default_rng(seed)
    out = {}
    for variant in dict.fromkeys(r.variant for r in results.runs):
        pairs = _pairs(results, baseline, variant)
        if not pairs:
            raise UserError(f"no run of variant {variant} has a baseline run with the same data, background and "
                            "training seeds")
        new = np.array([r.real_predictions for r, _ in pairs])
        base = np.array([b.real_predictions for _, b in pairs])
        draws = sorted({_draw(r) for r, _ in pairs})
        ens_new = np.array([new[[_draw(r) == d for r, _ in pairs]].mean(0) for d in draws])
        ens_base = np.array([base[[_draw(r) == d for r, _ in pairs]].mean(0) for d in draws])
        ens_each = np.array([ens_new[draws.index(_draw(r))] for r, _ in pairs])
        out[variant] = Comparison(pairs=len(pairs), baseline_variant=pairs[0][1].variant,
                                  runs=paired_differences(new, base, y, threshold, rng),
                                  ensemble=paired_differences(ens_new, ens_base, y, threshold, rng),
                                  ensemble_vs_single=paired_differences(ens_each, base, y, threshold, rng))
    return out
