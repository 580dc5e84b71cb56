"""The deformation spec: an expert's description of how a part can deform, loaded from YAML.

A spec names deformation *families* (crush, pinch, ...), each a list of *keys*; each key is a list of
parametric lattice operations (see :mod:`deformsim.spec.lattice_ops`). It also declares surface crinkle
(displacement textures limited to a vertex-selection rule), opening keys, materials and mesh units.
Validation happens here, before any rendering, with one-line errors naming the problem.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

from pydantic import ConfigDict, Field, ValidationError, field_validator, model_serializer, model_validator

from deformsim.errors import UserError
from deformsim.schema import Range, StrictModel, check_range, check_unique, first_error, read_mapping, shown
from deformsim.spec.lattice_ops import OPERATIONS
from deformsim.spec.mesh_numbers import check_size
from deformsim.spec.simulation import Simulation

BUILTIN_SPEC = Path(__file__).parent / "builtin" / "can.yaml"
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".fbx")
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "in": 0.0254, "ft": 0.3048}
PLAUSIBLE_SIZE = (0.005, 5.0)  # metres: a part's largest dimension outside this suggests a wrong ``units``
Offset = Annotated[float, Field(ge=-1000, le=1000)]

class Operation(StrictModel):
    """One lattice-point operation: ``op`` names a function of :data:`rig_ops.OPERATIONS`."""

    model_config = ConfigDict(extra="allow")
    op: str

    @model_validator(mode="after")
    def _known(self) -> "Operation":
        if self.op not in OPERATIONS:
            raise ValueError(f"unknown operation '{shown(self.op)}' (known: {', '.join(sorted(OPERATIONS))})")
        fn = OPERATIONS[self.op]
        try:
            fn.check(self.params)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"operation '{self.op}': {exc}") from None
        return self

    @property
    def params(self) -> dict:
        return dict(self.model_extra or {})


class Key(StrictModel):
    """A lattice shape key: the operations applied, in order, to the rest lattice at full weight."""

    name: str
    ops: list[Operation]

    @field_validator("ops")
    @classmethod
    def _nonempty(cls, v: list[Operation]) -> list[Operation]:
        if not v:
            raise ValueError("key has no operations")
        return v


class Family(StrictModel):
    """Keys of one kind of damage; ``weight``: how often a deformed sample draws it against the others (1 each)."""

    name: str
    keys: list[Key]
    weight: float = Field(1.0, gt=0, le=1000)

    @model_serializer(mode="wrap")
    def _dump(self, handler) -> dict:
        """The default weight is left out, so a spec without weights keeps its digest (and its datasets)."""
        data = handler(self)
        if self.weight == 1.0:
            data.pop("weight", None)
        return data

    @field_validator("keys")
    @classmethod
    def _nonempty(cls, v: list[Key]) -> list[Key]:
        if not v:
            raise ValueError("family has no keys")
        return v


class SelectionRule(StrictModel):
    """Which vertices (or faces) a rule selects; every given criterion must hold.

    ``group``: an existing vertex group (the built-in can makes ``side_wall``); ``max_normal_angle``: the
    normal is within this many degrees of horizontal; ``min_normal_angle``: at least this many (60: the ends of
    an upright part); ``height_band``: the height as a fraction of the object's height lies inside this band.
    """

    group: str | None = None
    max_normal_angle: float | None = Field(None, gt=0, le=90)
    min_normal_angle: float | None = Field(None, ge=0, lt=90)
    height_band: Range | None = None

    @field_validator("height_band")
    @classmethod
    def _band(cls, v: Range | None) -> Range | None:
        if v is not None:
            check_range(v, 0, name="height_band")
            if v[1] > 1:
                raise ValueError(f"height_band {list(v)} must lie inside [0, 1]")
        return v

    @model_validator(mode="after")
    def _some(self) -> "SelectionRule":
        if self.group is None and self.max_normal_angle is None and self.min_normal_angle is None \
                and self.height_band is None:
            raise ValueError("rule selects nothing: give group, max_normal_angle, min_normal_angle or height_band")
        lo, hi = self.min_normal_angle, self.max_normal_angle
        if lo is not None and hi is not None and lo >= hi:
            raise ValueError(f"min_normal_angle {lo} must be below max_normal_angle {hi}")
        return self


class Texture(StrictModel):
    """A hard Stucci displacement texture, applied as its own shape key."""

    name: str
    noise_scale: float = Field(0.01, gt=0, le=100, description="texture feature size, in object units (m)")
    strength: float = Field(0.002, gt=0, le=10, description="displacement at full weight (m)")
    turbulence: float = Field(5.0, ge=0, le=1000)
    stucci_type: Literal["PLASTIC", "WALL_IN", "WALL_OUT"] = "WALL_OUT"
    offset: tuple[Offset, Offset, Offset] = (0.0, 0.0, 0.0)


class Displacement(StrictModel):
    vertex_rule: SelectionRule
    textures: list[Texture] = []


class Openings(StrictModel):
    """Opening shape keys on the mesh; the tab is never more open than the seal."""

    seal: str | None = None
    tab: str | None = None

    @model_validator(mode="after")
    def _tab_needs_seal(self) -> "Openings":
        if self.tab and not self.seal:
            raise ValueError("a tab key needs a seal key (the tab is never more open than the seal)")
        return self


ColorRange = tuple[tuple[float, float, float], tuple[float, float, float]]


def _check_color(v: ColorRange) -> ColorRange:
    for lo, hi in zip(*v):
        if not 0 <= lo <= hi <= 1:
            raise ValueError(f"colour range {[list(c) for c in v]} must satisfy 0 <= min <= max <= 1")
    return v


class Print(StrictModel):
    """Printed marks on a finish, drawn per sample: ink laid on the surface, projected from each side of the part's
    box (on the ends of an upright part: seen from above)."""

    share: float = Field(1.0, ge=0, le=1, description="share of samples printed (the others bare)")
    inks: list[ColorRange] = Field(
        [((0.02, 0.02, 0.02), (0.25, 0.25, 0.25))], min_length=1,
        description="ink colour ranges: a printed sample draws one, then each channel in its range")
    styles: list[Literal["ring", "lines", "dots"]] = Field(
        ["ring", "lines", "dots"], min_length=1,
        description="what a printed sample draws one of: ring (words around the centre), lines (a few lines of text), "
        "dots (an ink-jet dot-matrix code)")

    @field_validator("inks")
    @classmethod
    def _inks(cls, v: list[ColorRange]) -> list[ColorRange]:
        return [_check_color(c) for c in v]


class Finish(StrictModel):
    """A randomised surface: kind, colour and roughness ranges drawn per sample, anisotropy, printed marks."""

    kind: Literal["metal", "plastic", "painted"] = "metal"
    color: ColorRange = ((0.6, 0.6, 0.62), (0.9, 0.9, 0.92))
    color_draw: Literal["channels", "blend"] = Field(
        "channels", description="channels: each colour channel drawn in its own range (any colour of the box); blend: "
        "one mix from the first colour to the second (a range of greys stays grey)"
    )
    roughness: Range = (0.2, 0.45)
    anisotropic: float | None = Field(
        None, ge=0, le=1, description="highlights stretched along the brushing or rolling direction (0-1; metal 0.3, "
        "plastic and painted 0 when not given)"
    )
    anisotropic_rotation: float = Field(
        0.0, ge=0, le=1, description="brushing direction in turns from around the up axis (0.25: along it)"
    )
    print: Print | None = Field(None, exclude_if=lambda v: v is None,
                                description="printed marks (text, codes) in a drawn ink; none when not given")

    @field_validator("color")
    @classmethod
    def _color(cls, v: ColorRange) -> ColorRange:
        return _check_color(v)

    @field_validator("roughness")
    @classmethod
    def _rough(cls, v: Range) -> Range:
        return check_range(v, 0, 1, name="roughness")


class Region(Finish):
    """A part of the mesh with a finish of its own: the faces whose centre and normal meet ``where``."""

    name: str
    where: SelectionRule


class Material(Finish):
    """Randomised surface for user meshes (the built-in can has its own label and aluminium); ``regions`` give parts of
    the mesh finishes of their own (a later region takes the faces it shares with an earlier one)."""

    regions: list[Region] = []

    @field_validator("regions")
    @classmethod
    def _names(cls, v: list[Region]) -> list[Region]:
        check_unique([r.name for r in v], "region")
        return v


class Lattice(StrictModel):
    points: tuple[int, int, int] = (6, 6, 8)
    margin: float = Field(0.04, ge=0, le=1, description="fraction of the bounding box added on each side")

    @field_validator("points")
    @classmethod
    def _points(cls, v):
        if min(v) < 2 or max(v) > 64:
            raise ValueError(f"lattice points {list(v)} must each be between 2 and 64")
        return v


class Spec(StrictModel):
    """A whole deformation spec."""

    name: str
    builtin: Literal["can"] | None = Field(None, description="built-in object instead of a mesh file")
    units: str = Field("m", description="length unit of the mesh file")
    size: float | None = Field(None, gt=0, le=1000, description="rescale so the largest dimension is this many metres")
    up_axis: Literal["Z", "Y"] = "Z"
    lattice: Lattice = Lattice()
    families: list[Family]
    displacement: Displacement | None = None
    openings: Openings = Openings()
    material: Material | None = None
    simulation: Simulation | None = Field(None, description="physically simulated deformations (a baked bank)")

    @field_validator("units")
    @classmethod
    def _units(cls, v: str) -> str:
        if v not in UNITS:
            raise ValueError(f"unknown unit '{shown(v)}' (known: {', '.join(UNITS)})")
        return v

    @model_validator(mode="after")
    def _unique(self) -> "Spec":
        if not self.families:
            raise ValueError("spec declares no deformation families")
        names = [k.name for f in self.families for k in f.keys]
        names += [t.name for t in (self.displacement.textures if self.displacement else [])]
        check_unique(names, "key")
        fams = [f.name for f in self.families]
        check_unique(fams, "family")
        clash = sorted(set(fams) & set(self.scenario_names))
        if clash:
            raise ValueError(f"scenario names that are also family names: {', '.join(clash)}")
        return self

    @property
    def scenario_names(self) -> list[str]:
        return [s.name for s in self.simulation.scenarios] if self.simulation else []

    @property
    def key_names(self) -> list[str]:
        return [k.name for f in self.families for k in f.keys]

    @property
    def texture_names(self) -> list[str]:
        return [t.name for t in self.displacement.textures] if self.displacement else []

    @property
    def unit_scale(self) -> float:
        return UNITS[self.units]


def load_spec(path: str | Path | None = None) -> Spec:
    """Load and validate a spec (default: the built-in can). Raises :class:`UserError` naming the problem."""
    path = Path(path) if path else BUILTIN_SPEC
    if not path.is_file():
        raise UserError(f"spec file not found: {path}")
    data = read_mapping(path, "spec")
    try:
        return Spec.model_validate(data)
    except ValidationError as exc:
        loc, msg, _ = first_error(exc, data)
        raise UserError(f"spec {path}: {_where(data, loc)}: {msg}") from None


def _where(data: dict, loc: tuple) -> str:
    """Turn a pydantic location into words, naming families and keys rather than list indices."""
    parts, node = [], data
    for p in loc:
        node = node[p] if isinstance(node, (dict, list)) and _has(node, p) else None
        if isinstance(p, int) and isinstance(node, dict) and "name" in node:
            parts[-1] = f"{parts[-1]} '{shown(node['name'], 40)}'"
        elif isinstance(p, int):
            parts[-1] = f"{parts[-1]}[{p}]"
        else:
            parts.append(shown(p, 40))
    return ".".join(parts) or "spec"


def _has(node, p) -> bool:
    return (isinstance(node, dict) and p in node) or (isinstance(node, list) and isinstance(p, int) and p < len(node))


def units_hint(size: list[float] | tuple[float, ...], spec: Spec) -> str | None:
    """A hint when the part's size in metres (after ``units``) suggests the wrong unit; None when it is plausible.

    The suggested unit is the one that makes the largest dimension closest to a hand-held part (15 cm).
    """
    largest = max(size)
    if spec.size is not None or PLAUSIBLE_SIZE[0] <= largest <= PLAUSIBLE_SIZE[1] or largest <= 0:
        return None
    raw = largest / spec.unit_scale
    best = min(UNITS, key=lambda u: abs(math.log(raw * UNITS[u] / 0.15)))
    dims = " x ".join(f"{v:.3g}" for v in size)
    if best == spec.units:
        return f"the part is {dims} m (units: {spec.units}): is that its real size? set size: METRES in the spec if not"
    fixed = " x ".join(f"{v / spec.unit_scale * UNITS[best] * 1000:.3g}" for v in size)
    return (f"the part is {dims} m with units: {spec.units}; if the mesh is in {best} (then {fixed} mm), "
            f"set units: {best} in the spec (or size: METRES)")


def check_mesh_file(path: str | Path) -> Path:
    """Fail with one line unless ``path`` is an existing, non-empty file of a supported mesh format, of a size its
    format allows (:func:`deformsim.spec.mesh_numbers.check_size`)."""
    path = Path(path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise UserError(f"mesh {path}: unsupported format '{path.suffix}' (use {', '.join(MESH_SUFFIXES)})")
    if not path.is_file():
        raise UserError(f"mesh file not found: {path}")
    if path.stat().st_size == 0:
        raise UserError(f"mesh {path} is empty (0 bytes)")
    check_size(path)
    return path
