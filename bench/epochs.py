"""How many epochs the default model needs: held-out renders and real photos after every epoch, paired over draws.

    python bench/epochs.py DATA [DATA ...] --real PHOTOS --out DIR [--variant backgrounds] [--baseline EVAL.json ...]

Each DATA (a generated dataset, one render draw) trains the quick preset's model once (``--set`` overrides it) into
``DIR/m<i>``, as ``deformsim train DATA --variant VARIANT`` does. After every epoch of every member, the member's
P(deformed) of every training image and of every photo is kept, so one training gives the model of every epoch
count E (with a constant learning rate the first E epochs of a longer training are a training of E epochs). Per E:
the held-out accuracy on the renders (each image by the members that held it out, both backbones averaged, as
``train.json``'s ``mixture_validation``) and the accuracy on the photos, with the paired difference to the full
``train.epochs`` on the same photos and draws (95 % bootstrap interval over photos and draws,
:mod:`deformsim.evaluate.paired`). ``--baseline`` (``deformsim evaluate MODEL --real PHOTOS --out EVAL.json`` of
another model per draw, in the order of DATA) adds the full training's paired difference to those models.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from _util import run_main

METRICS = ("accuracy", "f1", "precision", "recall")


def _train(data: Path, variant: str, cfg, photos: list[str], out: Path) -> dict:
    """Train into ``out``; per backbone, per member, per epoch: the P(deformed) of every image and photo."""
    import torch

    from deformsim.dataset.tables import load_table
    from deformsim.learn import train
    from deformsim.learn.features import cached_stem

    table = load_table(data, variant, cfg.variants[0], cfg.min_region)
    record: dict = {}
    evaluate = train._evaluate

    def recorded(model, inputs, rows, y, c):
        result = evaluate(model, inputs, rows, y, c)  # leaves the model in eval mode
        with torch.no_grad():
            renders = torch.sigmoid(model.tail(inputs.all(torch.arange(len(y)), c.batch_size)))
            real = torch.sigmoid(model.tail(cached_stem(model, photos, c.image_size, c.batch_size).to(y.device)))
        members = record.setdefault(model.backbone, [])
        if not members or len(members[-1]["epochs"]) == c.epochs:
            members.append({"val_rows": rows.tolist(), "epochs": []})
        members[-1]["epochs"].append({"renders": renders.tolist(), "real": real.tolist()})
        return result

    train._evaluate = recorded
    try:
        train.fit(table, cfg, out, progress=False)
    finally:
        train._evaluate = evaluate
    return {"y": table["y"].tolist(), "backbones": record}


def _per_epoch(run: dict, epochs: int):
    """Per epoch count: (held-out accuracy on the renders, P(deformed) of every photo)."""
    import numpy as np

    y = np.asarray(run["y"])
    out = []
    for e in range(epochs):
        held, real = [], []
        for members in run["backbones"].values():
            total, count = np.zeros(len(y)), np.zeros(len(y))
            for m in members:
                total[m["val_rows"]] += np.asarray(m["epochs"][e]["renders"])[m["val_rows"]]
                count[m["val_rows"]] += 1
            held.append(np.where(count > 0, total / np.maximum(count, 1), np.nan))
            real.append(np.mean([m["epochs"][e]["real"] for m in members], axis=0))
        p = np.mean(held, axis=0)
        seen = ~np.isnan(p)
        out.append((float(((p[seen] >= 0.5) == y[seen]).mean()), np.mean(real, axis=0)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", nargs="+", type=Path)
    ap.add_argument("--real", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--variant", default="backgrounds")
    ap.add_argument("--baseline", nargs="*", type=Path, default=[])
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    import numpy as np

    from deformsim.cli.common import parse_sets
    from deformsim.config import load_config
    from deformsim.dataset.real import real_table
    from deformsim.errors import UserError
    from deformsim.evaluate.paired import paired_differences

    if args.baseline and len(args.baseline) != len(args.data):
        raise UserError(f"--baseline needs one evaluation per DATA ({len(args.data)}), got {len(args.baseline)}")
    cfg = load_config("quick", parse_sets(args.sets)).train
    photos = real_table(args.real)
    paths, y = list(photos["path"]), photos["y"].to_numpy()
    runs = []
    for i, data in enumerate(args.data):
        cache = args.out / f"epochs-{i}.json"
        if not cache.is_file():
            args.out.mkdir(parents=True, exist_ok=True)
            cache.write_text(json.dumps(_train(data, args.variant, cfg, paths, args.out / f"m{i}")))
        runs.append(_per_epoch(json.loads(cache.read_text()), cfg.epochs))
    full = np.stack([r[-1][1] for r in runs])
    base = None
    if args.baseline:
        evals = [json.loads(b.read_text())["predictions"] for b in args.baseline]
        if any([str(Path(p["path"]).resolve()) for p in e] != paths for e in evals):
            raise UserError("a --baseline was evaluated on other photos than --real (deformsim evaluate --real PHOTOS)")
        base = np.stack([[p["prob"] for p in e] for e in evals])
    rng = np.random.default_rng(0)
    print(f"{len(runs)} draws, {len(y)} photos; differences in points, paired on the same photos and draws")
    print(f"| epochs | held-out renders | real accuracy | accuracy - {cfg.epochs} epochs | F1 - {cfg.epochs} epochs |"
          + (" accuracy - baseline | F1 - baseline |" if base is not None else ""))
    print("|---|---|---|---|---|" + ("---|---|" if base is not None else ""))
    for e in range(cfg.epochs):
        prob = np.stack([r[e][1] for r in runs])
        d = paired_differences(prob, full, y, cfg.threshold, rng)
        acc = float(((prob >= cfg.threshold) == y).mean())
        held = np.mean([r[e][0] for r in runs])
        row = f"| {e + 1} | {held:.3f} | {acc:.3f} | {_shown(d['accuracy'])} | {_shown(d['f1'])} |"
        if base is not None:
            b = paired_differences(prob, base, y, cfg.threshold, rng)
            row += f" {_shown(b['accuracy'])} | {_shown(b['f1'])} |"
        print(row)
    if base is not None:
        d = paired_differences(full, base, y, cfg.threshold, rng)
        print(f"{cfg.epochs} epochs against --baseline: " + ", ".join(f"{k} {_shown(d[k])}" for k in METRICS))


def _shown(d) -> str:
    return f"{100 * d.diff:+.1f} ({100 * d.low:+.1f} to {100 * d.high:+.1f})"


if __name__ == "__main__":
    run_main(main)
