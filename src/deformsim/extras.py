"""The optional parts of deformsim (pip extras) and the one line that names the extra a command is missing.

``pip install deformsim`` predicts with an exported ONNX model, composites, exports datasets as ImageFolder or
anomalib and runs every command's checks; rendering needs ``[render]`` (Blender as a module, OpenEXR), training,
evaluation and reports ``[train]`` (torch, torchvision, onnx for the offline VGG-16 weights and the ONNX export,
matplotlib for the figures), COCO export ``[export]``, the Ray backend ``[ray]``; ``[all]`` installs each.
"""

from __future__ import annotations

import importlib.util

from deformsim.errors import UserError

# extra -> the modules it installs (as imported); the first extra that lists a module is the one named for it
EXTRAS = {
    "render": ("bpy", "OpenEXR"),
    "train": ("torch", "torchvision", "onnx", "matplotlib"),
    "export": ("pycocotools", "onnx"),
    "ray": ("ray",),
}


class MissingExtra(UserError):
    """A module of an extra is not installed: one line naming the extra to install."""

    exit_code = 1


def extra_of(module: str) -> str | None:
    """The extra that installs ``module`` (a dotted name counts by its top package), or None."""
    top = module.split(".")[0]
    return next((extra for extra, modules in EXTRAS.items() if top in modules), None)


def missing_line(module: str, extra: str, what: str = "this command") -> str:
    return f"{what} needs {module}, which is not installed: pip install 'deformsim[{extra}]'"


def require(*extras: str, what: str = "this command") -> None:
    """A :class:`MissingExtra` naming the first extra of ``extras`` with a module that is not installed (nothing
    is imported: a command checks this before any work)."""
    for extra in extras:
        for module in EXTRAS[extra]:
            if importlib.util.find_spec(module) is None:
                raise MissingExtra(missing_line(module, extra, what))


def as_missing_extra(exc: ModuleNotFoundError) -> MissingExtra | None:
    """``exc`` as a :class:`MissingExtra` when the module it did not find belongs to an extra, else None."""
    extra = extra_of(exc.name or "")
    return MissingExtra(missing_line(exc.name, extra)) if extra else None
