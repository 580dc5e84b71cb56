"""The drawn parameters of a sample: what the driver sends a worker and a sample's record keeps."""

from __future__ import annotations

from dataclasses import dataclass

from deformsim.sampling.records import Record, optional
from deformsim.sampling.sun import SunParams


@dataclass(frozen=True)
class CameraParams(Record):
    """One camera image's view. The fields after ``radius`` are the per-image framing (``camera.fill``,
    ``offset``, ``partial``, a ``lens_mm`` range, ``fstop``: :func:`~deformsim.sampling.draws.draw_framing`); their
    defaults mean off, and the record leaves them out while off."""

    azimuth: float  # degrees
    polar: float  # degrees from the up axis
    radius: float  # metres (for the can; scaled with the object's size otherwise); unused when fill > 0
    fill: float = optional(0.0)  # fraction of the frame side the part's 2D box (longer side) fills; 0 = by radius
    shift_x: float = optional(0.0)  # the part's box centre right of the frame centre, fraction of the frame side
    shift_y: float = optional(0.0)  # ... above the frame centre
    cut: float = optional(0.0)  # share of the part's box past the frame border (camera.partial); 0 = whole part in frame
    cut_side: str = optional("")  # "left" | "right" | "top" | "bottom" the box crosses; "none": not cut; "": partial off
    lens: float = optional(0.0)  # focal length (mm); 0 = camera.lens_mm
    fstop: float = optional(0.0)  # aperture f-number of the depth of field, focused on the part's centre; 0 = no DOF

    @property
    def framed(self) -> bool:
        """Placed by the part's projected box (fill, offset or partial), not only aimed at its centre."""
        return self.fill > 0 or self.shift_x != 0 or self.shift_y != 0 or self.cut_side != ""


@dataclass(frozen=True)
class CanDesign(Record):
    """The artwork printed on the can's side wall (drawn by :mod:`deformsim.blender.part.can_label`)."""

    hue: float
    saturation: float
    value: float
    accent_hue: float
    bands: int
    band_seed: int
    word: str


@dataclass(frozen=True)
class PrintParams(Record):
    """A finish's printed marks (spec ``print``): the ink, the style and the seed of the marks' layout and words."""

    ink: tuple[float, float, float]
    style: str  # "ring" | "lines" | "dots"
    seed: int


@dataclass(frozen=True)
class MaterialParams(Record):
    """A user mesh's surface colour and roughness, then each of the spec's material regions' (in its order); the
    printed marks of a finish with ``print`` (None: bare this sample)."""

    color: tuple[float, float, float]
    roughness: float
    regions: tuple[MaterialParams, ...] = optional(())
    print: PrintParams | None = optional(None)


@dataclass(frozen=True)
class ShapeParams(Record):
    """``object.shapes``: the part's drawn shape. The built-in can's nominal size and proportions (a named size, or
    "A~B" for a blend of two), then the per-axis scale, taper and bulge any part takes."""

    size: str  # a named size of config.CAN_SIZES, "A~B" between two, "" for a mesh
    diameter: float  # mm: nominal body diameter (0 for a mesh)
    height: float  # mm: nominal height (0 for a mesh)
    rim: float  # rim radius over body radius
    neck: float  # factor on the neck's height
    dome: float  # factor on the bottom dome's depth
    scale: tuple[float, float, float]  # factors on x, y, z
    taper: float  # x, y scale by 1 + taper * (2 h - 1) at height share h
    bulge: float  # x, y scale by 1 + bulge * sin(pi h)


@dataclass(frozen=True)
class AppearanceParams(Record):
    """``render.appearance``: what is printed on the part and how it shines."""

    style: str  # can: "designer" | "bare" (bare-metal body) | "plain" (the old label) | "photo"; mesh: "photo" | "plain"
    seed: int  # the designer's layout, graphics and text
    metallic: bool  # some inks are metallic (silver shows through)
    photo: str  # style photo: the artwork's path
    crop: tuple[float, float, float]  # photo: left and top of the crop (shares of the room), zoom (>= 1)
    gloss: float  # clear-coat weight
    roughness: float  # ink roughness (can)


@dataclass(frozen=True)
class LightParams(Record):
    """One area light (``lighting.area_lights``), placed on a sphere around the part's centre and aimed at it.
    Lengths are metres for the built-in can and scale with the part, like :attr:`CameraParams.radius`."""

    kind: str  # "softbox" | "ring" | "window" | "overhead"
    azimuth: float  # degrees about +Z from +X
    elevation: float  # degrees above the horizontal through the part's centre
    distance: float  # metres from the part's centre
    size: float  # metres: the rectangle's width or the disk's diameter
    size_y: float  # metres: the rectangle's height (= size for a disk)
    spin: float  # degrees: rotation of the rectangle about its own axis
    power: float  # watts given to Blender for the built-in can (times the part's scale squared otherwise)
    temperature: float  # colour temperature in kelvin


@dataclass(frozen=True)
class SurfaceParams(Record):
    """The ground the part rests on (``render.surface``): a procedural material or a texture photo."""

    kind: str  # one of config.SURFACE_KINDS
    hue: float  # 0..1: the surface's colour (HSV), kept plausible per kind by blender.scene.surface
    saturation: float
    value: float
    roughness: float
    scale: float  # texture scale factor (1 = the kind's natural size at the built-in can's scale)
    rotation: float  # degrees: the texture's turn about the vertical (grain, weave, ridge direction)
    offset: tuple[float, float]  # texture shift (fractions of its pattern), so no two samples show the same patch
    photo: str = ""  # kind photo: the texture photo's path


@dataclass(frozen=True)
class SampleParams(Record):
    """One sample: a scene state (deformation, openings, label, lighting, pose) seen by each of its cameras."""

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
    shape: ShapeParams | None = optional(None)  # object.shapes: the part's drawn shape; None = as built
    appearance: AppearanceParams | None = optional(None)  # render.appearance: artwork and finish; None = off
    pair: int | None = optional(None)  # generate.paired: the deformed twin whose draws (all but the damage) it shares
    sun: SunParams | None = optional(None)  # lighting.sun: the sample's hard key light; None = off

    @property
    def deformed(self) -> bool:
        return self.label == "deformed"
