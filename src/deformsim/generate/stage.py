"""`deformsim generate`: render a labelled intact/deformed dataset with a pool of Blender workers.

The orchestrator never imports bpy. It validates every input before work starts (:func:`prepare`, refusing
what :mod:`.refusals` names), hands samples to worker processes as they ask, drawing each one's parameters then
(pure, by index, so planning holds nothing per sample), writes each finished sample's record atomically, and
consolidates the manifest at the end. Rerunning on the same folder resumes: finished samples are skipped, so the
result is the same as an uninterrupted run's whatever the number of workers.

A dataset records what it is rendered from (:mod:`.identity`) in ``inputs.json``, its config in ``config.yaml``
and the package versions in ``versions.json``.
"""

from __future__ import annotations

import platform
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from deformsim.atomic import write_json, write_text
from deformsim.bank.stage import bake
from deformsim.config import Config, dump_config
from deformsim.dataset.images import open_rgb
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import consolidate
from deformsim.errors import ResourceError, UserError
from deformsim.extras import require
from deformsim.generate.backend import Todo, disk_full, finished, remove_partial_files
from deformsim.generate.identity import appearance_photos, input_digests, texture_photos
from deformsim.generate.local import run_local
from deformsim.generate.probe import probe_mesh
from deformsim.generate.refusals import check_part, check_probe, existing_dataset, n_samples
from deformsim.generate.visibility import invisible_keys
from deformsim.hdri import drawn_hdris
from deformsim.log import get_logger
from deformsim.outputs import check_apart, check_folder_target, check_no_nested, check_outside, locked, remove_folder, sweep
from deformsim.sampling import allowed_families, sample_params
from deformsim.sampling.features import listings
from deformsim.spec.model import Spec, load_spec, units_hint
from deformsim.version import __version__

log = get_logger(__name__)

_PACKAGES = ("bpy", "numpy", "pydantic", "pandas", "pyarrow", "pillow", "opencv-python-headless", "torch", "torchvision")


@dataclass
class GenerateResult:
    images: int
    rendered: int  # samples rendered by this run (the rest were resumed)
    failed: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0
    device: str = ""


def prepare(cfg: Config, out: Path, overwrite: bool = False, spec: Spec | None = None,
            seen_with: Config | None = None) -> tuple[Spec, list[str]]:
    """Every check that can fail on user input, before any work and before touching ``out``; a warning is logged when
    the spec's keys are too small to see at the render size of ``seen_with`` (default ``cfg``; :mod:`.visibility`).

    ``out`` must be a new or empty folder, or a dataset of the same settings and inputs with no more samples than
    ``cfg`` asks for (it is resumed); with ``overwrite`` any dataset is accepted (:func:`generate` replaces it).
    ``spec``: ``cfg``'s spec when the caller has loaded it already.
    """
    out = check_folder_target(out, "--out")
    check_outside(out, "--out", cfg.photo_folders())  # its renders would be read as photos next time
    require("render", *(("ray",) if cfg.generate.backend == "ray" else ()), what="rendering")
    spec = spec or load_spec(cfg.object.spec)
    allowed_families(cfg, spec)
    if cfg.deform.sources.uses_bank and spec.simulation is None:
        raise UserError(f"deform.sources uses the simulated bank, but spec '{spec.name}' declares no simulation "
                        "scenarios (set deform.sources.bank and .both to 0, or add simulation: to the spec)")
    hdris = drawn_hdris(cfg.lighting.hdri_dir, cfg.lighting.hdris)
    for what, photos in (("render.surface.photos", texture_photos(cfg)), ("render.appearance.photos",
                                                                          appearance_photos(cfg))):
        for photo in photos or ():
            try:
                open_rgb(photo, min_size=(1, 1))  # Blender would fail on it mid-run
            except UserError as exc:
                raise UserError(f"{what}: {exc}") from None
    conflict = existing_dataset(cfg, out, spec)
    if conflict is not None and not overwrite:
        raise UserError(f"{out} {conflict}")
    if conflict is not None:
        check_folder_target(out, "--out", replace=True)  # it is removed as a whole
        check_no_nested(out)
        check_apart(out, "--out", cfg.input_paths())
    size, hint = check_part_mesh(spec, cfg.object.mesh, cfg.object.spec)
    if hint:
        log.warning("mesh %s: %s", cfg.object.mesh, hint)
    if tiny := invisible_keys(seen_with or cfg, spec, size):
        log.warning(tiny)
    return spec, hdris


def check_part_mesh(spec: Spec, mesh: Path | None, spec_path: Path | None) -> tuple[list[float] | None, str | None]:
    """The part checks of ``generate`` and ``spec check``: the spec fits the part (:func:`check_part`) and a mesh
    imports in a throwaway Blender process as a solid part (:func:`check_probe`). Its size (metres) and a hint
    when that suggests the wrong ``units``; (None, None) for the built-in part."""
    check_part(spec, mesh)
    if mesh is None:
        return None, None
    size = check_probe(mesh, probe_mesh(mesh, spec_path))
    return size, units_hint(size, spec)


def versions() -> dict:
    """deformsim's, Python's and the installed packages' versions (``versions.json``)."""
    out = {"deformsim": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def generate(cfg: Config, out: str | Path, progress: bool = True,
             prepared: tuple[Spec, list[str]] | None = None, overwrite: bool = False) -> GenerateResult:
    """:func:`_generate` while holding ``out``'s lock: a second generate into the same folder is refused with one
    line naming the first (:func:`deformsim.outputs.locked`)."""
    prepared = prepared or prepare(cfg, Path(out), overwrite)  # its checks before anything is made
    with locked(out, "generate"):
        return _generate(cfg, out, progress, prepared, overwrite)


def _generate(cfg: Config, out: str | Path, progress: bool, prepared: tuple[Spec, list[str]],
              overwrite: bool) -> GenerateResult:
    """Render ``cfg.generate.n`` images into ``out`` (resuming what is there) and write the manifest.

    ``prepared`` is what :func:`prepare` returned for the same ``cfg`` and ``out``.
    ``overwrite``: a dataset in ``out`` made with other settings or inputs, or more samples, is removed as a
    whole first (else it is refused); the same dataset is resumed.
    """
    t0 = time.perf_counter()
    out = Path(out)
    spec, hdris = prepared
    sweep(out)
    if overwrite and existing_dataset(cfg, out, spec) is not None:
        log.info("--overwrite: removing the dataset in %s", out)
        remove_folder(out)
    layout = Layout(out)
    out.mkdir(parents=True, exist_ok=True)
    files = {"mesh": str(cfg.object.mesh) if cfg.object.mesh else None, "spec": str(cfg.object.spec or ""),
             "hdri": str(cfg.lighting.hdri_dir) if cfg.lighting.hdri_dir else None}
    write_json(layout.inputs, {"kind": "dataset", "inputs": input_digests(cfg, spec), "files": files})
    write_text(layout.config, dump_config(cfg))
    layout.samples_dir.mkdir(parents=True, exist_ok=True)
    write_json(layout.versions, versions())
    remove_partial_files(layout)

    n = n_samples(cfg)
    listed, artwork = listings(cfg), appearance_photos(cfg)
    todo = Todo(n, finished(layout, n), lambda i: sample_params(i, cfg.generate.seed, cfg, spec, hdris, listed, artwork))
    if len(todo) and cfg.deform.sources.uses_bank:
        bake(spec, cfg.object.spec, cfg.object.mesh, progress)  # once; cached for every later run
    views = len(cfg.camera.azimuth_quadrants)
    log.info(
        "generate: %d images (%d samples x %d cameras), %d samples to render, %d already done",
        n * views, n, views, len(todo), len(todo.done),
    )
    result = GenerateResult(images=n * views, rendered=0)
    if len(todo):
        if cfg.generate.backend == "ray":
            from deformsim.generate.ray import run_ray

            failed, device = run_ray(cfg, layout, todo, progress)
        else:
            failed, device = run_local(cfg, layout, todo, progress)
        result.failed, result.device = failed, device
        result.rendered = len(todo) - len(failed)
    if result.failed:
        write_json(out / "failures.json", {str(k): v for k, v in result.failed.items()})
    else:
        (out / "failures.json").unlink(missing_ok=True)  # an earlier run's failures, since rendered
    done = [i for i in range(n) if i not in result.failed]
    if not done:
        full = disk_full(layout, *result.failed.values())
        if full is not None:
            raise full
        first = next(iter(result.failed.values()), "")
        raise ResourceError(f"no sample could be rendered (e.g. {first[:200]}); see {out / 'failures.json'} "
                            f"and {out / 'logs'}")
    consolidate(layout, done)
    if cfg.generate.preview:
        from deformsim.dataset.contact_sheet import contact_sheet

        shown = "surface" if cfg.render.part_alpha_only else "rgba"  # what training will see
        contact_sheet(layout, cfg.generate.preview, cfg.generate.seed, shown)
    result.images = len(done) * views
    result.seconds = time.perf_counter() - t0
    return result
