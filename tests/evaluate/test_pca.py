import io

import numpy as np
import pandas as pd
from PIL import Image

from deformsim.evaluate.pca import COLORS, REAL_COLOR, pixel_pca_png, pixel_vectors, project_2d


def test_project_2d_finds_the_main_directions():
    rng = np.random.default_rng(0)
    t = rng.normal(size=200)
    x = np.outer(t, [3.0, 4.0, 0.0]) + rng.normal(scale=0.01, size=(200, 3))
    coords, ratio = project_2d(x)
    assert ratio[0] > 0.99 and ratio.sum() <= 1 + 1e-9
    assert abs(np.corrcoef(coords[:, 0], t)[0, 1]) > 0.999  # PC1 recovers the line's coordinate
    assert np.allclose(np.linalg.norm(coords[:, 0]) / np.linalg.norm(t), 5.0, rtol=0.01)  # |(3, 4)| = 5


def _marks(image: np.ndarray, colour: str) -> np.ndarray:
    """Where ``image`` shows a scatter mark of ``colour`` (drawn at alpha 0.75 on white)."""
    rgb = np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)])
    return (np.abs(image - (0.75 * rgb + 0.25 * 255)) < 10).all(-1)


def test_pixel_pca_plot_shows_the_domains_apart_in_their_colours(tmp_path):
    paths = []
    for i, color in enumerate([(255, 0, 0), (250, 5, 0), (0, 0, 255), (0, 5, 250)]):
        p = tmp_path / f"{i}.png"
        Image.new("RGB", (40, 30), color).save(p)
        paths.append(str(p))
    v = pixel_vectors(paths, size=8)
    assert v.shape == (4, 8 * 8 * 3) and v.max() <= 1.0 and v[0, 0] == 1.0
    png = pixel_pca_png({"synthetic black": pd.DataFrame({"path": paths[:2], "y": [0, 1]}),
                         "real": pd.DataFrame({"path": paths[2:], "y": [0, 1]})}, size=8)
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)
    axes = image[: image.shape[0] * 3 // 5]  # the scatter; the legend lies below it
    synthetic, real = _marks(axes, COLORS[0]), _marks(axes, REAL_COLOR)
    assert synthetic.sum() > 10 and real.sum() > 10  # the synthetic domain in the first colour, the real photos in red
    gap = abs(np.nonzero(synthetic)[1].mean() - np.nonzero(real)[1].mean())
    assert gap > axes.shape[1] / 3  # red and blue photos lie at either end of PC1
