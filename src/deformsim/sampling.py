"""Everything random about a sample, drawn in pure Python (no Blender).

A *sample* is one scene state (object deformation, openings, label, lighting) seen by every camera, so
it yields one image per camera. ``sample_params(i, seed, ...)`` depends only on ``(seed, i)``: samples can
be drawn in any order, by any worker, and a resumed run draws the same ones.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from deformsim.config import Config
from deformsim.errors import UserError
from deformsim.spec.model import Spec


@dataclass(frozen=True)
class CameraParams:
    """One camera image's view. The fields after ``radius`` are the per-image framing (``camera.fill``,
    ``offset``, ``partial``, a ``lens_mm`` range, ``fstop``: :func:`draw_framing`); their defaults mean off."""

    azimuth: float  # degrees
    polar: float  # degrees from the up axis
    radius: float  # metres (for the can; scaled with the object's size otherwise); unused when fill > 0
    fill: float = 0.0  # fraction of the frame side the part's 2D box (longer side) fills; 0 = by radius
    shift_x: float = 0.0  # the part's box centre right of the frame centre, fraction of the frame side
    shift_y: float = 0.0  # ... above the frame centre
    cut: float = 0.0  # share of the part's box past the frame border (camera.partial); 0 = whole part in frame
    cut_side: str = ""  # "left" | "right" | "top" | "bottom" the box crosses; "none": not cut; "": partial off
    lens: float = 0.0  # focal length (mm); 0 = camera.lens_mm
    fstop: float = 0.0  # aperture f-number of the depth of field, focused on the part's centre; 0 = no DOF

    def to_dict(self) -> dict:
        """Without the framing fields that are off: a record drawn without them is as it was before them."""
        return {k: v for k, v in asdict(self).items() if k in ("azimuth", "polar", "radius") or v != _CAMERA_OFF[k]}

    @property
    def framed(self) -> bool:
        """Placed by the part's projected box (fill, offset or partial), not only aimed at its centre."""
        return self.fill > 0 or self.shift_x != 0 or self.shift_y != 0 or self.cut_side != ""


_CAMERA_OFF = {f.name: f.default for f in fields(CameraParams)}


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
class LightParams:
    """One area light (``lighting.area_lights``), placed on a sphere around the part's centre and aimed at it.
    Lengths are metres for the built-in can and scale with the part, like :attr:`CameraParams.radius`."""

    kind: str  # "softbox" | "ring" | "window"
    azimuth: float  # degrees about +Z from +X
    elevation: float  # degrees above the horizontal through the part's centre
    distance: float  # metres from the part's centre
    size: float  # metres: the rectangle's width or the disk's diameter
    size_y: float  # metres: the rectangle's height (= size for a disk)
    spin: float  # degrees: rotation of the rectangle about its own axis
    power: float  # watts given to Blender for the built-in can (times the part's scale squared otherwise)
    temperature: float  # colour temperature in kelvin


@dataclass(frozen=True)
class SurfaceParams:
    """The ground the part rests on (``render.surface``): a procedural material or a texture photo."""

    kind: str  # one of config.SURFACE_KINDS
    hue: float  # 0..1: the surface's colour (HSV), kept plausible per kind by blender.surface
    saturation: float
    value: float
    roughness: float
    scale: float  # texture scale factor (1 = the kind's natural size at the built-in can's scale)
    rotation: float  # degrees: the texture's turn about the vertical (grain, weave, ridge direction)
    offset: tuple[float, float]  # texture shift (fractions of its pattern), so no two samples show the same patch
    photo: str = ""  # kind photo: the texture photo's path


# Geometry of each kind of area light (built-in can, metres/degrees): size, aspect (height/width), distance,
# elevation. A ring sits just behind one of the sample's cameras, on its axis, instead (see draw_lights).
LIGHT_KINDS = {
    "softbox": {"size": (0.25, 0.5), "aspect": (0.5, 1.0), "distance": (0.5, 0.9), "elevation": (20.0, 65.0)},
    "ring": {"size": (0.12, 0.25), "aspect": (1.0, 1.0), "distance": (1.02, 1.2), "elevation": (-4.0, 4.0)},
    "window": {"size": (0.8, 1.5), "aspect": (0.6, 1.5), "distance": (1.5, 3.0), "elevation": (0.0, 25.0)},
}


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
    drop_rotation: tuple[float, ...] = ()  # pose.mode drop: start orientation (unit quaternion w, x, y, z); () = tilt
    lights: tuple[LightParams, ...] = ()  # lighting.area_lights: the sample's area lights; () = HDRI only
    surface: SurfaceParams | None = None  # render.surface: the ground the part rests on; None = no surface scene

    @property
    def deformed(self) -> bool:
        return self.label == "deformed"

    def to_dict(self) -> dict:
        d = asdict(self)
        d["cameras"] = [c.to_dict() for c in self.cameras]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "SampleParams":
        d = dict(d)
        d["families"] = tuple(d["families"])
        d["cameras"] = tuple(CameraParams(**c) for c in d["cameras"])
        d["design"] = CanDesign(**d["design"]) if d.get("design") else None
        if d.get("material"):
            m = d["material"]
            d["material"] = MaterialParams(color=tuple(m["color"]), roughness=m["roughness"])
        d["drop_rotation"] = tuple(d.get("drop_rotation", ()))
        d["lights"] = tuple(LightParams(**lp) for lp in d.get("lights", ()))
        if d.get("surface"):
            d["surface"] = SurfaceParams(**{**d["surface"], "offset": tuple(d["surface"]["offset"])})
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


def draw_drop(index: int, seed: int, upright: float) -> tuple[float, float, float, float]:
    """``pose.mode`` drop: the start orientation (unit quaternion w, x, y, z). With probability ``upright`` the part
    starts standing on one of its ends (either, tilted up to 15 degrees, any turn about the vertical), else in a
    uniformly random orientation. A stream of its own, so every other draw is the same as in tilt mode."""
    rng = np.random.default_rng([seed, index, 2])
    q = rng.normal(size=4)
    stand, flip = rng.uniform() < upright, rng.uniform() < 0.5
    yaw, tilt, axis = rng.uniform(0, 2 * np.pi), np.radians(rng.uniform(0, 15)), rng.uniform(0, 2 * np.pi)
    if stand:
        tilt = tilt + np.pi if flip else tilt
        a, t = yaw / 2, tilt / 2
        qz = np.array([np.cos(a), 0.0, 0.0, np.sin(a)])  # turn about the vertical, then tilt
        qt = np.array([np.cos(t), np.sin(t) * np.cos(axis), np.sin(t) * np.sin(axis), 0.0])
        w1, x1, y1, z1 = qt
        w2, x2, y2, z2 = qz
        q = np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                      w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
    q = q / np.linalg.norm(q) * (1.0 if q[0] >= 0 else -1.0)
    return tuple(float(v) for v in q)


def draw_lights(index: int, seed: int, cfg: Config, cameras: tuple[CameraParams, ...]) -> tuple[LightParams, ...]:
    """``lighting.area_lights``: the sample's area lights, from a stream of their own (so a config without
    lights draws exactly what it drew before they existed). A ring light goes on the axis of one of ``cameras``."""
    a = cfg.lighting.area_lights
    if a.count[1] == 0:
        return ()
    rng = np.random.default_rng([seed, index, 3])
    lights = []
    for _ in range(int(rng.integers(a.count[0], a.count[1] + 1))):
        kind = a.kinds[int(rng.integers(len(a.kinds)))]
        g = LIGHT_KINDS[kind]
        size = float(rng.uniform(*g["size"]))
        size_y = size * float(rng.uniform(*g["aspect"]))
        spin = float(rng.uniform(0, 180)) if kind != "ring" else 0.0
        dist = float(rng.uniform(*g["distance"]))
        elevation = float(rng.uniform(*g["elevation"]))
        azimuth = float(rng.uniform(0, 360))
        if kind == "ring":  # behind camera k on its axis: distance and elevation relative to the camera's
            cam = cameras[int(rng.integers(len(cameras)))]
            azimuth = cam.azimuth + float(rng.uniform(-4.0, 4.0))
            elevation += 90.0 - cam.polar
            dist *= cam.radius
        power = float(rng.uniform(*a.power)) * dist**2  # watts at 1 m -> watts at this distance
        lights.append(LightParams(kind=kind, azimuth=azimuth % 360.0, elevation=elevation, distance=dist, size=size,
                                  size_y=size_y, spin=spin, power=power,
                                  temperature=float(rng.uniform(*a.temperature))))
    return tuple(lights)


# Colour ranges (HSV) per surface kind: wood browns, white to cream paper, grey concrete, steel, any cloth, black rubber.
SURFACE_COLOURS = {
    "wood": {"hue": (0.04, 0.11), "saturation": (0.35, 0.75), "value": (0.25, 0.75), "roughness": (0.35, 0.7)},
    "paper": {"hue": (0.0, 1.0), "saturation": (0.0, 0.12), "value": (0.7, 0.95), "roughness": (0.85, 1.0)},
    "concrete": {"hue": (0.05, 0.15), "saturation": (0.0, 0.12), "value": (0.3, 0.7), "roughness": (0.85, 1.0)},
    "metal": {"hue": (0.0, 1.0), "saturation": (0.0, 0.05), "value": (0.55, 0.9), "roughness": (0.2, 0.45)},
    "cloth": {"hue": (0.0, 1.0), "saturation": (0.1, 0.8), "value": (0.15, 0.85), "roughness": (0.9, 1.0)},
    "conveyor": {"hue": (0.0, 1.0), "saturation": (0.0, 0.15), "value": (0.03, 0.15), "roughness": (0.55, 0.85)},
    "photo": {"hue": (0.0, 0.0), "saturation": (0.0, 0.0), "value": (0.8, 1.2), "roughness": (0.4, 0.9)},
}


def surface_photos(folder) -> list[str]:
    """The texture photos of ``render.surface.photos``, sorted (the draw picks by index); empty: a UserError."""
    from pathlib import Path

    from deformsim.dataset.images import IMAGE_EXTS, images_in

    root = Path(folder)
    if not root.is_dir():
        raise UserError(f"render.surface.photos: {root} is not a folder")
    found = [str(p) for p in images_in(root)]
    if not found:
        raise UserError(f"render.surface.photos: no images ({', '.join(sorted(IMAGE_EXTS))}) in {root}")
    return found


def draw_surface(index: int, seed: int, cfg: Config, photos: list[str] | None = None) -> SurfaceParams | None:
    """``render.surface``: the sample's ground, from a stream of its own (so a config without surfaces draws
    exactly what it drew before they existed). ``photos``: :func:`surface_photos` of the config's folder."""
    s = cfg.render.surface
    if s is None:
        return None
    rng = np.random.default_rng([seed, index, 4])
    kind = s.kinds[int(rng.integers(len(s.kinds)))]
    c = SURFACE_COLOURS[kind]
    hue, sat, val, rough = (float(rng.uniform(*c[k])) for k in ("hue", "saturation", "value", "roughness"))
    scale = float(np.exp(rng.uniform(np.log(s.scale[0]), np.log(s.scale[1]))))
    rotation, offset = float(rng.uniform(0, 360)), (float(rng.uniform()), float(rng.uniform()))
    photo = ""
    if kind == "photo":
        photos = photos if photos is not None else surface_photos(s.photos)
        photo = photos[int(rng.integers(len(photos)))]
    return SurfaceParams(kind=kind, hue=hue, saturation=sat, value=val, roughness=rough, scale=scale,
                         rotation=rotation, offset=offset, photo=photo)


CUT_SIDES = ("left", "right", "top", "bottom")


def draw_framing(index: int, seed: int, cfg: Config, cameras: tuple[CameraParams, ...]) -> tuple[CameraParams, ...]:
    """``camera.fill``, ``offset``, ``partial``, a ``lens_mm`` range and ``fstop``: each image's framing, from a
    stream of its own (so a config without them draws exactly what it drew before they existed); ``cameras``
    unchanged when all are off. Every image takes the same draws whichever options are on, so turning one on
    leaves the others' values as they were. f-numbers are drawn log-uniformly (stops are a ratio scale)."""
    c = cfg.camera
    if not c.framing:
        return cameras
    rng = np.random.default_rng([seed, index, 5])
    out = []
    for cam in cameras:
        u = rng.uniform(size=8)
        fill = float(c.fill[0] + (c.fill[1] - c.fill[0]) * u[0]) if c.fill is not None else 0.0
        sx, sy = (float(c.offset * (2 * v - 1)) if c.offset > 0 else 0.0 for v in u[1:3])
        cut, side = 0.0, ""
        if c.partial > 0:
            cut_now = u[3] < c.partial
            cut = float(0.1 + 0.3 * u[4]) if cut_now else 0.0
            side = CUT_SIDES[min(int(u[5] * 4), 3)] if cut_now else "none"
        lens = float(c.lens_mm[0] + (c.lens_mm[1] - c.lens_mm[0]) * u[6]) if isinstance(c.lens_mm, tuple) else 0.0
        fstop = 0.0
        if c.fstop is not None:
            fstop = float(np.exp(np.log(c.fstop[0]) + (np.log(c.fstop[1]) - np.log(c.fstop[0])) * u[7]))
        out.append(replace(cam, fill=fill, shift_x=sx, shift_y=sy, cut=cut, cut_side=side, lens=lens, fstop=fstop))
    return tuple(out)


def sample_params(index: int, seed: int, cfg: Config, spec: Spec, hdris: list[str],
                  photos: list[str] | None = None) -> SampleParams:
    """Draw sample ``index`` of a run seeded ``seed``. ``hdris`` are the available HDRI names; ``photos``: the
    surface texture photos (:func:`surface_photos`; listed here when None and the config uses them)."""
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
        cameras=draw_framing(index, seed, cfg, cameras),
        design=design,
        material=material,
        extent=extent,
        pose_tilt=pose_tilt,
        pose_axis=pose_axis,
        bank=bank,
        bank_amount=bank_amount,
        drop_rotation=draw_drop(index, seed, cfg.pose.drop_upright) if cfg.pose.mode == "drop" else (),
        lights=draw_lights(index, seed, cfg, cameras),
        surface=draw_surface(index, seed, cfg, photos),
    )
