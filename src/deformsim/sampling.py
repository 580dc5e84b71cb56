"""Everything random about a sample, drawn in pure Python (no Blender).

A *sample* is one scene state (object deformation, openings, label, lighting) seen by every camera, so
it yields one image per camera. ``sample_params(i, seed, ...)`` depends only on ``(seed, i)``: samples can
be drawn in any order, by any worker, and a resumed run draws the same ones.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.spec.model import Spec


@dataclass(frozen=True)
class CameraParams:
    azimuth: float  # degrees
    polar: float  # degrees from the up axis
    radius: float  # metres (for the can; scaled with the object's size otherwise)


@dataclass(frozen=True)
class CanDesign:
    """The artwork printed on the can's side wall (drawn by :mod:`deformsim.blender.can_label`)."""

    hue: float
    saturation: float
    value: float
    accent_hue: float
    bands: int
    band_seed: int
    word: str


@dataclass(frozen=True)
class MaterialParams:
    """A user mesh's surface colour and roughness."""

    color: tuple[float, float, float]
    roughness: float


@dataclass(frozen=True)
class SampleParams:
    index: int
    seed: int
    label: str  # "intact" | "deformed"
    families: tuple[str, ...]
    keys: dict[str, float]  # lattice shape-key values, every key of the spec
    displacement: dict[str, float]  # crinkle shape-key values, every texture of the spec
    seal: float
    tab: float
    hdri: str
    hdri_rotation: float  # degrees about the up axis
    hdri_strength: float
    cameras: tuple[CameraParams, ...]
    design: CanDesign | None = None
    material: MaterialParams | None = None
    extent: float = 0.0
    pose_tilt: float = 0.0  # degrees away from upright
    pose_axis: float = 0.0  # azimuth (degrees) of the horizontal axis the object is tilted about
    bank: str = ""  # simulated bank entry "SCENARIO/I" the sample uses ("" = none)
    bank_amount: float = 0.0

    @property
    def deformed(self) -> bool:
        return self.label == "deformed"

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "SampleParams":
        d = dict(d)
        d["families"] = tuple(d["families"])
        d["cameras"] = tuple(CameraParams(**c) for c in d["cameras"])
        d["design"] = CanDesign(**d["design"]) if d.get("design") else None
        if d.get("material"):
            m = d["material"]
            d["material"] = MaterialParams(color=tuple(m["color"]), roughness=m["roughness"])
        return cls(**d)


BRAND_WORDS = ("FIZZ", "COLA", "ZEST", "NOVA", "LIME", "BOLT", "AURA", "PEAK", "WAVE", "SODA", "BREW", "MAX")


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


def rng_for(seed: int, index: int) -> np.random.Generator:
    return np.random.default_rng([seed, index])


def draw_source(index: int, seed: int, cfg: Config, spec: Spec) -> tuple[str, str, float]:
    """(source, bank entry, amount) of a deformed sample: "lattice", "bank" or "both" by ``deform.sources``.

    A stream of its own, so a run that never uses the bank draws exactly what it drew before the bank existed.
    """
    w = cfg.deform.sources
    if not w.uses_bank:
        return "lattice", "", 0.0
    rng = np.random.default_rng([seed, index, 1])
    weights = np.array([w.lattice, w.bank, w.both])
    source = ("lattice", "bank", "both")[int(rng.choice(3, p=weights / weights.sum()))]
    scenario = spec.simulation.scenarios[int(rng.integers(len(spec.simulation.scenarios)))]
    entry = f"{scenario.name}/{int(rng.integers(scenario.variants))}"
    amount = float(rng.uniform(*cfg.deform.bank_amount))
    return (source, entry, amount) if source != "lattice" else (source, "", 0.0)


def sample_params(index: int, seed: int, cfg: Config, spec: Spec, hdris: list[str]) -> SampleParams:
    """Draw sample ``index`` of a run seeded ``seed``. ``hdris`` are the available HDRI names."""
    if not hdris:
        raise ValueError("no HDRI available")
    rng = rng_for(seed, index)
    label = label_for(index, cfg.generate.intact_fraction)
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
    chosen = sorted(rng.choice(allowed, size=k, replace=False).tolist())
    fam_w = rng.uniform(0.05, 1.0, size=k)
    draw_extent = float(rng.uniform(*d.extent))
    fam_w = fam_w / fam_w.sum() * draw_extent
    mixes = [rng.dirichlet(np.ones(len(spec.families[f].keys))) for f in chosen]
    disp_w = rng.uniform(0.05, 1.0, size=len(disp))
    disp_scale = float(rng.uniform(*d.displacement))
    bank, bank_amount = "", 0.0
    if label == "deformed":
        source, bank, bank_amount = draw_source(index, seed, cfg, spec)
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
            polar=float(rng.uniform(*cam.polar)),
            radius=float(rng.uniform(*cam.radius)),
        )
        for quad in cam.azimuth_quadrants
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
        lo_c, hi_c = spec.material.color
        material = MaterialParams(
            color=tuple(float(rng.uniform(a, b)) for a, b in zip(lo_c, hi_c)),
            roughness=float(rng.uniform(*spec.material.roughness)),
        )

    pose_tilt = float(rng.uniform(*cfg.pose.tilt))
    pose_axis = float(rng.uniform(0, 360))

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
        cameras=cameras,
        design=design,
        material=material,
        extent=extent,
        pose_tilt=pose_tilt,
        pose_axis=pose_axis,
        bank=bank,
        bank_amount=bank_amount,
    )
