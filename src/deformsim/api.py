"""The pipeline as a Python API: one :class:`Engine` holds a config and runs each command on paths.

    from deformsim import Engine

    engine = Engine("quick", {"generate.n": 16, "render.resolution": 64})
    engine.generate("out/data")
    engine.composite("out/data", backgrounds="photos/")
    model = engine.train("out/data", "out/model", variant="backgrounds").model_path
    print(engine.evaluate(model, real="real_photos/").metrics.accuracy)

Every method checks its inputs before any work and raises :class:`deformsim.errors.UserError` with one
line naming the problem. Each CLI command parses its options into an Engine, calls one of its methods and
prints what it returns. Heavy modules (torch, Blender workers) load only when a method needs them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from deformsim.config import Config, apply_overrides, load_config, validate_config
from deformsim.errors import UserError
from deformsim.log import get_logger

if TYPE_CHECKING:
    from deformsim.composite.stage import Composited
    from deformsim.evaluate.benchmark import Plan
    from deformsim.evaluate.fewshot_file import FewshotFile
    from deformsim.evaluate.metrics_file import Evaluation
    from deformsim.evaluate.results import ResultsFile
    from deformsim.learn.adapter import AdaptRecipe
    from deformsim.learn.finetune import Recipe
    from deformsim.spec.model import Spec

log = get_logger(__name__)


@dataclass(frozen=True)
class SpecCheck:
    """A valid spec and, with a mesh, the mesh's size in metres and a hint when that size suggests wrong units; a
    line naming the keys too small to see at the config's render size (:mod:`deformsim.generate.visibility`)."""

    spec: Spec
    size: list[float] | None = None
    hint: str | None = None
    small: str | None = None


@dataclass(frozen=True)
class Prediction:
    """A model's output per image: columns (CSV name -> one value per image), their table headings and, for a label
    model, the P(deformed) threshold of its labels."""

    paths: list[Path]
    columns: dict[str, Sequence]
    headings: tuple[str, ...]
    threshold: float | None = None
    prior: float | None = None  # with predict --adapt: the images' estimated share of deformed parts

    def frame(self):
        """The prediction as a pandas DataFrame: a ``path`` column (bytes that are not UTF-8 as \\xNN), then the
        columns."""
        import pandas as pd

        from deformsim.atomic import printable

        return pd.DataFrame({"path": [printable(str(p)) for p in self.paths], **self.columns})


def _path(p: str | Path | None) -> Path | None:
    return Path(p) if p is not None else None


class Engine:
    """One config (a :class:`Config`, a YAML path or a preset name, plus dotted overrides) and the stages.

    ``flags`` names the command-line option behind override keys (``{"generate.n": "--n"}``) in errors about a
    config read from a file or preset; ``notify`` receives one line on what a method found in its inputs before
    its work starts (the real photos, the test set).
    """

    def __init__(self, config: Config | str | Path | None = None, overrides: dict | None = None, progress: bool = False,
                 flags: dict[str, str] | None = None, notify: Callable[[str], None] | None = None):
        if isinstance(config, Config):
            self.config = validate_config(apply_overrides(config.model_dump(mode="json"), overrides), "Engine config")
        else:
            self.config = load_config(config, overrides, flags)
        self.progress = progress
        self.notify = notify or (lambda line: None)

    def generate(self, out: str | Path, overwrite: bool = False, yes: bool = False):
        """Render the dataset into ``out`` (resuming what is there); a :class:`GenerateResult`.

        A dataset of other settings or inputs in ``out`` is refused unless ``overwrite`` (then replaced whole); more
        than ``config.CONFIRM_IMAGES`` images unless ``yes``.
        """
        from deformsim.dataset.variants import stale_variants
        from deformsim.generate.refusals import check_plan
        from deformsim.generate.stage import generate

        check_plan(self.config, yes)
        result = generate(self.config, Path(out), progress=self.progress, overwrite=overwrite)
        for name in stale_variants(out):
            log.warning("variant %s holds other images than the dataset's %d now: rerun deformsim composite to "
                        "update it", name, result.images)
        return result

    def bake(self, force: bool = False) -> Path:
        """Simulate the spec's ``simulation:`` scenarios into the cached bank (reused when cached; ``force``
        simulates again); the bank folder. ``generate`` bakes on first use when ``deform.sources`` uses it."""
        from deformsim.bank.stage import bake
        from deformsim.generate.refusals import check_part
        from deformsim.spec.model import load_spec

        spec = load_spec(self.config.object.spec)
        check_part(spec, self.config.object.mesh)
        return bake(spec, self.config.object.spec, self.config.object.mesh, progress=self.progress, force=force)

    def composite(self, data: str | Path, name: str | None = None, seed: int = 0,
                  backgrounds: str | Path | None = None) -> Composited:
        """Put every image of ``data`` on background photos (or procedural ones); the variant made (its folder and
        counts)."""
        from deformsim.composite.stage import composite

        cfg = self.config.composite
        if backgrounds is not None:
            cfg = cfg.model_copy(update={"backgrounds": Path(backgrounds)})
        return composite(Path(data), cfg, name, seed, progress=self.progress)

    def export_data(self, data: str | Path, out: str | Path, format: str, variant: str | None = None,
                    overwrite: bool = False, copy: bool = False):
        """Export a variant of ``data`` as ``imagefolder``, ``coco`` or ``anomalib`` into ``out``; an ExportResult.

        Files are hard links to the dataset's own where possible (editing one in place changes the dataset); ``copy``
        makes an independent export. ``overwrite`` replaces an earlier export, never anything else."""
        from deformsim.export import export_data

        return export_data(Path(data), Path(out), format, variant, overwrite=overwrite, progress=self.progress,
                           copy=copy)

    def train(self, data: str | Path, out: str | Path, variant: str | None = None, adapt: str | Path | None = None,
              overwrite: bool = False):
        """Train on a dataset variant (default: the first of ``train.variants``) or a folder of intact/ and
        deformed/ photos; a :class:`deformsim.learn.stage.TrainedModel`.

        ``adapt``: a folder of unlabelled photos of real parts to adapt to (needs ``train.feature_norm``). A model
        of other settings in ``out`` is refused unless ``overwrite``.
        """
        from deformsim.learn.stage import train_model

        return train_model(Path(data), self.config.train, Path(out), variant, overwrite=overwrite,
                           progress=self.progress, adapt=_path(adapt))

    def finetune(self, model: str | Path, real: str | Path, out: str | Path, data: str | Path | None = None,
                 variant: str | None = None, recipe: Recipe | None = None, overwrite: bool = False,
                 unlabelled: str | Path | None = None):
        """Adapt a trained model with labelled real photos (intact/ and deformed/), mixed with a dataset variant's
        synthetic images when ``data`` is given, then to ``unlabelled`` photos (no label read) as :meth:`adapt`
        does; a :class:`deformsim.learn.finetune.Finetuned`. The model refuses to be scored on the labelled photos
        afterwards. A model of other settings or inputs in ``out`` is refused unless ``overwrite``."""
        from deformsim.learn.finetune import Recipe, finetune

        self._check_real(real)
        return finetune(Path(model), Path(real), Path(out), recipe or Recipe(), _path(data), variant,
                        overwrite=overwrite, progress=self.progress, unlabelled=_path(unlabelled))

    def adapt(self, model: str | Path, photos: str | Path | None, out: str | Path, recipe: AdaptRecipe | None = None,
              overwrite: bool = False, labelled: str | Path | None = None, groups: str = "date",
              data: str | Path | None = None, variant: str | None = None):
        """Adapt a trained model to a folder of unlabelled photos of real parts (no label read), to ``labelled``
        ones (``intact/`` + ``deformed/``, shooting sessions by ``groups``: ``date``, ``none`` or a CSV file), or
        both; a :class:`deformsim.learn.adapt_stage.Adapted`. The methods that train the networks (``fixmatch``,
        ``adamatch``, ``mcc``, ``cdan``) mix in the renders of ``data`` (its ``variant``). A model of other settings
        or inputs in ``out`` is refused unless ``overwrite``."""
        from deformsim.learn.adapt_stage import adapt_model
        from deformsim.learn.adapter import AdaptRecipe

        return adapt_model(Path(model), _path(photos), Path(out), recipe or AdaptRecipe(), overwrite=overwrite,
                           progress=self.progress, labelled=_path(labelled), groups=groups, data=_path(data),
                           variant=variant)

    def predict(self, model: str | Path, images: Sequence[str | Path], csv: str | Path | None = None,
                threshold: float | None = None, adapt: AdaptRecipe | None = None) -> Prediction:
        """P(deformed) and the label of each image (files, or folders searched recursively) at ``threshold``
        (default: the model's own), or what a model of another ``train.target`` predicts; also written to ``csv``
        (columns path, then the prediction's). ``model``: model.pt, its folder, or an exported ``.onnx`` file (read
        with onnxruntime alone, no torch).

        ``adapt``: first adapt the model, in memory, to the images themselves (no label read; at least 8 distinct
        photos, :mod:`deformsim.learn.adapt_stage`); the prediction's ``prior`` is their estimated share of
        deformed parts."""
        from deformsim.atomic import atomic_path
        from deformsim.dataset.real import expand_images
        from deformsim.outputs import check_file_target

        paths = expand_images(list(images))
        if csv is not None:
            check_file_target(csv, "--csv", [model, *paths])
        if threshold is not None and not 0 < threshold < 1:
            raise UserError(f"--threshold must lie in (0, 1), got {threshold:g}")
        if Path(model).suffix.lower() == ".onnx":
            from deformsim.learn.onnx_predict import OnnxPredictor

            if adapt is not None:
                raise UserError("predict --adapt needs the trained model.pt, not an exported .onnx")
            predictor = OnnxPredictor(model)
        else:
            from deformsim.learn.predict import load

            predictor = load(model)
        if threshold is not None and predictor.target != "label":
            raise UserError(f"--threshold applies to a model of train.target label; {model} predicts {predictor.target}")
        prior = None
        if adapt is not None:
            from deformsim.learn.adapt_stage import check_adaptable, distinct_photos, fit_on

            check_adaptable(predictor)
            distinct, _ = distinct_photos(paths, "predict --adapt")
            predictor.adapter = fit_on(predictor, distinct, adapt)[0]
            prior = predictor.adapter.prior
        if predictor.target == "label":
            cut = predictor.cfg.threshold if threshold is None else threshold
            proba, labels = predictor.predict(paths, cut)
            prediction = Prediction(paths, {"p_deformed": proba, "label": labels}, ("P(deformed)", "label"), cut,
                                    prior)
        else:
            prediction = _target_prediction(predictor, paths)
        if csv is not None:
            with atomic_path(csv) as tmp:
                prediction.frame().to_csv(tmp, index=False)
        return prediction

    def export_onnx(self, model: str | Path, onnx: str | Path) -> Path:
        """A trained model as an ONNX file (input: 0-1 RGB NCHW; output: P(deformed)); its path."""
        from deformsim.learn.onnx import to_onnx

        return to_onnx(model, onnx)

    def evaluate(self, model: str | Path, data: str | Path | None = None, variant: str | None = None,
                 real: str | Path | None = None, threshold: float | None = None,
                 out: str | Path | None = None) -> Evaluation:
        """Metrics and predictions of a trained model on a dataset variant or on real photos (also written to the
        JSON file ``out``)."""
        from deformsim.evaluate.experiments import evaluate_model
        from deformsim.outputs import check_file_target

        if out is not None:
            check_file_target(out, "--out", [model])
        self._check_real(real)
        what = real if real is not None else f"{data} / {variant}"
        self.notify(f"testing {model} on {what} (a progress bar follows on a terminal)")
        result = evaluate_model(model, data, variant, real, threshold)
        if out is not None:
            result.write(out)
        return result

    def report(self, data: str | Path, out: str | Path | None = None, real: str | Path | None = None,
               overwrite: bool = False, fewshot: str | Path | None = None) -> Path:
        """Train and test every variant (the paper's Table II) into ``out`` (default: DATA-report beside the dataset,
        never inside it), write the HTML report (with the curves of ``fewshot``, a ``bench fewshot`` fewshot.json,
        when given); its path. A report of other settings or inputs in ``out`` is refused unless ``overwrite``."""
        from deformsim.outputs import check_folder_target
        from deformsim.report.stage import make_report

        where = Path(data).resolve()
        out = check_folder_target(out if out is not None else where.parent / f"{where.name}-report", "--out")
        self._check_real(real)
        return make_report(Path(data), self.config.train, out, real=_path(real), overwrite=overwrite,
                           progress=self.progress, fewshot=_path(fewshot))

    def run(self, out: str | Path, real: str | Path | None = None, overwrite: bool = False, yes: bool = False,
            unlabelled: str | Path | None = None):
        """Every stage into ``out``, skipping those already up to date; a :class:`RunResult`. More than
        ``config.CONFIRM_IMAGES`` images are refused unless ``yes``. ``unlabelled``: photos of real parts (no label
        read) that the run's model adapts to last (``OUT/model-adapted``)."""
        from deformsim.generate.refusals import check_plan
        from deformsim.pipeline import run

        check_plan(self.config, yes)
        self._check_real(real)
        return run(self.config, Path(out), real=_path(real), progress=self.progress, overwrite=overwrite,
                   unlabelled=_path(unlabelled))

    def spec_check(self, spec: str | Path, mesh: str | Path | None = None) -> SpecCheck:
        """Validate a spec and, when given, its mesh by the part checks of ``generate`` (the mesh imported in a
        throwaway Blender process), and say which keys are too small to see with this config; nothing rendered."""
        from deformsim.generate.stage import check_part_mesh
        from deformsim.generate.visibility import invisible_keys
        from deformsim.spec.model import load_spec

        loaded = load_spec(spec)
        if mesh is None:
            return SpecCheck(loaded, small=invisible_keys(self.config, loaded, None) if loaded.builtin else None)
        size, hint = check_part_mesh(loaded, Path(mesh), Path(spec))
        return SpecCheck(loaded, size, hint, invisible_keys(self.config, loaded, size))

    def spec_preview(self, spec: str | Path | None, mesh: str | Path | None, out: str | Path, resolution: int = 192,
                     samples: int = 16, bank: bool = True) -> Path:
        """Render the rest shape and each key of a spec (default: the built-in can) at full weight into one labelled
        PNG ``out`` (``bank``: and each simulated bank entry, baked first when it is not cached); its path. Keys too
        small to see in a typical image of a run with this engine's config are warned about."""
        from deformsim.generate.spec_preview import render_preview
        from deformsim.outputs import check_file_target

        out = check_file_target(out, "--out", [spec, mesh])  # before rendering
        return render_preview(_path(spec), _path(mesh), out, resolution, samples, bank=bank, progress=self.progress,
                              seen_with=self.config)

    def sim2real(self, real: str | Path, out: str | Path, plan: Plan | None = None, adapt: str | Path | None = None,
                 datasets: str | Path | None = None, baseline: str | Path | None = None) -> ResultsFile:
        """The sim-to-real benchmark: train on synthetic images over the seeds of ``plan``, test on the labelled
        ``real`` photos; its results (also in ``out/results.json`` and ``out/report.html``), with the paired
        differences to the ``baseline`` benchmark's results when given."""
        from deformsim.evaluate.benchmark import Plan, run_benchmark

        return run_benchmark(self.config, Path(out), Path(real), plan or Plan(), adapt=_path(adapt),
                             datasets=_path(datasets), progress=self.progress, baseline=_path(baseline))

    def fewshot(self, real: str | Path, model: str | Path, out: str | Path, ks: Sequence[int] = (0, 1, 2, 5, 10, 20),
                draws: int = 5, seeds: int = 2, recipe: Recipe | None = None,
                curves: Sequence[str] = ("synthetic", "unadapted", "imagenet"), data: str | Path | None = None,
                variant: str | None = None, biased: bool = False) -> FewshotFile:
        """The few-shot benchmark: ``model`` adapted on k labelled photos per class of ``real`` and scored on the
        others, beside the ImageNet backbone trained on them alone; its results (also in ``out/fewshot.json``, the
        curves in ``out/fewshot.png``). ``biased``: each class's k photos from a different lighting."""
        from deformsim.evaluate.fewshot import run_fewshot

        self._check_real(real)
        return run_fewshot(Path(real), Path(model), Path(out), tuple(ks), draws, seeds, recipe, tuple(curves),
                           _path(data), variant, progress=self.progress, biased=biased)

    def _check_real(self, real: str | Path | None) -> None:
        """Check a folder of labelled real photos and say what it holds, per class and subfolder."""
        if real is not None:
            from deformsim.dataset.real import describe, real_table

            self.notify(f"real photos in {describe(real_table(real), real)}")


def _target_prediction(predictor, paths: list[Path]) -> Prediction:
    """The per-image columns and headings of a severity, family or localise model's output."""
    out = predictor.predict_outputs(paths)
    if predictor.target == "severity":
        return Prediction(paths, {"max_disp_mm": out}, ("max displacement (mm)",))
    if predictor.target == "family":
        names = predictor.outputs
        return Prediction(paths, {f"p_{n}": out[:, k] for k, n in enumerate(names)}, tuple(f"P({n})" for n in names))
    thr = predictor.cfg.threshold
    return Prediction(paths, {"region_fraction": (out >= thr).mean(axis=(1, 2)), "peak": out.max(axis=(1, 2))},
                      ("predicted region (share of image)", "peak P(region)"))
