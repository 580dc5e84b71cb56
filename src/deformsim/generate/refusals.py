"""Why a run cannot start: a spec that does not fit the part, a mesh that is no solid part, a plan too large to
start unasked, or an output folder that holds another dataset.

A folder rendered with other settings or inputs, or holding more samples than ``generate.n`` asks for, is
refused with one line (``--overwrite`` replaces it as a whole), so a dataset is never a mix of two parts, two
specs or two sizes; a folder that holds files but no dataset is never used.
"""

from __future__ import annotations

import math
from pathlib import Path

from deformsim.config import CONFIRM_IMAGES, Config
from deformsim.dataset.layout import RENDER_KINDS, Layout
from deformsim.errors import UserError
from deformsim.generate.identity import data_settings, input_digests
from deformsim.identity import content_inputs
from deformsim.outputs import check_kind, first_difference, read_inputs
from deformsim.sampling.features import extra_renders, png_bytes
from deformsim.schema import read_mapping, shown
from deformsim.spec.mesh_numbers import nonfinite_vertices
from deformsim.spec.model import Spec, check_mesh_file

_REPLACE = "use a new output folder, or --overwrite to replace it"
PART_SIZE = (1e-6, 1e5)  # metres: the largest dimension of a part that can be rendered
FLAT = 1e-6  # a part whose smallest dimension is below this share of its largest is flat


def n_samples(cfg: Config) -> int:
    """The samples ``cfg`` renders: ``generate.n`` images, one per camera each."""
    return cfg.generate.n // len(cfg.camera.azimuth_quadrants)


def check_part(spec: Spec, mesh: Path | None) -> None:
    """A spec for the built-in part takes no mesh; any other needs one, of a supported format, whose vertex
    coordinates are finite (:func:`~deformsim.spec.mesh_numbers.nonfinite_vertices`)."""
    if mesh is not None:
        check_mesh_file(mesh)
        if nonfinite_vertices(mesh):
            raise UserError(f"mesh {mesh} has vertex coordinates that are NaN or infinite (Blender would drop them "
                            "and the faces on them)")
        if spec.builtin:
            raise UserError(f"spec '{shown(spec.name, 40)}' is for the built-in {spec.builtin}, not for mesh {mesh}")
    elif not spec.builtin:
        raise UserError(f"spec '{shown(spec.name, 40)}' describes a mesh part: pass the mesh with --object")


def check_probe(mesh: Path, probed: dict) -> list[float]:
    """The size (metres) the mesh probe measured of ``mesh``, or one line when it is no solid part (not finite,
    fewer than 4 vertices, flat, or outside :data:`PART_SIZE`) or the spec cannot rig it (``rig``: a vertex rule
    or material region that selects nothing, opening keys that do not fit)."""
    size = [float(v) for v in probed["size"]]
    if not all(math.isfinite(v) for v in size):
        raise UserError(f"mesh {mesh} has a size that is not finite ({size})")
    vertices = probed["vertices"]
    if vertices < 4:
        raise UserError(f"mesh {mesh} has {vertices} vertices: a part needs a solid shape (4 or more)")
    dims = " x ".join(f"{v:.3g}" for v in size)
    if not PART_SIZE[0] <= max(size) <= PART_SIZE[1]:
        raise UserError(f"mesh {mesh} is {dims} m: a part must measure {PART_SIZE[0]:g} to {PART_SIZE[1]:g} m "
                        "(set units or size in the spec)")
    if min(size) <= FLAT * max(size):
        raise UserError(f"mesh {mesh} is flat ({dims} m): a part needs a solid shape")
    if probed.get("rig"):
        raise UserError(probed["rig"])
    return size


def render_seconds(cfg: Config) -> float:
    """About how long one image of ``cfg`` takes on a 2-core machine (docs/experiments/timings.md): each extra
    render of its features (:func:`~deformsim.sampling.features.extra_renders`) takes as long as ``rgba``'s."""
    r = cfg.render
    return (1.5 + 2e-6 * r.resolution**2 * r.samples) * (1 + extra_renders(cfg))


def check_plan(cfg: Config, yes: bool) -> None:
    """A plan of more than :data:`~deformsim.config.CONFIRM_IMAGES` images needs ``yes``: else one line with its
    estimated render time and disk (from docs/experiments/timings.md's 2-core machine)."""
    n = cfg.generate.n
    if n <= CONFIRM_IMAGES or yes:
        return
    pixels = cfg.render.resolution**2
    seconds = n * render_seconds(cfg)
    # bytes of PNG per pixel: 0.65 per rendered image (rgba, black, green and one per extra render), and the rest
    disk = n * pixels * (0.65 * (len(RENDER_KINDS) + extra_renders(cfg)) + png_bytes(cfg))
    raise UserError(f"generate.n {n} is more than {CONFIRM_IMAGES} images: about {seconds / 3600:,.0f} hours of "
                    f"rendering on a 2-core machine and {disk / 1e9:,.0f} GB of disk; pass --yes to start it")


def existing_dataset(cfg: Config, out: Path, spec: Spec) -> str | None:
    """Why ``out`` cannot be resumed as ``cfg``'s dataset (None: it is new, empty, or the same dataset).

    A :class:`UserError` when ``out`` holds files but no dataset: such a folder is never replaced.
    """
    out = Path(out)
    if not out.is_dir() or not any(out.iterdir()):
        return None
    check_kind(out, "dataset")
    layout = Layout(out)
    try:
        old_settings = data_settings(Config.model_validate(read_mapping(layout.config, "config")))
    except Exception:
        return f"holds an unreadable {layout.config.name}: {_REPLACE}"
    new = data_settings(cfg)
    if old_settings != new:
        return f"was generated with other settings ({first_difference(old_settings, new)}): {_REPLACE}"
    recorded = read_inputs(out)
    if recorded is None or not isinstance(recorded.get("inputs"), dict):
        return f"was generated by an older deformsim that did not record its inputs' contents: {_REPLACE}"
    now = input_digests(cfg, spec)
    named = [(rule.key, f"{rule.what} {path or '(built-in)'}") for rule, path in content_inputs(cfg)]
    for name, what in [("renderer", "renderer revision"), *named]:
        if recorded["inputs"].get(name) != now.get(name):
            was, new_hash = (recorded["inputs"].get(name) or "none")[:12], (now.get(name) or "none")[:12]
            return (f"was rendered from other contents of its {what} (sha256 {was}... there, {new_hash}... now): "
                    f"{_REPLACE}")
    samples = sorted(int(p.stem) for p in layout.samples_dir.glob("[0-9]*.json") if p.stem.isdigit())
    beyond = [i for i in samples if i >= n_samples(cfg)]
    if beyond:
        views = len(cfg.camera.azimuth_quadrants)
        return (f"holds {len(samples) * views} images; generate.n {cfg.generate.n} would leave {len(beyond) * views} "
                f"of them out of its manifest: pass --n {(samples[-1] + 1) * views} or more to keep (and extend) it, "
                f"{_REPLACE}")
    return None
