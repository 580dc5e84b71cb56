"""The headline figures are written once (docs/headline.json) and every page that quotes one quotes the same."""

from __future__ import annotations

import json
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FIGURES = json.loads((ROOT / "docs" / "headline.json").read_text(encoding="utf-8"))["figures"]


def _quoted(figure: dict) -> str:
    return f"{figure['mean']:.3f} ± {figure['std']:.3f}"


def test_every_page_quotes_each_headline_figure_as_written_once():
    missing = [f"{page}: {f['what']} {f['metric']} {_quoted(f)}" for f in FIGURES for page in f["quoted_in"]
               if _quoted(f) not in (ROOT / page).read_text(encoding="utf-8")]
    assert not missing, "pages that do not quote docs/headline.json's figure:\n" + "\n".join(missing)


def test_each_figure_names_a_command_that_exists():
    for f in FIGURES:
        page, _, anchor = f["command"].partition("#")
        text = (ROOT / page).read_text(encoding="utf-8")
        headings = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-") for h in re.findall(r"^#+ (.+)$", text, re.M)}
        assert anchor in headings, f"{f['command']}: no such heading"
        assert 0 < f["std"] < f["mean"] <= 1
