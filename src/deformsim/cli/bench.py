"""`deformsim bench`: real-photo metrics as mean and standard deviation over seeds (``sim2real``), paired
differences (``compare``), benchmarks combined after the fact (``merge``, ``mean``) and few-shot adaptation."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from deformsim.cli.choices import completes, variant_choices
from deformsim.cli.common import ConfigArgs, console, fail_cleanly, set_option
from deformsim.cli.summary import baseline_summary, sim2real_summary
from deformsim.errors import UserError

SIZES = {True: {"generate.n": 320}, False: {"generate.n": 640}}  # --quick or not

BIASED_HELP = ("draw the k photos as a biased sample: the intact ones from the warmer-lit half of the folder and the "
               "deformed ones from the cooler half (the reverse in every other draw)")


def register(app: typer.Typer) -> None:
    bench_app = typer.Typer(no_args_is_help=True, help="Benchmarks that measure what the product is for.")
    app.add_typer(bench_app, name="bench")

    @bench_app.command("sim2real")
    @fail_cleanly
    def sim2real(
        real: Path = typer.Option(..., "--real", help="labelled real photos (intact/ and deformed/), for scoring only"),
        backgrounds: Optional[Path] = typer.Option(None, "--backgrounds", help="background photos for compositing"),
        out: Path = typer.Option(Path("runs/sim2real"), "--out", "-o", help="benchmark folder"),
        datasets: Optional[Path] = typer.Option(
            None, "--datasets", help="where rendered datasets are kept and reused (default: the benchmark folder)"
        ),
        config: str = typer.Option("quick", "--config", "-c", help="YAML config file or preset name"),
        quick: bool = typer.Option(False, "--quick", help="320 images, 2 background draws, 2 training seeds (else 640, 3, 3)"),
        data_seeds: int = typer.Option(1, help="datasets with different generate seeds"),
        composite_seeds: Optional[int] = typer.Option(None, help="background draws per dataset (default 3)"),
        train_seeds: Optional[int] = typer.Option(None, help="training seeds per draw (default 3)"),
        variants: str = typer.Option("black,backgrounds", help="comma-separated variants to train on"),
        whole: bool = typer.Option(
            False, "--whole", help="train each model on every render, as deformsim run does (synthetic scores: its "
            "validation split); default: a test split of the renders is set aside first"),
        adapt: Optional[Path] = typer.Option(None, "--adapt", help="unlabelled real photos to adapt to (labels never read)"),
        baseline: Optional[Path] = typer.Option(
            None, "--baseline", help="another benchmark's results.json (or folder) on the same photos: print each "
            "metric's paired difference to it with a 95 % interval"),
        set_: list[str] = set_option(),
        progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
    ) -> None:
        """Train on synthetic images with several seeds; print real-photo metrics as mean ± std."""
        from deformsim.evaluate.benchmark import Plan

        engine = ConfigArgs(config, {"--backgrounds": ("composite.backgrounds", str(backgrounds) if backgrounds else None)},
                            overrides=SIZES[quick], sets=set_).engine(progress)
        plan = Plan(data_seeds=data_seeds,
                    composite_seeds=composite_seeds or (2 if quick else 3),
                    train_seeds=train_seeds or (2 if quick else 3),
                    variants=tuple(v.strip() for v in variants.split(",") if v.strip()), whole=whole)
        results = engine.sim2real(real, out, plan, adapt=adapt, datasets=datasets, baseline=baseline)
        console.print(f"{len(results.runs)} runs in {results.seconds:.0f} s; results: {out / 'results.json'}",
                      highlight=False, soft_wrap=True)
        sim2real_summary(results, out / "report.html")

    @bench_app.command("compare")
    @fail_cleanly
    def compare(
        results: Path = typer.Argument(..., help="a benchmark's results.json (or its folder)"),
        baseline: Path = typer.Option(..., "--baseline", help="the results to compare with, on the same photos"),
    ) -> None:
        """Print each metric's paired difference between two sim2real benchmarks, with 95 % intervals."""
        from deformsim.evaluate.paired import compare as paired
        from deformsim.evaluate.results import Baseline, read_results

        new = read_results(results)
        new.baseline = Baseline(results=str(baseline), comparison=paired(new, read_results(baseline)))
        baseline_summary(new)

    bench_app.command("merge")(fail_cleanly(merge))
    bench_app.command("mean")(fail_cleanly(mean))
    bench_app.command("bag")(fail_cleanly(bag))
    bench_app.command("fewshot")(fail_cleanly(fewshot))
    bench_app.command("adapt")(fail_cleanly(adapt))
    bench_app.command("ceiling")(fail_cleanly(ceiling))


_INPUTS = typer.Argument(..., help="two or more benchmarks' results.json (or their folders), on the same photos")
_OUT = typer.Option(..., "--out", "-o", help="folder for the combined results.json and report.html")


def merge(results: list[Path] = _INPUTS, out: Path = _OUT) -> None:
    """Pool the runs of benchmarks of other render draws into one, so that compare pairs over all of them."""
    from deformsim.evaluate.combine import merge as combine

    _combined(combine, results, out)


def mean(results: list[Path] = _INPUTS, out: Path = _OUT) -> None:
    """Score each run's mean prediction with its paired runs (same variant and seeds) in the other benchmarks: an
    ensemble of models trained apart, such as two backbones on the same renders."""
    from deformsim.evaluate.combine import mean as combine

    _combined(combine, results, out)


def bag(results: Path = typer.Argument(..., help="a benchmark's results.json (or its folder)"),
        members: int = typer.Option(..., "--members", "-k", help="training seeds per ensemble (2-16)"),
        out: Path = _OUT) -> None:
    """Score each draw's consecutive training seeds in blocks of --members as one ensemble each: with --whole, the
    model that train.ensemble trains."""
    from deformsim.evaluate.combine import bag as combine

    _combined(lambda inputs, sources: combine(inputs[0], members, sources[0]), [results], out)


def _combined(combine, results: list[Path], out: Path) -> None:
    """Combine ``results`` into ``out/results.json`` and ``out/report.html``, then print its summary."""
    from deformsim.evaluate.results import read_results
    from deformsim.outputs import check_file_target, check_folder_target
    from deformsim.report.benchmark import write_benchmark_report

    files = [p / "results.json" if p.is_dir() else p for p in results]
    check_folder_target(out, "--out")
    check_file_target(out / "results.json", "--out", files)
    combined = combine([read_results(f) for f in files], [str(f) for f in files])
    out.mkdir(parents=True, exist_ok=True)
    combined.write(out / "results.json")
    sim2real_summary(combined, write_benchmark_report(combined, out))


def fewshot(
    real: Path = typer.Option(..., "--real", help="labelled real photos (intact/ and deformed/): adapted on k per "
                              "class, scored on the others"),
    model: Path = typer.Option(..., "--model", help="trained model folder (from deformsim train) or its model.pt"),
    out: Path = typer.Option(Path("runs/fewshot"), "--out", "-o", help="folder for fewshot.json and fewshot.png"),
    k: str = typer.Option("0,1,2,5,10,20", "--k", help="comma-separated photos per class to adapt on (capped to "
                          "leave one of each class to score)"),
    draws: int = typer.Option(5, "--draws", help="draws of the k photos per k"),
    seeds: int = typer.Option(2, "--seeds", help="training seeds per draw"),
    part: str = typer.Option("head", "--part", autocompletion=completes("head", "tail"), help="what trains: head (on "
                             "cached features, fast), or tail (the head and the backbone layers that training trained)"),
    steps: int = typer.Option(100, "--steps", help="optimiser steps per adaptation"),
    lr: float = typer.Option(1e-4, "--lr", help="learning rate of the synthetic model's adaptation (the ImageNet "
                             "curve trains its new head at the model's train.lr)"),
    views: int = typer.Option(4, "--views", help="augmented views of each photo, beside its plain image"),
    curves: str = typer.Option("synthetic,unadapted,imagenet", "--curves", help="comma-separated curves: synthetic "
                               "(the model adapted), unadapted (the model as it is, on the same photos), imagenet "
                               "(ImageNet weights, trained on the k photos alone)"),
    data: Optional[Path] = typer.Option(None, "--data", help="generated dataset whose images are mixed into the "
                                        "synthetic model's batches (with --variant)"),
    variant: Optional[str] = typer.Option(None, "--variant", autocompletion=variant_choices,
                                         help="image variant of --data (default: the one the model was trained on)"),
    biased: bool = typer.Option(False, "--biased", help=BIASED_HELP),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
) -> None:
    """Adapt a model on k labelled real photos per class, score it on the remaining photos; print accuracy and F1
    per k (mean and 95 % interval over draws and seeds) beside the ImageNet backbone trained on the same photos."""
    from deformsim.cli.common import err_console, note, plain_engine
    from deformsim.cli.summary import fewshot_summary
    from deformsim.evaluate.fewshot import parse_ks
    from deformsim.learn.finetune import Recipe

    recipe = Recipe(part=part, steps=steps, lr=lr, views=views)
    engine = plain_engine(progress, notify=note(err_console))
    results = engine.fewshot(real, model, out, parse_ks(k), draws, seeds, recipe,
                             [c.strip() for c in curves.split(",") if c.strip()], data, variant, biased)
    console.print(f"{len(results.runs)} runs in {results.seconds:.0f} s; results: {out / 'fewshot.json'}",
                  highlight=False, soft_wrap=True)
    fewshot_summary(results, out / "fewshot.png")


def adapt(
    models: list[Path] = typer.Argument(..., help="trained model folders (from deformsim train) or their model.pt, "
                                        "e.g. one per render draw: pooled"),
    real: Path = typer.Option(..., "--real", help="labelled real photos (intact/ and deformed/): adapted on with "
                              "their labels unread, scored with them"),
    out: Path = typer.Option(Path("runs/adapt"), "--out", "-o", help="folder for adapt.json"),
    methods: str = typer.Option("probe,prior,probe+prior", "--methods", help="comma-separated methods of deformsim "
                                "adapt"),
    folds: int = typer.Option(2, "--folds", help="inductive protocol: folds of the photos, each scored by the model "
                              "adapted on the others"),
    seed: int = typer.Option(0, "--seed", help="seed of the folds, the draws and the intervals"),
    k: str = typer.Option("", "--k", help="also comma-separated labelled photos per class (e.g. 1,2,5,10,20): the "
                          "model beside a probe on those photos alone, the probe on them with the rest unlabelled, "
                          "and the model stacked with a residual on them, scored on the rest"),
    n: str = typer.Option("", "--n", help="also comma-separated counts of unlabelled photos (e.g. 10,20,30): each "
                          "method adapted on n photos drawn at random, transductive (scored on them) and inductive "
                          "(drawn from the other folds)"),
    draws: int = typer.Option(5, "--draws", help="draws of the k (or n) photos per model"),
    groups: str = typer.Option("date", "--groups", help="shooting sessions of the photos, which the stacked curve's "
                               "cross-validation keeps apart: date (EXIF or file name), none, or a path,group CSV file"),
    biased: bool = typer.Option(False, "--biased", help=BIASED_HELP),
    progress: bool = typer.Option(True, "--progress/--no-progress", help="Show progress while working."),
) -> None:
    """Adapt a model to real photos without their labels, transductive (adapted on the photos it is scored on) and
    inductive (on the other folds); print each method's metrics (mean ± std over the models) and paired difference
    to the unadapted models."""
    from deformsim.cli.summary import adaptation_summary
    from deformsim.evaluate.adaptation import run_adaptation
    from deformsim.evaluate.fewshot import parse_ks

    result = run_adaptation(models, real, out, tuple(m.strip() for m in methods.split(",") if m.strip()), folds,
                            seed=seed, progress=progress, ks=parse_ks(k) if k else [], draws=draws,
                            groups=groups, biased=biased, ns=parse_ks(n, "--n", "photos", 1) if n else [])
    adaptation_summary(result)
    console.print(f"results: {out / 'adapt.json'}", highlight=False, soft_wrap=True)


def ceiling(
    real: Path = typer.Option(..., "--real", help="labelled real photos (intact/ and deformed/), cross-validated"),
    out: Path = typer.Option(Path("runs/ceiling"), "--out", "-o", help="folder for ceiling.json"),
    backbones: str = typer.Option("vgg16,efficientnet_lite0,efficientnet_lite2", "--backbones",
                                  help="comma-separated backbones"),
    sizes: str = typer.Option("128,224", "--sizes", help="comma-separated input sizes in pixels"),
    folds: int = typer.Option(5, "--folds", help="cross-validation folds, stratified by class"),
    seed: int = typer.Option(0, "--seed", help="seed of the folds"),
) -> None:
    """How well each backbone's frozen ImageNet features separate a real folder's classes: a logistic regression
    cross-validated inside the folder (the ceiling of what adapting to such photos can reach)."""
    from rich.table import Table

    from deformsim.cli.summary import print_table
    from deformsim.evaluate.ceiling import run_ceiling

    try:
        size_list = [int(v) for v in sizes.split(",") if v.strip()]
    except ValueError:
        raise UserError(f"--sizes {sizes!r}: expected comma-separated whole numbers, e.g. 128,224") from None
    result = run_ceiling(real, out, [b.strip() for b in backbones.split(",") if b.strip()], size_list, folds, seed=seed)
    table = Table(title=f"Frozen ImageNet features, {result.folds}-fold logistic regression on {result.photos} "
                  f"photos (majority class {result.majority:.3f})", header_style="bold")
    for col in ("backbone", "size", "accuracy", "F1", "AUC", "s/photo"):
        table.add_column(col, justify="left" if col == "backbone" else "right")
    for r in result.rows:
        table.add_row(r.backbone, str(r.size), f"{r.accuracy:.3f}", f"{r.f1:.3f}", "-" if r.auc is None else f"{r.auc:.3f}",
                      "-" if r.seconds_per_photo is None else f"{r.seconds_per_photo:.3f}")
    print_table(table, None)
    console.print(f"results: {out / 'ceiling.json'}", highlight=False, soft_wrap=True)
