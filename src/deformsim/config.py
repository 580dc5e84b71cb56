"""The one configuration model: every default of every stage lives here.

A run is described by a YAML file (see ``configs/``) validated against :class:`Config`. Presets are YAML
files shipped in ``deformsim/presets``; ``quick`` is the default, ``paper`` reproduces the paper.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import ConfigDict, Field, ValidationError, field_validator, model_validator

from deformsim.errors import UserError
from deformsim.schema import Range, StrictModel, check_range, read_mapping

PRESET_DIR = Path(__file__).parent / "presets"


class _Model(StrictModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)  # overrides are validated too


class ObjectConfig(_Model):
    """What is rendered: the built-in can or a user mesh, and its deformation spec."""

    mesh: Path | None = Field(None, description="CAD mesh (stl/obj/ply/glb/gltf/fbx); None = built-in can")
    spec: Path | None = Field(None, description="deformation spec YAML; None = built-in can spec")


class CameraConfig(_Model):
    """Four cameras, one per azimuth quadrant, all tracking the object (paper, section III).

    The defaults are the paper's Table I cameras. ``fill``, ``offset``, ``partial``, a ``lens_mm`` range and
    ``fstop`` frame each image like a person with a camera (drawn per image, :func:`deformsim.sampling.draw_framing`;
    placed by :mod:`deformsim.blender.cameras`); all off by default.
    """

    azimuth_quadrants: list[Range] = [(20, 70), (110, 160), (200, 250), (290, 340)]
    polar: Range = (50.0, 70.0)
    radius: Range = (0.30, 0.45)
    lens_mm: float | Range = Field(50.0, description="focal length (mm), or a [min, max] range drawn per image")
    fill: Range | None = Field(
        None, description="fraction of the frame side the part's 2D bounding box (longer side) fills, drawn per image: "
        "the camera distance is solved for it (radius is then ignored); None = the drawn radius"
    )
    offset: float = Field(
        0.0, ge=0, le=0.5, description="the part's centre is shifted off the frame centre by up to this fraction of "
        "the frame in x and y (lens shift: no change of perspective)"
    )
    partial: float = Field(
        0.0, ge=0, le=1, description="share of images whose part crosses the frame border (10-40 % of its box cut "
        "off at a random side)"
    )
    fstop: Range | None = Field(
        None, description="depth of field: aperture f-number drawn per image (log-uniformly), focused on the part's "
        "centre; None = off"
    )

    @field_validator("lens_mm")
    @classmethod
    def _lens(cls, v: float | Range) -> float | Range:
        if isinstance(v, tuple):
            check_range(v, above=1, name="lens_mm")
        elif v <= 1:
            raise ValueError(f"lens_mm {v} must be above 1 mm")
        return v

    @field_validator("fill")
    @classmethod
    def _fill(cls, v: Range | None) -> Range | None:
        return v if v is None else check_range(v, hi=1, above=0, name="fill")

    @field_validator("fstop")
    @classmethod
    def _fstop(cls, v: Range | None) -> Range | None:
        return v if v is None else check_range(v, above=0, name="fstop")

    @property
    def lens_fixed(self) -> float:
        """The lens (mm) of an image that draws none: ``lens_mm``, or the middle of its range."""
        return self.lens_mm if not isinstance(self.lens_mm, tuple) else (self.lens_mm[0] + self.lens_mm[1]) / 2

    @property
    def framing(self) -> bool:
        """Any of the per-image framing options is on (else every image is framed as in the paper)."""
        return (self.fill is not None or self.offset > 0 or self.partial > 0 or isinstance(self.lens_mm, tuple)
                or self.fstop is not None)

    @field_validator("polar")
    @classmethod
    def _polar(cls, v: Range) -> Range:
        return check_range(v, 0, 180)

    @field_validator("radius")
    @classmethod
    def _radius(cls, v: Range) -> Range:
        return check_range(v, above=0, name="camera radius")

    @field_validator("azimuth_quadrants")
    @classmethod
    def _quadrants(cls, v: list[Range]) -> list[Range]:
        if not v:
            raise ValueError("at least one camera (azimuth range) is needed")
        return [check_range(r, -360, 720) for r in v]


class PoseConfig(_Model):
    """How the object lies. ``tilt`` mode: tilted away from upright by ``tilt`` degrees about a random
    horizontal axis, in the air. ``drop`` mode: the deformed part falls from a random orientation onto the
    ground with Blender's rigid-body solver and is rendered where it comes to rest (:mod:`deformsim.blender.drop`).

    The paper renders the part upright (tilt 0); real parts also lie on their side or show their ends.
    """

    mode: Literal["tilt", "drop"] = "tilt"
    tilt: Range = (0.0, 0.0)
    drop_height: float = Field(0.25, ge=0, le=5, description="drop: start clearance over the ground, in part sizes")
    drop_frames: int = Field(240, ge=10, le=2000, description="drop: most frames (24 fps) simulated before the pose is read")
    drop_upright: float = Field(0.25, ge=0, le=1, description="drop: share of drops that start standing on an end")

    @field_validator("tilt")
    @classmethod
    def _tilt(cls, v: Range) -> Range:
        return check_range(v, 0, 180)


class AreaLightsConfig(_Model):
    """Area lights added to the HDRI per sample, as in inspection set-ups (:mod:`deformsim.blender.lights`).

    Kinds: ``softbox`` (a large rectangle near the part, from above), ``ring`` (a disk light just behind one
    of the sample's cameras, on its axis) and ``window`` (a large rectangle far away, from the side). Sizes and
    distances are for the built-in can and scale with the part like the camera radius. Off by default.
    """

    count: tuple[int, int] = Field((0, 0), description="lights per sample, drawn uniformly in [min, max]; 0 = none")
    kinds: list[Literal["softbox", "ring", "window"]] = ["softbox", "ring", "window"]
    power: Range = Field(
        (25.0, 150.0), description="watts the light would need 1 m from the built-in can (roughly 400 W lights a "
        "white part as much as a uniform world of strength 1); the power given to Blender grows with the light's "
        "distance squared and the part's size squared, so the light on the part does not depend on either"
    )
    temperature: Range = Field((4500.0, 7500.0), description="colour temperature (K): warm below 6500, cool above")

    @field_validator("count")
    @classmethod
    def _count(cls, v: tuple[int, int]) -> tuple[int, int]:
        if v[0] < 0 or v[0] > v[1] or v[1] > 8:
            raise ValueError(f"area_lights.count {list(v)} must satisfy 0 <= min <= max <= 8")
        return v

    @field_validator("kinds")
    @classmethod
    def _kinds(cls, v: list[str]) -> list[str]:
        if not v:
            raise ValueError("area_lights.kinds is empty: name at least one of softbox, ring, window")
        return v

    @field_validator("power")
    @classmethod
    def _power(cls, v: Range) -> Range:
        return check_range(v, 0, name="area_lights.power")

    @field_validator("temperature")
    @classmethod
    def _temperature(cls, v: Range) -> Range:
        return check_range(v, 1000, 20000, name="area_lights.temperature")


class LightingConfig(_Model):
    """HDRI world lighting: a random EXR at a random rotation; optional area lights on top."""

    hdri_dir: Path | None = Field(None, description="folder of .exr/.hdr files; None = Blender's studiolights")
    rotation: Range = (0.0, 360.0)
    strength: Range = (0.8, 1.4)
    area_lights: AreaLightsConfig = AreaLightsConfig()

    @field_validator("strength")
    @classmethod
    def _strength(cls, v: Range) -> Range:
        return check_range(v, 0)


class Sources(_Model):
    """Relative weights of where a deformed sample's shape comes from: the spec's lattice keys (paper), an entry
    of the simulated bank (``simulation:`` in the spec, baked on first use), or both at once."""

    lattice: float = Field(1.0, ge=0)
    bank: float = Field(0.0, ge=0)
    both: float = Field(0.0, ge=0)

    @model_validator(mode="after")
    def _some(self) -> "Sources":
        if self.lattice + self.bank + self.both <= 0:
            raise ValueError("deform.sources weights are all 0: give lattice, bank or both a positive weight")
        return self

    @property
    def uses_bank(self) -> bool:
        return self.bank + self.both > 0


class DeformConfig(_Model):
    """How deformed samples mix the spec's keys (paper, section III-B) and the simulated bank."""

    families: tuple[int, int] = (3, 5)
    use_families: list[str] | None = Field(None, description="simulate only these families of the spec")
    extent: Range = (0.7, 1.5)
    displacement: Range = (0.6, 1.0)
    sources: Sources = Sources()
    bank_amount: Range = Field((0.7, 1.0), description="weight of the drawn bank entry (1 = as simulated)")

    @field_validator("families")
    @classmethod
    def _families(cls, v: tuple[int, int]) -> tuple[int, int]:
        if v[0] < 1 or v[0] > v[1]:
            raise ValueError(f"families range {list(v)} must satisfy 1 <= min <= max")
        return v

    @field_validator("extent", "displacement")
    @classmethod
    def _pos(cls, v: Range) -> Range:
        return check_range(v, 0)

    @field_validator("bank_amount")
    @classmethod
    def _amount(cls, v: Range) -> Range:
        return check_range(v, 0, 1.5, name="bank_amount")  # above 1 extrapolates the simulation


SURFACE_KINDS = ("wood", "paper", "concrete", "metal", "cloth", "conveyor", "photo")


class SurfaceConfig(_Model):
    """``render.surface``: a textured ground plane under the part, rendered with it as a whole scene."""

    kinds: list[Literal[SURFACE_KINDS]] = Field(
        ["wood", "paper", "concrete", "metal", "cloth", "conveyor"], min_length=1,
        description="surface kinds drawn per sample (procedural materials; photo: a picture from photos)",
    )
    photos: Path | None = Field(None, description="folder of texture photos (table tops, floors) for kind photo")
    scale: Range = Field((0.6, 1.6), description="texture scale: 1 = wood grain, weave, ridges at a real part's size")

    @field_validator("scale")
    @classmethod
    def _scale(cls, v: Range) -> Range:
        return check_range(v, above=0, name="scale")

    @model_validator(mode="after")
    def _photos(self) -> "SurfaceConfig":
        if "photo" in self.kinds and self.photos is None:
            raise ValueError("render.surface kind photo needs render.surface.photos (a folder of texture photos)")
        return self


class RenderConfig(_Model):
    """Cycles settings."""

    resolution: int = Field(128, ge=16, le=4096)
    samples: int = Field(16, ge=1, le=4096)
    denoise: bool = True
    device: Literal["auto", "cpu", "gpu"] = "auto"
    threads: int = Field(0, ge=0, description="Cycles threads per worker; 0 = cores / workers")
    render_backgrounds: bool = Field(
        False,
        description="render the black and green variants with Cycles instead of compositing them over the "
        "exact alpha (identical for opaque objects, 3x slower)",
    )
    dense: bool = Field(False, description="also write mask, depth, normal, deformation and region maps per image")
    region_threshold_mm: float = Field(1.0, gt=0, description="deformation (mm) from which a pixel is in the region")
    creases: bool = Field(False, description="scuffed bare metal on sharp ridges and darkened folds (Cycles pointiness)")
    shadow: bool = Field(
        False, description="also write images/shadow/ID.png: the shadow and contact occlusion the part casts on a "
        "ground plane under it (a Cycles shadow catcher lit by the world), for compositing; rgba stays the part alone"
    )
    surface: SurfaceConfig | None = Field(
        None, description="also write images/surface/ID.png: the part resting on a textured ground plane, the "
        "whole scene rendered under the same light (deformsim composite uses it by composite.surface); None = off"
    )
    # Cycles quality/speed (bench/render_quality.py measures them); defaults are Blender's, max_bounces 6.
    adaptive: bool = Field(False, description="adaptive sampling: stop pixels whose noise is below the threshold")
    adaptive_threshold: float = Field(0.01, gt=0, le=1, description="adaptive sampling noise threshold")
    adaptive_min_samples: int = Field(0, ge=0, le=4096, description="samples before adaptive stopping; 0 = automatic")
    max_bounces: int = Field(6, ge=0, le=1024, description="light-path bounces in total")
    diffuse_bounces: int = Field(4, ge=0, le=1024)
    glossy_bounces: int = Field(4, ge=0, le=1024)
    transmission_bounces: int = Field(12, ge=0, le=1024)
    transparent_bounces: int = Field(8, ge=0, le=1024)
    volume_bounces: int = Field(0, ge=0, le=1024)
    caustics_reflective: bool = True
    caustics_refractive: bool = True
    clamp_direct: float = Field(0.0, ge=0, description="clamp direct light samples to this value; 0 = off")
    clamp_indirect: float = Field(10.0, ge=0, description="clamp indirect light samples to this value; 0 = off")
    denoise_input: Literal["rgb", "rgb_albedo", "rgb_albedo_normal"] = Field(
        "rgb_albedo_normal", description="guide passes given to the denoiser"
    )
    denoise_prefilter: Literal["none", "fast", "accurate"] = Field("accurate", description="denoising of the guides")
    denoise_quality: Literal["high", "balanced", "fast"] = "high"
    tile_size: int = Field(2048, ge=8, le=8192, description="Cycles tile size in pixels")
    view_transform: Literal["Standard", "AgX", "Filmic", "Khronos PBR Neutral"] = Field(
        "Standard", description="colour view transform: Standard clips highlights at 1.0 (exact flat colours); "
        "AgX, Filmic and Khronos PBR Neutral roll bright highlights off like a camera"
    )
    look: Literal["None", "Very Low Contrast", "Low Contrast", "Medium Low Contrast", "Medium Contrast",
                  "Medium High Contrast", "High Contrast", "Very High Contrast", "Punchy"] = Field(
        "None", description="contrast look on top of the view transform (Punchy: AgX only)"
    )

    @property
    def scene_kinds(self) -> tuple[str, ...]:
        """The extra images each render writes after the part's own (dataset.layout.SCENE_KINDS), in order."""
        return tuple(k for k, on in (("shadow", self.shadow), ("surface", self.surface is not None)) if on)

    @model_validator(mode="after")
    def _look(self) -> "RenderConfig":
        if self.look == "Punchy" and self.view_transform != "AgX":
            raise ValueError(f"render.look Punchy needs view_transform AgX (got {self.view_transform})")
        return self


class GenerateConfig(_Model):
    """Dataset size, seed and the worker pool."""

    n: int = Field(64, ge=1, description="number of images (intact + deformed)")
    seed: int = 0
    intact_fraction: float = Field(0.5, ge=0, le=1)
    workers: int = Field(0, ge=0, description="render processes; 0 = automatic")
    recycle_every: int = Field(200, ge=1, description="restart a worker after this many images")
    max_retries: int = Field(2, ge=0)
    backend: Literal["local", "ray"] = "local"
    address: str | None = None
    gather: bool = False
    preview: int = Field(16, ge=0, description="images on the contact sheet")


class CameraEffects(_Model):
    """Camera effects drawn per composite (:mod:`deformsim.composite.effects`); None turns one off."""

    exposure: Range | None = Field((-0.5, 0.5), description="exposure change in stops")
    white_balance: Range | None = Field((-0.08, 0.08), description="red/blue gain shift (warm > 0)")
    vignette: Range | None = Field((0.0, 0.35), description="darkening at the corners")
    blur: Range | None = Field((0.0, 0.006), description="defocus: Gaussian sigma as a fraction of the image size")
    motion_blur: Range | None = Field(
        None, description="camera shake: blur along a random direction, its length a fraction of the image size"
    )
    noise: Range | None = Field((0.0, 0.025), description="sensor noise: standard deviation in 0-1 units")
    jpeg_quality: tuple[int, int] | None = Field((45, 95), description="JPEG re-compression quality")

    @field_validator("blur", "noise", "vignette")
    @classmethod
    def _nonneg(cls, v: Range | None) -> Range | None:
        return v if v is None else check_range(v, 0)

    @field_validator("exposure", "white_balance")
    @classmethod
    def _ordered(cls, v: Range | None) -> Range | None:
        return v if v is None else check_range(v)

    @field_validator("jpeg_quality")
    @classmethod
    def _quality(cls, v: tuple[int, int] | None) -> tuple[int, int] | None:
        return v if v is None else check_range(v, 1, 100, name="jpeg_quality")


class CompositeConfig(_Model):
    """Chroma-key matting and compositing onto backgrounds."""

    matte: Literal["alpha", "chroma", "inrange"] = Field(
        "chroma", description="alpha: exact render alpha; chroma: soft green key; inrange: the paper's hard key"
    )
    key_color: tuple[int, int, int] = (0, 255, 0)
    tolerance: int = Field(60, ge=0, le=255)
    close_kernel: int = Field(5, ge=0)
    open_kernel: int = Field(3, ge=0)
    erode_kernel: int = Field(3, ge=0)
    backgrounds: Path | None = Field(None, description="folder of photos; None = procedural backgrounds")
    scale_jitter: Range = (1.0, 1.3)
    flip: bool = True
    flip_part: float = Field(0.0, ge=0, le=1, description="probability of mirroring the part (and its maps) left-right")
    workers: int = Field(0, ge=0)
    variants: list[str] = ["black", "backgrounds"]
    balance_backgrounds: bool = Field(
        False, description="use each photo about equally often behind intact and deformed images"
    )
    object_fill: Range | None = Field(
        None, description="crop around the object so its longer side fills this fraction of the frame; None = as rendered"
    )
    fill_offset: float = Field(0.1, ge=0, le=0.5, description="random shift of the object from the frame centre")
    effects: CameraEffects | None = Field(None, description="camera effects per composite; None = none")
    surface: float = Field(
        0.0, ge=0, le=1, description="share of images that show the rendered surface scene of a dataset rendered "
        "with render.surface instead of the part over a background (no matte; framing, flip and effects apply)"
    )
    shadow_strength: Range = Field(
        (1.0, 1.0), description="alpha matte on a dataset rendered with render.shadow: the part's shadow darkens "
        "the background by strength * shadow, strength drawn per image from this range (0 = no shadow)"
    )

    @field_validator("object_fill")
    @classmethod
    def _fill(cls, v: Range | None) -> Range | None:
        return v if v is None else check_range(v, hi=1, above=0, name="object_fill")

    @field_validator("scale_jitter")
    @classmethod
    def _scale(cls, v: Range) -> Range:
        check_range(v, 1.0)
        return v

    @field_validator("shadow_strength")
    @classmethod
    def _shadow(cls, v: Range) -> Range:
        return check_range(v, 0, 1, "shadow_strength")


class TrainConfig(_Model):
    """The condition-assessment model (paper, section IV)."""

    backbone: Literal["vgg16", "mobilenet_v2"] = "vgg16"
    weights: Literal["imagenet", "offline", "none"] = "imagenet"
    image_size: int = Field(224, ge=32)
    hidden: tuple[int, int] = (256, 128)
    dropout: float = Field(0.5, ge=0, lt=1)
    lr: float = Field(1e-3, gt=0)
    batch_size: int = Field(32, ge=1)
    epochs: int = Field(15, ge=1)
    split: float = Field(0.8, gt=0, lt=1)
    augment: bool = False
    cache_features: bool = True
    threshold: float = Field(0.5, gt=0, lt=1)
    variants: list[str] = ["black", "backgrounds"]
    seed: int = 0
    device: Literal["auto", "cpu", "cuda"] = Field("auto", description="auto = cuda when available")
    finetune: Literal["last_conv", "last_block"] = Field(
        "last_conv", description="trainable part of the backbone: its last convolution (the paper) or last block"
    )
    head: Literal["mlp", "linear"] = Field("mlp", description="mlp: the paper's 3 layers; linear: a linear probe")
    feature_norm: bool = Field(
        False, description="batch-normalise the pooled features (lets --adapt re-estimate them on real photos)"
    )
    adapt_method: Literal["adabn", "selftrain"] = Field(
        "adabn", description="with unlabelled photos: adabn re-estimates feature statistics; selftrain adds "
        "confident pseudo-labels of the photos and trains on"
    )
    adapt_epochs: int = Field(5, ge=1, description="selftrain: epochs on synthetic + pseudo-labelled photos")
    pseudo_confidence: float = Field(0.9, gt=0.5, lt=1, description="selftrain: keep photos predicted this surely")
    target: Literal["label", "severity", "family", "localise"] = Field(
        "label", description="label: intact/deformed (the paper); on dense datasets also severity (max displacement, "
        "mm), family (deformation kinds, multi-label) or localise (deformed-region mask)"
    )


class Config(_Model):
    """A whole run: object, rig sampling, scene, rendering, compositing and training."""

    object: ObjectConfig = ObjectConfig()
    camera: CameraConfig = CameraConfig()
    pose: PoseConfig = PoseConfig()
    lighting: LightingConfig = LightingConfig()
    deform: DeformConfig = DeformConfig()
    render: RenderConfig = RenderConfig()
    generate: GenerateConfig = GenerateConfig()
    composite: CompositeConfig = CompositeConfig()
    train: TrainConfig = TrainConfig()

    @model_validator(mode="after")
    def _balanced(self) -> "Config":
        views = len(self.camera.azimuth_quadrants)
        if self.generate.n % views:
            raise ValueError(f"generate.n={self.generate.n} must be a multiple of the {views} cameras")
        return self


def preset_path(name: str) -> Path:
    return PRESET_DIR / f"{name}.yaml"


def load_config(source: str | Path | None = None, overrides: dict | None = None,
                flags: dict[str, str] | None = None) -> Config:
    """Load a config from a YAML path or preset name (default ``quick``), apply dotted overrides.

    ``overrides`` maps dotted keys (``"render.resolution"``) to values; ``None`` values are ignored.
    ``flags`` names where an override came from (``{"generate.n": "--n"}``), for error messages.
    Raises :class:`UserError` with one line naming the bad file or value (a bad override by its flag).
    """
    source = source or "quick"
    path = Path(source)
    if not path.exists() and preset_path(str(source)).exists():
        path = preset_path(str(source))
    if not path.is_file():
        raise UserError(f"config file not found: {source} (presets: {', '.join(list_presets())})")
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    return validate_config(apply_overrides(read_mapping(path, "config"), given), str(path), given, flags)


def apply_overrides(data: dict, overrides: dict | None) -> dict:
    """``data`` with dotted keys (``"render.resolution"``) set to their values; ``None`` values are ignored."""
    for key, value in (overrides or {}).items():
        if value is None:
            continue
        node = data
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
    return data


def validate_config(data: dict, origin: str = "config", overrides: dict | None = None,
                    flags: dict[str, str] | None = None) -> Config:
    """``data`` as a :class:`Config`, or one :class:`UserError` line naming the bad value and where it came from:
    ``origin`` (the file), or, for a key set by ``overrides``, its flag in ``flags`` (else "override KEY")."""
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(p) for p in err["loc"]) or "config"
        msg = err["msg"].removeprefix("Value error, ")
        key = where if where in (overrides or {}) else next((k for k in overrides or {} if k in msg), None)
        if key is not None:
            flag = (flags or {}).get(key) or f"override {key}"
            what = f"invalid {key}: {msg}" if key == where else msg
            raise UserError(f"{flag} {overrides[key]}: {what}") from None
        raise UserError(f"{origin}: invalid {where}: {msg} (got {err.get('input')!r})") from None


def list_presets() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def dump_config(cfg: Config) -> str:
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
