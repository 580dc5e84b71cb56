"""Where a dataset's files live. Every stage reads and writes through this one map.

    OUT/
      config.yaml, versions.json      resolved config and package versions of the run
      inputs.json                     sha256 of what it is rendered from: mesh file, parsed spec, HDRI files
      samples/000012.json             one record per finished sample (its manifest rows): the resume state
      images/{rgba,black,green}/ID.png  exact-alpha render and its black / green camera-background variants
      images/{mask,depth,normal,deform,region}/ID.png  dense ground truth (render.dense; see dataset.dense)
      images/shadow/ID.png            8-bit opacity of the part's shadow on the ground (render.shadow)
      images/surface/ID.png           the part on a textured ground, the whole scene rendered (render.surface)
      manifest.parquet, manifest.csv  one row per image, consolidated from the sample records
      preview.png                     contact sheet
      variants/NAME/                  composited variants: images/ID.png + manifest.parquet
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

RENDER_KINDS = ("rgba", "black", "green")
DENSE_KINDS = ("mask", "depth", "normal", "deform", "region")
SHADOW_KIND = "shadow"  # render.shadow: the shadow the part casts on the ground (blender.scene.shadow)
SURFACE_KIND = "surface"  # render.surface: the part resting on a textured ground, rendered whole (blender.scene.surface)


def image_id(sample: int, camera: int) -> str:
    return f"{sample:06d}_c{camera}"


@dataclass(frozen=True)
class Layout:
    root: Path

    def __post_init__(self) -> None:
        object.__setattr__(self, "root", Path(self.root))

    def image(self, kind: str, iid: str) -> Path:
        return self.root / "images" / kind / f"{iid}.png"

    def sample_record(self, index: int) -> Path:
        return self.root / "samples" / f"{index:06d}.json"

    def variant_dir(self, name: str) -> Path:
        return self.root / "variants" / name

    @property
    def samples_dir(self) -> Path:
        return self.root / "samples"

    @property
    def manifest(self) -> Path:
        return self.root / "manifest.parquet"

    @property
    def manifest_csv(self) -> Path:
        return self.root / "manifest.csv"

    @property
    def config(self) -> Path:
        return self.root / "config.yaml"

    @property
    def inputs(self) -> Path:
        return self.root / "inputs.json"

    @property
    def versions(self) -> Path:
        return self.root / "versions.json"

    @property
    def preview(self) -> Path:
        return self.root / "preview.png"

    def rel(self, path: Path) -> str:
        return str(Path(path).relative_to(self.root))
