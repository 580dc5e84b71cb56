"""Exports of a dataset variant to layouts other tools read (``deformsim export-data DATA OUT --format F``).

``imagefolder`` (torchvision / Hugging Face, :mod:`.imagefolder`), ``coco`` (instances JSON with RLE masks and
severity attributes, :mod:`.coco`) and ``anomalib`` (its ``Folder`` layout, :mod:`.anomalib`). Pictures (and
masks) are hard-linked where the dataset shares OUT's filesystem, else copied; the dataset is never changed.
OUT is checked before any work, built beside itself and swapped in whole; it records ``export.json``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from deformsim.atomic import write_json, write_text
from deformsim.dataset.manifest import read_manifest
from deformsim.errors import UserError
from deformsim.export.files import MARKER, claim_export
from deformsim.export.source import default_variant, export_table
from deformsim.log import progress_bar
from deformsim.outputs import replacing

FORMATS = ("imagefolder", "coco", "anomalib")


@dataclass(frozen=True)
class ExportResult:
    out: Path
    format: str
    variant: str
    summary: dict


def _writer(fmt: str):
    if fmt == "imagefolder":
        from deformsim.export.imagefolder import write_imagefolder as write
    elif fmt == "coco":
        from deformsim.export.coco import write_coco as write
    else:
        from deformsim.export.anomalib import write_anomalib as write
    return write


def export_data(data: str | Path, out: str | Path, fmt: str, variant: str | None = None, overwrite: bool = False,
                progress: bool = True) -> ExportResult:
    """Export the images of ``variant`` of the dataset at ``data`` (default: its first composited variant, else
    ``black``) into ``out`` in format ``fmt``. :class:`UserError` for bad input, before anything is written."""
    if fmt not in FORMATS:
        raise UserError(f"unknown export format {fmt!r} (have: {', '.join(FORMATS)})")
    data, out = Path(data), Path(out)
    read_manifest(data)  # a clear line when DATA is not a dataset
    if out.resolve().is_relative_to(data.resolve()) or data.resolve().is_relative_to(out.resolve()):
        raise UserError(f"OUT {out} and the dataset {data} overlap: choose a folder outside the dataset")
    variant = variant or default_variant(data)
    claim_export(out, overwrite)
    table = export_table(data, variant)
    write = _writer(fmt)
    if fmt == "coco":
        from deformsim.export.coco import require_masks

        require_masks(table)
    with replacing(out) as staging, progress_bar(len(table), f"export {fmt}", progress) as bar:
        summary = write(table, staging, out, bar)
        write_text(staging / "README.txt", summary.pop("readme"))
        write_json(staging / MARKER, {"format": fmt, "variant": variant, "data": str(data.resolve()), **summary})
    return ExportResult(out, fmt, variant, summary)
