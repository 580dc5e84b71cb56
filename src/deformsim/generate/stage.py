"""`deformsim generate`: render a labelled intact/deformed dataset with a pool of Blender workers.

The orchestrator never imports bpy. It validates every input before work starts, draws each sample's
parameters (pure, by index), hands indices to worker processes, writes each finished sample's record
atomically, and consolidates the manifest at the end. Rerunning on the same folder resumes: finished samples
are skipped, so the result is the same as an uninterrupted run's whatever the number of workers.

A dataset records what it is rendered from in ``inputs.json``: the sha256 of the mesh file's bytes, of the
parsed spec and of the HDRI files. A folder rendered with other settings or inputs, or holding more samples
than ``generate.n`` asks for, is refused with one line (``--overwrite`` replaces it as a whole), so a dataset is
never a mix of two parts, two specs or two sizes.
"""

from __future__ import annotations

import hashlib
import json
import platform
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import yaml

from deformsim.atomic import write_json, write_text
from deformsim.bank.stage import bake
from deformsim.bank.store import bank_key
from deformsim.config import Config, dump_config
from deformsim.dataset.images import open_rgb
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import consolidate, read_record
from deformsim.errors import ResourceError, UserError
from deformsim.generate.backend import disk_full, remove_partial_files
from deformsim.generate.local import run_local
from deformsim.generate.probe import probe_mesh
from deformsim.hdri import hdri_files, list_hdris
from deformsim.identity import digest, file_digest, files_digest
from deformsim.log import get_logger
from deformsim.outputs import check_folder_target, read_inputs, remove_folder
from deformsim.sampling import allowed_families, sample_params, surface_photos
from deformsim.spec.model import Spec, check_mesh_file, load_spec, units_hint
from deformsim.version import __version__

log = get_logger(__name__)

# Settings that do not change what is rendered: a resumed run may differ in these.
_RUN_ONLY = {"generate": {"n", "workers", "recycle_every", "max_retries", "backend", "address", "gather", "preview"}}
_DATA_SECTIONS = ("object", "camera", "pose", "lighting", "deform", "render", "generate")
# Bumped whenever the Blender side renders the same settings differently (2: the can's lid and bottom are
# aluminium again), so no dataset mixes or reuses renders of an older renderer.
RENDERER = 2
_PACKAGES = ("bpy", "numpy", "pydantic", "pandas", "pyarrow", "pillow", "opencv-python-headless", "torch", "torchvision")


@dataclass
class GenerateResult:
    images: int
    rendered: int  # samples rendered by this run (the rest were resumed)
    failed: dict[int, str] = field(default_factory=dict)
    seconds: float = 0.0
    device: str = ""


def data_settings(cfg: Config) -> dict:
    """The part of a config that determines the rendered data."""
    d = cfg.model_dump(mode="json")
    out = {k: d[k] for k in _DATA_SECTIONS}
    for section, keys in _RUN_ONLY.items():
        out[section] = {k: v for k, v in out[section].items() if k not in keys}
    if out["pose"]["mode"] == "tilt":  # the drop settings (added later) do not change tilt-mode data: keep its identity
        out["pose"] = {k: v for k, v in out["pose"].items() if k == "tilt"}
    for section, off in _ADDED_LATER.items():  # so are options added later, while off: older datasets keep theirs
        out[section] = {k: v for k, v in out[section].items() if k not in off or v != off[k]}
    return out


# Options added after datasets were made, and their "off" values: left out of the identity while off.
_ADDED_LATER = {"camera": {"fill": None, "offset": 0.0, "partial": 0.0, "fstop": None}, "render": {"surface": None}}


def n_samples(cfg: Config) -> int:
    return cfg.generate.n // len(cfg.camera.azimuth_quadrants)


def input_digests(cfg: Config, spec: Spec | None = None) -> dict:
    """What the renders are made from, by content: sha256 of the mesh file, of the parsed spec (so a comment
    or a reformatting does not count, a changed range does), of the HDRI files, and the simulated bank's key
    when the samples use it."""
    spec = spec or load_spec(cfg.object.spec)
    mesh = cfg.object.mesh
    if mesh is not None:
        check_mesh_file(mesh)
    hdri = cfg.lighting.hdri_dir
    return {
        "renderer": RENDERER,
        "mesh": file_digest(mesh) if mesh is not None else None,
        "spec": hashlib.sha256(json.dumps(spec.model_dump(mode="json"), sort_keys=True).encode()).hexdigest(),
        "hdri": files_digest(list(hdri_files(hdri).values()), hdri) if hdri is not None else None,
        "bank": bank_key(spec, mesh) if cfg.deform.sources.uses_bank and spec.simulation else None,
        **({"surface": files_digest(photos, cfg.render.surface.photos)} if (photos := texture_photos(cfg)) else {}),
    }


def texture_photos(cfg: Config) -> list[str] | None:
    """The surface texture photos the config draws from (``render.surface`` with kind photo), else None."""
    s = cfg.render.surface
    return surface_photos(s.photos) if s is not None and "photo" in s.kinds else None


def data_identity(cfg: Config, spec: Spec | None = None) -> dict:
    """The settings and input contents that determine the rendered data (``generate.n`` aside)."""
    return {"settings": data_settings(cfg), "inputs": input_digests(cfg, spec)}


def data_name(cfg: Config, spec: Spec | None = None) -> str:
    """A dataset folder name for ``cfg``: ``data-`` and a digest of :func:`data_identity`."""
    return f"data-{digest(data_identity(cfg, spec))}"


def check_part(spec: Spec, mesh: Path | None) -> None:
    """A spec for the built-in part takes no mesh; any other needs one, of a supported format."""
    if mesh is not None:
        check_mesh_file(mesh)
        if spec.builtin:
            raise UserError(f"spec '{spec.name}' is for the built-in {spec.builtin}, not for mesh {mesh}")
    elif not spec.builtin:
        raise UserError(f"spec '{spec.name}' describes a mesh part: pass the mesh with --object")


def prepare(cfg: Config, out: Path, overwrite: bool = False, spec: Spec | None = None) -> tuple[Spec, list[str]]:
    """Every check that can fail on user input, before any work and before touching ``out``.

    ``out`` must be a new or empty folder, or a dataset of the same settings and inputs with no more samples than
    ``cfg`` asks for (it is resumed); with ``overwrite`` any dataset is accepted (:func:`generate` replaces it).
    ``spec``: ``cfg``'s spec when the caller has loaded it already.
    """
    out = check_folder_target(out, "--out")
    spec = spec or load_spec(cfg.object.spec)
    check_part(spec, cfg.object.mesh)
    allowed_families(cfg, spec)
    if cfg.deform.sources.uses_bank and spec.simulation is None:
        raise UserError(f"deform.sources uses the simulated bank, but spec '{spec.name}' declares no simulation "
                        "scenarios (set deform.sources.bank and .both to 0, or add simulation: to the spec)")
    hdris = list_hdris(cfg.lighting.hdri_dir)
    for photo in texture_photos(cfg) or ():
        try:
            open_rgb(photo, min_size=(1, 1))  # Blender would fail on it mid-run
        except UserError as exc:
            raise UserError(f"render.surface.photos: {exc}") from None
    conflict = existing_dataset(cfg, out, spec)
    if conflict is not None and not overwrite:
        raise UserError(f"{out} {conflict}")
    if conflict is not None:
        check_folder_target(out, "--out", replace=True)  # it is removed as a whole
    if cfg.object.mesh is not None:
        size = probe_mesh(cfg.object.mesh, cfg.object.spec)["size"]
        hint = units_hint(size, spec)
        if hint:
            log.warning("mesh %s: %s", cfg.object.mesh, hint)
    return spec, hdris


_REPLACE = "use a new output folder, or --overwrite to replace it"


def existing_dataset(cfg: Config, out: Path, spec: Spec) -> str | None:
    """Why ``out`` cannot be resumed as ``cfg``'s dataset (None: it is new, empty, or the same dataset).

    A :class:`UserError` when ``out`` holds files but no dataset: such a folder is never replaced.
    """
    out = Path(out)
    if not out.is_dir() or not any(out.iterdir()):
        return None
    layout = Layout(out)
    if not layout.config.is_file():
        raise UserError(f"{out} holds files but no deformsim dataset: choose a new or empty output folder")
    try:
        old_settings = data_settings(Config.model_validate(yaml.safe_load(layout.config.read_text())))
    except Exception:
        return f"holds an unreadable {layout.config.name}: {_REPLACE}"
    new = data_settings(cfg)
    if old_settings != new:
        return f"was generated with other settings ({_first_difference(old_settings, new)}): {_REPLACE}"
    recorded = read_inputs(out)
    if recorded is None or not isinstance(recorded.get("inputs"), dict):
        return f"was generated by an older deformsim that did not record its inputs' contents: {_REPLACE}"
    now = input_digests(cfg, spec)
    for name, what in (("renderer", "renderer revision"), ("mesh", f"mesh {cfg.object.mesh}"),
                       ("spec", f"spec {cfg.object.spec or '(built-in)'}"),
                       ("hdri", f"HDRI folder {cfg.lighting.hdri_dir}"),
                       ("surface", f"surface photo folder {cfg.render.surface and cfg.render.surface.photos}")):
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


def _first_difference(a: dict, b: dict, prefix: str = "") -> str:
    for k in sorted(set(a) | set(b)):
        va, vb = a.get(k), b.get(k)
        if isinstance(va, dict) and isinstance(vb, dict):
            if va != vb:
                return _first_difference(va, vb, f"{prefix}{k}.")
        elif va != vb:
            return f"{prefix}{k}: {va!r} there, {vb!r} now"
    return "?"


def versions() -> dict:
    out = {"deformsim": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def generate(cfg: Config, out: str | Path, progress: bool = True,
             prepared: tuple[Spec, list[str]] | None = None, overwrite: bool = False) -> GenerateResult:
    """Render ``cfg.generate.n`` images into ``out`` (resuming what is there) and write the manifest.

    ``prepared`` is what :func:`prepare` returned for the same ``cfg`` and ``out``, when the caller already ran it.
    ``overwrite``: a dataset in ``out`` made with other settings or inputs, or more samples, is removed as a
    whole first (else it is refused); the same dataset is resumed.
    """
    t0 = time.perf_counter()
    out = Path(out)
    spec, hdris = prepared or prepare(cfg, out, overwrite)
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

    indices = list(range(n_samples(cfg)))
    todo = [i for i in indices if read_record(layout, i) is None]
    if todo and cfg.deform.sources.uses_bank:
        bake(spec, cfg.object.spec, cfg.object.mesh, progress)  # once; cached for every later run
    photos = texture_photos(cfg)
    params = {i: sample_params(i, cfg.generate.seed, cfg, spec, hdris, photos) for i in todo}
    views = len(cfg.camera.azimuth_quadrants)
    log.info(
        "generate: %d images (%d samples x %d cameras), %d samples to render, %d already done",
        len(indices) * views, len(indices), views, len(todo), len(indices) - len(todo),
    )
    result = GenerateResult(images=len(indices) * views, rendered=0)
    if todo:
        if cfg.generate.backend == "ray":
            from deformsim.generate.ray import run_ray

            failed, device = run_ray(cfg, layout, params, progress)
        else:
            failed, device = run_local(cfg, layout, params, progress)
        result.failed, result.device = failed, device
        result.rendered = len(todo) - len(failed)
    if result.failed:
        write_json(out / "failures.json", {str(k): v for k, v in result.failed.items()})
    else:
        (out / "failures.json").unlink(missing_ok=True)  # an earlier run's failures, since rendered
    done = [i for i in indices if i not in result.failed]
    if not done:
        full = disk_full(layout, *result.failed.values())
        if full is not None:
            raise full
        first = next(iter(result.failed.values()), "")
        raise ResourceError(f"no sample could be rendered (e.g. {first[:200]}); see {out / 'failures.json'} "
                            f"and {out / 'logs'}")
    consolidate(layout, done)
    _warn_stale_variants(layout, len(done) * views)
    if cfg.generate.preview:
        from deformsim.dataset.contact_sheet import contact_sheet

        contact_sheet(layout, cfg.generate.preview, cfg.generate.seed)
    result.images = len(done) * views
    result.seconds = time.perf_counter() - t0
    return result


def _warn_stale_variants(layout: Layout, images: int) -> None:
    """Composited variants made before the dataset grew cover only part of it: say so."""
    import pyarrow.parquet as pq

    from deformsim.dataset.variants import VARIANT_MANIFEST

    for manifest in sorted((layout.root / "variants").glob(f"*/{VARIANT_MANIFEST}")):
        try:
            rows = pq.ParquetFile(manifest).metadata.num_rows
        except Exception:  # pyarrow raises several types for corrupt files
            continue
        if rows != images:
            log.warning("variant %s holds %d of the %d images: rerun deformsim composite to update it",
                        manifest.parent.name, rows, images)
