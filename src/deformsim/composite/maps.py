"""Dense ground-truth maps through compositing: each composite's mask, deformation and region maps.

A dataset rendered with ``render.dense`` has ``images/{mask,deform,region}/ID.png`` (formats in
:mod:`deformsim.dataset.dense`). A composite moves the part (framing crop and resize, an optional left-right
flip); its maps go through exactly the same moves with nearest-neighbour sampling, so every pixel of a map
still holds a value of the render (a label stays 0/255, a deformation stays a measured one) and lines up with
the composited picture. The variant's manifest gets the maps' paths and statistics recomputed on them.
"""

from __future__ import annotations

import os

import cv2
import numpy as np

from deformsim.composite.framing import warp
from deformsim.dataset.dense import DEFORM_SCALE, map_stats, save_png
from deformsim.errors import UserError

MAP_KINDS = ("mask", "deform", "region")


def read_maps(paths: dict[str, str], shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """The stored maps (uint8 or uint16, as written), each checked to be ``shape`` (H, W)."""
    out = {}
    for kind, path in paths.items():
        img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        if img is None or img.ndim != 2:
            raise UserError(f"cannot read {kind} map {path} (a single-channel PNG is expected)")
        if img.shape != shape:
            raise UserError(f"{kind} map {path} is {img.shape[1]}x{img.shape[0]}, its render {shape[1]}x{shape[0]}")
        out[kind] = img
    return out


def move_maps(maps: dict[str, np.ndarray], m: np.ndarray | None, flip: bool) -> dict[str, np.ndarray]:
    """The maps through the framing map ``m`` (None: unmoved), then mirrored left-right when ``flip``."""
    moved = {k: warp(v, m, nearest=True) for k, v in maps.items()}
    return {k: np.ascontiguousarray(v[:, ::-1]) if flip else v for k, v in moved.items()}


def write_maps(maps: dict[str, np.ndarray], folder: str, prefix: str, iid: str) -> dict:
    """Write ``folder/KIND/ID.png`` for each map; the manifest columns: paths (``prefix/KIND/ID.png``) and stats."""
    for kind, img in maps.items():
        save_png(os.path.join(folder, kind, f"{iid}.png"), img)
    stats = map_stats(maps["mask"] >= 128, maps["deform"].astype(np.float32) / DEFORM_SCALE, maps["region"] >= 128)
    return {**{kind: f"{prefix}/{kind}/{iid}.png" for kind in maps}, **stats}
