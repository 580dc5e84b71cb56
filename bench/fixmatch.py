"""FixMatch/FreeMatch self-training on unlabelled photos (:mod:`deformsim.learn.fixmatch`) against the unadapted model
and the default adapter (``deformsim adapt``'s probe), inductive: the photos split into 2 folds by content, each
fold scored by the model adapted on the other, the same folds for both methods; paired over models and photos.

    python bench/fixmatch.py runs/cans/m0 runs/cans/m1 --data runs/cans/d0 runs/cans/d1 \\
        --real ../shared/data/real_cans_dev

Each model self-trains with renders of the dataset it was trained on (``--data``, same order; ``--variant``,
default backgrounds). Labels of ``--real`` are read only to score.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict
from pathlib import Path

from _util import positive_int, run_main


def adapted_probs(model: Path, data: Path, variant: str, train: list[str], test: list[str], recipe):
    """P(deformed) of ``test`` by ``model`` self-trained on the photos ``train``."""
    from deformsim.learn import checkpoint
    from deformsim.learn.fixmatch import self_trained
    from deformsim.learn.predict import Predictor
    from deformsim.learn.stage import model_renders

    ckpt, path = checkpoint.read_checkpoint(model)
    renders = model_renders(data, variant, path, checkpoint.saved_config(ckpt, path))
    return Predictor(self_trained(ckpt, path, train, renders, recipe), path, False).predict_outputs(test)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("models", nargs="+", type=Path, help="trained model folders, one per render draw")
    ap.add_argument("--data", nargs="+", type=Path, required=True, help="each model's training dataset, same order")
    ap.add_argument("--variant", default="backgrounds", help="the datasets' variant the models trained on")
    ap.add_argument("--real", type=Path, required=True, help="labelled real photos (intact/ and deformed/)")
    ap.add_argument("--steps", type=positive_int, default=200, help="self-training steps per network")
    ap.add_argument("--weight", type=float, default=1.0, help="the photos' loss beside the renders'")
    ap.add_argument("--method", default="fixmatch", help="fixmatch, adamatch, mcc or cdan (deformsim.learn.fixmatch)")
    ap.add_argument("--out", type=Path, help="write the figures as JSON here")
    args = ap.parse_args()
    import numpy as np

    from deformsim.errors import UserError
    from deformsim.evaluate.adaptation import adapted_probabilities, content_folds
    from deformsim.evaluate.fewshot import unique_photos
    from deformsim.evaluate.paired import METRICS, paired_differences
    from deformsim.learn.adapter import AdaptRecipe
    from deformsim.learn.fixmatch import MatchRecipe
    from deformsim.learn.predict import load

    if len(args.models) != len(args.data):
        raise UserError(f"--data needs one dataset per model ({len(args.models)}), got {len(args.data)}")
    recipe = MatchRecipe(steps=args.steps, weight=args.weight, method=args.method)
    photos = unique_photos(args.real).sort_values("digest")  # bench adapt's photos, order and folds
    paths, y = list(photos["path"]), photos["y"].to_numpy()
    fold = content_folds(len(paths), 2, 0)
    probs = {"unadapted": [], "probe": [], args.method: []}
    report = {"recipe": asdict(recipe), "models": [str(m) for m in args.models], "real": str(args.real)}
    start = time.perf_counter()
    for model, data in zip(args.models, args.data):
        predictor = load(model, progress=False)
        p0, features = predictor.outputs_and_features(paths, True)
        probe, match = adapted_probabilities(p0, features, fold, AdaptRecipe(), "inductive")[0], np.empty(len(y))
        for f in (0, 1):
            test, train = fold == f, fold != f
            match[test] = adapted_probs(model, data, args.variant, [paths[i] for i in np.flatnonzero(train)],
                                        [paths[i] for i in np.flatnonzero(test)], recipe)
        for name, p in (("unadapted", p0), ("probe", probe), (args.method, match)):
            probs[name].append(p)
        print(f"{model}: done at {time.perf_counter() - start:.0f} s", flush=True)
    threshold = predictor.cfg.threshold
    base = np.stack(probs["unadapted"])
    report["rows"] = {}
    for name, ps in probs.items():
        acc = [float(((p >= threshold) == (y == 1)).mean()) for p in ps]
        row = {"accuracy": float(np.mean(acc)), "accuracy_std": float(np.std(acc)), "each": acc}
        line = f"{name}: accuracy {np.mean(acc):.3f} ± {np.std(acc):.3f}"
        if name != "unadapted":
            diffs = paired_differences(np.stack(ps), base, y, threshold, np.random.default_rng(0))
            row["paired"] = {m: [diffs[m].diff, diffs[m].low, diffs[m].high] for m in METRICS}
            d = diffs["accuracy"]
            line += f", against unadapted {100 * d.diff:+.1f} ({100 * d.low:+.1f} to {100 * d.high:+.1f})"
        report["rows"][name] = row
        print(line, flush=True)
    if args.out:
        args.out.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    run_main(main)
