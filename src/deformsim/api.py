"""The pipeline as a Python API: one :class:`Engine` holds a config and runs each stage on paths.

    from deformsim import Engine

    engine = Engine("quick", {"generate.n": 16, "render.resolution": 64})
    engine.generate("out/data")
    engine.composite("out/data", backgrounds="photos/")
    model = engine.train("out/data", "out/model", variant="backgrounds").model_path
    print(engine.evaluate(model, real="real_photos/")["metrics"]["accuracy"])

Every method checks its inputs before any work and raises :class:`deformsim.errors.UserError` with one
line naming the problem. The CLI is a thin layer over this class. Heavy modules (torch, Blender workers)
load only when a method needs them.
"""

from __future__ import annotations

from pathlib import Path

from deformsim.config import Config, apply_overrides, load_config, validate_config


class Engine:
    """One config (a :class:`Config`, a YAML path or a preset name, plus dotted overrides) and the stages."""

    def __init__(self, config: Config | str | Path | None = None, overrides: dict | None = None, progress: bool = False):
        if isinstance(config, Config):
            self.config = validate_config(apply_overrides(config.model_dump(mode="json"), overrides), "Engine config")
        else:
            self.config = load_config(config, overrides)
        self.progress = progress

    def generate(self, out: str | Path, overwrite: bool = False):
        """Render the dataset into ``out`` (resuming what is there); a :class:`GenerateResult`.

        A dataset of other settings or inputs in ``out`` is refused unless ``overwrite`` (then replaced whole).
        """
        from deformsim.generate.stage import generate

        return generate(self.config, Path(out), progress=self.progress, overwrite=overwrite)

    def bake(self, force: bool = False) -> Path:
        """Simulate the spec's ``simulation:`` scenarios into the cached bank (reused when cached; ``force``
        simulates again); the bank folder. ``generate`` bakes on first use when ``deform.sources`` uses it."""
        from deformsim.bank.stage import bake
        from deformsim.generate.stage import check_part
        from deformsim.spec.model import load_spec

        spec = load_spec(self.config.object.spec)
        check_part(spec, self.config.object.mesh)
        return bake(spec, self.config.object.spec, self.config.object.mesh, progress=self.progress, force=force)

    def composite(self, data: str | Path, name: str | None = None, seed: int = 0,
                  backgrounds: str | Path | None = None) -> Path:
        """Put every image of ``data`` on background photos (or procedural ones); the variant folder."""
        from deformsim.composite.stage import composite

        cfg = self.config.composite
        if backgrounds is not None:
            cfg = cfg.model_copy(update={"backgrounds": Path(backgrounds)})
        return composite(Path(data), cfg, name, seed, progress=self.progress)

    def export_data(self, data: str | Path, out: str | Path, format: str, variant: str | None = None,
                    overwrite: bool = False):
        """Export a variant of ``data`` as ``imagefolder``, ``coco`` or ``anomalib`` into ``out``; an ExportResult."""
        from deformsim.export import export_data

        return export_data(Path(data), Path(out), format, variant, overwrite=overwrite, progress=self.progress)

    def train(self, data: str | Path, out: str | Path, variant: str | None = None, adapt: str | Path | None = None,
              overwrite: bool = False):
        """Train on a dataset variant or a folder of intact/ and deformed/ photos; a :class:`TrainResult`.

        ``adapt``: a folder of unlabelled photos of real parts to adapt to (needs ``train.feature_norm``). A model
        of other settings in ``out`` is refused unless ``overwrite``.
        """
        from deformsim.dataset.tables import load_table
        from deformsim.pipeline import train_model

        table = load_table(Path(data), variant, self.config.train.variants[0])
        return train_model(table, self.config.train, Path(out), Path(data), variant or self.config.train.variants[0],
                           overwrite=overwrite,
                           progress=self.progress, adapt=Path(adapt) if adapt is not None else None)

    def evaluate(self, model: str | Path, data: str | Path | None = None, variant: str | None = None,
                 real: str | Path | None = None, threshold: float | None = None) -> dict:
        """Metrics and predictions of a trained model on a dataset variant or on real photos."""
        from deformsim.evaluate.experiments import evaluate_model

        return evaluate_model(model, data, variant, real, threshold)

    def report(self, data: str | Path, out: str | Path | None = None, real: str | Path | None = None,
               overwrite: bool = False) -> Path:
        """Train and test every variant (the paper's Table II), write the HTML report; its path."""
        from deformsim.pipeline import make_report

        out = Path(out) if out is not None else Path(data) / "report"
        return make_report(Path(data), self.config.train, out, real=Path(real) if real is not None else None,
                           overwrite=overwrite, progress=self.progress)

    def run(self, out: str | Path, real: str | Path | None = None, overwrite: bool = False):
        """Every stage into ``out``, skipping those already up to date; a :class:`RunResult`."""
        from deformsim.pipeline import run

        return run(self.config, Path(out), real=Path(real) if real is not None else None, progress=self.progress,
                   overwrite=overwrite)
