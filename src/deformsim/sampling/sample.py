"""A whole sample: its label, its main draws (stream "sample") and the optional parts (:mod:`~.draws`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.sampling.draws import draw_appearance, draw_finish, draw_framing, draw_prints, draw_shape, draw_source
from deformsim.sampling.features import draw_features
from deformsim.sampling.params import CameraParams, CanDesign, SampleParams
from deformsim.sampling.streams import stream
from deformsim.sampling.tables import BRAND_WORDS
from deformsim.spec.model import Spec


def label_for(index: int, intact_fraction: float) -> str:
    """Deterministic, evenly spread labels: any prefix of samples is as balanced as possible."""
    intact = int(np.floor((index + 1) * intact_fraction)) - int(np.floor(index * intact_fraction))
    return "intact" if intact else "deformed"


def allowed_families(cfg: Config, spec: Spec) -> list[int]:
    """Indices of the spec's families a run may use (``deform.use_families``; default: all)."""
    names = [f.name for f in spec.families]
    if cfg.deform.use_families is None:
        return list(range(len(names)))
    unknown = [f for f in cfg.deform.use_families if f not in names]
    if unknown:
        raise UserError(f"deform.use_families: unknown family '{unknown[0]}' (spec '{spec.name}' has: {', '.join(names)})")
    if not cfg.deform.use_families:
        raise UserError("deform.use_families is empty: name at least one family or leave it out")
    return [names.index(f) for f in cfg.deform.use_families]


def sample_params(index: int, seed: int, cfg: Config, spec: Spec, hdris: list[str],
                  listed: dict[str, list[str] | None] | None = None, artwork: list[str] | None = None) -> SampleParams:
    """Draw sample ``index`` of a run seeded ``seed``. ``hdris`` are the available HDRI names; ``listed``: the
    render features' input files (:func:`~deformsim.sampling.features.listings`), ``artwork``: the appearance
    photos (:func:`artwork_photos`; each listed here when None and the config uses them)."""
    if not hdris:
        raise ValueError("no HDRI available")
    label = label_for(index, cfg.generate.intact_fraction)
    pair = index - index % 2 if cfg.generate.paired else index  # the twins 2k (deformed) and 2k + 1 (intact)
    rng = stream("sample", seed, pair)
    keys = {k: 0.0 for k in spec.key_names}
    disp = {t: 0.0 for t in spec.texture_names}
    families: tuple[str, ...] = ()
    extent = 0.0

    # Always draw the deformation so that every later draw uses the same stream position for both labels.
    d = cfg.deform
    allowed = allowed_families(cfg, spec)
    lo, hi = d.families
    hi = min(hi, len(allowed))
    k = int(rng.integers(min(lo, hi), hi + 1))
    weights = np.array([spec.families[f].weight for f in allowed])
    p = None if (weights == weights[0]).all() else weights / weights.sum()  # equal weights: the uniform draw
    chosen = sorted(rng.choice(allowed, size=k, replace=False, p=p).tolist())
    fam_w = rng.uniform(0.05, 1.0, size=k)
    draw_extent = float(rng.uniform(*d.extent))
    fam_w = fam_w / fam_w.sum() * draw_extent
    mixes = [rng.dirichlet(np.ones(len(spec.families[f].keys))) for f in chosen]
    disp_w = rng.uniform(0.05, 1.0, size=len(disp))
    disp_scale = float(rng.uniform(*d.displacement))
    bank, bank_amount = "", 0.0
    if label == "deformed":
        source, bank, bank_amount = draw_source(pair, seed, cfg, spec)
        if source != "bank":
            families = tuple(spec.families[f].name for f in chosen)
            extent = draw_extent
            for f, w, mix in zip(chosen, fam_w, mixes):
                for key, m in zip(spec.families[f].keys, mix):
                    keys[key.name] = float(w * m)
        if bank:
            families += (bank.split("/")[0],)
        if disp:
            disp_w = disp_w / disp_w.sum() * disp_scale
            disp = {t: float(v) for t, v in zip(disp, disp_w)}

    seal = float(rng.uniform(0, 1)) if spec.openings.seal else 0.0
    tab = float(seal * rng.uniform(0, 1)) if spec.openings.tab else 0.0

    lighting = cfg.lighting
    hdri = hdris[int(rng.integers(len(hdris)))]
    rotation = float(rng.uniform(*lighting.rotation))
    strength = float(rng.uniform(*lighting.strength))

    cam = cfg.camera
    cameras = tuple(
        CameraParams(
            azimuth=float(rng.uniform(*quad)),
            polar=float(rng.uniform(*polar)),
            radius=float(rng.uniform(*cam.radius)),
        )
        for quad, polar in zip(cam.azimuth_quadrants, cam.polars)
    )

    design = None
    if spec.builtin == "can":
        design = CanDesign(
            hue=float(rng.uniform(0, 1)),
            saturation=float(rng.uniform(0.35, 1.0)),
            value=float(rng.uniform(0.25, 0.95)),
            accent_hue=float(rng.uniform(0, 1)),
            bands=int(rng.integers(1, 5)),
            band_seed=int(rng.integers(2**31)),
            word=BRAND_WORDS[int(rng.integers(len(BRAND_WORDS)))],
        )
    material = None
    if spec.material is not None:
        material = draw_finish(rng, spec.material)
        if spec.material.regions:
            regions = stream("regions", seed, pair)
            material = replace(material, regions=tuple(draw_finish(regions, r) for r in spec.material.regions))
        material = draw_prints(pair, seed, spec.material, material)

    pose_tilt = float(rng.uniform(*cfg.pose.tilt))
    pose_axis = float(rng.uniform(0, 360))
    if cfg.pose.mode == "drop":  # drawn all the same, so every later draw is where it is in tilt mode
        pose_tilt = pose_axis = 0.0

    return SampleParams(
        index=index,
        seed=seed,
        label=label,
        families=families,
        keys=keys,
        displacement=disp,
        seal=seal,
        tab=tab,
        hdri=hdri,
        hdri_rotation=rotation,
        hdri_strength=strength,
        cameras=draw_framing(pair, seed, cfg, cameras),
        design=design,
        material=material,
        extent=extent,
        pose_tilt=pose_tilt,
        pose_axis=pose_axis,
        bank=bank,
        bank_amount=bank_amount,
        shape=draw_shape(pair, seed, cfg, spec),
        appearance=draw_appearance(pair, seed, cfg, spec, artwork),
        pair=pair if cfg.generate.paired else None,
        **draw_features(pair, seed, cfg, spec, cameras, listed),
    )
