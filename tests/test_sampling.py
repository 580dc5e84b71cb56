"""Sampling is pure: these run without Blender."""

import numpy as np
import pytest

from deformsim.config import load_config
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
