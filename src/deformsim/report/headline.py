"""A report's headline test, and its model: the one a user of the report is meant to use.

The headline is the real-photo test with the best accuracy, else the held-out synthetic test with the best accuracy;
its model is the one that test scored."""

from __future__ import annotations

from pathlib import Path

from deformsim.errors import UserError
from deformsim.evaluate.metrics_file import Experiment, MetricsFile, read_metrics

RUN_MODEL = "model"  # the folder of a run (deformsim run) that holds the model it is meant to be used with


def headline(metrics: MetricsFile) -> tuple[str, str, Experiment] | None:
    """(variant, part, test) of the report's headline test; None when no test ran."""
    ran = metrics.results()
    for want in ("real", "split"):
        cands = [r for r in ran if r[1] == want]
        if cands:
            return max(cands, key=lambda r: r[2].metrics.accuracy)
    return None


def link_model(model: Path, out: Path) -> Path:
    """Make ``out`` hold the files of the model folder ``model``, hard-linked where the file system allows (no
    second copy on disk), copied otherwise; a folder in ``out`` before is replaced whole. Returns ``out``."""
    import shutil

    from deformsim.outputs import replacing

    with replacing(out) as staging:
        shutil.copytree(model, staging, copy_function=_link, dirs_exist_ok=True)
    return out


def _link(src: str, dst: str) -> None:
    import os
    import shutil

    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def headline_model(report: str | Path) -> Path | None:
    """The model folder of the headline test of the report folder ``report``; None when ``report`` holds no readable
    report or that model is gone."""
    try:
        head = headline(read_metrics(Path(report) / "metrics.json"))
    except UserError:
        return None
    if head is None:
        return None
    model = Path(report) / head[2].model  # the model file, or (an older report) its folder
    model = model.parent if model.name == "model.pt" else model
    return model if (model / "model.pt").is_file() else None
