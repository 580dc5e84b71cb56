"""Render every key of a spec at full weight from one fixed camera, as one labelled contact sheet."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

from PIL import Image

from deformsim.atomic import atomic_path
from deformsim.bank.stage import bake
from deformsim.bank.store import bank_dir, is_complete
from deformsim.config import Config, load_config
from deformsim.dataset.contact_sheet import grid
from deformsim.dataset.layout import Layout, image_id
from deformsim.generate.backend import worker_setup
from deformsim.generate.refusals import render_seconds
from deformsim.generate.stage import prepare
from deformsim.log import get_logger, progress_bar
from deformsim.sampling import SampleParams, sample_params
from deformsim.spec.model import load_spec
from deformsim.spec.simulation import entry_names

log = get_logger(__name__)

BAKE_SECONDS_PER_ENTRY = 13  # measured on 2 cores (docs/experiments/bank.md)
WORKER_START_S = 10  # a Blender worker's start and scene setup, on 2 cores
SHEET_TILE = 128  # pixels: the least a tile is shown at, so that its caption reads whole
REST_GREY, DEFORMED_RED = (60, 60, 60), (207, 34, 46)

FIXED_VIEW = {"camera.azimuth_quadrants": [[40, 40]], "pose.tilt": [0, 0], "camera.polar": [62, 62],
              "camera.radius": [0.36, 0.36], "lighting.rotation": [90, 90], "lighting.strength": [1.0, 1.0]}


def preview_states(base: SampleParams, openings: bool, bank: list[str] = ()) -> list[tuple[str, SampleParams]]:
    """The rest shape, then each lattice key, each displacement texture, each opening and each simulated bank
    entry at full weight."""
    zero_k = {k: 0.0 for k in base.keys}
    zero_d = {k: 0.0 for k in base.displacement}
    rest = dataclasses.replace(base, label="intact", keys=zero_k, displacement=zero_d, seal=0.0, tab=0.0, bank="",
                               bank_amount=0.0)
    states = [("rest", rest)]
    states += [(k, dataclasses.replace(rest, label="deformed", keys={**zero_k, k: 1.0})) for k in base.keys]
    states += [(d, dataclasses.replace(rest, label="deformed", displacement={**zero_d, d: 1.0})) for d in base.displacement]
    if openings:
        states += [("seal open", dataclasses.replace(rest, seal=1.0)),
                   ("tab + seal open", dataclasses.replace(rest, seal=1.0, tab=1.0))]
    states += [(e, dataclasses.replace(rest, label="deformed", bank=e, bank_amount=1.0)) for e in bank]
    return [(name, dataclasses.replace(p, index=i)) for i, (name, p) in enumerate(states)]


def plan_message(states: list[tuple[str, SampleParams]], bake_entries: int, tile_seconds: float) -> str:
    """What the preview is about to do: its tiles and about how long they take (``tile_seconds`` each, after a
    worker's start), and the bank bake first when one is due."""
    total = WORKER_START_S + len(states) * tile_seconds
    when = f"about {max(1, round(total / 60))} min" if total >= 90 else f"about {max(10, round(total, -1)):.0f} s"
    text = f"spec preview: {len(states)} tiles ({', '.join(name for name, _ in states)}), {when} on 2 cores"
    if bake_entries:
        minutes = max(1, round(bake_entries * BAKE_SECONDS_PER_ENTRY / 60))
        text += (f"; the simulated bank is not baked yet: baking its {bake_entries} scenarios first, about "
                 f"{minutes} min on 2 cores (--no-bank skips them)")
    return text


def render_preview(spec_path: Path | None, mesh: Path | None, out: Path, resolution: int, samples: int,
                   bank: bool = True, progress: bool = True, seen_with: Config | None = None) -> Path:
    """Write the preview sheet ``out``; ``bank=False`` leaves out the simulated bank's tiles (and its bake). Keys too
    small to see in a typical image of a run with config ``seen_with`` (default the quick preset) are warned about."""
    from deformsim.generate.worker_client import WorkerProcess

    overrides = {**FIXED_VIEW, "object.spec": spec_path, "object.mesh": mesh, "generate.n": 1,
                 "render.resolution": resolution, "render.samples": samples}
    spec = load_spec(spec_path)
    bank = bank and spec.simulation is not None
    if bank:
        overrides["deform.sources.bank"] = 1.0  # the worker loads the bank
    cfg = load_config("quick", overrides)
    with tempfile.TemporaryDirectory(prefix="deformsim-preview-") as tmp:
        spec, hdris = prepare(cfg, Path(tmp), spec=spec, seen_with=seen_with or load_config("quick"))
        hdri = "studio" if "studio" in hdris else hdris[0]
        base = dataclasses.replace(sample_params(0, 0, cfg, spec, hdris), hdri=hdri)
        states = preview_states(base, openings=bool(spec.openings.seal),
                                bank=entry_names(spec.simulation) if bank else [])
        to_bake = len(entry_names(spec.simulation)) if bank and not is_complete(bank_dir(spec, mesh), spec) else 0
        log.info(plan_message(states, to_bake, render_seconds(cfg)))
        if bank:
            bake(spec, spec_path, mesh, progress=progress)
        layout = Layout(Path(tmp))
        worker = WorkerProcess(log_path=Path(tmp) / "worker.log")
        try:
            worker.start(worker_setup(cfg, layout))
            images, captions = [], []
            with progress_bar(len(states), "preview tiles", progress) as bar:
                for name, p in states:
                    reply = worker.render(p.to_dict())
                    if "error" in reply:
                        raise RuntimeError(f"rendering '{name}' failed: {reply['message']}")
                    img = Image.open(layout.image("black", image_id(p.index, 0)))
                    images.append(img.copy())
                    captions.append((name, DEFORMED_RED if p.label == "deformed" else REST_GREY))
                    bar.update(1)
        finally:
            worker.close()
    sheet = grid(images, captions, tile=max(resolution, SHEET_TILE), cols=5)
    with atomic_path(out) as t:
        sheet.save(t, format="PNG")
    return out
