"""`deformsim run`: generate -> composite -> train/evaluate -> report, skipping stages that are up to date.

Each stage's settings and inputs are hashed, inputs by their contents (the mesh file's bytes, the parsed spec,
the HDRI, background and real photos), never by their paths or times; a stage whose outputs exist and whose
hash matches the one recorded in ``OUT/stages.json`` is skipped. The dataset folder is named after the hash of
the settings and input contents that determine the renders, so changing only training settings reuses the
renders, growing ``n`` resumes, and an edited mesh or spec renders a new dataset. The report is built beside
the old one and replaces it whole; the model of its headline test is hard-linked into ``OUT/model``, the one to
use (``deformsim predict OUT/model PHOTOS``). ``OUT`` holds no other deformsim output, no input lies in a folder the run
replaces (the dataset, the report), and ``OUT`` does not lie in a folder of photos it reads.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from deformsim.atomic import write_json
from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.extras import require
from deformsim.generate.identity import data_identity
from deformsim.generate.stage import prepare
from deformsim.identity import digest
from deformsim.log import get_logger
from deformsim.outputs import check_apart, check_folder_target, check_outside, kinds_in, sweep
from deformsim.report.headline import RUN_MODEL, headline_model, link_model
from deformsim.report.stage import make_report, real_digest
from deformsim.spec.model import load_spec

log = get_logger(__name__)

__all__ = ["RunResult", "Stages", "run"]


@dataclass
class RunResult:
    out: Path
    data: Path
    report: Path | None
    seconds: dict[str, float] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    model: Path | None = None  # the model of the report's headline test, the one to use
    adapted: Path | None = None  # with unlabelled photos: that model adapted to them (deformsim adapt)


class Stages:
    """The stamps of finished stages, kept in ``OUT/stages.json``."""

    def __init__(self, out: Path):
        self.path = out / "stages.json"
        try:
            self.stamps = json.loads(self.path.read_text())
        except (OSError, ValueError):  # none yet, or unreadable: every stage is redone
            self.stamps = {}

    def fresh(self, name: str, stamp: str, output: Path) -> bool:
        return self.stamps.get(name) == stamp and output.exists()

    def done(self, name: str, stamp: str) -> None:
        self.stamps[name] = stamp
        write_json(self.path, self.stamps)


STAGE_TITLES = {"generate": "generate: render the dataset", "report": "report: train and test each variant",
                "adapt": "adapt: the model to the unlabelled photos"}
ADAPTED_MODEL = "model-adapted"  # OUT's model adapted to --unlabelled photos


def _report_split(seconds: float, metrics: Path) -> dict[str, float]:
    """The report stage's ``seconds`` as the time its models trained, its dense-label heads took (when it has them)
    and the rest (testing, plots, the page), by the times in its ``metrics`` file."""
    from deformsim.evaluate.metrics_file import read_metrics

    try:
        recorded = read_metrics(metrics)
    except UserError:
        return {"report": seconds}
    trained = sum(test.train_seconds for _, _, test in recorded.results())
    dense = recorded.dense.seconds if recorded.dense is not None else 0.0
    out = {"report: training": trained}
    if dense:
        out["report: dense-label heads"] = dense
    out["report: testing, plots and the page"] = max(0.0, seconds - trained - dense)
    return out


def _inputs(cfg: Config, real: Path | None) -> dict[str, Path | None]:
    """Every file and folder a run reads, by what it is."""
    return {"real photos": real, "backgrounds folder": cfg.composite.backgrounds, **cfg.input_paths()}


def run(cfg: Config, out: Path, real: Path | None = None, progress: bool = True, overwrite: bool = False,
        unlabelled: Path | None = None) -> RunResult:
    """Run every stage for ``cfg`` into ``out``; returns where things are and what each stage took.

    ``overwrite``: a dataset folder that cannot be resumed (it holds more samples than ``generate.n``) is
    rendered again from scratch instead of refused. ``unlabelled``: photos of real parts (labels never read) that
    the run's model adapts to last, into ``OUT/model-adapted`` (:mod:`deformsim.learn.adapt_stage`).
    """
    from deformsim.composite.backgrounds import photos_digest
    from deformsim.composite.stage import composite
    from deformsim.generate.stage import generate

    out = check_folder_target(out, "--out")
    require("render", "train", what="deformsim run")
    found = kinds_in(out)
    if found:
        raise UserError(f"--out {out} holds a deformsim {' and '.join(sorted(found))}, not a run: choose a new or "
                        "empty folder, or an earlier run's")
    spec = load_spec(cfg.object.spec)
    identity = data_identity(cfg, spec)
    data = out / f"data-{digest(identity)}"
    inputs = _inputs(cfg, real) | {"unlabelled photos": unlabelled}
    for replaced, what in ((data, "the run's dataset folder"), (out / "report", "the run's report folder"),
                           (out / RUN_MODEL, "the run's model folder"), (out / ADAPTED_MODEL, "the run's adapted model")):
        check_apart(replaced, what, inputs)
    check_outside(out, "--out", {"real photos": real, "backgrounds folder": cfg.composite.backgrounds,
                                 "unlabelled photos": unlabelled, **cfg.photo_folders()})
    photos = None
    if unlabelled is not None:
        from deformsim.learn.adapt_stage import unlabelled_photos

        photos = digest(unlabelled_photos(unlabelled, "--unlabelled")[1])
    prepared = prepare(cfg, data, overwrite, spec)  # every input check before any work
    real_id = real_digest(real)
    backgrounds = cfg.composite.backgrounds
    if backgrounds is not None and not Path(backgrounds).is_dir():
        raise UserError(f"backgrounds folder not found: {backgrounds}")
    photos_id = photos_digest(backgrounds)
    out.mkdir(parents=True, exist_ok=True)
    sweep(data)  # what a killed --overwrite left of it (the report's go with its replacing)
    stages = Stages(out)
    result = RunResult(out=out, data=data, report=out / "report" / "report.html")

    variants = [v if v != "backgrounds" or cfg.composite.backgrounds else "procedural" for v in cfg.composite.variants]
    composited = [v for v in variants if v not in ("black", "green")]
    names = ["generate", *(f"composite:{v}" for v in composited), "report", *(["adapt"] if unlabelled else [])]

    def stage(name: str, stamp: str, output: Path, work) -> None:
        title = STAGE_TITLES.get(name) or f"{name.replace(':', ' ')}: the renders on backgrounds"
        header = f"stage {names.index(name) + 1} of {len(names)}, {title}"
        if stages.fresh(name, stamp, output):
            result.skipped.append(name)
            log.info("%s: up to date, skipped", header)
            return
        log.info("%s", header)
        t0 = time.perf_counter()
        work()
        result.seconds[name] = time.perf_counter() - t0
        stages.done(name, stamp)

    gen_stamp = digest([identity, cfg.generate.n])
    stage("generate", gen_stamp, data / "manifest.parquet",
          lambda: generate(cfg, data, progress=progress, prepared=prepared, overwrite=overwrite))

    comp_stamps = {}
    for name in composited:
        # "procedural" always uses the built-in backgrounds; any other name the photo folder, when given
        comp_cfg = cfg.composite.model_copy(update={"backgrounds": None}) if name == "procedural" else cfg.composite
        comp_stamp = digest([gen_stamp, comp_cfg.model_dump(mode="json"), name,
                             photos_id if comp_cfg.backgrounds is not None else None])
        comp_stamps[name] = comp_stamp
        stage(f"composite:{name}", comp_stamp, data / "variants" / name / "manifest.parquet",
              lambda name=name, c=comp_cfg: composite(data, c, name, cfg.generate.seed, progress=progress))

    train_cfg = cfg.train.model_copy(update={"variants": variants})
    report_stamp = digest([gen_stamp, comp_stamps, train_cfg.model_dump(mode="json"), real_id])

    def report() -> None:  # the old report's models and plots go with it
        make_report(data, train_cfg, out / "report", real=real, overwrite=True, progress=progress)

    stage("report", report_stamp, result.report, report)
    if "report" in result.seconds:
        result.seconds.update(_report_split(result.seconds.pop("report"), out / "report" / "metrics.json"))
    model = headline_model(out / "report")
    if model is not None:
        result.model = out / RUN_MODEL
        if not stages.fresh("model", report_stamp, result.model / "model.pt"):
            link_model(model, result.model)
            stages.done("model", report_stamp)
        if unlabelled is not None:
            from deformsim.learn.adapt_stage import adapt_model

            result.adapted = out / ADAPTED_MODEL
            stage("adapt", digest([report_stamp, photos]), result.adapted / "model.pt",
                  lambda: adapt_model(result.model, unlabelled, result.adapted, overwrite=True, progress=progress))
    return result
