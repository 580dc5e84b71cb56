"""Screenshots of a report at a desktop's and a phone's width, and a check that nothing is cut off on the phone.

    .venv/bin/python bench/report_screens.py [REPORT_DIR] [--out DIR] [--widths 1400 420]

Without REPORT_DIR it makes a small report of random images first (two variants, 40 photos with long names; no
Blender or training), in ``DIR/tiny-report``.

Loads ``REPORT_DIR/report.html`` in headless Chromium (``apt-get install -y chromium`` where ``chromium`` is
missing) in a frame of each width (Chromium's window is never narrower than 500 px; the frame is the page's
viewport): first with a small script that measures the page (its scroll width and height, the elements that
reach past the right edge outside a scrolling box, settings labels narrower than their longest word, a table wider
than its box without a visible hint to swipe, prediction cards of unequal size, figures shrunk below
:data:`MIN_SCALE` of their pixels), then for a screenshot of the whole page height, written as
``DIR/report-WIDTH.png`` (default DIR: ``report-screens`` in the current folder). Exits 1 when any of these shows
at any width: something would be cut off, unreadable or need the page itself to scroll sideways.
"""

from __future__ import annotations

import argparse
import html
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from _util import positive_int, run_main
from PIL import Image

from deformsim.config import TrainConfig
from deformsim.evaluate.metrics import compute_metrics
from deformsim.evaluate.metrics_file import MetricsFile
from deformsim.records import made
from deformsim.report.html import write_report
from deformsim.version import __version__

MAX_HEIGHT = 16000  # the longest screenshot, pixels
MIN_WINDOW = 500  # Chromium's narrowest window
MIN_SCALE = 0.6  # a figure drawn smaller than this share of its pixels has text too small to read (9 pt at 110 dpi: 8 px)
MEASURE = """<script>addEventListener("load", () => {
  const w = innerWidth, wide = [], broken = [], hidden = [], small = [], cards = new Set();
  for (const el of document.querySelectorAll("body *")) {
    const r = el.getBoundingClientRect(), box = el.closest(".scroll");
    if (r.right > w + 0.5 && !(box && box !== el)) wide.push(el.tagName.toLowerCase() + "." + el.className);
  }
  const ctx = document.createElement("canvas").getContext("2d");
  for (const td of document.querySelectorAll(".kv td:first-child")) {
    const cs = getComputedStyle(td);
    ctx.font = cs.font;
    const room = td.clientWidth - parseFloat(cs.paddingLeft) - parseFloat(cs.paddingRight);
    const longest = Math.max(...td.textContent.split(/\\s+/).map(word => ctx.measureText(word).width));
    if (longest > room + 1) broken.push(td.textContent);
  }
  for (const box of document.querySelectorAll(".scroll")) {
    const hint = box.nextElementSibling;
    const shown = hint && hint.classList.contains("hint") && getComputedStyle(hint).display !== "none";
    if (box.scrollWidth > box.clientWidth + 1 && box.querySelector("table.t2") && !shown) hidden.push("t2");
  }
  for (const img of document.querySelectorAll(".thumb.ok img, .thumb.bad img, table.wrong img")) {
    if (!img.closest(".cam")) cards.add(Math.round(img.getBoundingClientRect().width));
  }
  for (const img of document.querySelectorAll(".plots img")) {
    const scale = img.width / img.naturalWidth;
    if (img.naturalWidth && scale < SCALE) small.push(img.alt + " " + scale.toFixed(2));
  }
  const out = parent.document.createElement("pre");
  out.id = "measure";
  out.textContent = JSON.stringify({width: w, scroll_width: document.documentElement.scrollWidth,
                                    height: document.documentElement.scrollHeight, wide: wide.slice(0, 12),
                                    broken_labels: broken, hidden_columns: hidden, card_widths: [...cards],
                                    small_figures: small});
  parent.document.body.appendChild(out);
});</script>""".replace("SCALE", str(MIN_SCALE))


def tiny_report(folder: Path) -> Path:
    """A report of random 128x96 photos: two variants near chance and one with no deformed prediction, its data in a
    folder as deep as a run's."""
    rng = np.random.default_rng(0)
    y = [0, 1] * 20
    photos = folder / "photos"
    photos.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, label in enumerate(y):
        paths.append(str(photos / f"IMG_2024{i:04d}_{('intact', 'dented')[label]}_side_view_with_a_long_name.png"))
        Image.fromarray(rng.integers(0, 255, (96, 128, 3), dtype=np.uint8)).save(paths[-1])
    history = [{"epoch": e, "loss": 0.7 / e, "acc": 0.5 + 0.08 * e, "val_loss": 0.8 / e, "val_acc": 0.45 + 0.07 * e,
                "seconds": 1.0} for e in range(1, 6)]

    def result(prob: list[float]) -> dict:
        return {"train": {"n": 16, "n_deformed": 8}, "test": {"n": 40, "n_deformed": 20}, "model": "models/m/model.pt",
                "weights": "offline", "history": history, "train_seconds": 2.0, "predict_seconds": 0.5,
                "metrics": compute_metrics(y, prob), "predictions": [{"path": p, "y": a, "prob": b}
                                                                     for p, a, b in zip(paths, y, prob)]}

    near = np.clip(np.array(y) * 0.3 + rng.uniform(0.1, 0.7, 40), 0, 1).round(3).tolist()
    variants = {"procedural": {"n_images": 16, "n_samples": 4, "examples": [], "real": result(near),
                               "split": {"skipped": "a split needs at least 2 samples of each class"}},
                "backgrounds": {"n_images": 16, "n_samples": 4, "examples": [], "real": result(near[::-1]),
                                "split": {"skipped": "a split needs at least 2 samples of each class"}},
                "black": {"n_images": 16, "n_samples": 4, "examples": [], "split": {"skipped": "too few samples"},
                          "real": result(rng.uniform(0.0, 0.45, 40).round(3).tolist())}}
    data = folder / "home" / "someone" / "projects" / "deformsim" / "runs" / "demo" / "data-3f2a9c81d0e4b5a6"
    metrics = {"created": "2026-01-01T00:00:00+00:00", "data_root": str(data), "real_dir": str(photos),
               "settings": TrainConfig(weights="offline", epochs=5).model_dump(mode="json"), "version": __version__,
               "missing_variants": [], "variants": variants, "plots": {}, "seconds": 12.0}
    return write_report(made(MetricsFile, metrics), folder / "report").parent


def problems(m: dict) -> list[str]:
    """What :func:`measure` found wrong with a page, one line each."""
    found = []
    if m["scroll_width"] > m["width"]:
        found.append(f"WIDER THAN THE WINDOW: {', '.join(m['wide']) or '?'}")
    if m["broken_labels"]:
        found.append(f"settings labels break inside a word: {', '.join(m['broken_labels'])}")
    if m["hidden_columns"]:
        found.append("Table II has columns off screen and no hint to swipe")
    if len(m["card_widths"]) > 1:
        found.append(f"prediction cards of different sizes: {sorted(m['card_widths'])} px")
    if m["small_figures"]:
        found.append(f"figures shrunk below {MIN_SCALE:g} of their pixels: {', '.join(m['small_figures'])}")
    return found


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if path := shutil.which(name):
            return path
    sys.exit("no chromium: apt-get install -y chromium")


def browse(page: str, width: int, height: int, *args: str) -> str:
    """Chromium's output for ``page`` (HTML) shown in a frame ``width`` x ``height`` px wide at the top left."""
    frame = (f'<!DOCTYPE html><html><body style="margin:0"><iframe style="border:0;display:block;width:{width}px;'
             f'height:{height}px" srcdoc="{html.escape(page)}"></iframe></body></html>')
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "frame.html"
        path.write_text(frame)
        cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
               "--disable-component-update", "--no-first-run", "--hide-scrollbars", f"--user-data-dir={tmp}/profile",
               f"--window-size={max(width, MIN_WINDOW)},{height}", "--virtual-time-budget=5000", *args, path.as_uri()]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=True).stdout


def measure(report: Path, width: int) -> dict:
    dom = browse(report.read_text().replace("</body>", MEASURE + "</body>"), width, 2400, "--dump-dom")
    found = re.search(r'<pre id="measure">(.*?)</pre>', dom, re.S)
    if not found:
        sys.exit(f"no measurement at {width} px (Chromium printed {len(dom)} characters)")
    return json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report_dir", type=Path, nargs="?")
    ap.add_argument("--out", type=Path, default=Path("report-screens"))
    ap.add_argument("--widths", type=positive_int, nargs="+", default=[1400, 420])
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report_dir = args.report_dir or tiny_report(args.out / "tiny-report")
    report = report_dir / "report.html"
    if not report.is_file():
        sys.exit(f"no report.html in {report_dir}")
    cut = False
    for width in args.widths:
        m = measure(report, width)
        png = (args.out / f"report-{width}.png").resolve()
        height = min(m["height"], MAX_HEIGHT)
        browse(report.read_text(), width, height, f"--screenshot={png}")
        Image.open(png).crop((0, 0, width, height)).save(png)
        found = problems(m)
        cut |= bool(found)
        print(f"{width:>5} px: page {m['scroll_width']} x {m['height']} px, "
              + ("; ".join(found) or "nothing cut off, broken or too small") + f" -> {png}")
    sys.exit(1 if cut else 0)


if __name__ == "__main__":
    run_main(main)
