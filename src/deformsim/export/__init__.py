"""Exports of a dataset variant to layouts other tools read (``deformsim export-data DATA OUT --format F``).

``imagefolder`` (torchvision / Hugging Face, :mod:`.imagefolder`), ``coco`` (instances JSON with RLE masks and
severity attributes, :mod:`.coco`) and ``anomalib`` (its ``Folder`` layout, :mod:`.anomalib`). Every file read is
checked to be an image inside the dataset first (:mod:`deformsim.dataset.paths`). Pictures (and masks) are
hard-linked where the dataset shares OUT's filesystem, else copied (always copied with ``copy``), and the README
says which; the dataset is never changed. OUT is checked before any work, built beside itself and swapped in
whole; it records ``export.json`` (kind ``export``). The package imports what exporting needs only when
:func:`export_data` runs, so the command line's help and completion read :data:`FORMATS` without pandas.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from deformsim.errors import UserError

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


def links_note(linked: int, images: int) -> str:
    """The README's line on whether the export's files are the dataset's own (hard links) or copies."""
    if not linked:
        return "Every file here is a copy: this export is independent of the dataset.\n"
    which = "The images (and masks)" if linked == images else f"{linked} of the {images} images (and their masks)"
    return (f"{which} here are hard links to the dataset's own files: editing one in place changes the dataset "
            "too. Export with --copy for independent files.\n")


def export_data(data: str | Path, out: str | Path, fmt: str, variant: str | None = None, overwrite: bool = False,
                progress: bool = True, copy: bool = False) -> ExportResult:
    """Export the images of ``variant`` of the dataset at ``data`` (default: its first composited variant, else
    ``black``) into ``out`` in format ``fmt``, hard-linked where possible unless ``copy``. :class:`UserError` for
    bad input, before anything is written."""
    from deformsim.atomic import write_json, write_text
    from deformsim.dataset.manifest import read_manifest
    from deformsim.export.files import claim_export
    from deformsim.export.source import default_variant, export_table
    from deformsim.log import progress_bar
    from deformsim.outputs import EXPORT, check_apart, check_outside, replacing

    if fmt not in FORMATS:
        raise UserError(f"unknown export format {fmt!r} (have: {', '.join(FORMATS)})")
    data, out = Path(data), Path(out)
    read_manifest(data)  # a clear line when DATA is not a dataset
    check_apart(out, "OUT", {"dataset": data})
    check_outside(out, "OUT", {"dataset": data})
    variant = variant or default_variant(data)
    claim_export(out, overwrite)
    table = export_table(data, variant)
    write = _writer(fmt)
    if fmt == "coco":
        from deformsim.export.coco import require_masks

        require_masks(table)
    with replacing(out) as staging, progress_bar(len(table), f"export {fmt}", progress) as bar:
        summary = write(table, staging, out, bar, copy=copy)
        readme = summary.pop("readme") + links_note(summary["linked"], summary["images"])
        write_text(staging / "README.txt", readme)
        write_json(staging / EXPORT, {"kind": "export", "format": fmt, "variant": variant,
                                      "data": str(data.resolve()), "copy": copy, **summary})
    return ExportResult(out, fmt, variant, summary)
