"""Lattice operations and vertex rules: pure NumPy."""

import numpy as np
import pytest

from deformsim.spec.lattice_ops import OPERATIONS, key_points, rest_lattice, select_vertices
from deformsim.spec.model import load_spec


def test_every_key_of_the_can_spec_moves_lattice_points():
    spec = load_spec()
    rest = rest_lattice(spec.lattice.points)
    for fam in spec.families:
        for key in fam.keys:
            moved = key_points(rest, [(op.op, op.params) for op in key.ops])
            assert np.abs(moved - rest).max() > 0.05, key.name


def test_rest_lattice_order_is_u_fastest():
    p = rest_lattice((2, 3, 4))
    assert p.shape == (24, 3)
    assert p[0].tolist() == [-0.5, -0.5, -0.5] and p[1].tolist() == [0.5, -0.5, -0.5]
    assert p[2][1] == 0.0 and p[6][2] > p[0][2]


@pytest.mark.parametrize("name", sorted(OPERATIONS))
def test_zero_strength_operations_leave_points_alone(name):
    rest = rest_lattice((4, 4, 5))
    zero = {"compress": {"amount": 0, "bulge": 0}, "squeeze": {"amount": 0}, "bend": {"angle": 0, "kink": 0},
            "twist": {"angle": 0}, "crumple": {"amount": 0}, "dent": {"depth": 0}}[name]
    assert np.allclose(OPERATIONS[name](rest, **zero), rest)


def test_compress_shortens_and_bulges():
    rest = rest_lattice((4, 4, 5))
    p = OPERATIONS["compress"](rest, amount=0.4, anchor="bottom", bulge=0.2)
    assert np.isclose(p[:, 2].max() - p[:, 2].min(), 0.6)
    assert np.abs(p[:, 0]).max() > 0.5


def test_unknown_parameter_is_rejected():
    with pytest.raises(ValueError, match="unknown parameter"):
        OPERATIONS["twist"].check({"angel": 3})


def test_vertex_rules_combine():
    co = np.array([[1, 0, 0.0], [1, 0, 0.5], [1, 0, 1.0], [0, 0, 1.0]])
    normals = np.array([[1, 0, 0.0], [1, 0, 0.1], [0.2, 0, 1], [0, 0, 1.0]])
    assert select_vertices(co, normals, max_normal_angle=20).tolist() == [True, True, False, False]
    assert select_vertices(co, normals, height_band=(0.2, 0.8)).tolist() == [False, True, False, False]
    group = np.array([True, False, True, True])
    assert select_vertices(co, normals, in_group=group, max_normal_angle=20).tolist() == [True, False, False, False]


def test_a_minimum_normal_angle_selects_the_ends():
    normals = np.array([[1, 0, 0.0], [1, 0, 0.6], [0.2, 0, 1], [0, 0, -1.0]])
    co = np.zeros((4, 3))
    assert select_vertices(co, normals, min_normal_angle=60).tolist() == [False, False, True, True]
    assert select_vertices(co, normals, min_normal_angle=20, max_normal_angle=60).tolist() == [False, True, False, False]
