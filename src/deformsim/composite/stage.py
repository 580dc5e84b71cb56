"""The composite stage: matte every rendered image, put it on a background, write a named variant.

A variant is ``OUT/variants/NAME/`` with ``images/ID.png``, ``manifest.parquet`` (``id``, ``image`` and what
went into each composite) and ``composite.json`` (the settings); for a dataset with dense maps also
``{mask,deform,region}/ID.png``, moved exactly like the part (:mod:`deformsim.composite.maps`). Each image
draws from its own streams (:mod:`deformsim.sampling.streams`, keyed by the image id), so the result does not depend
on the number of workers. The variant is built in a staging folder beside it and swapped in only when complete
(:func:`deformsim.outputs.replacing`); workers end with the run, and the next run removes the staging folder of one
that was killed. Optional steps, each recorded
per image: a class-balanced choice of background photo, framing around the object
(:mod:`deformsim.composite.framing`), a left-right flip of the part (``flip_part``, from a stream of its own)
and camera effects (:mod:`deformsim.composite.effects`). With ``composite.surface`` a share of the images (drawn
per image from a stream of its own) shows the dataset's rendered surface scene (``render.surface``) instead:
no matte and no background, framed, flipped and with effects like the rest. With the alpha matte, a dataset rendered with
``render.shadow`` also gets the part's shadow: the background behind the part is multiplied by
``1 - strength * shadow`` (the shadow map moved like the part, bilinear; ``strength`` drawn per image from
``shadow_strength``, from a stream of its own) before the part is laid over it. The chroma keys ignore it.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np
import pandas as pd

from deformsim.atomic import write_json
from deformsim.composite.backgrounds import (
    PROCEDURAL_KINDS,
    fit,
    load_photo,
    photos_digest,
    procedural,
    scan_backgrounds,
    warn_skipped,
)
from deformsim.composite.effects import apply_effects
from deformsim.composite.framing import frame_matrix, warp
from deformsim.composite.maps import MAP_KINDS, move_maps, read_maps, write_maps
from deformsim.composite.matte import alpha_matte, binary_iou, chroma_matte, inrange_matte
from deformsim.config import VARIANT_NAME, CompositeConfig
from deformsim.dataset.layout import RENDER_KINDS, SHADOW_KIND, SURFACE_KIND, Layout, image_id
from deformsim.dataset.manifest import read_manifest
from deformsim.dataset.paths import dataset_resolver
from deformsim.dataset.variants import VARIANT_MANIFEST
from deformsim.errors import UserError
from deformsim.log import progress_bar
from deformsim.outputs import replacing
from deformsim.parallel import worker_count
from deformsim.pool import Pool
from deformsim.sampling.streams import stable_int, stream
from deformsim.schema import MAX_SEED, shown

_NAME = re.compile(VARIANT_NAME)


SETTINGS_FILE = "composite.json"


def variant_settings(name: str, seed: int, cfg: CompositeConfig) -> dict:
    """What a variant's ``composite.json`` records: its name, seed and compositing settings, and the contents of the
    background photos (``backgrounds_digest``), so that a changed photo is never taken for the one composited."""
    return {"name": name, "seed": seed, **cfg.model_dump(mode="json"), "backgrounds_digest": photos_digest(cfg.backgrounds)}


def default_name(cfg: CompositeConfig) -> str:
    return "backgrounds" if cfg.backgrounds else "procedural"


@dataclass(frozen=True)
class Composited:
    """A variant just made: its folder, its number of images, how many of them show a rendered surface scene, and
    the IoU of each matte compared with the exact alpha (the chroma mattes of a dataset rendered with it)."""

    folder: Path
    images: int
    surfaces: int
    matte_iou: list[float]


def composite(root: Path, cfg: CompositeConfig, name: str | None = None, seed: int = 0,
              progress: bool = True) -> Composited:
    """Composite every image of the dataset at ``root`` onto backgrounds into a variant folder.

    Inputs are checked before any work (:class:`UserError`); an existing variant of the same name is
    replaced only when the new one is complete.
    """
    if not (isinstance(seed, int) and 0 <= seed <= MAX_SEED):
        raise UserError(f"--seed {shown(seed)}: a seed is a whole number from 0 to {MAX_SEED}")
    layout = Layout(Path(root))
    manifest = read_manifest(layout.root)
    name = name or default_name(cfg)
    if not _NAME.match(name) or name in RENDER_KINDS:
        raise UserError(f"invalid variant name {name!r}: letters, digits, '_-.' and not {'/'.join(RENDER_KINDS)}")
    photos = [str(p) for p in scan_backgrounds(cfg.backgrounds)] if cfg.backgrounds else []
    source = "rgba" if cfg.matte == "alpha" else "green"
    jobs = _jobs(layout, manifest, source, shadows=cfg.matte == "alpha", surfaces=cfg.surface > 0)
    if cfg.surface < 1 and not _part_in_colour(layout):
        raise UserError(f"dataset {layout.root} was rendered with render.surface.part_colour: false, so only its "
                        f"surface scenes are training images: set composite.surface to 1, not {cfg.surface:g}")
    twins = twin_ids(manifest)
    if photos and cfg.balance_backgrounds:
        first = balanced_photos(manifest["id"].tolist(), manifest["y"].tolist(), len(photos), seed)
        jobs = [replace(job, photo=first[twins.get(job.iid, job.iid)]) for job in jobs]  # a twin's photo: its twin's

    final = layout.variant_dir(name)
    with replacing(final) as tmp:
        (tmp / "images").mkdir()
        plan = Plan(cfg, seed, photos, str(tmp / "images"), f"variants/{name}/images", str(tmp), f"variants/{name}",
                    twins)
        rows, bad = _run(jobs, plan, worker_count(len(jobs), cfg.workers, most=8, jobs_each=16), progress)
        for path, reason in sorted(bad.items()):
            warn_skipped(Path(path), reason)
        if photos:
            base = Path(cfg.backgrounds)
            for r in rows:
                if r["background"] != SURFACE_KIND:
                    r["background"] = str(Path(r["background"]).relative_to(base))
        df = pd.DataFrame(rows).sort_values("id").reset_index(drop=True)
        df.to_parquet(tmp / VARIANT_MANIFEST, index=False)
        write_json(tmp / SETTINGS_FILE, variant_settings(name, seed, cfg))
    surfaces = int((df["background"] == SURFACE_KIND).sum()) if "background" in df else 0
    return Composited(final, len(df), surfaces, df["matte_iou"].dropna().tolist())


def _part_in_colour(layout: Layout) -> bool:
    """Whether the dataset's images of the part alone are in colour (all but ``render.surface.part_colour: false``,
    read from its config.yaml; a dataset without one predates the setting)."""
    from deformsim.schema import read_mapping

    if not layout.config.is_file():
        return True
    surface = (read_mapping(layout.config, "config").get("render") or {}).get("surface") or {}
    return surface.get("part_colour", True) is not False


def twin_ids(manifest: pd.DataFrame) -> dict[str, str]:
    """Image id -> the id of the image whose composite draws it shares: its deformed twin's, in a dataset drawn with
    ``generate.paired`` (column ``pair``); empty otherwise."""
    if "pair" not in manifest.columns:
        return {}
    twins = {iid: image_id(int(pair), int(camera)) for iid, pair, camera in
             zip(manifest["id"], manifest["pair"], manifest["camera"])}
    return {iid: twin for iid, twin in twins.items() if twin != iid}


def balanced_photos(ids: list[str], labels: list[int], n_photos: int, seed: int) -> dict[str, int]:
    """Image id -> photo index, each photo used equally often (to within one) behind every class."""
    rng = stream("balance", seed)
    out = {}
    for y in sorted(set(labels)):
        members = sorted((i for i, label in zip(ids, labels) if label == y), key=stable_int)
        photos = rng.permutation(n_photos)
        for k, j in enumerate(rng.permutation(len(members))):
            out[members[j]] = int(photos[k % n_photos])
    return out


@dataclass(frozen=True)
class Job:
    """One image to composite: its id, source image, exact-alpha render, dense maps, shadow map and rendered surface
    scene (each None when the dataset has none), and the background photo assigned to it (index; None: drawn)."""

    iid: str
    src: str
    exact: str | None = None
    maps: dict[str, str] | None = None
    shadow: str | None = None
    scene: str | None = None
    photo: int | None = None


def _jobs(layout: Layout, manifest: pd.DataFrame, source: str, shadows: bool = False,
          surfaces: bool = False) -> list[Job]:
    """A :class:`Job` per image, its files all checked to exist; ``shadows``: use the shadow maps where the dataset has
    them; ``surfaces``: the dataset must have surface scenes (``render.surface``)."""
    if manifest.empty:
        raise UserError(f"dataset {layout.root} has no images")
    missing = {"id", "y", source} - set(manifest.columns)
    if missing:
        raise UserError(f"manifest of {layout.root} lacks column(s) {', '.join(sorted(missing))}: composite needs "
                        f"its {source} renders")
    if surfaces and SURFACE_KIND not in manifest.columns:
        raise UserError(f"composite.surface needs surface scenes, and dataset {layout.root} was rendered without "
                        "render.surface: render it with render.surface, or set composite.surface to 0")
    dense = "mask" in manifest.columns
    jobs = []
    resolve = dataset_resolver(layout.root)
    for i, row in enumerate(manifest.itertuples(index=False)):
        def file(col: str, row=row, i=i) -> Path:
            return resolve(getattr(row, col), f"manifest row {i} ({col})")

        src = file(source)
        if not src.is_file():
            raise UserError(f"image missing: {src} (is the dataset at {layout.root} complete?)")
        exact = file("rgba") if "rgba" in manifest.columns else None
        maps = {k: file(k) for k in MAP_KINDS} if dense else None
        for path in (maps or {}).values():
            if not path.is_file():
                raise UserError(f"dense map missing: {path} (is the dataset at {layout.root} complete?)")
        shadow = file(SHADOW_KIND) if shadows and SHADOW_KIND in manifest.columns else None
        if shadow is not None and not shadow.is_file():
            raise UserError(f"shadow map missing: {shadow} (is the dataset at {layout.root} complete?)")
        scene = file(SURFACE_KIND) if surfaces else None
        if scene is not None and not (scene.is_file() and exact is not None and exact.is_file()):
            raise UserError(f"surface scene or its rgba render missing: {scene} (is the dataset at {layout.root} "
                            "complete?)")
        jobs.append(Job(row.id, str(src), str(exact) if exact is not None and exact.is_file() else None,
                        {k: str(p) for k, p in maps.items()} if maps else None, str(shadow) if shadow else None,
                        str(scene) if scene else None))
    return jobs


def _run(jobs: list[Job], plan: Plan, workers: int, progress: bool) -> tuple[list[dict], dict[str, str]]:
    """The manifest rows of ``jobs`` composited by ``workers`` processes, and the photos that could not be read
    (path -> why)."""
    size = max(1, min(32, len(jobs) // (workers * 4) or 1))
    rows, bad = [], {}
    with progress_bar(len(jobs), "composite", progress) as bar, \
            Pool(plan.worker, workers, processes=True, setup=_one_thread) as pool:
        for done in pool.map(jobs, chunk=size):
            rows.append(done.row)
            bad.update(done.skipped)
            bar.update(1)
    return rows, bad


def _one_thread() -> None:
    cv2.setNumThreads(1)  # the pool is the parallelism


@dataclass(frozen=True)
class Plan:
    """What every worker composites with: the settings, seed and photos, where the images (``out``, manifest paths
    ``prefix``) and dense maps go, and each image's twin whose draws it makes (:func:`twin_ids`)."""

    cfg: CompositeConfig
    seed: int
    photos: list[str]
    out: str
    prefix: str
    maps_out: str
    maps_prefix: str
    twins: dict[str, str]

    def worker(self, slot: int) -> Compositor:
        return Compositor(self)


class Outcome(NamedTuple):
    """One composited image: its manifest row and the photos it could not read."""

    row: dict  # the image's manifest row
    skipped: dict[str, str]  # background photos that could not be read: path -> why


@dataclass
class Compositor:
    """One worker: composites a :class:`Job` at a time after :class:`Plan`."""

    plan: Plan
    bad: dict[str, str] = field(default_factory=dict)  # the photos the current job could not read

    def __call__(self, job: Job) -> Outcome:
        """Matte, background and composite one image; writes it (and its moved maps). ``job.shadow``: the part's
        shadow map (alpha matte only); ``job.scene``: the rendered surface scene, shown whole instead with
        probability ``composite.surface``."""
        self.bad = {}
        iid, src, exact, maps, shadow, scene, photo = (job.iid, job.src, job.exact, job.maps, job.shadow, job.scene,
                                                       job.photo)
        draws = self.plan.twins.get(iid, iid)
        cfg, rng = self.plan.cfg, stream("image", self.plan.seed, stable_int(draws))
        if scene is not None and use_surface(self.plan.seed, draws, cfg.surface):
            return Outcome(self._surface_one(iid, scene, exact, maps, rng, cfg), self.bad)
        if cfg.matte == "alpha":
            alpha, fg = alpha_matte(_read(src, cv2.IMREAD_UNCHANGED))
            iou = float("nan")
        else:
            key = chroma_matte if cfg.matte == "chroma" else inrange_matte
            alpha, fg = key(_read(src, cv2.IMREAD_COLOR), cfg)
            iou = binary_iou(alpha, _read(exact, cv2.IMREAD_UNCHANGED)[..., 3] / 255.0) if exact else float("nan")
        h, w = alpha.shape
        dense = read_maps(maps, (h, w)) if maps else None
        shade = read_shadow(shadow, (h, w)) if shadow else None
        bg, info = self._background(rng, cfg, h, w, photo)
        fg, alpha, shade = self._move_part(iid, alpha, [fg, alpha, shade], dense, rng, cfg, info)
        alpha = np.clip(alpha, 0, 1)
        shade = np.clip(shade, 0, 1) if shade is not None else None
        bg = bg.astype(np.float32)
        if shade is not None:
            strength = shadow_strength(self.plan.seed, draws, cfg.shadow_strength)
            bg = bg * (1.0 - strength * shade)[..., None]
            info["shadow_strength"] = strength
        out = fg + (1.0 - alpha)[..., None] * bg
        return Outcome(self._finish(iid, out, rng, cfg, {"matte": cfg.matte, **info}, iou), self.bad)

    def _surface_one(self, iid: str, scene: str, exact: str, maps: dict[str, str] | None, rng: np.random.Generator,
                     cfg: CompositeConfig) -> dict:
        """One image that shows the rendered surface scene whole: framed around the part (its box from the exact
        alpha), flipped and given camera effects like a composite, with no matte and no background."""
        img = _read(scene, cv2.IMREAD_COLOR).astype(np.float32)
        alpha = _read(exact, cv2.IMREAD_UNCHANGED)[..., 3].astype(np.float32) / 255.0
        h, w = alpha.shape
        if img.shape[:2] != (h, w):
            raise UserError(f"surface scene {scene} is {img.shape[1]}x{img.shape[0]}, its render {w}x{h}")
        dense = read_maps(maps, (h, w)) if maps else None
        info: dict = {"background": SURFACE_KIND}
        (img,) = self._move_part(iid, alpha, [img], dense, rng, cfg, info)
        return self._finish(iid, img, rng, cfg, {"matte": "none", **info}, float("nan"))

    def _move_part(self, iid: str, alpha: np.ndarray, layers: list, dense: dict | None, rng: np.random.Generator,
                   cfg: CompositeConfig, info: dict) -> list:
        """``layers`` (images or None) framed around the part whose alpha is ``alpha`` (``composite.object_fill``) and
        mirrored with it (``flip_part``); the dense maps are moved alike and written; both are recorded in ``info``."""
        m = None
        if cfg.object_fill is not None:
            m, frame = frame_matrix(alpha, cfg.object_fill, cfg.fill_offset, rng)
            layers = [warp(x, m) if x is not None else None for x in layers]
            info.update(frame)
        flip = part_flip(self.plan.seed, self.plan.twins.get(iid, iid), cfg.flip_part)
        if flip:
            layers = [x[:, ::-1] if x is not None else None for x in layers]
        info["part_flip"] = flip
        if dense:
            info.update(write_maps(move_maps(dense, m, flip), self.plan.maps_out, self.plan.maps_prefix, iid))
        return layers

    def _finish(self, iid: str, img: np.ndarray, rng: np.random.Generator, cfg: CompositeConfig, info: dict,
                iou: float) -> dict:
        """Round ``img`` to 8 bits, add the camera effects, write it; return its manifest row (``iou``: the matte's)."""
        out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
        if cfg.effects is not None:
            out, fx = apply_effects(out, cfg.effects, rng)
            info.update(fx)
        if not cv2.imwrite(os.path.join(self.plan.out, f"{iid}.png"), cv2.cvtColor(out, cv2.COLOR_RGB2BGR)):
            raise OSError(f"cannot write composite of {iid} to {self.plan.out}")
        return {"id": iid, "image": f"{self.plan.prefix}/{iid}.png", **info, "matte_iou": iou}

    def _background(self, rng: np.random.Generator, cfg: CompositeConfig, h: int, w: int,
                    photo_index: int | None) -> tuple[np.ndarray, dict]:
        photos = self.plan.photos
        if not photos:
            kind, sub = PROCEDURAL_KINDS[int(rng.integers(len(PROCEDURAL_KINDS)))], int(rng.integers(2**31))
            info = {"background": f"procedural:{kind}:{sub}", "bg_x": 0.0, "bg_y": 0.0, "bg_scale": 1.0, "bg_flip": False}
            return procedural(kind, sub, h, w), info
        first = int(rng.integers(len(photos)))  # drawn even when assigned, so later draws stay where they were
        first = first if photo_index is None else photo_index
        smax = cfg.scale_jitter[1]
        for k in range(len(photos)):  # a corrupt photo deterministically falls through to the next one
            path = photos[(first + k) % len(photos)]
            try:
                photo = load_photo(path, math.ceil(w * smax), math.ceil(h * smax))
            except Exception as exc:  # PIL raises many types for corrupt data
                self.bad[path] = str(exc) or type(exc).__name__
                continue
            bg, info = fit(photo, h, w, rng, cfg.scale_jitter, cfg.flip)
            return bg, {"background": path, **info}
        raise UserError("no background photo could be decoded: " + ", ".join(sorted(self.bad)))

def _read(path: str, flags: int) -> np.ndarray:
    """An 8-bit RGB image (``cv2.IMREAD_COLOR``) or the render's 8-bit RGBA (``cv2.IMREAD_UNCHANGED``)."""
    try:
        img = cv2.imread(path, flags)
    except cv2.error:  # larger than OpenCV reads
        img = None
    channels = 4 if flags == cv2.IMREAD_UNCHANGED else 3
    if img is None or img.dtype != np.uint8 or img.ndim != 3 or img.shape[2] != channels:
        what = "an 8-bit RGBA render" if channels == 4 else "an 8-bit image"
        raise UserError(f"cannot read image {path} as {what}")
    return cv2.cvtColor(img, cv2.COLOR_BGRA2RGBA if channels == 4 else cv2.COLOR_BGR2RGB)


def use_surface(seed: int, iid: str, p: float) -> bool:
    """Whether image ``iid`` shows its rendered surface scene: probability ``p``, from stream "scene"."""
    return bool(p >= 1 or (p > 0 and stream("scene", seed, stable_int(iid)).random() < p))


def part_flip(seed: int, iid: str, p: float) -> bool:
    """Whether image ``iid`` shows its part mirrored: probability ``p``, from stream "flip"."""
    return bool(p > 0 and stream("flip", seed, stable_int(iid)).random() < p)


def shadow_strength(seed: int, iid: str, r: tuple[float, float]) -> float:
    """How strongly image ``iid``'s shadow darkens the background: uniform in ``r``, from stream "shadow"."""
    return float(r[0]) if r[0] == r[1] else float(stream("shadow", seed, stable_int(iid)).uniform(*r))


def read_shadow(path: str, shape: tuple[int, int]) -> np.ndarray:
    """A shadow map (8-bit opacity, :mod:`deformsim.blender.scene.shadow`) as float32 in 0..1, checked to be ``shape``."""
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None or img.ndim != 2:
        raise UserError(f"cannot read shadow map {path} (a single-channel PNG is expected)")
    if img.shape != shape:
        raise UserError(f"shadow map {path} is {img.shape[1]}x{img.shape[0]}, its render {shape[1]}x{shape[0]}")
    return img.astype(np.float32) / 255.0
