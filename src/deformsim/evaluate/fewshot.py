"""The few-shot benchmark (``deformsim bench fewshot``): real-photo scores after adapting on k photos per class.

For each k, ``draws`` draws (a numpy Generator seeded by k and the draw) of k photos of each class from one
labelled folder; for each draw and each of ``seeds`` training seeds, a model adapts on those photos and is scored
on the remaining photos of the folder: never one of the k, nor a copy of one (photos are told apart by content:
the folder's copies count once), or with ``biased`` as a biased sample does (each class's k photos from a different
lighting, :mod:`deformsim.evaluate.draws`). Three curves, on the same draws:

- ``synthetic``: the trained model, adapted (:func:`deformsim.learn.finetune.adapt`) at the recipe's small
  learning rate, with the synthetic images of ``data`` mixed in when given; k = 0 is the model as it is.
- ``unadapted``: the trained model as it is, scored on the same photos as ``synthetic`` (what adapting adds).
- ``imagenet``: the same backbone with ImageNet weights only (a fresh ``build`` of the model's config, its
  feature BatchNorm off as nothing would estimate it), trained on the k photos alone at the training learning
  rate; k = 0 is the majority baseline. As k grows, the photos left to score grow more unbalanced: each k
  records the majority-class share of its scored photos.

Every photo's stem activations come from the feature cache; its augmented views (image-level, computed once per
photo and shared by all draws) and, with ``part="head"`` (the default), their pooled features are computed once
per model, so a run trains the head alone in about a second on a CPU. Photos are seen as the model's test-time
``crop`` shows them and scored with its ``tta_flip``, as ``evaluate`` scores them. Per k and curve: mean accuracy
and F1 over the runs with a 95 % percentile-bootstrap interval of that mean over the draws, each draw the mean of
its seeds (one run at k = 0: the interval over the photos, Wilson's and a bootstrap's). This is the only place
where real labels train anything, and only inside this cross-validation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from deformsim.atomic import write_bytes
from deformsim.errors import UserError
from deformsim.evaluate.draws import Drawing, drawing
from deformsim.evaluate.fewshot_file import CURVES, FewshotFile
from deformsim.log import get_logger
from deformsim.records import made, read_record

if TYPE_CHECKING:
    import pandas as pd

    from deformsim.config import TrainConfig
    from deformsim.learn.finetune import Recipe

log = get_logger(__name__)

KS = (0, 1, 2, 5, 10, 20)
TITLES = {"synthetic": "synthetic-pretrained, adapted", "unadapted": "synthetic-pretrained, not adapted",
          "imagenet": "ImageNet only, trained on the k photos"}
BOOTSTRAP = 2000


def parse_ks(text: str, flag: str = "--k", what: str = "photos per class", low: int = 0) -> list[int]:
    """``"0,1,2,5"`` as sorted distinct ints of at least ``low``; one line naming the bad value of ``flag`` (counts of
    ``what``) otherwise."""
    try:
        ks = sorted({int(v) for v in text.split(",") if v.strip()})
    except ValueError:
        raise UserError(f"{flag} {text!r}: expected comma-separated whole numbers, e.g. 0,1,2,5") from None
    if not ks or ks[0] < low:
        raise UserError(f"{flag} {text!r}: expected {what} of at least {low}")
    return ks


def mean_interval(values: list[float], seed: int = 0) -> tuple[float, list[float]]:
    """The mean of ``values`` and a 95 % percentile-bootstrap interval of it (seeded)."""
    a = np.asarray(values, dtype=float)
    means = a[np.random.default_rng(seed).integers(0, a.size, (BOOTSTRAP, a.size))].mean(axis=1)
    return float(a.mean()), [float(v) for v in np.percentile(means, [2.5, 97.5])]


def unique_photos(real: Path):
    """The folder's photos, one per content (a copy could otherwise land on both sides of a draw)."""
    from deformsim.dataset.real import real_table
    from deformsim.identity import file_digest

    table = real_table(real)
    table["digest"] = [file_digest(p) for p in table["path"]]
    unique = table.drop_duplicates("digest").reset_index(drop=True)
    if len(unique) < len(table):
        log.warning("%s: photos that copy others count once (%d copies)", real, len(table) - len(unique))
    return unique


def _summary(runs: list[dict], ks: list[int], curve: str, y: np.ndarray, seed: int) -> list[dict]:
    """Per k: the runs' mean accuracy and F1 with their 95 % intervals, resampling the draws (each the mean of its
    seeds; the seeds with a single draw, the photos with a single run), and the majority-class share of the photos
    scored (the draw leaves the rest as unbalanced as the folder, or more)."""
    rows = []
    for k in ks:
        mine = [r for r in runs if r["curve"] == curve and r["k"] == k]
        if not mine:
            continue
        by_draw: dict[int, list[dict]] = {}
        for r in mine:
            by_draw.setdefault(r["draw"], []).append(r)
        left = np.array([(y == 0).sum(), (y == 1).sum()]) - k
        over = "photos" if len(mine) == 1 else "draws" if len(by_draw) > 1 else "seeds"
        row = {"k": k, "runs": len(mine), "interval": over, "majority": float(left.max() / left.sum())}
        for key in ("accuracy", "f1"):
            if over == "photos":
                row[key], row[f"{key}_interval"] = mine[0][key], mine[0]["interval"][key]
                continue
            units = [[r[key] for r in rs] for rs in by_draw.values()] if over == "draws" else [[r[key]] for r in mine]
            row[key], row[f"{key}_interval"] = mean_interval([float(np.mean(u)) for u in units], seed)
        rows.append(row)
    return rows


def run_fewshot(real: Path, model: Path, out: Path, ks: tuple[int, ...] = KS, draws: int = 5, seeds: int = 2,
                recipe: Recipe | None = None, curves: tuple[str, ...] = CURVES, data: Path | None = None,
                variant: str | None = None, progress: bool = True, biased: bool = False) -> FewshotFile:
    """Both curves (or those in ``curves``) on the labelled photos of ``real`` for the trained ``model``; written
    to ``out/fewshot.json`` and ``out/fewshot.png``. ``biased``: each class's k photos from a different lighting
    (:func:`deformsim.evaluate.draws.biased_draw`). Every input is checked before any work."""
    from deformsim.learn.finetune import Recipe
    from deformsim.report.figures import fewshot_png

    start = time.perf_counter()
    recipe = recipe or Recipe(part="head")
    inputs = _validate(real, model, out, ks, draws, seeds, curves, data, variant, biased)
    bench = _Bench.prepare(inputs, recipe, curves, progress)
    results = made(FewshotFile, _summarise(inputs, bench, _loop(bench, inputs)) | {"seconds": time.perf_counter() - start})
    results.write(inputs.out / "fewshot.json")
    write_bytes(inputs.out / "fewshot.png", fewshot_png(results.curves, TITLES))
    return results


@dataclass
class _Inputs:
    """What :func:`_validate` checked: the output folder, the model (its checkpoint, file and config), the photos
    (one per content) and their labels, the k values (``capped``: those asked beyond the photos), the draws and
    seeds, and the synthetic images to mix in (None: none; ``data`` and ``variant`` as given)."""

    real: Path
    out: Path
    ckpt: dict
    path: Path
    cfg: TrainConfig
    table: pd.DataFrame
    y: np.ndarray
    ks: list[int]
    capped: list[int]
    draws: int
    seeds: int
    synthetic: pd.DataFrame | None
    data: Path | None
    variant: str | None
    sampling: Drawing  # how the k photos are drawn: at random, or as a biased sample


def _validate(real: Path, model: Path, out: Path, ks: tuple[int, ...], draws: int, seeds: int,
              curves: tuple[str, ...], data: Path | None, variant: str | None, biased: bool = False) -> _Inputs:
    """Every input checked (one line naming the bad value otherwise), the model and the photos read."""
    from deformsim.learn import checkpoint
    from deformsim.learn.finetune import check_unseen
    from deformsim.learn.stage import model_renders
    from deformsim.outputs import check_apart, check_folder_target, check_outside

    bad = [c for c in curves if c not in CURVES]
    if bad or not curves:
        raise UserError(f"--curves: expected some of {', '.join(CURVES)}, got {', '.join(bad) or 'none'}")
    for name, value in (("--draws", draws), ("--seeds", seeds)):
        if not 1 <= value <= 1000:
            raise UserError(f"{name} must lie in [1, 1000], got {value}")
    out = check_folder_target(out, "--out")
    check_apart(out, "--out", {"model": model, "real photos": real, "synthetic data": data})
    check_outside(out, "--out", {"real photos": real})
    ckpt, path = checkpoint.read_checkpoint(model)
    cfg = checkpoint.saved_config(ckpt, path)
    if cfg.target != "label" or cfg.ensemble > 1 or cfg.ensemble_backbones:
        raise UserError(f"{path} is no single label classifier (train.target {cfg.target}, or an ensemble): the "
                        "few-shot benchmark needs one (train it with --set train.ensemble=1 --set "
                        "'train.ensemble_backbones=[]')")
    table = unique_photos(real)
    check_unseen(path, table["path"])
    y = table["y"].to_numpy()
    cap = int(min((y == 0).sum(), (y == 1).sum())) - 1  # at least one photo of each class left to score
    if cap < 1:
        raise UserError(f"{real} needs at least 2 photos of each class (one to adapt on, one to score)")
    ks = sorted(set(ks))
    capped = [k for k in ks if k > cap]
    ks = sorted({min(k, cap) for k in ks})
    if capped:
        log.warning("%s allows at most %d photos per class to adapt on: k %s counted as %d", real, cap,
                    ", ".join(map(str, capped)), cap)
    if variant is not None and data is None:
        raise UserError(f"--variant {variant} needs --data (the synthetic images to mix in)")
    synthetic = model_renders(data, variant, path, cfg) if data is not None else None
    sampling = drawing(y, list(table["path"]), ks, biased, real)
    return _Inputs(real, out, ckpt, path, cfg, table, y, ks, capped, draws, seeds, synthetic, data, variant, sampling)


@dataclass
class _Bench:
    """The models of the curves, on ``device``, and what they train on and score: every photo's augmented views
    through each model's frozen part (``inputs``), what is scored (the plain photo, and its mirror with
    ``tta_flip``), the part each run trains and its starting weights, the synthetic images to mix in (or None) and
    each curve's learning rate."""

    cfg: TrainConfig
    recipe: Recipe
    device: object
    models: dict
    weights: dict[str, str]
    inputs: dict
    scored: dict
    trains: dict
    starts: dict
    mix: tuple | None
    labels: object
    lrs: dict[str, float]

    @classmethod
    def prepare(cls, inputs: _Inputs, recipe: Recipe, curves: tuple[str, ...], progress: bool) -> _Bench:
        import torch

        from deformsim.learn import checkpoint
        from deformsim.learn.device import pick_device, set_threads
        from deformsim.learn.features import cached_stem
        from deformsim.learn.finetune import part_inputs
        from deformsim.learn.models import build
        from deformsim.learn.views import photo_views

        cfg, ckpt = inputs.cfg, inputs.ckpt
        set_threads()
        device = pick_device(cfg.device)
        trained, _ = checkpoint.restore(ckpt, inputs.path)
        models, weights = {}, {}
        for curve in ("synthetic", "unadapted"):
            if curve in curves:
                models[curve], weights[curve] = trained.to(device), ckpt.get("weights", "")
        if "imagenet" in curves:
            fresh, weights["imagenet"] = build(cfg.model_copy(update={"feature_norm": False}))
            models["imagenet"] = fresh.to(device)
        paths = list(inputs.table["path"])
        views = photo_views(trained, paths, cfg.image_size, recipe.views, recipe.seed, cfg.batch_size, progress, cfg.crop)
        parts = {c: part_inputs(m, views, recipe.part, cfg.batch_size) for c, m in models.items()}
        scored = {c: [x[0]] for c, x in parts.items()}  # what is scored: the plain image, and its mirror with tta_flip
        if cfg.tta_flip:
            mirrored = cached_stem(trained, paths, cfg.image_size, cfg.batch_size, progress, cfg.crop, True)
            for c, m in models.items():
                scored[c].append(part_inputs(m, mirrored, recipe.part, cfg.batch_size))
        trains = {c: m.head if recipe.part == "head" else m for c, m in models.items()}  # reset before each run
        starts = {c: {k: v.clone() for k, v in m.state_dict().items()} for c, m in trains.items()}
        mix = None
        if inputs.synthetic is not None and "synthetic" in models:
            stems = cached_stem(trained, list(inputs.synthetic["path"]), cfg.image_size, cfg.batch_size, progress)
            mix = (part_inputs(trained, stems, recipe.part, cfg.batch_size),
                   torch.tensor(inputs.synthetic["y"].to_numpy()))
        return cls(cfg, recipe, device, models, weights, parts, scored, trains, starts, mix, torch.tensor(inputs.y),
                   {"synthetic": recipe.lr, "imagenet": cfg.lr})

    def run(self, curve: str, k: int, seed: int, chosen: np.ndarray, rest: np.ndarray, y: np.ndarray) -> dict:
        """Train ``curve``'s model afresh on the photos ``chosen`` (k per class; with k = 0 or unadapted, it trains
        nothing) with training seed ``seed``; its metrics on the photos ``rest``."""
        import torch

        from deformsim.learn.finetune import Recipe, adapt

        net = self.models[curve]
        self.trains[curve].load_state_dict(self.starts[curve])
        if k and curve != "unadapted":
            r = self.recipe
            recipe = Recipe(part=r.part, steps=r.steps, lr=self.lrs[curve], batch_size=r.batch_size, views=r.views,
                            seed=seed)
            if curve == "imagenet":
                _reset_head(net, seed)
            rows = torch.as_tensor(chosen, dtype=torch.long)
            adapt(net, self.inputs[curve][:, rows], self.labels[rows], recipe, self.mix if curve == "synthetic" else None)
        return self.score(curve, rest, y)

    def score(self, curve: str, rows: np.ndarray, y: np.ndarray) -> dict:
        """The metrics of ``curve``'s model on the photos ``rows`` (their probabilities averaged over what is
        scored: with ``tta_flip``, the photo and its mirror)."""
        import torch

        from deformsim.evaluate.metrics import compute_metrics
        from deformsim.learn.finetune import part_logits

        net, pick = self.models[curve].eval(), torch.as_tensor(rows, dtype=torch.long)
        with torch.no_grad():
            prob = torch.stack([torch.cat([torch.sigmoid(part_logits(net, b.to(self.device), self.recipe.part)).cpu()
                                           for b in x[pick].split(self.cfg.batch_size)])
                                for x in self.scored[curve]]).mean(0)
        return compute_metrics(y[rows], prob.double().numpy(), self.cfg.threshold)


def _loop(bench: _Bench, inputs: _Inputs) -> list[dict]:
    """Every run: per k, ``draws`` draws of k photos per class (one draw, and only the synthetic curve, at k = 0);
    per draw, each curve ``seeds`` times (the unadapted model once: it draws nothing)."""
    table, y, draws = inputs.table, inputs.y, inputs.draws
    repeats = {c: inputs.seeds if c != "unadapted" else 1 for c in bench.models}
    total = sum(draws * sum(repeats.values()) if k else int("synthetic" in bench.models) for k in inputs.ks)
    runs: list[dict] = []
    for k in inputs.ks:
        for d in range(draws if k else 1):
            chosen, rest = inputs.sampling.rows(k, d, np.random.default_rng([k, d]))
            for curve, s in _runs_of_draw(k, bench.models, repeats):
                m = bench.run(curve, k, s, chosen, rest, y)
                runs.append({"curve": curve, "k": k, "draw": d, "seed": s, "adapted_on": list(table["id"].iloc[chosen]),
                             "n_test": int(len(rest)), "accuracy": m["accuracy"], "f1": m["f1"],
                             "interval": m["interval"]})
                log.info("run %d/%d: %s, k %d, draw %d, seed %d: accuracy %.3f, F1 %.3f on %d photos",
                         len(runs), total, curve, k, d, s, m["accuracy"], m["f1"], len(rest))
    return runs


def _runs_of_draw(k: int, models: dict, repeats: dict[str, int]) -> list[tuple[str, int]]:
    """(curve, training seed) of each run on one draw: every curve ``repeats`` times; at k = 0, where nothing is
    adapted, the synthetic curve once."""
    if not k:
        return [("synthetic", 0)] if "synthetic" in models else []
    return [(c, s) for c in models for s in range(repeats[c])]


def _summarise(inputs: _Inputs, bench: _Bench, runs: list[dict]) -> dict:
    """What ``fewshot.json`` records (all but ``seconds``): the inputs, settings, per-curve summaries and runs."""
    y, recipe = inputs.y, bench.recipe
    share = float(y.mean())
    return {
        "kind": "fewshot",
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "real_dir": str(Path(inputs.real).resolve()), "model": str(inputs.path), "backbone": inputs.cfg.backbone,
        "weights": bench.weights,
        "photos": {"intact": int((y == 0).sum()), "deformed": int((y == 1).sum())},
        "majority_baseline": max(share, 1 - share),
        "ks": inputs.ks, "capped": inputs.capped, "draws": inputs.draws, "seeds": inputs.seeds,
        "biased": inputs.sampling.biased,
        "recipe": {"part": recipe.part, "steps": recipe.steps, "batch_size": recipe.batch_size,
                   "views": recipe.views, "lr": bench.lrs},
        "data": None if inputs.data is None else str(inputs.data), "variant": inputs.variant,
        "curves": {c: rows for c in bench.models if (rows := _summary(runs, inputs.ks, c, y, 0))},  # --k 0: no imagenet
        "runs": runs,
    }


def _reset_head(net, seed: int) -> None:
    """A new head, initialised from torch's RNG seeded by ``seed`` (the caller's RNG left as it was)."""
    import torch

    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        for layer in net.head.modules():
            if hasattr(layer, "reset_parameters"):
                layer.reset_parameters()


def read_results(path: str | Path) -> FewshotFile:
    """The ``fewshot.json`` at ``path`` (given as ``--fewshot``); one line naming the file and its first bad value
    when it is none."""
    return read_record(path, FewshotFile, f"--fewshot {path}")
