"""`deformsim run`: generate -> composite -> train/evaluate -> report, skipping stages that are up to date.

Each stage's settings and inputs are hashed, inputs by their contents (the mesh file's bytes, the parsed spec,
the HDRI, background and real photos), never by their paths or times; a stage whose outputs exist and whose
hash matches the one recorded in ``OUT/stages.json`` is skipped. The dataset folder is named after the hash of
the settings and input contents that determine the renders, so changing only training settings reuses the
renders, growing ``n`` resumes, and an edited mesh or spec renders a new dataset. The report is built beside
the old one and replaces it whole.

:func:`train_model` and :func:`make_report` put a model or a report into a folder the same way for the
command line and the Python API: refused when the folder holds one made with other settings or inputs (unless
``overwrite``), built beside it and swapped in whole.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

from deformsim.atomic import write_json
from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.generate.stage import data_identity, prepare
from deformsim.identity import digest, files_digest, folder_digest
from deformsim.log import get_logger
from deformsim.outputs import check_folder_target, claim, replacing
from deformsim.spec.model import load_spec

log = get_logger(__name__)

__all__ = ["RunResult", "Stages", "digest", "folder_digest", "make_report", "run", "train_model"]


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
        try:
            self.stamps = json.loads(self.path.read_text())
        except (OSError, ValueError):  # none yet, or unreadable: every stage is redone
            self.stamps = {}

    def fresh(self, name: str, stamp: str, output: Path) -> bool:
        return self.stamps.get(name) == stamp and output.exists()

    def done(self, name: str, stamp: str) -> None:
        self.stamps[name] = stamp
        write_json(self.path, self.stamps)


def run(cfg: Config, out: Path, real: Path | None = None, progress: bool = True, overwrite: bool = False) -> RunResult:
    """Run every stage for ``cfg`` into ``out``; returns where things are and what each stage took.

    ``overwrite``: a dataset folder that cannot be resumed (it holds more samples than ``generate.n``) is
    rendered again from scratch instead of refused.
    """
    from deformsim.composite.stage import composite
    from deformsim.dataset.images import images_in
    from deformsim.generate.stage import generate

    out = check_folder_target(out, "--out")
    spec = load_spec(cfg.object.spec)
    identity = data_identity(cfg, spec)
    data = out / f"data-{digest(identity)}"
    prepared = prepare(cfg, data, overwrite, spec)  # every input check before any work
    real_id = real_digest(real)
    backgrounds = cfg.composite.backgrounds
    if backgrounds is not None and not Path(backgrounds).is_dir():
        raise UserError(f"backgrounds folder not found: {backgrounds}")
    photos_id = files_digest(images_in(Path(backgrounds)), backgrounds) if backgrounds is not None else None
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

    gen_stamp = digest([identity, cfg.generate.n])
    stage("generate", gen_stamp, data / "manifest.parquet",
          lambda: generate(cfg, data, progress=progress, prepared=prepared, overwrite=overwrite))

    variants = [v if v != "backgrounds" or cfg.composite.backgrounds else "procedural" for v in cfg.composite.variants]
    composited = [v for v in variants if v not in ("black", "green")]
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
    return result


def real_digest(real: Path | None) -> str | None:
    """A folder of labelled real photos by content and place (the folder gives the label); None without one."""
    from deformsim.dataset.real import real_table

    return files_digest(list(real_table(real)["path"]), real) if real is not None else None


def images_digest(table, root: Path) -> str:
    """A training table's images by content, names (relative to ``root``) and labels."""
    return digest([files_digest(list(table["path"]), root), [int(y) for y in table["y"]]])


def train_model(table, cfg, out: Path, data: Path, variant: str | None = None, overwrite: bool = False,
                progress: bool = True, **fit_args):
    """:func:`deformsim.learn.train.fit` on ``table`` (from ``data``, its ``variant``) into the folder ``out``.

    Refused with one line when ``out`` is a file, holds files but no model, or holds a model trained with other
    settings or images (unless ``overwrite``); the model is built beside ``out`` and swapped in whole. Returns
    fit's result with ``model_path`` in ``out``.
    """
    import dataclasses

    from deformsim.dataset.tables import check_table
    from deformsim.learn.checkpoint import MODEL_FILE
    from deformsim.learn.train import fit

    out = check_folder_target(out, "--out")
    check_table(table)
    identity = {"settings": cfg.model_dump(mode="json"),
                "inputs": {"variant": variant, "images": images_digest(table, data)}}
    claim(out, "model", identity, overwrite)
    with replacing(out, identity, "model") as tmp:
        result = fit(table, cfg, tmp, progress=progress, **fit_args)
    return dataclasses.replace(result, model_path=out / MODEL_FILE)


def make_report(data: Path, cfg, out: Path, real: Path | None = None, overwrite: bool = False,
                progress: bool = True) -> Path:
    """The paper's Table II on dataset ``data`` with training settings ``cfg``, as ``out/report.html``.

    Refused with one line when ``out`` is a file, holds files but no report, or holds a report made with other
    settings or inputs (unless ``overwrite``); built beside ``out`` and swapped in whole, so no model or plot
    of an older report is left. Returns the path of report.html.
    """
    from deformsim.dataset.layout import Layout
    from deformsim.dataset.manifest import read_manifest
    from deformsim.dataset.variants import VARIANT_MANIFEST
    from deformsim.evaluate.experiments import run_experiments
    from deformsim.report.html import write_report

    out = check_folder_target(out, "--out")
    read_manifest(data)  # a clear error when ``data`` is not a dataset
    layout = Layout(data)
    manifests = [layout.manifest, *sorted((layout.root / "variants").glob(f"*/{VARIANT_MANIFEST}"))]
    real_id = real_digest(real)
    identity = {"settings": cfg.model_dump(mode="json"), "inputs": {"data": files_digest(manifests, data),
                                                                    "real": real_id}}
    claim(out, "report", identity, overwrite)
    with replacing(out, identity, "report") as tmp:
        metrics = run_experiments(data, cfg, tmp, real_dir=real, progress=progress)
        write_report(metrics, tmp)
    return out / "report.html"
