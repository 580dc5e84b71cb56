"""What an optional render feature declares to the driver, in one place (no Blender).

A feature is one :class:`RenderFeature` in :data:`deformsim.sampling.features.FEATURES` and one class of its Blender
side (:class:`deformsim.blender.feature.Feature`, named by :attr:`~RenderFeature.blender`). Sampling draws it, the
manifest writes its columns, the refusals count its cost and the worker sets up its Blender side by looping over
the registry, so none of them names a feature.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from deformsim.config import Config
from deformsim.sampling.streams import Stream, generator
from deformsim.spec.model import Spec


class Given(NamedTuple):
    """What a feature's draw reads besides its stream: the config, the spec, the sample's cameras before their
    framing (``CameraParams``) and the files its :attr:`~RenderFeature.listing` listed once per run."""

    cfg: Config
    spec: Spec
    cameras: tuple
    listing: list[str] | None


@dataclass(frozen=True)
class RenderFeature:
    """One optional render feature, as the driver sees it."""

    name: str  # the stream's name and the key of its listing
    section: str  # the config key that turns it on (for people: docs and messages)
    on: Callable[[Config], bool]  # whether a config turns it on
    blender: str  # "module:Class" of its Blender side, set up by each worker when ``on``
    field: str = ""  # the SampleParams field its draw fills ("": it draws nothing)
    stream: Stream | None = None  # the named random stream of its draw, keyed by the sample's index
    draw: Callable[[np.random.Generator, Given], Any] | None = None
    off: Any = None  # the field's value while the feature is off
    columns: Callable[[Any], dict] | None = None  # the manifest columns of its drawn value (the off value's too)
    kinds: tuple[str, ...] = ()  # image kinds its Blender side writes per camera
    renders: int = 0  # extra Cycles renders per image (each writes one image of its kinds)
    png_bytes: float = 0.0  # bytes per pixel of the images it writes without an extra render (disk estimate)
    listing: Callable[[Config], list[str] | None] | None = None  # the input files its draw picks from

    def value(self, index: int, seed: int, given: Given) -> Any:
        """The drawn value of sample ``index`` (its pair's index with ``generate.paired``) of run ``seed``."""
        if not self.on(given.cfg):
            return self.off
        return self.draw(generator(self.stream, seed, index, name=self.name), given)
