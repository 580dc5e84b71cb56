"""Sampling is pure: these run without Blender."""

import numpy as np
import pytest

from deformsim.config import load_config
from deformsim.errors import UserError
from deformsim.sampling import SampleParams, label_for, sample_params
from deformsim.spec.model import load_spec

HDRIS = ["city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"]


@pytest.fixture(scope="module")
def setup():
    return load_config("quick", {"generate.n": 40000}), load_spec()


def test_10000_samples_respect_the_tables(setup):
    cfg, spec = setup
    quads = cfg.camera.azimuth_quadrants
    for i in range(10_000):
        p = sample_params(i, 1, cfg, spec, HDRIS)
        assert 0 <= p.tab <= p.seal <= 1
        assert p.hdri in HDRIS and 0 <= p.hdri_rotation < 360
        assert len(p.cameras) == 4
        for cam, (lo, hi) in zip(p.cameras, quads):
            assert lo <= cam.azimuth <= hi
            assert 50 <= cam.polar <= 70
            assert 0.30 <= cam.radius <= 0.45
        if p.deformed:
            assert 3 <= len(p.families) <= 5
            assert 0.7 <= sum(p.keys.values()) <= 1.5 + 1e-9
            assert 0.6 <= sum(p.displacement.values()) <= 1.0 + 1e-9
            used = {f.name for f in spec.families if any(p.keys[k.name] > 0 for k in f.keys)}
            assert used == set(p.families)
        else:
            assert not any(p.keys.values()) and not any(p.displacement.values()) and not p.families


def test_family_weights_draw_a_family_more_often_and_equal_weights_draw_as_before():
    cfg = load_config("quick", {"generate.n": 40000, "deform.families": [1, 1]})
    spec = load_spec()

    def weighted(weights):
        return spec.model_copy(update={"families": [f.model_copy(update={"weight": w})
                                                    for f, w in zip(spec.families, weights)]})

    n, first = len(spec.families), spec.families[0].name
    equal, heavy = weighted([2.0] * n), weighted([4.0 * (n - 1)] + [1.0] * (n - 1))  # the first: 80 % of draws
    plain = favoured = deformed = 0
    for i in range(400):
        p, q = sample_params(i, 1, cfg, spec, HDRIS), sample_params(i, 1, cfg, heavy, HDRIS)
        assert sample_params(i, 1, cfg, equal, HDRIS) == p and sample_params(i, 1, cfg, heavy, HDRIS) == q
        if p.deformed:
            deformed += 1
            plain, favoured = plain + (first in p.families), favoured + (first in q.families)
    assert abs(plain / deformed - 1 / n) < 0.08 and abs(favoured / deformed - 0.8) < 0.08


def test_a_spec_without_weights_keeps_its_datasets_identity():
    """Weights left at 1 leave the spec's digest as it was before families had weights (datasets stay current)."""
    from deformsim.generate.identity import input_digests

    cfg, spec = load_config("quick"), load_spec()
    one = spec.model_copy(update={"families": [f.model_copy(update={"weight": 1.0}) for f in spec.families]})
    two = spec.model_copy(update={"families": [spec.families[0].model_copy(update={"weight": 2.0}), *spec.families[1:]]})
    assert "weight" not in spec.model_dump(mode="json")["families"][0]
    assert input_digests(cfg, one)["spec"] == input_digests(cfg, spec)["spec"] != input_digests(cfg, two)["spec"]


def test_labels_are_balanced_in_every_prefix():
    labels = [label_for(i, 0.5) for i in range(1000)]
    for n in range(2, 1000, 2):
        assert labels[:n].count("intact") == n // 2


def test_same_seed_same_params_and_other_seed_differs(setup):
    cfg, spec = setup
    a = [sample_params(i, 7, cfg, spec, HDRIS).to_dict() for i in range(20)]
    b = [sample_params(i, 7, cfg, spec, HDRIS).to_dict() for i in reversed(range(20))][::-1]
    c = [sample_params(i, 8, cfg, spec, HDRIS).to_dict() for i in range(20)]
    assert a == b
    assert a != c


def test_params_round_trip_through_dict(setup):
    cfg, spec = setup
    p = sample_params(3, 2, cfg, spec, HDRIS)
    assert SampleParams.from_dict(p.to_dict()) == p


def test_deformation_extent_is_sampled_in_range(setup):
    cfg, spec = setup
    extents = np.array([sample_params(i, 5, cfg, spec, HDRIS).extent for i in range(0, 400, 2)])
    assert extents.min() >= 0.7 and extents.max() <= 1.5 and extents.std() > 0.1


def test_lattice_only_runs_draw_what_they_drew_before_the_bank(setup):
    """The bank draws from a stream of its own: a lattice-only config's samples equal a spec without simulation's."""
    cfg, spec = setup
    bare = type(spec).model_validate({**spec.model_dump(), "simulation": None})
    for i in range(200):
        assert sample_params(i, 3, cfg, spec, HDRIS) == sample_params(i, 3, cfg, bare, HDRIS)
    mixed = load_config("quick", {"deform.sources.bank": 1.0, "deform.sources.both": 1.0})
    for i in range(200):  # every draw but the deformation source is the same
        a, b = sample_params(i, 3, cfg, spec, HDRIS), sample_params(i, 3, mixed, spec, HDRIS)
        assert (a.cameras, a.hdri, a.design, a.seal, a.pose_tilt) == (b.cameras, b.hdri, b.design, b.seal, b.pose_tilt)


def test_sources_weights_pick_lattice_bank_or_both(setup):
    _, spec = setup
    cfg = load_config("quick", {"deform.sources.lattice": 1.0, "deform.sources.bank": 2.0, "deform.sources.both": 1.0,
                                "deform.bank_amount": [0.8, 0.9]})
    entries = {f"{s.name}/{i}" for s in spec.simulation.scenarios for i in range(s.variants)}
    counts = {"lattice": 0, "bank": 0, "both": 0}
    for i in range(4000):
        p = sample_params(i, 5, cfg, spec, HDRIS)
        if not p.deformed:
            assert p.bank == "" and p.bank_amount == 0
            continue
        lattice = any(p.keys.values())
        if p.bank:
            assert p.bank in entries and 0.8 <= p.bank_amount <= 0.9
            assert p.families[-1] == p.bank.split("/")[0]
        source = "both" if lattice and p.bank else ("bank" if p.bank else "lattice")
        counts[source] += 1
        assert any(p.displacement.values())  # crinkle goes with every source
    total = sum(counts.values())
    assert abs(counts["bank"] / total - 0.5) < 0.04 and abs(counts["lattice"] / total - 0.25) < 0.04
    assert abs(counts["both"] / total - 0.25) < 0.04


def test_bank_weights_need_a_simulation_and_a_positive_weight(setup):
    from deformsim.errors import UserError

    with pytest.raises(UserError, match="all 0"):
        load_config("quick", {"deform.sources.lattice": 0})
    with pytest.raises(UserError, match="bank_amount"):
        load_config("quick", {"deform.bank_amount": [0.5, 2.0]})


FRAMING = {"camera.fill": [0.4, 0.8], "camera.offset": 0.2, "camera.partial": 0.3, "camera.lens_mm": [35, 85],
           "camera.fstop": [1.4, 16]}


def test_default_framing_draws_what_it_drew_before(setup):
    """camera.fill/offset/partial/lens range/fstop off: the paper's cameras, unchanged and with no new draws."""
    from deformsim.sampling import CameraParams, draw_framing

    cfg, spec = setup
    explicit = load_config("quick", {"generate.n": 40000, "camera.fill": None, "camera.offset": 0.0,
                                     "camera.partial": 0.0, "camera.lens_mm": 70.0, "camera.fstop": None})
    for i in range(100):
        p = sample_params(i, 4, cfg, spec, HDRIS)
        assert p == sample_params(i, 4, explicit, spec, HDRIS)
        assert draw_framing(i, 4, cfg, p.cameras) is p.cameras
        assert all(c == CameraParams(c.azimuth, c.polar, c.radius) and not c.framed for c in p.cameras)


def test_framing_draws_in_range_from_a_stream_of_its_own(setup):
    cfg, spec = setup
    on = load_config("quick", {"generate.n": 40000, **FRAMING})
    fstop_only = load_config("quick", {"generate.n": 40000, "camera.fstop": [1.4, 16]})
    cams, cut = [], 0
    for i in range(500):
        a, b = sample_params(i, 4, cfg, spec, HDRIS), sample_params(i, 4, on, spec, HDRIS)
        c = sample_params(i, 4, fstop_only, spec, HDRIS)
        assert b.to_dict() | {"cameras": None} == a.to_dict() | {"cameras": None}  # every other draw as before
        for x, y, z in zip(a.cameras, b.cameras, c.cameras):
            assert (y.azimuth, y.polar, y.radius) == (x.azimuth, x.polar, x.radius)
            assert z.fstop == y.fstop and z.fill == 0 and z.cut_side == "" and z.lens == 0  # options draw apart
            assert 0.4 <= y.fill <= 0.8 and abs(y.shift_x) <= 0.2 and abs(y.shift_y) <= 0.2
            assert 35 <= y.lens <= 85 and 1.4 <= y.fstop <= 16 and y.framed
            if y.cut_side == "none":
                assert y.cut == 0
            else:
                assert y.cut_side in ("left", "right", "top", "bottom") and 0.1 <= y.cut <= 0.4
                cut += 1
            cams.append(y)
        assert SampleParams.from_dict(b.to_dict()) == b
    assert abs(cut / len(cams) - 0.3) < 0.04
    assert np.median([c.fstop for c in cams]) < 6  # log-uniform: the geometric middle of 1.4..16 is 4.7


def test_records_without_framing_fields_still_load(setup):
    cfg, spec = setup
    d = sample_params(0, 4, cfg, spec, HDRIS).to_dict()
    d["cameras"] = [{k: c[k] for k in ("azimuth", "polar", "radius")} for c in d["cameras"]]
    assert SampleParams.from_dict(d) == sample_params(0, 4, cfg, spec, HDRIS)


def test_surfaces_draw_from_a_stream_of_their_own(setup, tmp_path):
    from PIL import Image

    from deformsim.errors import UserError
    from deformsim.sampling import SURFACE_COLOURS, surface_photos

    cfg, spec = setup
    for name in ("b.png", "a.jpg"):
        Image.new("RGB", (8, 8)).save(tmp_path / name)
    (tmp_path / "notes.txt").write_text("not a photo")
    on = load_config("quick", {"render.surface": {"kinds": ["wood", "cloth", "photo"], "photos": str(tmp_path)}})
    kinds = set()
    for i in range(60):
        a, b = sample_params(i, 2, cfg, spec, HDRIS), sample_params(i, 2, on, spec, HDRIS)
        assert a.surface is None and b == SampleParams(**{**a.__dict__, "surface": b.surface})  # nothing else moved
        s, c = b.surface, SURFACE_COLOURS[b.surface.kind]
        assert c["value"][0] <= s.value <= c["value"][1] and 0.6 <= s.scale <= 1.6 and 0 <= s.rotation < 360
        assert (s.photo in surface_photos(tmp_path)) == (s.kind == "photo")
        assert SampleParams.from_dict(b.to_dict()) == b
        kinds.add(s.kind)
    assert kinds == {"wood", "cloth", "photo"}
    assert [p.rsplit("/", 1)[1] for p in surface_photos(tmp_path)] == ["a.jpg", "b.png"]
    (tmp_path / "a.jpg").unlink(), (tmp_path / "b.png").unlink()
    with pytest.raises(UserError, match="no images"):
        surface_photos(tmp_path)


def test_polar_views_draw_each_cameras_polar_from_its_own_range():
    from deformsim.errors import UserError
    from deformsim.hdri import list_hdris

    spec, hdris = load_spec(None), list_hdris(None)
    views = [[72, 88], [72, 88], [72, 88], [2, 10]]
    cfg = load_config("quick", {"camera.polar_views": views})
    polars = np.array([[c.polar for c in sample_params(i, 0, cfg, spec, hdris).cameras] for i in range(20)])
    assert (polars[:, :3] >= 72).all() and (polars[:, :3] <= 88).all() and (polars[:, 3] <= 10).all()
    # the same stream positions as one range for all: polar_views of the preset's polar draws the same scenes
    plain = load_config("quick")
    same = load_config("quick", {"camera.polar_views": [list(plain.camera.polar)] * 4})
    assert all(sample_params(i, 0, plain, spec, hdris) == sample_params(i, 0, same, spec, hdris) for i in range(4))
    with pytest.raises(UserError, match="camera.polar_views has 2 ranges for 4 cameras"):
        load_config("quick", {"camera.polar_views": [[0, 10], [80, 90]]})


def test_fill_views_draw_each_cameras_fill_from_its_own_range():
    from deformsim.errors import UserError
    from deformsim.hdri import list_hdris

    spec, hdris = load_spec(None), list_hdris(None)
    views = [[0.5, 0.7], [0.5, 0.7], [0.5, 0.7], [0.2, 0.3]]
    cfg = load_config("quick", {"camera.fill_views": views})
    fills = np.array([[c.fill for c in sample_params(i, 0, cfg, spec, hdris).cameras] for i in range(20)])
    assert (fills[:, :3] >= 0.5).all() and (fills[:, :3] <= 0.7).all()
    assert (fills[:, 3] >= 0.2).all() and (fills[:, 3] <= 0.3).all()
    # the same draws as one fill range for all when the ranges are that one
    one = load_config("quick", {"camera.fill": [0.3, 0.6]})
    same = load_config("quick", {"camera.fill_views": [[0.3, 0.6]] * 4})
    assert all(sample_params(i, 0, one, spec, hdris) == sample_params(i, 0, same, spec, hdris) for i in range(4))
    with pytest.raises(UserError, match="camera.fill_views has 3 ranges for 4 cameras"):
        load_config("quick", {"camera.fill_views": views[:3]})


def test_paired_twins_share_every_draw_but_the_damage():
    """generate.paired: sample 2k is deformed, 2k + 1 intact in the same scene (cameras, lights, surface, material,
    shape), so no scene setting differs between the classes; off, every sample draws its own."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2] / "examples" / "tin"
    cfg = load_config(root / "config.yaml", {"object.spec": str(root / "spec.yaml")})
    assert cfg.generate.paired  # the tin example draws twins
    spec = load_spec(root / "spec.yaml")
    for k in range(20):
        damaged, twin = sample_params(2 * k, 3, cfg, spec, HDRIS), sample_params(2 * k + 1, 3, cfg, spec, HDRIS)
        assert damaged.deformed and not twin.deformed and damaged.pair == twin.pair == 2 * k
        assert any(damaged.keys.values()) and not any(twin.keys.values())
        differ = {f for f in SampleParams.__dataclass_fields__ if getattr(damaged, f) != getattr(twin, f)}
        assert differ <= {"index", "label", "families", "keys", "displacement", "extent", "bank", "bank_amount"}
        assert damaged.surface is not None and damaged.material is not None and damaged.lights
    unpaired = load_config(root / "config.yaml", {"object.spec": str(root / "spec.yaml"), "generate.paired": False})
    a, b = sample_params(0, 3, unpaired, spec, HDRIS), sample_params(1, 3, unpaired, spec, HDRIS)
    assert a.pair is None and a.cameras != b.cameras and a.surface != b.surface
    from dataclasses import replace  # a deformed twin (2k) draws as it would unpaired
    assert sample_params(2, 3, unpaired, spec, HDRIS) == replace(sample_params(2, 3, cfg, spec, HDRIS), pair=None)
    with pytest.raises(UserError, match="paired needs generate.intact_fraction 0.5.*not 0.3"):
        load_config("quick", {"generate.paired": True, "generate.intact_fraction": 0.3})
