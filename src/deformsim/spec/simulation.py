"""Simulated deformation scenarios of a spec (``simulation:``) and the variants a bank holds of each.

A scenario is a physical situation the part can be crushed in; a bake simulates ``variants`` draws of its
parameters (travel, tilt, impact point ...) once, with Blender's cloth solver (:mod:`deformsim.blender.motion.simulate`),
and keeps each result as a bank entry. Travels are fractions of the part's extent along the press.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from deformsim.schema import Range, StrictModel, check_range, check_unique

KINDS = ("axial_crush", "lateral_squash", "impact_dent", "crumple")


class Scenario(StrictModel):
    """One way the part gets crushed.

    ``axial_crush``: a plate presses the standing part onto the ground (``tilt``: plate tilt, degrees);
    ``lateral_squash``: two plates squeeze it from opposite sides; ``impact_dent``: an ``impactor`` of ``size``
    (fraction of the part) is driven into it at a height in ``height_band``; ``crumple``: plates from
    ``directions`` sides at once, a fist around the part.
    """

    name: str
    kind: Literal["axial_crush", "lateral_squash", "impact_dent", "crumple"]
    variants: int = Field(6, ge=1, le=500, description="bank entries simulated for this scenario")
    travel: Range = (0.3, 0.6)
    tilt: Range = (0.0, 0.0)
    impactor: Literal["sphere", "cylinder", "box"] = "sphere"
    size: Range = (0.2, 0.4)
    height_band: Range = (0.2, 0.8)
    directions: tuple[int, int] = (3, 4)

    @field_validator("travel")
    @classmethod
    def _travel(cls, v: Range) -> Range:
        check_range(v, 0, name="travel")
        if v[1] >= 1:
            raise ValueError(f"travel {list(v)} must stay below 1 (a fraction of the part's extent)")
        return v

    @field_validator("tilt")
    @classmethod
    def _tilt(cls, v: Range) -> Range:
        return check_range(v, 0, 45, name="tilt")

    @field_validator("size", "height_band")
    @classmethod
    def _fraction(cls, v: Range, info) -> Range:
        return check_range(v, 0, 1, name=info.field_name)

    @field_validator("directions")
    @classmethod
    def _directions(cls, v: tuple[int, int]) -> tuple[int, int]:
        if not 2 <= v[0] <= v[1] <= 6:
            raise ValueError(f"directions {list(v)} must satisfy 2 <= min <= max <= 6")
        return v


class Simulation(StrictModel):
    """Solver settings shared by every scenario (a changed value re-bakes the bank)."""

    resolution: int = Field(40, ge=8, le=160, description="voxels across the part's largest dimension")
    frames: int = Field(30, ge=4, le=400, description="frames the colliders take to travel")
    quality: int = Field(5, ge=1, le=40, description="cloth solver steps per frame")
    stiffness: float = Field(40.0, gt=0, le=10000, description="tension, compression and shear stiffness")
    bending: float = Field(5.0, ge=0, le=10000, description="bending stiffness: higher folds like thicker metal")
    scenarios: list[Scenario]

    @model_validator(mode="after")
    def _names(self) -> "Simulation":
        if not self.scenarios:
            raise ValueError("simulation declares no scenarios")
        check_unique([s.name for s in self.scenarios], "scenario")
        return self


@dataclass(frozen=True)
class Variant:
    """The drawn parameters of one bank entry."""

    index: int
    travel: float
    tilt: float
    azimuth: float
    height: float = 0.5
    size: float = 0.0
    directions: tuple[float, ...] = ()
    elevations: tuple[float, ...] = ()

    def to_dict(self) -> dict:
        return asdict(self)


def variants(scenario: Scenario) -> list[Variant]:
    """The scenario's bank entries: fixed by its name and settings, drawn in index order."""
    out = []
    for i in range(scenario.variants):
        rng = np.random.default_rng([zlib.crc32(scenario.name.encode()), i])
        travel = float(rng.uniform(*scenario.travel))
        tilt = float(rng.uniform(*scenario.tilt))
        azimuth = float(rng.uniform(0, 360))
        height = float(rng.uniform(*scenario.height_band))
        size = float(rng.uniform(*scenario.size))
        k = int(rng.integers(scenario.directions[0], scenario.directions[1] + 1))
        dirs = tuple(float(a) for a in azimuth + np.sort(rng.uniform(0, 360, size=k)))
        elev = tuple(float(e) for e in rng.uniform(-30, 30, size=k))
        out.append(Variant(i, travel, tilt, azimuth, height, size, dirs, elev))
    return out


def entry_names(sim: Simulation | None) -> list[str]:
    """Every bank entry's name, ``SCENARIO/INDEX``, in bank order."""
    if sim is None:
        return []
    return [f"{s.name}/{i}" for s in sim.scenarios for i in range(s.variants)]
