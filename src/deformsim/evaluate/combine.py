"""Sim-to-real benchmarks combined after the fact, on the same photos: ``merge`` pools the runs of several (other
render draws, so a comparison pairs over all of them), ``mean`` scores each run's mean prediction with its paired runs
in the others (an ensemble of models trained apart, such as two backbones on the same renders), and ``bag`` scores
blocks of one benchmark's consecutive training seeds as one run each (the models ``train.ensemble`` trains).

Runs pair as :mod:`deformsim.evaluate.paired` pairs them: by variant, data and background seed and training seed. The
real metrics of a ``mean`` run are those of its mean probabilities; its synthetic figures are its members' mean (their
held-out renders' predictions are not kept). Both keep the first benchmark's settings (the threshold they score at);
the report's plan names every input.
"""

from __future__ import annotations

from datetime import datetime, timezone

import numpy as np
from pydantic import ValidationError

from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.evaluate.benchmark import aggregate, run_record
from deformsim.evaluate.paired import check_same_photos, draw_groups, ensembles, run_key
from deformsim.evaluate.results import ResultsFile, Run
from deformsim.identity import settings
from deformsim.outputs import differences
from deformsim.records import made
from deformsim.schema import clip, shown


def _named(key: tuple) -> str:
    variant, data, background, train = key
    return f"variant {variant}, data seed {data}, background seed {background}, training seed {train}"


def _checked(inputs: list[ResultsFile], sources: list[str]) -> None:
    """One line unless there are two or more benchmarks, all on the first's photos at its threshold."""
    if len(inputs) < 2:
        raise UserError("give two or more benchmark results to combine")
    for results, source in zip(inputs[1:], sources[1:]):
        try:
            check_same_photos(results.real_paths, results.real_labels, inputs[0])
        except UserError:
            raise UserError(f"{source} was scored on other photos (or labels) than {sources[0]}: combine benchmarks "
                            "of the same --real folder") from None
        if results.threshold != inputs[0].threshold:
            raise UserError(f"{source} scores at threshold {results.threshold:g}, {sources[0]} at "
                            f"{inputs[0].threshold:g}: combine benchmarks of the same train.threshold")


def _results(inputs: list[ResultsFile], runs: list[Run], sources: list[str], how: str) -> ResultsFile:
    """Results as the benchmark writes them, with the first input's photos and settings; the time is all inputs'."""
    first = inputs[0]
    out = made(ResultsFile, {
        "real_dir": first.real_dir, "real_images": first.real_images, "real_paths": first.real_paths,
        "real_labels": first.real_labels, "majority_baseline": first.majority_baseline,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "plan": {how: sources, "whole": first.plan.whole},
        "adapt": None, "settings": first.settings, "variants": aggregate(runs), "runs": runs,
        "seconds": float(sum(results.seconds for results in inputs))})
    out.ensembles = ensembles(out)
    return out


def _config(results: ResultsFile, source: str) -> dict:
    """What a benchmark's runs were made with, less the seeds that tell draws apart; paths count as set or not, their
    files by content (:func:`deformsim.identity.settings`); ``whole``: whether its models trained on every render."""
    try:
        cfg = Config.model_validate(results.config())
    except ValidationError as exc:
        raise UserError(f"{source}: its settings are no config of this version ({clip(str(exc).splitlines()[1], 80)})"
                        ) from None
    data = settings(cfg)
    data["generate"].pop("seed", None)
    composite = cfg.composite.model_dump(mode="json") | {"backgrounds": cfg.composite.backgrounds is not None}
    return {**data, "composite": composite, "train": cfg.train.model_dump(mode="json", exclude={"seed"}),
            "whole": results.plan.whole}


def merge(inputs: list[ResultsFile], sources: list[str]) -> ResultsFile:
    """The runs of every benchmark in ``inputs`` (named by ``sources``) as one benchmark's results; one line when two
    were made with other settings (but for their seeds) or hold the same run (they would count twice)."""
    _checked(inputs, sources)
    first = _config(inputs[0], sources[0])
    for results, source in zip(inputs[1:], sources[1:]):
        if diffs := differences(first, _config(results, source)):
            key, in_first, in_source = diffs[0]
            raise UserError(f"{source} was made with other settings than {sources[0]} ({key}: {shown(in_source, 40)} "
                            f"against {shown(in_first, 40)}): merge the draws of one config (it may differ in "
                            "generate.seed and train.seed only)")
    seen: dict[tuple, str] = {}
    for results, source in zip(inputs, sources):
        for run in results.runs:
            if (key := run_key(run)) in seen:
                raise UserError(f"{seen[key]} and {source} both hold the run of {_named(key)}: merge benchmarks of "
                                "other render draws (generate.seed)")
            seen[key] = source
    return _results(inputs, [r for results in inputs for r in results.runs], sources, "merged")


def mean(inputs: list[ResultsFile], sources: list[str]) -> ResultsFile:
    """Each run of the first benchmark that every other one pairs with, scored on its and its pairs' mean
    probabilities; one line when no run pairs across all of them."""
    _checked(inputs, sources)
    y, threshold = np.asarray(inputs[0].real_labels), inputs[0].threshold
    by_key = [{run_key(r): r for r in results.runs} for results in inputs]
    runs = []
    for key in by_key[0]:
        if not all(key in other for other in by_key[1:]):
            continue
        members = [found[key] for found in by_key]
        prob = np.mean([member.real_predictions for member in members], axis=0)
        runs.append(run_record(key, [member.model for member in members], y, prob, threshold, _synthetic(members)))
    if not runs:
        raise UserError(f"no run of {sources[0]} has a run with the same variant and seeds in every other benchmark")
    return _results(inputs, runs, sources, "mean of")


def bag(results: ResultsFile, members: int, source: str) -> ResultsFile:
    """Each draw's runs of training seeds s, s+1, ..., s+members-1 (s its first seed, then every ``members``-th) as
    one run of seed s, scored on their mean probabilities: with ``--whole`` the model ``train.ensemble: members``
    trains with ``train.seed`` s. Seeds of no complete block are left out; one line when no draw has one."""
    if not 2 <= members <= 16:
        raise UserError(f"--members must lie in [2, 16], got {members}")
    y, threshold = np.asarray(results.real_labels), results.threshold
    runs = []
    for variant, draws in draw_groups(results.runs).items():
        for draw, group in draws.items():
            by_seed = {r.train_seed: r for r in group}
            for start in range(min(by_seed), max(by_seed) + 1, members):
                block = [by_seed.get(start + k) for k in range(members)]
                if None in block:
                    continue
                prob = np.mean([r.real_predictions for r in block], axis=0)
                runs.append(run_record((variant, *draw, start), [r.model for r in block], y, prob, threshold,
                                       _synthetic(block)))
    if not runs:
        raise UserError(f"{source} has no draw with {members} consecutive training seeds: run it with --train-seeds "
                        f"{members} or more")
    out = _results([results], runs, [source], "bagged")
    out.plan.members = members
    for ensemble in out.ensembles.values():  # a draw's ensemble of its blocks is that of their seeds
        ensemble.members *= members
    return out


def _synthetic(runs: list[Run]) -> dict[str, float]:
    """The held-out accuracy and F1 of combined ``runs``: their members' mean."""
    return {k: float(np.mean([getattr(r.synthetic, k) for r in runs])) for k in ("accuracy", "f1")}
