"""Empty scene, Cycles settings (deterministic, exact-alpha RGBA PNG output, CPU or GPU device) and one render."""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np
from PIL import Image

from deformsim.config import RenderConfig
from deformsim.errors import UserError

GPU_BACKENDS = ("OPTIX", "CUDA", "HIP", "ONEAPI", "METAL")
SEED = 0


def reset() -> None:
    """Start from Blender's empty factory scene."""
    bpy.ops.wm.read_factory_settings(use_empty=True)


def _enable_gpu() -> str | None:
    """Enable every device of the first GPU backend that has one; return its description, or None."""
    prefs = bpy.context.preferences.addons["cycles"].preferences
    for backend in GPU_BACKENDS:
        try:
            prefs.compute_device_type = backend
        except TypeError:  # backend not compiled into this build
            continue
        prefs.refresh_devices()
        gpus = [d for d in prefs.get_devices_for_type(backend) if d.type != "CPU"]
        if gpus:
            for d in prefs.get_devices_for_type(backend):
                d.use = d.type != "CPU"
            return f"GPU {backend}: " + ", ".join(d.name for d in gpus)
    prefs.compute_device_type = "NONE"
    return None


def configure_cycles(scene, render_cfg: RenderConfig, threads: int = 0) -> str:
    """Set up Cycles from ``render_cfg``; return a one-line description of the device used.

    ``threads`` = 0 lets Cycles use every core. Raises UserError when ``device: gpu`` finds no GPU.
    """
    scene.render.engine = "CYCLES"
    cy = scene.cycles
    gpu = _enable_gpu() if render_cfg.device in ("auto", "gpu") else None
    if render_cfg.device == "gpu" and gpu is None:
        raise UserError(f"render.device=gpu but no GPU was found (tried {', '.join(GPU_BACKENDS)})")
    cy.device = "GPU" if gpu else "CPU"
    cy.samples = render_cfg.samples
    cy.seed = SEED
    cy.use_animated_seed = False
    _quality(cy, render_cfg, bool(gpu))
    if scene.world is not None:  # the HDRI's light importance map, rebuilt whenever the world changes
        scene.world.cycles.sampling_method = "MANUAL" if render_cfg.world_map else "AUTOMATIC"
        scene.world.cycles.sample_map_resolution = render_cfg.world_map or 1024
    scene.render.resolution_x = scene.render.resolution_y = render_cfg.resolution
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.render.dither_intensity = 0.0  # exact flat colours in 8-bit output
    scene.render.use_persistent_data = True
    scene.render.threads_mode = "FIXED" if threads else "AUTO"
    if threads:
        scene.render.threads = threads
    scene.render.use_stamp = False
    for attr in dir(scene.render):  # no render date/time in the file: equal inputs give equal bytes
        if attr.startswith("use_stamp_"):
            setattr(scene.render, attr, False)
    img = scene.render.image_settings
    img.file_format = "PNG"
    img.color_mode = "RGBA"
    img.color_depth = "8"
    img.compression = 15
    # Standard view (the default): linear (0, 1, 0) is written as sRGB (0, 255, 0), so rendered green is exact.
    # The filmic transforms roll highlights off; the background variants stay exact (render.py sets uncovered
    # pixels and composites over the alpha), only pixels the object covers change.
    scene.view_settings.view_transform = render_cfg.view_transform
    scene.view_settings.look = look_name(render_cfg.view_transform, render_cfg.look)
    threads_txt = f"{threads} threads" if threads else "auto threads"
    return gpu or f"CPU ({threads_txt})"


def look_name(view_transform: str, look: str) -> str:
    """Blender's name of contrast ``look`` under ``view_transform``: AgX's looks carry its prefix and call the
    medium one "Base Contrast"."""
    if look == "None" or view_transform != "AgX":
        return look
    return "AgX - " + ("Base Contrast" if look == "Medium Contrast" else look)


def _quality(cy, r: RenderConfig, gpu: bool) -> None:
    """Sampling, light paths, clamping, denoiser and tiles: every speed/quality setting of ``r``."""
    cy.use_adaptive_sampling = r.adaptive
    cy.adaptive_threshold = r.adaptive_threshold
    cy.adaptive_min_samples = r.adaptive_min_samples
    cy.max_bounces = r.max_bounces
    cy.diffuse_bounces = r.diffuse_bounces
    cy.glossy_bounces = r.glossy_bounces
    cy.transmission_bounces = r.transmission_bounces
    cy.transparent_max_bounces = r.transparent_bounces
    cy.volume_bounces = r.volume_bounces
    cy.caustics_reflective = r.caustics_reflective
    cy.caustics_refractive = r.caustics_refractive
    cy.sample_clamp_direct = r.clamp_direct
    cy.sample_clamp_indirect = r.clamp_indirect
    cy.use_denoising = r.denoise
    if r.denoise:
        cy.denoiser = "OPENIMAGEDENOISE"
        cy.denoising_use_gpu = gpu
        cy.denoising_input_passes = r.denoise_input.upper()
        cy.denoising_prefilter = r.denoise_prefilter.upper()
        cy.denoising_quality = r.denoise_quality.upper()
    cy.use_auto_tile = True
    cy.tile_size = r.tile_size


def render_to_array(scene, target: Path) -> tuple[np.ndarray, float]:
    """Render the scene's camera into a temporary PNG beside ``target``; return (uint8 pixels, seconds)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.render.", suffix=".png", dir=target.parent)
    os.close(fd)
    try:
        scene.render.filepath = tmp
        t0 = time.perf_counter()
        bpy.ops.render.render(write_still=True)
        seconds = time.perf_counter() - t0
        with Image.open(tmp) as im:
            pixels = np.array(im.convert("RGBA" if scene.render.film_transparent else "RGB"))
    finally:
        Path(tmp).unlink(missing_ok=True)
    return pixels, seconds
