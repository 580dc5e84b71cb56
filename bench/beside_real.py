"""Preview sheet: synthetic images of a dataset's variants beside real photos, to judge them at thumbnail size.

    .venv/bin/python bench/beside_real.py DATA --variant NAME [--variant NAME ...] [--real DIR] [--n 5]
        [--label intact] [--label deformed] [--camera K] [--real-match GLOB] [--seed 0] [--out sheet.png]

Per ``--label``, one row of ``--n`` real photos of that label (centre-cropped square, as a person frames them),
then one row per variant (``black``, ``surface`` for the rendered surface scenes, or a composited variant's name)
of as many images of that label, drawn with ``--seed``. Without --real it uses ../shared/data/real_cans_dev.
``--camera K`` keeps the synthetic images of camera K (a view, such as a top view), ``--real-match`` the real photos
whose file name matches the glob (the same view, where the names tell it).
"""

from __future__ import annotations

import argparse
from fnmatch import fnmatch
from pathlib import Path

from _util import SHARED, positive_int, run_main
from PIL import ImageOps

from deformsim.dataset.contact_sheet import COLORS, grid
from deformsim.dataset.images import open_rgb
from deformsim.dataset.layout import Layout
from deformsim.dataset.manifest import read_manifest
from deformsim.dataset.real import real_table
from deformsim.dataset.variants import variant_table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path)
    ap.add_argument("--variant", action="append", required=True)
    ap.add_argument("--real", type=Path, default=SHARED / "real_cans_dev")
    ap.add_argument("--n", type=positive_int, default=5)
    ap.add_argument("--label", action="append", choices=["intact", "deformed"], help="repeat for both; default deformed")
    ap.add_argument("--camera", type=int, help="only the synthetic images of this camera")
    ap.add_argument("--real-match", help="only the real photos whose file name matches this glob")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tile", type=positive_int, default=192)
    ap.add_argument("--out", type=Path, default=Path("sheet.png"))
    a = ap.parse_args()
    table = real_table(a.real)
    if a.real_match:
        table = table[[fnmatch(Path(p).name, a.real_match) for p in table["path"]]]
    synthetic = {}  # each variant's table, read once for every label
    for name in a.variant:
        if name == "surface":
            df = read_manifest(a.data)
            synthetic[name] = df.assign(path=[str(Layout(a.data).root / p) for p in df["surface"]])
        else:
            synthetic[name] = variant_table(a.data, name)
        if a.camera is not None:
            synthetic[name] = synthetic[name][synthetic[name]["camera"] == a.camera]
    images, captions = [], []
    for label in a.label or ["deformed"]:
        real = table[table["label"] == label].sample(n=a.n, random_state=a.seed)
        images += [ImageOps.fit(open_rgb(p), (a.tile, a.tile)) for p in real["path"]]  # centre-cropped square
        captions += [(f"real {label}", COLORS[label])] * a.n
        for name, df in synthetic.items():
            df = df[df["label"] == label].sample(n=a.n, random_state=a.seed)
            images += [open_rgb(p) for p in df["path"]]
            captions += [(f"{name} {r.id}", COLORS[label]) for r in df.itertuples()]
    grid(images, captions, tile=a.tile, cols=a.n).save(a.out)
    print(a.out)


if __name__ == "__main__":
    run_main(main)
