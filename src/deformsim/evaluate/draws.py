"""Which labelled photos a benchmark adapts on and which it scores: k of each class at random (:func:`draw`), or
as a biased sample does (:func:`biased_draw`): each class's k photos from a different lighting, the warmer or the
cooler half of the folder (:func:`warm_half`, from the photos' pixels), which a model fitted on them can take for the
damage."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from deformsim.errors import UserError


def draw(y: np.ndarray, k: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rows of k photos of each class (to adapt on) and the remaining rows (to score)."""
    chosen = np.sort(np.concatenate([rng.choice(np.flatnonzero(y == c), size=k, replace=False) for c in (0, 1)]))
    rest = np.setdiff1d(np.arange(len(y)), chosen)
    return chosen.astype(int), rest


def warm_half(paths: list[str]) -> np.ndarray:
    """Whether each photo is warmer-lit than the folder's median: its mean red minus mean blue (8-bit sRGB as every
    stage reads it, a JPEG decoded at a reduced size covering 256 px), above the median of the folder's; a photo
    that cannot be read is a :class:`UserError` naming it."""
    from deformsim.dataset.images import open_rgb

    warmth = []
    for path in paths:
        rgb = np.asarray(open_rgb(path, min_size=(256, 256)), dtype=np.float64)
        warmth.append(rgb[..., 0].mean() - rgb[..., 2].mean())
    warmth = np.array(warmth)
    return warmth > np.median(warmth)


def biased_draw(y: np.ndarray, k: int, warm: np.ndarray, intact_warm: bool,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rows of k photos of each class, the intact ones from the warm half (``intact_warm``, else the cool half) and the
    deformed ones from the other, and the remaining rows (to score)."""
    pools = [np.flatnonzero((y == c) & (warm == (intact_warm == (c == 0)))) for c in (0, 1)]
    chosen = np.sort(np.concatenate([rng.choice(pool, size=k, replace=False) for pool in pools]))
    return chosen.astype(int), np.setdiff1d(np.arange(len(y)), chosen)


def check_biased(y: np.ndarray, warm: np.ndarray, k: int, real: Path) -> None:
    """One line when a class has fewer than k photos (and one to score) on a side of the lighting split."""
    for c, name in ((0, "intact"), (1, "deformed")):
        for side, light in ((True, "warm"), (False, "cool")):
            held = int(((y == c) & (warm == side)).sum())
            if held < k + 1:
                raise UserError(f"--biased --k {k}: {real} holds {held} {light}-lit {name} photos; the biased draw "
                                f"needs {k} and one left to score")


@dataclass(frozen=True)
class Drawing:
    """How a benchmark draws k labelled photos of each class from photos labelled ``y``: at random, or with ``warm``
    (:func:`warm_half`) as a biased sample, the intact ones from the warm half in even draws and from the cool half in
    odd ones."""

    y: np.ndarray
    warm: np.ndarray | None = None

    @property
    def biased(self) -> bool:
        return self.warm is not None

    def rows(self, k: int, d: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``d``'s rows of k photos of each class and the remaining rows."""
        return draw(self.y, k, rng) if self.warm is None else biased_draw(self.y, k, self.warm, d % 2 == 0, rng)


def drawing(y: np.ndarray, paths: list[str], ks: list[int], biased: bool, real: Path) -> Drawing:
    """The :class:`Drawing` of the photos ``paths`` labelled ``y`` in the folder ``real``; biased, checked first: one line
    when a lighting half holds too few photos of a class for one of ``ks`` (:func:`check_biased`)."""
    if not biased:
        return Drawing(y)
    warm = warm_half(paths)
    for k in ks:
        check_biased(y, warm, k, real)
    return Drawing(y, warm)
