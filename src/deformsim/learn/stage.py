"""The training stage: a model trained on a dataset variant (or a photo folder) and put into its own folder.

The folder is refused when it holds one trained with other settings or images (unless ``overwrite``), anything
but a model, or the training data; the new model is built beside it and swapped in whole.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from deformsim.config import TrainConfig
from deformsim.identity import digest, files_digest
from deformsim.learn.train import TrainResult
from deformsim.outputs import check_apart, check_folder_target, claim, replacing


@dataclass
class TrainedModel(TrainResult):
    """:class:`TrainResult` of a model in its folder, with the number of images it was trained and validated on."""

    images: int


def images_digest(table, root: Path) -> str:
    """A training table's images by content, names (relative to ``root``) and labels."""
    return digest([files_digest(list(table["path"]), root), [int(y) for y in table["y"]]])


def train_model(data: Path, cfg: TrainConfig, out: Path, variant: str | None = None, overwrite: bool = False,
                progress: bool = True, adapt: Path | None = None) -> TrainedModel:
    """:func:`deformsim.learn.train.fit` on ``data`` into the folder ``out``.

    ``data`` is a generated dataset (its ``variant``, default the first of ``cfg.variants``) or a folder of
    intact/ and deformed/ photos. Refused with one line when ``out`` is a file, holds anything but a model (even
    with ``overwrite``), is or holds ``data`` or ``adapt``, or holds a model trained with other settings or images
    (unless ``overwrite``).
    """
    from deformsim.dataset.tables import load_table
    from deformsim.learn.checkpoint import MODEL_FILE
    from deformsim.learn.train import fit

    out = check_folder_target(out, "--out")
    check_apart(out, "--out", {"training data": data, "--adapt photos": adapt})
    table = load_table(data, variant, cfg.variants[0], cfg.min_region)
    identity = {"settings": cfg.model_dump(mode="json"),
                "inputs": {"variant": variant or cfg.variants[0], "images": images_digest(table, data)}}
    claim(out, "model", identity, overwrite)
    with replacing(out, identity, "model") as tmp:
        result = fit(table, cfg, tmp, progress=progress, adapt=adapt)
    trained = {f.name: getattr(result, f.name) for f in fields(result)}
    return TrainedModel(**{**trained, "model_path": out / MODEL_FILE}, images=len(table))


def model_renders(data: Path, variant: str | None, path: Path, cfg):
    """The renders that fine-tuning, or an adapt method that trains the networks, mixes in: ``data``'s ``variant`` (a
    generated dataset; or a folder of images in intact/ and deformed/), default the variant the model in ``path`` was
    trained on (its folder's ``inputs.json``, as :func:`train_model` wrote it), else the config's first; without the
    deformed images whose damage the model was trained not to see (``train.min_region``), whose label would be wrong."""
    from deformsim.dataset.layout import Layout
    from deformsim.dataset.tables import load_table
    from deformsim.outputs import read_inputs

    if variant is None and Layout(data).manifest.is_file():
        inputs = (read_inputs(path.parent) or {}).get("inputs")
        recorded = inputs.get("variant") if isinstance(inputs, dict) else None
        variant = recorded if isinstance(recorded, str) else None
    return load_table(data, variant, cfg.variants[0], cfg.min_region)
