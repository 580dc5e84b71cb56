"""Planning a render draws nothing ahead: each sample's parameters are drawn from (seed, index) when a worker takes
it, so a plan of ten million images starts at once in constant memory, and a small plan renders exactly the samples
it drew before (the same parameters, records and manifest).

Renders come from fake workers (tests/generate/fakes.py): no Blender.
"""

from __future__ import annotations

import json
import time
import tracemalloc

import pytest

from deformsim.config import load_config
from deformsim.dataset.layout import Layout
from deformsim.generate import local, stage
from deformsim.generate.stage import generate
from deformsim.hdri import drawn_hdris
from deformsim.sampling import sample_params
from deformsim.spec.model import load_spec
from tests.generate.fakes import FakeWorker, use_fakes


class _FirstRender(Exception):
    pass


def test_a_huge_plan_reaches_its_first_render_at_once_in_constant_memory(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    seen = {}

    def first_render(self, params: dict) -> dict:
        seen["index"], seen["peak"] = params["index"], tracemalloc.get_traced_memory()[1]
        raise _FirstRender

    monkeypatch.setattr(FakeWorker, "render", first_render)
    cfg = load_config("quick", {"generate.n": 400_000, "generate.workers": 1, "generate.preview": 0})
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        with pytest.raises(_FirstRender):
            generate(cfg, tmp_path / "D", progress=False)
    finally:
        tracemalloc.stop()
    assert seen["index"] == 0
    assert seen["peak"] < 20 * 2**20  # the eager plan of its 100 000 samples held 270 MB
    assert time.perf_counter() - t0 < 20


def test_a_small_plan_renders_the_samples_an_eager_plan_drew(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    sent = []
    render = FakeWorker.render

    def recorded(self, params: dict) -> dict:
        sent.append(params)
        return render(self, params)

    monkeypatch.setattr(FakeWorker, "render", recorded)
    cfg = load_config("quick", {"generate.n": 12, "generate.workers": 2, "generate.preview": 0})
    out = tmp_path / "D"
    generate(cfg, out, progress=False)
    spec, hdris = load_spec(cfg.object.spec), drawn_hdris(cfg.lighting.hdri_dir, cfg.lighting.hdris)
    views = len(cfg.camera.azimuth_quadrants)
    eager = [sample_params(i, cfg.generate.seed, cfg, spec, hdris).to_dict() for i in range(stage.n_samples(cfg))]
    assert len(eager) == 12 // views
    assert sorted(sent, key=lambda p: p["index"]) == eager
    layout = Layout(out)
    for i, params in enumerate(eager):  # each record holds the rows of the parameters drawn for it
        record = json.loads(layout.sample_record(i).read_text())
        assert [row["label"] for row in record["rows"]] == [params["label"]] * views

    (out / "samples" / "000001.json").unlink()  # a resumed run draws the missing sample alone, the same again
    sent.clear()
    generate(cfg, out, progress=False)
    assert sent == [eager[1]]


def test_retried_samples_are_handed_out_again(monkeypatch, tmp_path):
    use_fakes(monkeypatch)
    failed_once: set[int] = set()
    render = FakeWorker.render

    def flaky(self, params: dict) -> dict:
        if params["index"] % 2 and params["index"] not in failed_once:
            failed_once.add(params["index"])
            return {"error": params["index"], "message": "flaky"}
        return render(self, params)

    monkeypatch.setattr(FakeWorker, "render", flaky)
    monkeypatch.setattr(local, "render_workers", lambda cfg, n: 1)
    cfg = load_config("quick", {"generate.n": 16, "generate.preview": 0, "generate.max_retries": 1})
    result = generate(cfg, tmp_path / "D", progress=False)
    assert stage.n_samples(cfg) == 4
    assert result.rendered == 4 and not result.failed and failed_once == {1, 3}
