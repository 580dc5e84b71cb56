"""The bank's cache key: a changed scenario, solver setting or mesh re-bakes; other spec edits reuse it."""

from __future__ import annotations

import pytest

from deformsim.bank.store import bank_dir, bank_key
from deformsim.spec.model import load_spec


def _variant(spec, **changes):
    data = spec.model_dump()
    for path, value in changes.items():
        node = data
        *head, last = path.split(".")
        for p in head:
            node = node[int(p)] if p.isdigit() else node[p]
        node[last] = value
    return type(spec).model_validate(data)


def test_key_follows_what_the_bake_depends_on(tmp_path, monkeypatch):
    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path))
    spec = load_spec()
    key = bank_key(spec, None)
    assert bank_key(load_spec(), None) == key
    assert bank_key(_variant(spec, **{"simulation.scenarios.0.travel": (0.1, 0.2)}), None) != key
    assert bank_key(_variant(spec, **{"simulation.bending": 7.0}), None) != key
    assert bank_key(_variant(spec, **{"families.0.keys.0.ops.0.amount": 0.1}), None) == key  # lattice only
    mesh = tmp_path / "a.stl"
    mesh.write_bytes(b"solid a\nendsolid a\n")
    first = bank_key(spec, mesh)
    mesh.write_bytes(b"solid b\nendsolid b\n")
    assert bank_key(spec, mesh) != first != key
    assert bank_dir(spec, None).parent == tmp_path / "banks"


def test_no_simulation_no_key():
    spec = _variant(load_spec(), simulation=None)
    with pytest.raises(ValueError, match="declares no simulation"):
        bank_key(spec, None)


def test_a_rebaked_bank_makes_a_new_dataset_identity(monkeypatch):
    """Renders made from one bank are never resumed with another: the bank key is part of the data identity."""
    from deformsim.bank import store
    from deformsim.config import load_config
    from deformsim.generate.identity import data_name

    lattice = load_config("quick", {})
    bank = load_config("quick", {"deform.sources.bank": 1})
    before = data_name(bank), data_name(lattice)
    monkeypatch.setattr(store, "BAKE_REVISION", store.BAKE_REVISION + 1)
    assert data_name(bank) != before[0]
    assert data_name(lattice) == before[1]  # a lattice-only dataset does not depend on the bank
