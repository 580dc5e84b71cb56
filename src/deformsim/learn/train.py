"""Training: Adam on the trainable tail and head, BCE-with-logits, an 80/20 split grouped by rendered object.

With ``train.feature_norm`` the pooled-feature statistics are set exactly from the training images at the end;
``adapt`` (a folder of unlabelled real photos) then adapts them (:mod:`deformsim.learn.adapt`).

With ``cache_features`` (and neither ``augment`` nor ``random_conv``) every epoch trains on the cached stem activations of the
images (:mod:`deformsim.learn.features`); otherwise each batch goes through the whole network.

``train.target`` other than ``label`` trains a head on the dense labels instead (:mod:`deformsim.learn.targets`).

``train.ensemble`` K > 1 trains K members one after the other on the same cached stem, member k with seed
``seed + k`` (its own training/validation split, initialisation, batch order, dropout): a bagged ensemble whose
members each miss a different fifth of the images. The history is their mean per epoch; the ensemble's validation
scores are out of bag (each image by the members that held it out).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import torch
from torch import nn

from deformsim.config import TrainConfig
from deformsim.dataset.tables import check_table, split
from deformsim.errors import UserError
from deformsim.learn import checkpoint
from deformsim.learn.data import ImageSet, training_transform
from deformsim.learn.device import adam, pick_device, set_threads, step_autocast, step_bfloat16
from deformsim.learn.features import cached_stem, fill, pass_size
from deformsim.learn.models import LOGIT_EPS, DeformNet, build, members
from deformsim.learn.train_file import TrainFile
from deformsim.log import get_logger, progress_bar
from deformsim.records import made

log = get_logger(__name__)
STALL_MARGIN = 0.02  # training accuracy within this of the majority class's share: the model learned nothing


@dataclass
class TrainResult:
    model_path: Path
    history: list[dict]  # per epoch: epoch, loss, acc (train), val_loss, val_acc (None without a val split), seconds
    # (other targets: score and val_score instead of acc and val_acc, and the score's name as metric)
    weights: str  # where the ImageNet weights came from; several backbones' joined by " + "
    seconds: float
    held_out: dict | None  # label models: ids and P(deformed) of the images training held out
    record: TrainFile  # what train.json holds


class _Inputs:
    """Stem activations for rows of the table: from the cache, or images through the frozen stem."""

    def __init__(self, model: DeformNet, paths: list[str], cfg: TrainConfig, device: torch.device, progress: bool):
        self.model, self.device = model, device
        self.feats = None
        self.per_pass = pass_size(model, cfg.image_size, cfg.batch_size)
        self.plain = ImageSet(paths, cfg.image_size)
        transform = training_transform(cfg.augment, cfg.random_conv, cfg.image_size)
        self.augmented = ImageSet(paths, cfg.image_size, transform) if transform else self.plain
        if cfg.cache_features and transform is None:
            self.feats = cached_stem(model, paths, cfg.image_size, cfg.batch_size, progress).to(device)

    def all(self, rows: torch.Tensor, batch_size: int) -> torch.Tensor:
        """Plain (not augmented) stem activations of ``rows``."""
        return torch.cat([self(b, train=False) for b in rows.split(batch_size)])

    def __call__(self, rows: torch.Tensor, train: bool) -> torch.Tensor:
        if self.feats is not None:
            return self.feats[rows]
        images = self.augmented if train else self.plain
        with torch.no_grad():  # in passes that fit the memory budget
            return torch.cat([self.model.stem(torch.stack([images[int(i)] for i in part]).to(self.device))
                              for part in rows.split(self.per_pass)])


def _evaluate(model: DeformNet, inputs: _Inputs, rows: torch.Tensor, y: torch.Tensor,
              cfg: TrainConfig) -> tuple[float | None, float | None]:
    if len(rows) == 0:
        return None, None
    model.eval()
    with torch.no_grad():
        logits = torch.cat([model.tail(inputs(b, train=False)) for b in rows.split(cfg.batch_size)])
    return _scores(logits, y[rows.to(y.device)], cfg.threshold)


def _scores(logits: torch.Tensor, target: torch.Tensor, threshold: float) -> tuple[float, float]:
    """BCE loss and accuracy of ``logits`` against ``target``."""
    loss = nn.functional.binary_cross_entropy_with_logits(logits, target).item()
    acc = ((torch.sigmoid(logits) >= threshold).float() == target).float().mean().item()
    return loss, acc


def _held_out(nets: list[DeformNet], inputs: _Inputs, val_rows: list[torch.Tensor], y: torch.Tensor,
              cfg: TrainConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """The rows some member held out of its training, and each one's P(deformed): the mean of the members that held
    it out (one model: its validation split; an ensemble: out of bag, as :class:`Ensemble` predicts)."""
    total, count = torch.zeros(len(y), device=y.device), torch.zeros(len(y), device=y.device)
    with torch.no_grad():
        for net, rows in zip(nets, val_rows):
            if len(rows):
                net.eval()
                total[rows.to(y.device)] += torch.cat([torch.sigmoid(net.tail(inputs(b, train=False)))
                                                       for b in rows.split(cfg.batch_size)])
                count[rows.to(y.device)] += 1
    held = torch.nonzero(count).flatten()
    return held, total[held] / count[held]


def _out_of_bag(held: tuple[torch.Tensor, torch.Tensor], members: int, y: torch.Tensor, cfg: TrainConfig) -> dict:
    """An ensemble's validation scores on its ``held`` out images (:func:`_held_out`), through its clamped logit;
    images every member trained on are left out."""
    rows, prob = held
    loss, acc = (None, None) if len(rows) == 0 else _scores(torch.logit(prob, eps=LOGIT_EPS), y[rows], cfg.threshold)
    return {"members": members, "val_loss": loss, "val_acc": acc, "n_val": len(rows)}


def _class_weight(target: torch.Tensor, cfg: TrainConfig) -> torch.Tensor | None:
    """With ``train.balance``, the weight of a deformed image in the loss that makes both classes of ``target`` (the
    training images' labels) weigh the same: intact images over deformed ones; None otherwise."""
    deformed = float(target.sum())
    if not cfg.balance or deformed == 0 or deformed == len(target):
        return None
    return torch.tensor((len(target) - deformed) / deformed, device=target.device)


def _step(model: DeformNet, opt, z: torch.Tensor, target: torch.Tensor, cfg: TrainConfig,
          pos_weight: torch.Tensor | None = None) -> tuple[float, int]:
    """One optimiser step (deformed images weighted by ``pos_weight``); returns the summed loss and the number of
    correct predictions."""
    with step_autocast(cfg.precision, z.device):
        logits = model.tail(z).float()
    loss = nn.functional.binary_cross_entropy_with_logits(logits, target, pos_weight=pos_weight)
    opt.zero_grad()
    loss.backward()
    opt.step()
    return loss.item() * len(z), int(((torch.sigmoid(logits) >= cfg.threshold).float() == target).sum())


def _adapt_paths(cfg: TrainConfig, adapt: Path | None) -> list[str]:
    """The unlabelled photos to adapt to (any folder, searched recursively); checked before training."""
    if adapt is None:
        return []
    from deformsim.dataset.real import expand_images

    if not cfg.feature_norm:
        raise UserError("--adapt needs train.feature_norm: true (the statistics it re-estimates)")
    if not Path(adapt).is_dir():
        raise UserError(f"--adapt folder not found: {adapt}")
    return [str(p) for p in expand_images([adapt])]


def _adapt(model: DeformNet, opt, inputs: _Inputs, train_rows: torch.Tensor, y: torch.Tensor, cfg: TrainConfig,
           paths: list[str], device: torch.device, progress: bool) -> dict:
    from deformsim.learn.adapt import pseudo_labels, set_feature_stats

    target = cached_stem(model, paths, cfg.image_size, cfg.batch_size, progress).to(device)
    set_feature_stats(model, target, cfg.batch_size)
    info = {"images": len(paths), "method": cfg.adapt_method}
    if cfg.adapt_method == "selftrain":
        rows, labels = pseudo_labels(model, target, cfg)
        info["pseudo_labels"] = {"deformed": int(labels.sum()), "intact": int(len(labels) - labels.sum())}
        if len(rows) == 0:
            log.warning("self-training: no photo was classified surely enough; AdaBN only")
        order = torch.Generator().manual_seed(cfg.seed + 1)
        for _ in range(cfg.adapt_epochs if len(rows) else 0):
            model.train()
            # one domain per batch, so the feature BatchNorm normalises each domain by its own statistics
            syn = train_rows[torch.randperm(len(train_rows), generator=order)].split(cfg.batch_size)
            real = torch.randperm(len(rows), generator=order).split(cfg.batch_size)
            for s_batch, r_batch in zip(syn, real * (len(syn) // max(1, len(real)) + 1)):
                if len(s_batch) > 1:
                    _step(model, opt, inputs(s_batch, train=True), y[s_batch.to(device)], cfg)
                if len(r_batch) > 1:
                    _step(model, opt, target[rows[r_batch]], labels[r_batch], cfg)
        set_feature_stats(model, target, cfg.batch_size)
    return info


def _optimiser(model: DeformNet, cfg: TrainConfig) -> torch.optim.Adam:
    return adam([p for p in model.parameters() if p.requires_grad], cfg.lr)


def _fit_label(model: DeformNet, opt, inputs: _Inputs, train_rows: torch.Tensor, val_rows: torch.Tensor,
               y: torch.Tensor, cfg: TrainConfig, device: torch.device, progress: bool) -> list[dict]:
    order = torch.Generator().manual_seed(cfg.seed)
    schedule = torch.optim.lr_scheduler.CosineAnnealingLR(opt, cfg.epochs) if cfg.schedule == "cosine" else None
    torch.manual_seed(cfg.seed)  # dropout and augmentation draw from here; a cache miss must not shift them
    pos_weight = _class_weight(y[train_rows.to(y.device)], cfg)
    history = []
    with progress_bar(cfg.epochs, "epochs", progress) as bar:
        for epoch in range(1, cfg.epochs + 1):
            t0 = time.perf_counter()
            model.train()
            total, correct = 0.0, 0
            for batch in train_rows[torch.randperm(len(train_rows), generator=order)].split(cfg.batch_size):
                if cfg.feature_norm and len(batch) < 2:
                    continue  # batch statistics need two images
                loss, right = _step(model, opt, inputs(batch, train=True), y[batch.to(device)], cfg, pos_weight)
                total += loss
                correct += right
            if schedule is not None:
                schedule.step()
            val_loss, val_acc = _evaluate(model, inputs, val_rows, y, cfg)
            row = {"epoch": epoch, "loss": total / len(train_rows), "acc": correct / len(train_rows),
                   "val_loss": val_loss, "val_acc": val_acc, "seconds": time.perf_counter() - t0}
            history.append(row)
            bar.update()
            log.debug("epoch %d/%d: loss %.3f, accuracy %.3f, validation accuracy %s", epoch, cfg.epochs, row["loss"],
                      row["acc"], "-" if val_acc is None else f"{val_acc:.3f}")
    return history


def _mean_history(histories: list[list[dict]]) -> list[dict]:
    """Per epoch, the mean of the members' rows (one member: its own rows)."""
    if len(histories) == 1:
        return histories[0]
    rows = []
    for epoch_rows in zip(*histories):
        row = dict(epoch_rows[0])
        for key in ("loss", "acc", "val_loss", "val_acc"):
            values = [r[key] for r in epoch_rows]
            row[key] = None if None in values else sum(values) / len(values)
        row["seconds"] = sum(r["seconds"] for r in epoch_rows)
        rows.append(row)
    return rows


def _log_summary(history: list[dict], cfg: TrainConfig, n_train: int, n_val: int, seconds: float) -> None:
    """One info line per training: the last epoch's loss and score on the training and the validation images."""
    last = history[-1]
    metric = last.get("metric", "accuracy")
    score, val = (last["acc"], last["val_acc"]) if cfg.target == "label" else (last["score"], last["val_score"])
    checked = f", validation {metric} {val:.3f} ({n_val} images)" if val is not None and n_val else ""
    steps = ""
    if cfg.target == "label":
        steps = " (bfloat16)" if step_bfloat16(cfg.precision, pick_device(cfg.device)) else " (float32)"
    log.info("trained %d epoch%s%s on %d images in %.1f s: loss %.3f, %s %.3f%s", len(history),
             "" if len(history) == 1 else "s", steps, n_train, seconds, last["loss"], metric, score, checked)


def stalled(history: list[dict], y: torch.Tensor, cfg: TrainConfig) -> str | None:
    """A warning when a label model's last epoch (``history``) scored its training images (labels ``y``) no better
    than calling them all the majority class (within :data:`STALL_MARGIN`): the optimiser never left the start, or
    left it and died; None otherwise."""
    share = float(y.float().mean())
    majority, acc = max(share, 1 - share), history[-1]["acc"]
    if acc > majority + STALL_MARGIN:
        return None
    epochs = f"{len(history)} epoch{'' if len(history) == 1 else 's'}"
    return (f"training did not learn: after {epochs} the model scores its training images "
            f"{acc:.3f}, no better than calling them all one class ({majority:.3f}), and its loss is "
            f"{history[-1]['loss']:.3f}; lower train.lr (now {cfg.lr:g}; a whole block, train.finetune last_block, "
            "learns at about 0.0001)")


@dataclass
class _Trained:
    """One backbone's trained model and what its training says."""

    model: DeformNet
    cfg: TrainConfig
    weights: str
    history: list[dict]
    splits: list[tuple[torch.Tensor, torch.Tensor]]
    adapted: dict | None
    ensemble: dict | None
    held: tuple[torch.Tensor, torch.Tensor] | None  # label models: rows held out of training, their P(deformed)


def fit(table: pd.DataFrame, cfg: TrainConfig, out_dir: Path, progress: bool = True,
        adapt: Path | None = None) -> TrainResult:
    """Train on ``table`` (columns id, path, y), validate on its held-out split, save ``out_dir/model.pt``.

    ``adapt``: a folder of unlabelled real photos to adapt to (needs ``train.feature_norm``; labels never read).
    Other targets than ``label`` also need the table's dense columns (:func:`deformsim.learn.targets.check_target`).
    With ``train.ensemble_backbones`` each further backbone's model trains the same way and is saved beside the first
    (``mixture``), which then predicts their mean probability; their feature caches fill from one decoding of each image.
    """
    from deformsim.learn.targets import check_target, output_names

    check_table(table)
    check_target(table, cfg)
    if adapt is not None and cfg.target != "label":
        raise UserError(f"--adapt applies to train.target label, not {cfg.target}")
    adapt_paths = _adapt_paths(cfg, adapt)
    start = time.perf_counter()
    set_threads()
    table = table.reset_index(drop=True)
    outputs = output_names(table, cfg.target)
    cfgs = [cfg] + [cfg.model_copy(update={"backbone": b, "ensemble_backbones": []}) for b in cfg.ensemble_backbones]
    built = [build(c, outputs=len(outputs)) for c in cfgs]
    if len(cfgs) > 1 and cfg.cache_features and training_transform(cfg.augment, cfg.random_conv, cfg.image_size) is None:
        for model, _ in built:  # every backbone's stem reads each image decoded once
            model.to(pick_device(cfg.device))
        fill([m for m, _ in built], list(table["path"]) + adapt_paths, cfg.image_size, cfg.batch_size, progress)
    trained = []
    for c, model in zip(cfgs, built):
        if len(cfgs) > 1:
            log.info("backbone %s (%d of %d)", c.backbone, len(trained) + 1, len(cfgs))
        t0 = time.perf_counter()
        trained.append(_train(table, c, model, progress, adapt, adapt_paths))
        train_rows, val_rows = trained[-1].splits[0]
        _log_summary(trained[-1].history, c, len(train_rows), len(val_rows), time.perf_counter() - t0)
    first = trained[0]
    out_dir = Path(out_dir)
    model_path = out_dir / checkpoint.MODEL_FILE
    seconds = time.perf_counter() - start
    train_rows, val_rows = first.splits[0]
    held_out = mixed = None
    if first.held is not None:  # every backbone trained on the same splits, so held out the same rows
        rows = first.held[0].cpu().numpy()
        prob = torch.stack([t.held[1] for t in trained]).mean(0).cpu()
        held_out = {"ids": table["id"].iloc[rows].tolist(), "p_deformed": prob.tolist()}
        if len(trained) > 1 and len(rows):
            y = torch.tensor(table["y"].to_numpy(dtype="float32"))[rows]
            mixed = {"backbones": len(trained), "val_acc": float(((prob >= cfg.threshold).float() == y).float().mean()),
                     "n_val": len(rows)}
            log.info("%d backbones together: validation accuracy %.3f (%d images)", len(trained), mixed["val_acc"],
                     len(rows))
    ids = [{"train": table["id"].iloc[t.numpy()].tolist(), "val": table["id"].iloc[v.numpy()].tolist()}
           for t, v in first.splits]
    split_ids = ids[0] | ({"members": ids} if len(ids) > 1 else {})
    mixture = [(t.model, t.cfg, t.weights) for t in trained[1:]]
    checkpoint.save(model_path, first.model, cfg, first.weights, first.history, split_ids,
                    None if cfg.target == "label" else outputs, mixture=mixture)
    info = {"weights": first.weights, "seconds": seconds, "history": first.history, "n_train": len(train_rows),
            "n_val": len(val_rows), "adapted": first.adapted, "ensemble": first.ensemble, "held_out": held_out,
            "config": cfg.model_dump(mode="json")}
    if mixture:
        info["mixture"] = [{"backbone": t.cfg.backbone, "weights": t.weights, "history": t.history,
                            "adapted": t.adapted, "ensemble": t.ensemble} for t in trained[1:]]
        info["mixture_validation"] = mixed
    record = made(TrainFile, info)
    record.write(out_dir / "train.json")
    return TrainResult(model_path, first.history, " + ".join(t.weights for t in trained), seconds, held_out, record)


def _train(table: pd.DataFrame, cfg: TrainConfig, built: tuple[DeformNet, str], progress: bool, adapt: Path | None,
           adapt_paths: list[str]) -> _Trained:
    """Train ``cfg.backbone``'s model (its ``train.ensemble`` members; :func:`build`'s model and weights) on ``table``."""
    from deformsim.learn.targets import fit_head

    device = pick_device(cfg.device)
    model, weights = built
    model.to(device)
    y = torch.tensor(table["y"].to_numpy(dtype="float32"), device=device)
    inputs = _Inputs(model, list(table["path"]), cfg, device, progress)
    nets = members(model)
    opts = [_optimiser(net, cfg) for net in nets]
    seeded = [cfg.model_copy(update={"seed": cfg.seed + k}) for k in range(len(nets))]
    splits = [tuple(torch.as_tensor(r, dtype=torch.long) for r in split(table, cfg.split, c.seed)) for c in seeded]
    train_rows, val_rows = splits[0]
    if cfg.target == "label":
        histories = [_fit_label(net, opt, inputs, t, v, y, c, device, progress)
                     for net, opt, c, (t, v) in zip(nets, opts, seeded, splits)]
        for k, (h, (t, _)) in enumerate(zip(histories, splits)):
            if warning := stalled(h, y[t.to(y.device)], cfg):
                log.warning("%s%s", f"ensemble member {k + 1}: " if len(nets) > 1 else "", warning)
        history = _mean_history(histories)
    else:
        history = fit_head(model, inputs.all(torch.arange(len(table)), cfg.batch_size), table, train_rows, val_rows,
                           cfg, progress)
    adapted = None
    if cfg.feature_norm and cfg.target == "label":
        from deformsim.learn.adapt import set_feature_stats

        for net, (t, _) in zip(nets, splits):
            set_feature_stats(net, inputs.all(t, cfg.batch_size), cfg.batch_size)
    if adapt_paths:
        infos = [_adapt(net, opt, inputs, t, y, c, adapt_paths, device, progress)
                 for net, opt, c, (t, _) in zip(nets, opts, seeded, splits)]
        adapted = {"folder": str(adapt), **infos[0]}
    held = _held_out(nets, inputs, [v for _, v in splits], y, cfg) if cfg.target == "label" else None
    ensemble = None
    if len(nets) > 1 and held is not None:
        ensemble = _out_of_bag(held, len(nets), y, cfg)
        if ensemble["val_acc"] is not None and ensemble["n_val"]:  # else every image trained a member: no score
            log.info("ensemble of %d: out-of-bag accuracy %.3f on %d images", len(nets), ensemble["val_acc"],
                     ensemble["n_val"])
    return _Trained(model, cfg, weights, history, splits, adapted, ensemble, held)
