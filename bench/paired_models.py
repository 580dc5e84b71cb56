"""Two sets of models, one per render draw each (NEW and --baseline OLD, in the same draw order), paired on the same
real photos: each metric's mean difference with its 95 % bootstrap interval over the draws and the photos.

    python bench/paired_models.py runs/tins/n0 runs/tins/n1 --baseline runs/tins/m0 runs/tins/m1 \\
        --real ../shared/data/real_tins_dev

The equal-accuracy check of a change that alters renders or training: render (or train) each draw both ways, then
pair the models here. Labels are read only to score.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from _util import run_main


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("new", nargs="+", type=Path, help="model folders, one per render draw")
    ap.add_argument("--baseline", nargs="+", type=Path, required=True, help="the models they replace, same order")
    ap.add_argument("--real", type=Path, required=True, help="labelled real photos (intact/ and deformed/)")
    args = ap.parse_args()
    import numpy as np

    from deformsim.dataset.real import real_table
    from deformsim.errors import UserError
    from deformsim.evaluate.metrics import compute_metrics
    from deformsim.evaluate.paired import METRICS, paired_differences
    from deformsim.learn.predict import load

    if len(args.new) != len(args.baseline):
        raise UserError(f"--baseline needs one model per NEW model ({len(args.new)}), got {len(args.baseline)}")
    photos = real_table(args.real)
    paths, y = list(photos["path"]), photos["y"].to_numpy()
    predictors = {"new": [load(m, progress=False) for m in args.new],
                  "baseline": [load(m, progress=False) for m in args.baseline]}
    threshold = predictors["new"][0].cfg.threshold
    probs = {k: np.stack([p.predict_proba(paths) for p in ps]) for k, ps in predictors.items()}
    print(f"{len(args.new)} draws, {len(y)} photos of {args.real}")
    for k, prob in probs.items():
        acc = [compute_metrics(y, p, threshold)["accuracy"] for p in prob]
        print(f"{k}: accuracy {np.mean(acc):.3f} ± {np.std(acc):.3f} ({', '.join(f'{a:.3f}' for a in acc)})")
    diffs = paired_differences(probs["new"], probs["baseline"], y, threshold, np.random.default_rng(0))
    for metric in METRICS:
        d = diffs[metric]
        mark = " (beyond the noise)" if d.clears else ""
        print(f"{metric}: {100 * d.diff:+.1f} points ({100 * d.low:+.1f} to {100 * d.high:+.1f}){mark}")


if __name__ == "__main__":
    run_main(main)
