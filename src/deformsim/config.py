"""The one configuration model: every default of every stage lives here.

A run is described by a YAML file (see ``configs/``) validated against :class:`Config`. Presets are YAML
files shipped in ``deformsim/presets``; ``quick`` is the default, ``paper`` reproduces the paper. Every field
says what it does (``docs/configuration.md`` is written from the descriptions by :mod:`deformsim.config_reference`)
and, by an :mod:`deformsim.identity` rule, whether a dataset's identity depends on it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import yaml
from pydantic import ConfigDict, Field, ValidationError, model_validator

from deformsim import identity
from deformsim.errors import UserError
from deformsim.learn.backbones import BACKBONES
from deformsim.schema import (
    Above,
    FractionRange,
    NonEmpty,
    Range,
    Seed,
    StrictModel,
    Within,
    first_error,
    read_mapping,
    shown,
)

PRESET_DIR = Path(__file__).parent / "presets"
MAX_IMAGES = 10_000_000  # generate.n
CONFIRM_IMAGES = 100_000  # a plan of more images asks for --yes (deformsim.generate.refusals.check_plan)
# a variant's name is a folder under DATA/variants/ and part of the report's model folders: a plain name
VARIANT_NAME = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"  # a variant is a folder: a plain name
VariantName = Annotated[str, Field(pattern=VARIANT_NAME)]
ONE_MODEL = {"ensemble": 1, "ensemble_backbones": []}  # train: what a dense target trains (TrainConfig.for_target)


class _Model(StrictModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)  # overrides are validated too


AngleRange = Annotated[Range, Within(0, 180)]
UnitRange = Annotated[Range, Within(0, 1)]
ScaleRange = Annotated[Range, Within(hi=10, above=0)]
# The built-in can's named sizes (their real dimensions: deformsim.sampling.tables.CAN_SIZES).
CAN_SIZES = ("slim250", "sleek330", "standard330", "standard355", "tall473", "tall500", "tall568")


class ShapesConfig(_Model):
    """``object.shapes``: the part's shape, drawn per sample. The built-in can takes one of its named sizes (real
    diameter, height, neck and dome) or, in a share ``continuous`` of samples, a blend of two; any part then takes
    the per-axis scale, taper and bulge. Every deformation (lattice keys, bank entries, crinkle, openings) follows
    the shape (docs/variety.md). Off (null) by default."""

    sizes: Annotated[list[Literal[CAN_SIZES]], NonEmpty("object.shapes.sizes is empty: name at least one size")] = Field(
        list(CAN_SIZES), description="built-in can: the named sizes drawn from (uniformly); ignored for a mesh"
    )
    continuous: float = Field(
        0.3, ge=0, le=1, description="built-in can: share of samples drawn between two of the sizes (every dimension "
        "blended at a uniform point); the others take one size exactly"
    )
    neck: Annotated[Range, Within(0.5, 2)] = Field(
        (1.0, 1.0), description="built-in can: factor on the neck's height, drawn per sample"
    )
    dome: Annotated[Range, Within(0.5, 2)] = Field(
        (1.0, 1.0), description="built-in can: factor on the bottom dome's depth, drawn per sample"
    )
    scale: tuple[ScaleRange, ScaleRange, ScaleRange] = Field(
        ((1.0, 1.0), (1.0, 1.0), (1.0, 1.0)), description="factors on the part's x, y and z extent, each drawn per "
        "sample (x and y about the part's vertical axis, z from the ground up)"
    )
    round: Annotated[bool, identity.WHEN_SET] = Field(
        False, description="y takes x's drawn scale factor, so a round part stays round (a tin of another "
        "diameter, not an oval one); scale's y range must then equal x's"
    )
    taper: Annotated[Range, Within(-0.9, 0.9)] = Field(
        (0.0, 0.0), description="widening towards the top, drawn per sample: x and y scale by 1 + taper * (2 h - 1) "
        "at height share h (negative: a narrower top)"
    )
    bulge: Annotated[Range, Within(-0.5, 0.5)] = Field(
        (0.0, 0.0), description="barrel, drawn per sample: x and y scale by 1 + bulge * sin(pi h) at height share h "
        "(negative: a waist)"
    )

    @model_validator(mode="after")
    def _round(self) -> "ShapesConfig":
        if self.round and self.scale[1] != self.scale[0]:
            raise ValueError(f"object.shapes.round takes y's scale from x's, but their ranges differ "
                             f"({list(self.scale[0])} and {list(self.scale[1])}): give y the same range")
        return self


class ObjectConfig(_Model):
    """What is rendered: the built-in can or a user mesh, and its deformation spec."""

    mesh: Annotated[Path | None, identity.by_content("mesh", "mesh")] = Field(
        None, description="CAD mesh (stl/obj/ply/glb/gltf/fbx); null = built-in can")
    spec: Annotated[Path | None, identity.by_content("spec", "spec")] = Field(
        None, description="deformation spec YAML; null = built-in can spec")
    shapes: Annotated[ShapesConfig | None, identity.WHEN_SET] = Field(
        None, description="the part's shape drawn per sample (can sizes, per-axis scale, taper, bulge); null = "
        "the part as built"
    )
Byte = Annotated[int, Field(ge=0, le=255)]
Width = Annotated[int, Field(ge=1, le=8192)]  # a layer's width


REFERENCE_SIZE = 0.122  # m: the built-in can's height; camera distances are given for it, scaled with a mesh's size


class CameraConfig(_Model):
    """Four cameras, one per azimuth quadrant, all tracking the object (paper, section III).

    The defaults are the paper's Table I cameras. ``fill``, ``offset``, ``partial``, a ``lens_mm`` range and
    ``fstop`` frame each image like a person with a camera (drawn per image); all off by default.
    """

    azimuth_quadrants: Annotated[list[Annotated[Range, Within(-360, 720)]],
                                 NonEmpty("at least one camera (azimuth range) is needed")] = Field(
        [(20, 70), (110, 160), (200, 250), (290, 340)], max_length=64, description="one camera per range: its azimuth (degrees "
        "about the up axis) drawn per sample in [min, max]; generate.n is a multiple of the number of cameras"
    )
    polar: AngleRange = Field((50.0, 70.0), description="camera angle from the up axis (degrees), drawn per camera")
    polar_views: Annotated[list[AngleRange] | None, identity.WHEN_SET] = Field(
        None, max_length=64, description="one polar range per camera (as azimuth_quadrants), e.g. side views and a top "
        "view; null = polar for every camera"
    )
    radius: Annotated[Range, Within(hi=100, above=0)] = Field(
        (0.30, 0.45), description="camera distance (m for the built-in can; scaled with a mesh's size), drawn per camera"
    )
    lens_mm: Annotated[float | Range, Above(1, hi=2000)] = Field(
        50.0, description="focal length (mm), or a [min, max] range drawn per image"
    )
    fill: Annotated[FractionRange | None, identity.WHEN_SET] = Field(
        None, description="fraction of the frame side the part's 2D bounding box (longer side) fills, drawn per image: "
        "the camera distance is solved for it (radius is then ignored); null = the drawn radius"
    )
    fill_views: Annotated[list[FractionRange] | None, identity.WHEN_SET] = Field(
        None, max_length=64, description="one fill range per camera (as azimuth_quadrants), e.g. top views from "
        "farther away than side views; null = fill for every camera"
    )
    offset: Annotated[float, identity.WHEN_SET] = Field(
        0.0, ge=0, le=0.5, description="the part's centre is shifted off the frame centre by up to this fraction of "
        "the frame in x and y (lens shift: no change of perspective)"
    )
    partial: Annotated[float, identity.WHEN_SET] = Field(
        0.0, ge=0, le=1, description="share of images whose part crosses the frame border (10-40 % of its box cut "
        "off at a random side)"
    )
    fstop: Annotated[Annotated[Range, Within(hi=256, above=0)] | None, identity.WHEN_SET] = Field(
        None, description="depth of field: aperture f-number drawn per image (log-uniformly), focused on the part's "
        "centre; null = off"
    )

    @model_validator(mode="after")
    def _views(self) -> "CameraConfig":
        for name in ("polar_views", "fill_views"):
            views = getattr(self, name)
            if views is not None and len(views) != len(self.azimuth_quadrants):
                raise ValueError(f"camera.{name} has {len(views)} ranges for {len(self.azimuth_quadrants)} cameras: "
                                 "give one per azimuth range")
        return self

    def _per_camera(self, views: list | None, one):
        """``views`` (one per camera), else ``one`` for every camera."""
        return list(views) if views is not None else [one] * len(self.azimuth_quadrants)

    @property
    def polars(self) -> list[tuple[float, float]]:
        """Each camera's polar range: ``polar_views``, else ``polar`` for all."""
        return self._per_camera(self.polar_views, self.polar)

    @property
    def fills(self) -> list[tuple[float, float] | None]:
        """Each camera's fill range: ``fill_views``, else ``fill`` (or None: the drawn radius) for all."""
        return self._per_camera(self.fill_views, self.fill)

    @property
    def lens_fixed(self) -> float:
        """The lens (mm) of an image that draws none: ``lens_mm``, or the middle of its range."""
        return self.lens_mm if not isinstance(self.lens_mm, tuple) else (self.lens_mm[0] + self.lens_mm[1]) / 2

    @property
    def framing(self) -> bool:
        """Any of the per-image framing options is on (else every image is framed as in the paper)."""
        return (any(f is not None for f in self.fills) or self.offset > 0 or self.partial > 0
                or isinstance(self.lens_mm, tuple) or self.fstop is not None)


_DROP_ONLY = identity.when(mode="drop")


class PoseConfig(_Model):
    """How the object lies. ``tilt`` mode: tilted away from upright by ``tilt`` degrees about a random
    horizontal axis, in the air. ``drop`` mode: the deformed part falls from a random orientation onto the
    ground with Blender's rigid-body solver and is rendered where it comes to rest.

    The paper renders the part upright (tilt 0); real parts also lie on their side or show their ends.
    """

    mode: Annotated[Literal["tilt", "drop"], identity.WHEN_SET] = Field(
        "tilt", description="tilt: tilted in the air; drop: dropped onto the ground, rendered where it rests"
    )
    tilt: AngleRange = Field((0.0, 0.0), description="tilt mode: degrees away from upright, drawn per sample")
    drop_height: Annotated[float, _DROP_ONLY] = Field(
        0.25, ge=0, le=5, description="drop: start clearance over the ground, in part sizes"
    )
    drop_frames: Annotated[int, _DROP_ONLY] = Field(
        240, ge=10, le=2000, description="drop: most frames (24 fps) simulated before the pose is read"
    )
    drop_upright: Annotated[float, _DROP_ONLY] = Field(
        0.25, ge=0, le=1, description="drop: share of drops that start standing on an end"
    )


class AreaLightsConfig(_Model):
    """Area lights added to the HDRI per sample, as in inspection set-ups.

    Kinds: ``softbox`` (a large rectangle near the part, from above), ``ring`` (a disk light just behind one
    of the sample's cameras, on its axis), ``window`` (a large rectangle far away, from the side) and ``overhead``
    (a ceiling panel or inspection hood high above the part). Sizes and
    distances are for the built-in can and scale with the part like the camera radius. Off by default.
    """

    count: Annotated[tuple[int, int], Within(0, 8)] = Field(
        (0, 0), description="lights per sample, drawn uniformly in [min, max]; 0 = none"
    )
    kinds: Annotated[list[Literal["softbox", "ring", "window", "overhead"]],
                     NonEmpty("area_lights.kinds is empty: name at least one of softbox, ring, window, overhead")] = Field(
        ["softbox", "ring", "window"], description="kinds drawn per light"
    )
    power: Annotated[Range, Within(0, 1_000_000)] = Field(
        (25.0, 150.0), description="watts the light would need 1 m from the built-in can (roughly 400 W lights a "
        "white part as much as a uniform world of strength 1); the power given to Blender grows with the light's "
        "distance squared and the part's size squared, so the light on the part does not depend on either"
    )
    temperature: Annotated[Range, Within(1000, 20000)] = Field(
        (4500.0, 7500.0), description="colour temperature (K): warm below 6500, cool above"
    )


class SunConfig(_Model):
    """``lighting.sun``: a hard key light from far away (sunlight through a window, a bare lamp across a hall), drawn
    per sample on top of the HDRI: crisp shadows and sharp highlights, from one direction."""

    share: float = Field(1.0, ge=0, le=1, description="share of samples the sun lights (the rest: HDRI and area lights only)")
    strength: Annotated[Range, Within(0, 100)] = Field(
        (2.0, 8.0), description="irradiance (W/m2) of Blender's sun lamp, drawn per sample: on Blender's studio "
        "HDRIs 2 raises the part's mean brightness by 8-19 levels of 255, 10 by 22-43"
    )
    elevation: Annotated[Range, Within(0, 90)] = Field(
        (20.0, 70.0), description="degrees above the horizon the light comes from, drawn per sample (its azimuth in "
        "0-360)"
    )
    angle: Annotated[Range, Within(0, 30)] = Field(
        (0.5, 5.0), description="the light's angular diameter in degrees, drawn per sample: 0.5 is the sun's (sharp "
        "shadows), larger softens their edges"
    )
    temperature: Annotated[Range, Within(1000, 20000)] = Field(
        (4500.0, 6500.0), description="colour temperature (K), drawn per sample"
    )


class LightingConfig(_Model):
    """HDRI world lighting: a random EXR at a random rotation; optional area lights on top."""

    hdri_dir: Annotated[Path | None, identity.by_content("hdri", "HDRI folder")] = Field(
        None, description="folder of .exr/.hdr files; null = Blender's studiolights")
    hdris: Annotated[list[str] | None, identity.WHEN_SET] = Field(
        None, min_length=1, description="draw only these HDRIs (file names without extension, e.g. [interior, "
        "studio] of Blender's); null = every HDRI found"
    )
    rotation: Annotated[Range, Within(-360, 720)] = Field(
        (0.0, 360.0), description="rotation of the HDRI about the up axis (degrees), drawn per sample"
    )
    strength: Annotated[Range, Within(0, 1000)] = Field((0.8, 1.4), description="strength of the HDRI world, drawn per sample")
    area_lights: AreaLightsConfig = Field(AreaLightsConfig(), description="area lights on top of the HDRI")
    sun: Annotated[SunConfig | None, identity.WHEN_SET] = Field(
        None, description="a hard directional key light per sample (blender sun lamp), recorded in the manifest's "
        "sun_* columns; null = off"
    )


class Sources(_Model):
    """Relative weights of where a deformed sample's shape comes from: the spec's lattice keys (paper), an entry
    of the simulated bank (``simulation:`` in the spec, baked on first use), or both at once."""

    lattice: float = Field(1.0, ge=0, le=1_000_000, description="weight of shapes made from the spec's lattice keys")
    bank: float = Field(0.0, ge=0, le=1_000_000, description="weight of shapes taken from the simulated bank")
    both: float = Field(0.0, ge=0, le=1_000_000, description="weight of a bank entry with lattice keys on top")

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

    families: Annotated[tuple[int, int], Within(1, 1000)] = Field(
        (3, 5), description="number of the spec's families mixed in one deformed sample, drawn in [min, max] "
        "(at most the families allowed)"
    )
    use_families: list[str] | None = Field(None, description="simulate only these families of the spec")
    extent: Annotated[Range, Within(0, 100)] = Field(
        (0.7, 1.5), description="total weight of the drawn families' shape keys, drawn per sample"
    )
    displacement: Annotated[Range, Within(0, 100)] = Field(
        (0.6, 1.0), description="total strength of the spec's displacement textures (surface crinkle), drawn per sample"
    )
    sources: Sources = Field(Sources(), description="where a deformed shape comes from: lattice keys, bank or both")
    bank_amount: Annotated[Range, Within(0, 1.5)] = Field(
        (0.7, 1.0), description="weight of the drawn bank entry (1 = as simulated, above 1 extrapolates)"
    )


SURFACE_KINDS = ("wood", "paper", "concrete", "metal", "cloth", "conveyor", "photo")


class VisibleRegionConfig(_Model):
    """``render.region_visible``: the region map keeps the displaced pixels that show it. Displacement is measured
    after taking out the part's change of size along its axes (``object.shapes`` draws that for intact parts too);
    movement along the line of sight that barely turns the surface (an end pushed straight in, a lid tilted a
    little, seen from above) leaves the image as it was."""

    across_px: float = Field(
        2.0, gt=0, le=100, description="a displaced pixel shows where it moved at least this far across the image "
        "(perpendicular to the line of sight), in pixels at the render size"
    )
    turn_deg: float = Field(
        15.0, gt=0, lt=90, description="or where its surface turned by at least this angle, in degrees (15: a matte "
        "surface's shading changes by 3 %)"
    )
    view_fit: Annotated[bool, identity.WHEN_SET] = Field(
        False, description="count movement across the image only beyond the affine map that best fits the whole "
        "visible part's (an end moved sideways or tilted as a whole, seen from above, looks intact); false: every "
        "movement across it"
    )


class SurfaceConfig(_Model):
    """``render.surface``: a textured ground plane under the part, rendered with it as a whole scene."""

    kinds: list[Literal[SURFACE_KINDS]] = Field(
        ["wood", "paper", "concrete", "metal", "cloth", "conveyor"], min_length=1,
        description="surface kinds drawn per sample (procedural materials; photo: a picture from photos)",
    )
    photos: Annotated[Path | None, identity.by_content("surface", "surface photo folder", whole=True)] = Field(
        None, description="folder of texture photos (table tops, floors) for kind photo")
    scale: Annotated[Range, Within(hi=100, above=0)] = Field(
        (0.6, 1.6), description="texture scale: 1 = wood grain, weave, ridges at a real part's size"
    )
    value: Annotated[UnitRange | None, identity.WHEN_SET] = Field(
        None, description="the ground's brightness (HSV value, 0 black to 1 white) drawn per sample in place of its "
        "kind's range, e.g. [0.15, 0.4] for a dark grey table; null = the kind's own range"
    )
    backdrop: Annotated[float | None, identity.WHEN_SET] = Field(
        None, gt=0, le=100, description="a matte wall this many part sizes behind the part, facing each side view "
        "(cameras more than 45 degrees from straight down), coloured like the ground but darker; null = the HDRI "
        "beyond the ground"
    )
    part_colour: Annotated[bool, identity.WHEN_SET] = Field(
        True, description="render the part's own images (rgba, black, green) in full colour; false: only their "
        "alpha and the dense maps are exact (direct light only, not denoised), for a dataset whose training images "
        "are all surface scenes (composite.surface: 1); the same labels, masks and surface images, fewer seconds"
    )

    @model_validator(mode="after")
    def _photos(self) -> "SurfaceConfig":
        if "photo" in self.kinds and self.photos is None:
            raise ValueError("render.surface kind photo needs render.surface.photos (a folder of texture photos)")
        return self


class AppearanceConfig(_Model):
    """``render.appearance``: printed artwork like real cans and texture photos on a user mesh, drawn per sample.

    On the built-in can the label designer draws gradients, fine graphics, small text blocks, logos, metallic
    (silver-showing) inks and bare-metal bodies, or a photo from ``photos`` becomes the artwork; on a user mesh a
    photo from ``photos`` is its texture. Gloss and ink roughness are drawn per sample. Off (null) by default."""

    designer: bool = Field(
        True, description="built-in can: the label designer; false: the plain label (flat fields, a word, a barcode)"
    )
    photos: Annotated[Path | None, identity.by_content("artwork", "artwork photo folder", whole=True)] = Field(
        None, description="folder of images used as artwork: the can's label, or a mesh's texture (box-projected), "
        "in a share photo_share of samples"
    )
    photo_share: float = Field(0.5, ge=0, le=1, description="share of samples whose artwork is a photo (with photos)")
    metallic_share: float = Field(
        0.4, ge=0, le=1, description="built-in can: share of designs printed partly in metallic inks (silver showing)"
    )
    bare_share: float = Field(
        0.15, ge=0, le=1, description="built-in can: share of designs on a bare-metal body (brushed aluminium, a few "
        "inks on it)"
    )
    gloss: UnitRange = Field((0.0, 0.8), description="clear-coat weight (varnish gloss), drawn per sample")
    roughness: UnitRange = Field(
        (0.15, 0.5), description="built-in can: ink roughness, drawn per sample (a mesh keeps its spec's)"
    )


class RenderConfig(_Model):
    """Cycles settings."""

    resolution: int = Field(128, ge=16, le=4096, description="image width and height in pixels")
    samples: int = Field(16, ge=1, le=4096, description="Cycles samples per pixel")
    denoise: bool = Field(True, description="denoise each render (OpenImageDenoise)")
    device: Literal["auto", "cpu", "gpu"] = Field("auto", description="auto = a GPU when Blender finds one")
    threads: int = Field(0, ge=0, le=1024, description="Cycles threads per worker; 0 = cores / workers")
    render_backgrounds: bool = Field(
        False,
        description="render the black and green variants with Cycles instead of compositing them over the "
        "exact alpha (identical for opaque objects, 3x slower)",
    )
    dense: bool = Field(False, description="also write mask, depth, normal, deformation and region maps per image")
    region_threshold_mm: float = Field(1.0, gt=0, le=1000, description="deformation (mm) from which a pixel is in the region")
    region_visible: Annotated[VisibleRegionConfig | None, identity.WHEN_SET] = Field(
        None, description="count in the region only the deformation that shows in the image (a deformed image whose "
        "damage does not show is no deformed image for train.min_region); null = every displaced pixel"
    )
    creases: bool = Field(False, description="scuffed bare metal on sharp ridges and darkened folds (Cycles pointiness)")
    shadow: bool = Field(
        False, description="also write images/shadow/ID.png: the shadow and contact occlusion the part casts on a "
        "ground plane under it (a Cycles shadow catcher lit by the world), for compositing; rgba stays the part alone"
    )
    surface: Annotated[SurfaceConfig | None, identity.WHEN_SET] = Field(
        None, description="also write images/surface/ID.png: the part resting on a textured ground plane, the "
        "whole scene rendered under the same light (deformsim composite uses it by composite.surface); null = off"
    )
    appearance: Annotated[AppearanceConfig | None, identity.WHEN_SET] = Field(
        None, description="printed artwork like real cans (designer, photos, metallic inks, bare metal) and texture "
        "photos on a mesh, with gloss drawn per sample; null = the plain label and the spec's material"
    )
    # Cycles quality/speed (bench/render_quality.py measures them); defaults are Blender's, max_bounces 6.
    adaptive: bool = Field(False, description="adaptive sampling: stop pixels whose noise is below the threshold")
    adaptive_threshold: float = Field(0.01, gt=0, le=1, description="adaptive sampling noise threshold")
    adaptive_min_samples: int = Field(0, ge=0, le=4096, description="samples before adaptive stopping; 0 = automatic")
    max_bounces: int = Field(6, ge=0, le=1024, description="light-path bounces in total")
    diffuse_bounces: int = Field(4, ge=0, le=1024, description="diffuse bounces")
    glossy_bounces: int = Field(4, ge=0, le=1024, description="glossy bounces")
    transmission_bounces: int = Field(12, ge=0, le=1024, description="transmission bounces")
    transparent_bounces: int = Field(8, ge=0, le=1024, description="transparent bounces")
    volume_bounces: int = Field(0, ge=0, le=1024, description="volume bounces")
    caustics_reflective: bool = Field(True, description="reflective caustics")
    caustics_refractive: bool = Field(True, description="refractive caustics")
    clamp_direct: float = Field(0.0, ge=0, le=1_000_000, description="clamp direct light samples to this value; 0 = off")
    clamp_indirect: float = Field(10.0, ge=0, le=1_000_000, description="clamp indirect light samples to this value; 0 = off")
    denoise_input: Literal["rgb", "rgb_albedo", "rgb_albedo_normal"] = Field(
        "rgb_albedo_normal", description="guide passes given to the denoiser"
    )
    denoise_prefilter: Literal["none", "fast", "accurate"] = Field("accurate", description="denoising of the guides")
    denoise_quality: Literal["high", "balanced", "fast"] = Field("high", description="denoiser quality")
    tile_size: int = Field(2048, ge=8, le=8192, description="Cycles tile size in pixels")
    world_map: Annotated[int, identity.WHEN_SET] = Field(
        0, ge=0, le=8192, description="width of the HDRI's light importance map (its height is half), which Cycles "
        "builds again for every scene state: a smaller map builds faster and guides light sampling more coarsely; "
        "0 = Cycles' automatic size (finer than 2048 for Blender's 1024 x 512 HDRIs, and 4x slower to build)"
    )
    view_transform: Literal["Standard", "AgX", "Filmic", "Khronos PBR Neutral"] = Field(
        "Standard", description="colour view transform: Standard clips highlights at 1.0 (exact flat colours); "
        "AgX, Filmic and Khronos PBR Neutral roll bright highlights off like a camera"
    )
    look: Literal["None", "Very Low Contrast", "Low Contrast", "Medium Low Contrast", "Medium Contrast",
                  "Medium High Contrast", "High Contrast", "Very High Contrast", "Punchy"] = Field(
        "None", description="contrast look on top of the view transform (Punchy: AgX only)"
    )

    @model_validator(mode="after")
    def _look(self) -> "RenderConfig":
        if self.look == "Punchy" and self.view_transform != "AgX":
            raise ValueError(f"render.look Punchy needs view_transform AgX (got {self.view_transform})")
        if 0 < self.world_map < 4:
            raise ValueError(f"render.world_map {self.world_map} is below Cycles' least map width, 4 (0 = automatic)")
        return self

    @property
    def part_alpha_only(self) -> bool:
        """Whether the part alone is rendered for its alpha and dense maps only (``surface.part_colour: false``)."""
        return self.surface is not None and not self.surface.part_colour


class GenerateConfig(_Model):
    """Dataset size, seed and the worker pool. A dataset can be resumed or extended with other values of the
    settings that are not in its identity."""

    n: Annotated[int, identity.NEVER] = Field(
        64, ge=1, le=MAX_IMAGES, description="number of images (intact + deformed); more than "
        f"{CONFIRM_IMAGES} ask for --yes"
    )
    seed: Seed = Field(0, description="seed of every random draw of every sample")
    intact_fraction: float = Field(0.5, ge=0, le=1, description="share of intact samples, spread evenly over them")
    paired: Annotated[bool, identity.WHEN_SET] = Field(
        False, description="samples in twins: each deformed sample and the intact one after it share every draw but "
        "the damage (cameras, lights, surface, material, shape and each image's composite), so nothing else tells the "
        "classes apart; needs intact_fraction 0.5"
    )
    workers: Annotated[int, identity.NEVER] = Field(0, ge=0, le=1024, description="render processes; 0 = automatic")
    recycle_every: Annotated[int, identity.NEVER] = Field(
        200, ge=1, le=10**6, description="restart a worker after this many images"
    )
    max_retries: Annotated[int, identity.NEVER] = Field(
        2, ge=0, le=100, description="retries of a failed sample before it is recorded in failures.json"
    )
    backend: Annotated[Literal["local", "ray"], identity.NEVER] = Field(
        "local", description="local: worker processes on this machine; ray: actors on a Ray cluster"
    )
    address: Annotated[str | None, identity.NEVER] = Field(
        None, description="Ray cluster address (HOST:PORT or auto); null = a Ray started on this machine"
    )
    gather: Annotated[bool, identity.NEVER] = Field(
        False, description="Ray: render on each node's local disk and return the images to the driver"
    )
    preview: Annotated[int, identity.NEVER] = Field(16, ge=0, le=1024, description="images on the contact sheet")


class CameraEffects(_Model):
    """Camera effects drawn per composite; null turns one off."""

    exposure: Annotated[Range, Within(-20, 20)] | None = Field((-0.5, 0.5), description="exposure change in stops")
    white_balance: Annotated[Range, Within(-1, 1)] | None = Field((-0.08, 0.08), description="red/blue gain shift (warm > 0)")
    vignette: UnitRange | None = Field((0.0, 0.35), description="darkening at the corners")
    blur: UnitRange | None = Field(
        (0.0, 0.006), description="defocus: Gaussian sigma as a fraction of the image size"
    )
    motion_blur: UnitRange | None = Field(
        None, description="camera shake: blur along a random direction, its length a fraction of the image size"
    )
    noise: UnitRange | None = Field((0.0, 0.025), description="sensor noise: standard deviation in 0-1 units")
    jpeg_quality: Annotated[tuple[int, int], Within(1, 100)] | None = Field(
        (45, 95), description="JPEG re-compression quality"
    )


class CompositeConfig(_Model):
    """Chroma-key matting and compositing onto backgrounds."""

    matte: Literal["alpha", "chroma", "inrange"] = Field(
        "chroma", description="alpha: exact render alpha; chroma: soft green key; inrange: the paper's hard key"
    )
    key_color: tuple[Byte, Byte, Byte] = Field((0, 255, 0), description="RGB colour of the screen behind the part")
    tolerance: int = Field(
        60, ge=0, le=255, description="key tolerance (0-255): how far from the screen a pixel still counts as screen"
    )
    close_kernel: int = Field(5, ge=0, le=255, description="closing of the part's key mask: kernel size in pixels")
    open_kernel: int = Field(3, ge=0, le=255, description="opening of the part's key mask: kernel size in pixels")
    erode_kernel: int = Field(3, ge=0, le=255, description="erosion at the part's edge: kernel size in pixels")
    backgrounds: Path | None = Field(None, description="folder of photos; null = procedural backgrounds")
    scale_jitter: Annotated[Range, Within(1.0, 100)] = Field(
        (1.0, 1.3), description="zoom into the background photo, drawn per image (1 = the photo just covers the frame)"
    )
    flip: bool = Field(True, description="mirror background photos left-right at random")
    flip_part: float = Field(0.0, ge=0, le=1, description="probability of mirroring the part (and its maps) left-right")
    workers: int = Field(0, ge=0, le=1024, description="composite processes; 0 = automatic")
    variants: Annotated[list[VariantName], NonEmpty("composite.variants is empty: name at least one variant")] = Field(
        ["black", "backgrounds"], description="variants deformsim run makes: black and green are the renders; "
        "backgrounds composites onto composite.backgrounds (procedural backgrounds when it is null)"
    )
    balance_backgrounds: bool = Field(
        False, description="use each photo about equally often behind intact and deformed images"
    )
    object_fill: FractionRange | None = Field(
        None, description="crop around the object so its longer side fills this fraction of the frame; null = as rendered"
    )
    fill_offset: float = Field(0.1, ge=0, le=0.5, description="random shift of the object from the frame centre")
    effects: CameraEffects | None = Field(None, description="camera effects per composite; null = none")
    surface: float = Field(
        0.0, ge=0, le=1, description="share of images that show the rendered surface scene of a dataset rendered "
        "with render.surface instead of the part over a background (no matte; framing, flip and effects apply)"
    )
    shadow_strength: Annotated[Range, Within(0, 1)] = Field(
        (1.0, 1.0), description="alpha matte on a dataset rendered with render.shadow: the part's shadow darkens "
        "the background by strength * shadow, strength drawn per image from this range (0 = no shadow)"
    )


class TrainConfig(_Model):
    """The condition-assessment model (paper, section IV)."""

    backbone: Literal[tuple(BACKBONES)] = Field(
        "vgg16", description="ImageNet-pretrained network whose features the head learns on (deformsim.learn.backbones); "
        "set by --backbone or --set, it also empties train.ensemble_backbones unless that is named too"
    )
    weights: Literal["imagenet", "offline", "none"] = Field(
        "imagenet", description="imagenet: the backbone's download (torchvision's file, DINOv2's through torch.hub) from "
        "the hub cache or the internet, else the offline package's; offline: the offline package's only; none: random "
        "initialisation"
    )
    image_size: int = Field(224, ge=32, le=1024, description="input size in pixels (images are resized to it)")
    hidden: tuple[Width, Width] = Field((256, 128), description="widths of the mlp head's two hidden layers")
    dropout: float = Field(0.5, ge=0, lt=1, description="dropout in the head")
    lr: float = Field(1e-3, gt=0, le=10, description="Adam learning rate")
    batch_size: int = Field(32, ge=1, le=4096, description="images per batch")
    epochs: int = Field(15, ge=1, le=10_000, description="passes over the training images")
    split: float = Field(
        0.8, gt=0, lt=1, description="share of the rendered objects that trains (the rest validates; an object's "
        "cameras stay on one side)"
    )
    augment: bool = Field(False, description="random resized crops, flips and colour jitter while training")
    random_conv: float = Field(
        0, ge=0, le=1, description="share of the training images filtered by a random convolution that keeps shapes "
        "and changes texture and colour (Xu et al. 2021; learn.data.RandomConv)"
    )
    cache_features: bool = Field(
        True, description="train on cached activations of the frozen backbone (not with augment or random_conv)"
    )
    grey: bool = Field(
        False, description="judge brightness only: every image turns grey before the backbone, in training and in "
        "prediction, so the print's and the light's colours cannot tell the classes apart"
    )
    threshold: float = Field(0.5, gt=0, lt=1, description="probability from which an image (or pixel) is deformed")
    variants: Annotated[list[VariantName], NonEmpty("train.variants is empty: name at least one variant")] = Field(
        ["black", "backgrounds"], description="image variants the report trains and evaluates on; the first is "
        "deformsim train's default"
    )
    seed: Seed = Field(0, description="seed of the split, the initialisation and the batch order")
    device: Literal["auto", "cpu", "cuda"] = Field("auto", description="auto = cuda when available")
    precision: Literal["auto", "float32", "bfloat16"] = Field(
        "auto", description="number format of the training steps' forward and backward passes (the weights, the "
        "cached features and every prediction stay float32): auto = bfloat16 where the device computes it natively "
        "(a CPU with AVX-512 BF16 or AMX, a CUDA GPU that supports it), else float32"
    )
    finetune: Literal["last_conv", "last_block", "none"] = Field(
        "last_conv", description="trainable part of the backbone: its last convolution (the paper), last block, or "
        "none (the head alone learns, on the whole frozen network's cached features)"
    )
    head: Literal["mlp", "linear"] = Field("mlp", description="mlp: the paper's 3 layers; linear: a linear probe")
    pool: Literal["avg", "max", "avgmax"] = Field(
        "avg", description="how the trainable layers' feature map becomes the head's input: its mean (the paper's), "
        "its maximum (a local feature counts however small its area) or both side by side"
    )
    feature_norm: bool = Field(
        False, description="batch-normalise the pooled features (lets --adapt re-estimate them on real photos)"
    )
    adapt_method: Literal["adabn", "selftrain"] = Field(
        "adabn", description="with unlabelled photos: adabn re-estimates feature statistics; selftrain adds "
        "confident pseudo-labels of the photos and trains on"
    )
    adapt_epochs: int = Field(5, ge=1, le=10_000, description="selftrain: epochs on synthetic + pseudo-labelled photos")
    pseudo_confidence: float = Field(0.9, gt=0.5, lt=1, description="selftrain: keep photos predicted this surely")
    target: Literal["label", "severity", "family", "localise"] = Field(
        "label", description="label: intact/deformed (the paper); on dense datasets also severity (max displacement, "
        "mm), family (deformation kinds, multi-label) or localise (deformed-region mask), each one model of "
        "train.backbone (set by --target or --set, a dense target also sets train.ensemble 1 and empties "
        "train.ensemble_backbones unless they are named too)"
    )
    schedule: Literal["constant", "cosine"] = Field(
        "constant", description="learning rate over the epochs: constant, or cosine decay to zero (fine-tuning)"
    )
    ensemble: int = Field(
        1, ge=1, le=16, description="models trained with seeds seed, seed+1, ..., each on its own training/validation "
        "split (bagging), saved as one that predicts their mean probability (they share the frozen layers, so their "
        "cached features too)"
    )
    ensemble_backbones: list[Literal[tuple(BACKBONES)]] = Field(
        [], description="more backbones whose models join the saved one: each trains as train.backbone's does (the "
        "same split, seeds and train.ensemble members, its own frozen layers and cached features), and the model "
        "predicts the mean of every backbone's probability"
    )
    balance: bool = Field(
        False, description="weigh both classes the same in the loss (each deformed image by the training split's "
        "intact over deformed images): train.min_region leaves deformed images out, which tilts the model towards intact"
    )
    min_region: float = Field(
        0.0, ge=0, lt=1, description="deformed images whose deformed region (render.dense's region map) covers less "
        "than this share of the visible part are left out of training and the synthetic test: their damage faces "
        "away from the camera or is too small to see, so their label would be wrong; 0 keeps every image"
    )
    tta_flip: bool = Field(
        False, description="test time: average the prediction of each image and its mirror image"
    )
    crop: Literal["none", "saliency", "center", "pad"] = Field(
        "none", description="test time: make each image square before classifying: saliency, a crop around its most "
        "salient region (the part, by spectral-residual saliency); center, its largest centred square; pad, the whole "
        "image on a square, its margins the image stretched and blurred; none: the whole image, resized to a square "
        "(squeezed if not square); training images (square renders) are not changed"
    )

    @model_validator(mode="after")
    def _spatial(self) -> "TrainConfig":
        if self.target == "localise" and not BACKBONES[self.backbone].spatial:
            raise ValueError(f"train.target localise needs a convolutional backbone; {self.backbone} outputs tokens")
        if self.balance and self.target != "label":
            raise ValueError(f"train.balance applies to train.target label, not {self.target}")
        if self.ensemble > 1 and self.target != "label":
            raise ValueError(f"train.ensemble applies to train.target label, not {self.target}")
        if self.ensemble_backbones and self.target != "label":
            raise ValueError(f"train.ensemble_backbones applies to train.target label, not {self.target}")
        if self.backbone in self.ensemble_backbones:
            raise ValueError(f"train.ensemble_backbones names train.backbone ({self.backbone}) again: list the other "
                             "backbones (train.ensemble adds members of the same one)")
        if twice := [b for b in dict.fromkeys(self.ensemble_backbones) if self.ensemble_backbones.count(b) > 1]:
            raise ValueError(f"train.ensemble_backbones names {twice[0]} twice")
        return self

    def for_target(self, target: str) -> "TrainConfig":
        """This config trained for ``target``: a dense target is one model of ``train.backbone`` (``train.ensemble``
        and ``train.ensemble_backbones`` shape the label classifier)."""
        return self.model_copy(update={"target": target, **({} if target == "label" else ONE_MODEL)})


class Config(_Model):
    """A whole run: object, rig sampling, scene, rendering, compositing and training."""

    object: ObjectConfig = Field(ObjectConfig(), description="the part and its deformation spec")
    camera: CameraConfig = Field(CameraConfig(), description="the cameras and how each image is framed")
    pose: PoseConfig = Field(PoseConfig(), description="how the part lies")
    lighting: LightingConfig = Field(LightingConfig(), description="HDRI world and area lights")
    deform: DeformConfig = Field(DeformConfig(), description="how deformed samples are shaped")
    render: RenderConfig = Field(RenderConfig(), description="Cycles settings and the extra images per render")
    generate: GenerateConfig = Field(GenerateConfig(), description="dataset size, seed and the render workers")
    composite: Annotated[CompositeConfig, identity.NEVER] = Field(
        CompositeConfig(), description="matting and backgrounds (deformsim composite)"
    )
    train: Annotated[TrainConfig, identity.NEVER] = Field(TrainConfig(), description="the model (deformsim train)")

    @model_validator(mode="after")
    def _balanced(self) -> "Config":
        views = len(self.camera.azimuth_quadrants)
        if self.generate.n % views:
            raise ValueError(f"generate.n={self.generate.n} must be a multiple of the {views} cameras")
        if self.generate.paired and self.generate.intact_fraction != 0.5:
            raise ValueError(f"generate.paired needs generate.intact_fraction 0.5 (one intact twin per deformed "
                             f"sample), not {self.generate.intact_fraction:g}")
        if self.render.region_visible and not self.render.dense:
            raise ValueError("render.region_visible needs render.dense: true (it shapes the region maps)")
        if self.train.min_region and not self.render.dense:
            raise ValueError(f"train.min_region={self.train.min_region:g} needs render.dense: true (each image's "
                             "deformed region)")
        if self.render.part_alpha_only and self.composite.surface < 1:
            raise ValueError(f"render.surface.part_colour: false needs composite.surface: 1 (the part alone is not "
                             f"rendered in colour, only its surface scenes can be shown), not {self.composite.surface:g}")
        return self

    def input_paths(self) -> dict[str, Path | None]:
        """Every file and folder the renders are made from (the fields read by content), by what it is:
        ``{"mesh": ..., "spec": ..., "HDRI folder": ..., "artwork photo folder": ...}``; None where unset."""
        return {rule.what: path for rule, path in identity.content_inputs(self)}

    def photo_folders(self) -> dict[str, Path | None]:
        """The input folders read with everything under them (photos found recursively), by what each is: an
        output inside one would be read as input next time."""
        return {rule.what: path for rule, path in identity.content_inputs(self) if rule.whole}


def preset_path(name: str) -> Path:
    return PRESET_DIR / f"{name}.yaml"


def load_config(source: str | Path | None = None, overrides: dict | None = None,
                flags: dict[str, str] | None = None) -> Config:
    """Load a config from a YAML path or preset name (default ``quick``), apply dotted overrides.

    ``overrides`` maps dotted keys (``"render.resolution"``) to values; ``None`` sets null (an effect off).
    ``flags`` names where an override came from (``{"generate.n": "--n"}``), for error messages.
    Raises :class:`UserError` with one line naming the bad file or value (a bad override by its flag).
    """
    source = source or "quick"
    path = Path(source)
    if not path.exists() and preset_path(str(source)).exists():
        path = preset_path(str(source))
    if not path.is_file():
        raise UserError(f"config file not found: {source} (presets: {', '.join(list_presets())})")
    given = overrides or {}
    data = apply_overrides(apply_overrides(read_mapping(path, "config"), given), _yielding(given))
    return validate_config(data, str(path), given, flags)


def _yielding(given: dict) -> dict:
    """What of the file's model yields to ``given`` overrides that do not name it: its further backbones to a
    train.backbone (a model of the backbone named), its ensemble too to a dense train.target (one model)."""
    reset = {"train.ensemble_backbones": []} if "train.backbone" in given else {}
    if given.get("train.target", "label") != "label":
        reset |= {f"train.{k}": v for k, v in ONE_MODEL.items()}
    return {k: v for k, v in reset.items() if k not in given}


def apply_overrides(data: dict, overrides: dict | None) -> dict:
    """``data`` with dotted keys (``"render.resolution"``) set to their values (``None`` is YAML's null); a key under
    a value that is no mapping is ignored (validation names that value)."""
    for key, value in (overrides or {}).items():
        node = data
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                break
        else:
            node[leaf] = value
    return data


def validate_config(data: dict, origin: str = "config", overrides: dict | None = None,
                    flags: dict[str, str] | None = None) -> Config:
    """``data`` as a :class:`Config`, or one :class:`UserError` line naming the bad value and where it came from:
    ``origin`` (the file), or, for a key set by ``overrides`` (the bad value is that key or inside it, or the
    message names it), its flag in ``flags`` (else "override KEY")."""
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        loc, msg, value = first_error(exc, data)
        where = ".".join(str(p) for p in loc) or "config"
        given = overrides or {}
        key = next((k for k in given if where == k or where.startswith(f"{k}.")), None)
        what = f"invalid {where}: {msg}"
        if key is None:
            key, what = next((k for k in given if k in msg), None), msg
        if key is not None:
            flag = (flags or {}).get(key) or f"override {key}"
            raise UserError(f"{flag} {shown(given[key])}: {what}") from None
        raise UserError(f"{origin}: invalid {where}: {msg} (got {shown(value)})") from None


def list_presets() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def dump_config(cfg: Config) -> str:
    return yaml.safe_dump(cfg.model_dump(mode="json"), sort_keys=False)
