"""The report stage: the paper's Table II on a dataset, put into its own folder as ``report.html``.

The folder is refused when it holds a report made with other settings or inputs (unless ``overwrite``), anything
but a report, or the report's inputs; the new report is built beside it and swapped in whole, so no model or plot
of an older one is left.
"""

from __future__ import annotations

from pathlib import Path

from deformsim.config import TrainConfig
from deformsim.identity import file_digest, files_digest
from deformsim.log import get_logger
from deformsim.outputs import check_apart, check_folder_target, check_outside, claim, replacing

log = get_logger(__name__)


def real_digest(real: Path | None) -> str | None:
    """A folder of labelled real photos by content and place (the folder gives the label); None without one."""
    from deformsim.dataset.real import real_table

    return files_digest(list(real_table(real)["path"]), real) if real is not None else None


def present_variants(data: Path, cfg: TrainConfig) -> tuple[TrainConfig, str | None]:
    """``cfg`` training the variants of dataset ``data`` it names; when some are not in ``data``, the composited
    variants that are take their place (as ``deformsim run`` composites ``procedural`` without background photos).
    Also a warning naming the variants that change, or those left untrained, and ``--variants``, which picks them;
    None when there is nothing to say."""
    from deformsim.dataset.layout import RENDER_KINDS
    from deformsim.dataset.variants import list_variants

    available = list_variants(data)
    missing = [v for v in cfg.variants if v not in available]
    extra = [v for v in available if v not in RENDER_KINDS and v not in cfg.variants]
    if not extra:
        return cfg, None
    if missing:
        chosen = [v for v in cfg.variants if v in available] + extra
        return cfg.model_copy(update={"variants": chosen}), (
            f"variant{'s' * (len(missing) > 1)} {', '.join(missing)} not in {data}: training on {', '.join(chosen)} "
            "instead (--variants picks)")
    return cfg, (f"variant{'s' * (len(extra) > 1)} {', '.join(extra)} of {data} not trained (train.variants: "
                 f"{', '.join(cfg.variants)}): add {'them' if len(extra) > 1 else 'it'} with --variants "
                 f"{','.join([*cfg.variants, *extra])}")


def make_report(data: Path, cfg: TrainConfig, out: Path, real: Path | None = None, overwrite: bool = False,
                progress: bool = True, fewshot: Path | None = None) -> Path:
    """Train and test every variant of dataset ``data`` with settings ``cfg`` (on ``real`` photos too) into the
    folder ``out``; the path of its report.html, showing the curves of ``fewshot`` (``bench fewshot``'s
    fewshot.json) when given.

    Refused with one line when ``out`` is a file, holds anything but a report (even with ``overwrite``), is or holds
    ``data`` or ``real`` or lies inside ``real``, or holds a report made with other settings or inputs (unless
    ``overwrite``).
    """
    from deformsim.dataset.layout import Layout
    from deformsim.dataset.manifest import read_manifest
    from deformsim.dataset.variants import made_manifests
    from deformsim.evaluate.experiments import run_experiments
    from deformsim.report.html import write_report

    out = check_folder_target(out, "--out")
    check_apart(out, "--out", {"dataset": data, "real photos": real, "few-shot results": fewshot})
    check_outside(out, "--out", {"real photos": real})  # its plots would be read as photos
    read_manifest(data)  # a clear error when ``data`` is not a dataset
    cfg, variants_note = present_variants(data, cfg)
    layout = Layout(data)
    manifests = [layout.manifest, *made_manifests(data)]
    identity = {"settings": cfg.model_dump(mode="json"), "inputs": {"data": files_digest(manifests, data),
                                                                    "real": real_digest(real)}}
    shots = None
    if fewshot is not None:
        from deformsim.evaluate.fewshot import read_results

        shots = read_results(fewshot)
        identity["inputs"]["fewshot"] = file_digest(fewshot)
    claim(out, "report", identity, overwrite)
    if variants_note is not None:
        log.warning("%s", variants_note)
    with replacing(out, identity, "report") as tmp:
        metrics = run_experiments(data, cfg, tmp, real_dir=real, progress=progress)
        if shots is not None:
            metrics.fewshot = shots
            metrics.write(tmp / "metrics.json")
        write_report(metrics, tmp)
    return out / "report.html"
