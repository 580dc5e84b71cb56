"""Sim-to-real benchmark: `deformsim bench sim2real` with the development data beside the checkout.

    python bench/sim2real.py [--quick] [--real DIR] [--backgrounds DIR] [--out DIR] [other options]

Without --real / --backgrounds it uses ../shared/data/real_cans_dev and ../shared/data/backgrounds.
Prints real accuracy, F1, precision, recall, AUC and synthetic held-out accuracy per variant as mean ± std over
background draws and training seeds, and writes OUT/results.json with every run.
"""

from __future__ import annotations

import sys

from _util import SHARED

from deformsim.cli.app import app

if __name__ == "__main__":
    args = sys.argv[1:]
    defaults = {"--real": SHARED / "real_cans_dev", "--backgrounds": SHARED / "backgrounds"}
    for flag, path in defaults.items():
        if flag not in args and path.is_dir():
            args += [flag, str(path)]
    if "--out" not in args and "-o" not in args:
        args += ["--out", "runs/sim2real-quick" if "--quick" in args else "runs/sim2real"]
    app(["bench", "sim2real", *args])
