"""The seam of optional render features: the scene a worker builds once, and the interface each feature implements.

A feature (area lights, drop poses, dense maps, shadow, surface) is declared once in the registry
:data:`deformsim.sampling.features.FEATURES` (its config section, draw, manifest columns, image kinds, cost), which
names its Blender side: one class implementing :class:`Feature`. It is set up once per worker when its config
option is on (:func:`deformsim.blender.features.set_up`), then
:func:`deformsim.blender.passes.render.render_sample` calls its hooks for every sample, in the registry's order:
:meth:`~Feature.place` (at most one feature puts the part in place), :meth:`~Feature.apply` before the
cameras, :meth:`~Feature.image` after each camera's ``rgba`` render, :meth:`~Feature.render_pass` for the
features with :attr:`~Feature.extra_pass` after all the sample's other images, and the manifest columns last.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from deformsim.blender.motion.rig import Rig
from deformsim.blender.scene.world import World
from deformsim.config import Config
from deformsim.dataset.layout import Layout
from deformsim.sampling import SampleParams
from deformsim.sampling.feature import RenderFeature
from deformsim.sampling.features import FEATURES
from deformsim.spec.model import Spec


@dataclass
class RenderContext:
    """Everything the worker built once and reuses for every sample."""

    cfg: Config
    spec: Spec
    scene: object
    obj: object
    rig: Rig
    world: World
    cameras: list
    pivot: object  # tilts object and lattice together (see blender.motion.pose)
    target: tuple[float, float, float]  # bounding-box centre the cameras aim at
    camera_scale: float = 1.0
    ground: float = 0.0  # z the part stands on at rest
    features: list = field(default_factory=list)  # the active features, in registry order
    shaper: object = None  # object.shapes: the blender.part.shapes.Shaper that shapes the part per sample


class Feature:
    """One optional render feature. Every hook does nothing unless the feature overrides it."""

    def __init__(self, ctx: RenderContext):
        """Set up once per worker, on the scene the worker has built."""
        self.ctx = ctx

    @property
    def declared(self) -> RenderFeature:
        """Its declaration in the registry (:data:`deformsim.sampling.features.FEATURES`)."""
        name = f"{type(self).__module__}:{type(self).__qualname__}"
        return next(f for f in FEATURES if f.blender == name)

    @property
    def kinds(self) -> tuple[str, ...]:
        """The image kinds it writes per camera: a manifest path column each."""
        return self.declared.kinds

    @property
    def extra_pass(self) -> bool:
        """Whether its one kind comes from one more render per camera, after the sample's other images."""
        return self.declared.renders > 0

    def place(self, p: SampleParams) -> tuple[float, float, float] | None:
        """Put the part where sample ``p`` has it, after the rig; return the point the cameras aim at, or None to
        leave it to the sample's tilt."""
        return None

    def apply(self, p: SampleParams, target: tuple[float, float, float]) -> None:
        """Put the scene in sample ``p``'s state, after the part, its materials and the world."""

    def image(self, c: int, iid: str, rgba: np.ndarray, layout: Layout) -> None:
        """After camera ``c``'s ``rgba`` render (still Cycles' last render result), before its background variants."""

    def render_pass(self, c: int, path: Path, last: bool) -> tuple[np.ndarray, float]:
        """Render camera ``c``'s image of the :attr:`extra_pass` kind: (pixels to save at ``path``, seconds);
        ``last``: the sample's last extra render (it resets the Cycles session, see blender.scene.ground)."""
        raise NotImplementedError

    def sample_columns(self) -> dict:
        """Manifest columns of the sample just rendered, written after its drawn pose."""
        return {}

    def image_columns(self, c: int) -> dict:
        """Manifest columns of camera ``c``'s image just rendered, written after its :attr:`kinds` paths."""
        return {}
