"""The report's settings section: the part, the spec, the version and every non-default setting as YAML."""

import json

import yaml

from deformsim.config import Config, TrainConfig, dump_config
from deformsim.dataset.layout import Layout
from deformsim.evaluate.experiments import provenance
from deformsim.evaluate.metrics_file import MetricsFile
from deformsim.records import made
from deformsim.report.settings import non_default, settings_section
from deformsim.version import __version__


def _dataset(root, cfg):
    layout = Layout(root)
    (root / "variants" / "procedural").mkdir(parents=True)
    layout.config.write_text(dump_config(cfg))
    layout.inputs.write_text(json.dumps({"mesh": "ab" * 32, "spec": "cd" * 32}))
    (root / "variants" / "procedural" / "composite.json").write_text(
        json.dumps({"name": "procedural", "seed": 0, **cfg.composite.model_dump(mode="json"), "blur": [0.0, 2.0]}))


def _pre(html):
    return html[html.index("<pre class=yaml>") + len("<pre class=yaml>"):html.index("</pre>")]


def test_settings_show_the_part_spec_version_and_every_changed_setting(tmp_path):
    cfg = Config.model_validate({"object": {"mesh": "carton.stl"}, "render": {"resolution": 64, "samples": 4,
                                                                                "denoise": False},
                                 "camera": {"polar": [40.0, 60.0]}, "generate": {"n": 16}})
    _dataset(tmp_path, cfg)
    train = TrainConfig(epochs=2, weights="offline")
    metrics = made(MetricsFile, {"settings": train.model_dump(mode="json"), "version": __version__,
                                 "data": provenance(tmp_path, ["procedural", "black"]), "variants": {}})
    html = settings_section(metrics, [("data", str(tmp_path))])
    assert "mesh carton.stl (sha256 abababababababab)" in html
    assert "built-in can spec (sha256 cdcdcdcdcdcdcdcd)" in html and f"<td>{__version__}</td>" in html
    shown = yaml.safe_load(_pre(html))
    assert shown == {"object.mesh": "carton.stl", "camera.polar": [40.0, 60.0], "render.resolution": 64,
                     "render.samples": 4, "render.denoise": False, "generate.n": 16, "composite.blur": [0.0, 2.0],
                     "train.epochs": 2, "train.weights": "offline"}
    lines = _pre(html).splitlines()  # one YAML line per setting, not Python literals
    assert "render.denoise: false" in lines and "camera.polar: [40.0, 60.0]" in lines and len(lines) == len(shown)


def test_defaults_everywhere_say_so_and_a_broken_record_is_left_out(tmp_path):
    _dataset(tmp_path, Config())
    Layout(tmp_path).inputs.write_text("{not json")
    (tmp_path / "variants" / "procedural" / "composite.json").unlink()
    metrics = made(MetricsFile, {"settings": TrainConfig().model_dump(mode="json"), "version": __version__,
                                 "data": provenance(tmp_path, ["procedural"]), "variants": {}})
    html = settings_section(metrics, [])
    assert "built-in soda can" in html and "sha256" not in html
    assert _pre(html) == "# every setting at its default"


def test_non_default_compares_dotted_keys():
    assert non_default({"a": {"b": 1, "c": {"d": None}}, "e": [1]}, {"a": {"b": 1, "c": None}, "e": [2]}) == {
        "a.c.d": None, "e": [1]}
