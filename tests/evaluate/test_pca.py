import numpy as np
import pandas as pd
from PIL import Image

from deformsim.evaluate.pca import pixel_pca_png, pixel_vectors, project_2d


def test_project_2d_finds_the_main_directions():
    rng = np.random.default_rng(0)
    t = rng.normal(size=200)
    x = np.outer(t, [3.0, 4.0, 0.0]) + rng.normal(scale=0.01, size=(200, 3))
    coords, ratio = project_2d(x)
    assert ratio[0] > 0.99 and ratio.sum() <= 1 + 1e-9
    assert abs(np.corrcoef(coords[:, 0], t)[0, 1]) > 0.999  # PC1 recovers the line's coordinate
    assert np.allclose(np.linalg.norm(coords[:, 0]) / np.linalg.norm(t), 5.0, rtol=0.01)  # |(3, 4)| = 5


def test_pixel_pca_plot(tmp_path):
    paths = []
    for i, color in enumerate([(255, 0, 0), (250, 5, 0), (0, 0, 255), (0, 5, 250)]):
        p = tmp_path / f"{i}.png"
        Image.new("RGB", (40, 30), color).save(p)
        paths.append(str(p))
    v = pixel_vectors(paths, size=8)
    assert v.shape == (4, 8 * 8 * 3) and v.max() <= 1.0 and v[0, 0] == 1.0
    png = pixel_pca_png({"synthetic black": pd.DataFrame({"path": paths[:2], "y": [0, 1]}),
                         "real": pd.DataFrame({"path": paths[2:], "y": [0, 1]})}, size=8)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
