"""`deformsim run`: generate -> composite -> train/evaluate -> report, skipping stages that are up to date.

Each stage's settings and inputs are hashed; a stage whose outputs exist and whose hash matches the one
recorded in ``OUT/stages.json`` is skipped. The dataset folder is named after the hash of the settings that
determine the renders, so changing only training settings reuses the renders, and growing ``n`` resumes.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from deformsim.atomic import write_json
from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.generate.stage import data_settings, prepare
from deformsim.log import get_logger

log = get_logger(__name__)


def digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:12]


def folder_digest(folder: Path) -> str:
    """Identity of a folder of files: names, sizes and modification times."""
    entries = sorted((str(p.relative_to(folder)), p.stat().st_size, int(p.stat().st_mtime))
                     for p in folder.rglob("*") if p.is_file())
    return digest(entries)


@dataclass
class RunResult:
    out: Path
    data: Path
    report: Path | None
    seconds: dict[str, float] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)


class Stages:
    """The stamps of finished stages, kept in ``OUT/stages.json``."""

    def __init__(self, out: Path):
        self.path = out / "stages.json"
        self.stamps = json.loads(self.path.read_text()) if self.path.is_file() else {}

    def fresh(self, name: str, stamp: str, output: Path) -> bool:
        return self.stamps.get(name) == stamp and output.exists()

    def done(self, name: str, stamp: str) -> None:
        self.stamps[name] = stamp
        write_json(self.path, self.stamps)


def run(cfg: Config, out: Path, real: Path | None = None, progress: bool = True) -> RunResult:
    """Run every stage for ``cfg`` into ``out``; returns where things are and what each stage took."""
    from deformsim.composite.stage import composite
    from deformsim.dataset.real import real_table
    from deformsim.evaluate.experiments import run_experiments
    from deformsim.generate.stage import generate
    from deformsim.report.html import write_report

    out = Path(out)
    data = out / f"data-{digest(data_settings(cfg))}"
    prepared = prepare(cfg, data)  # every input check before any work
    if real is not None:
        real_table(real)
    if cfg.composite.backgrounds is not None and not Path(cfg.composite.backgrounds).is_dir():
        raise UserError(f"backgrounds folder not found: {cfg.composite.backgrounds}")
    out.mkdir(parents=True, exist_ok=True)
    stages = Stages(out)
    result = RunResult(out=out, data=data, report=out / "report" / "report.html")

    def stage(name: str, stamp: str, output: Path, work) -> None:
        if stages.fresh(name, stamp, output):
            result.skipped.append(name)
            log.info("stage %s is up to date: skipped", name)
            return
        t0 = time.perf_counter()
        work()
        result.seconds[name] = time.perf_counter() - t0
        stages.done(name, stamp)

    gen_stamp = digest([data_settings(cfg), cfg.generate.n])
    stage("generate", gen_stamp, data / "manifest.parquet", lambda: generate(cfg, data, progress=progress, prepared=prepared))

    variants = [v if v != "backgrounds" or cfg.composite.backgrounds else "procedural" for v in cfg.composite.variants]
    composited = [v for v in variants if v not in ("black", "green")]
    comp_stamps = {}
    for name in composited:
        # "procedural" always uses the built-in backgrounds; any other name the photo folder, when given
        comp_cfg = cfg.composite.model_copy(update={"backgrounds": None}) if name == "procedural" else cfg.composite
        comp_stamp = digest([gen_stamp, comp_cfg.model_dump(mode="json"), name])
        comp_stamps[name] = comp_stamp
        stage(f"composite:{name}", comp_stamp, data / "variants" / name / "manifest.parquet",
              lambda name=name, c=comp_cfg: composite(data, c, name, cfg.generate.seed, progress=progress))

    train_cfg = cfg.train.model_copy(update={"variants": variants})
    report_stamp = digest([gen_stamp, comp_stamps, train_cfg.model_dump(mode="json"),
                           folder_digest(real) if real else None])

    def report() -> None:
        metrics = run_experiments(data, train_cfg, out / "report", real_dir=real, progress=progress)
        write_report(metrics, out / "report")

    stage("report", report_stamp, result.report, report)
    return result
