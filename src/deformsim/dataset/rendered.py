"""What a render worker reports for one rendered sample: the typed reply both the worker and the driver read.

The driver writes its manifest columns and fetches its image kinds without knowing which render feature
(:mod:`deformsim.blender.features`) made them.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Rendered:
    index: int
    render_seconds: list[float]  # Cycles' seconds per camera
    kinds: tuple[str, ...] = ()  # image kinds written per camera besides dataset.layout.RENDER_KINDS
    sample_columns: dict = field(default_factory=dict)  # the sample's measured columns, written after its drawn pose
    image_columns: list[dict] = field(default_factory=list)  # per camera (or none): columns written after the timing

    def to_dict(self) -> dict:
        """The reply line: ``done`` carries the sample index."""
        return {"done": self.index, "render_seconds": self.render_seconds, "kinds": list(self.kinds),
                "sample_columns": self.sample_columns, "image_columns": self.image_columns}

    @classmethod
    def from_dict(cls, reply: dict) -> Rendered:
        return cls(index=reply["done"], render_seconds=list(reply["render_seconds"]),
                   kinds=tuple(reply.get("kinds", ())), sample_columns=dict(reply.get("sample_columns", {})),
                   image_columns=list(reply.get("image_columns", [])))
