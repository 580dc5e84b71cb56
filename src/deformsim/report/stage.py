"""The report stage: the paper's Table II on a dataset, put into its own folder as ``report.html``.

The folder is refused when it holds a report made with other settings or inputs (unless ``overwrite``), anything
but a report, or the report's inputs; the new report is built beside it and swapped in whole, so no model or plot
of an older one is left.
"""

from __future__ import annotations

from pathlib import Path

from deformsim.atomic import write_json
from deformsim.config import TrainConfig
from deformsim.identity import file_digest, files_digest
from deformsim.outputs import check_apart, check_folder_target, check_outside, claim, replacing


def real_digest(real: Path | None) -> str | None:
    """A folder of labelled real photos by content and place (the folder gives the label); None without one."""
    from deformsim.dataset.real import real_table

    return files_digest(list(real_table(real)["path"]), real) if real is not None else None


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
    with replacing(out, identity, "report") as tmp:
        metrics = run_experiments(data, cfg, tmp, real_dir=real, progress=progress)
        if shots is not None:
            metrics["fewshot"] = shots
            write_json(tmp / "metrics.json", metrics)
        write_report(metrics, tmp)
    return out / "report.html"
