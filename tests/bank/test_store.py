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


def test_a_bake_replaces_the_bank_whole_and_keeps_one_baked_meanwhile(tmp_path, monkeypatch):
    """The simulation is faked (no Blender): what a bake keeps, replaces and leaves behind."""
    import numpy as np

    from deformsim.bank import stage
    from deformsim.bank.store import is_complete, load_bank
    from deformsim.spec.simulation import entry_names

    monkeypatch.setenv("DEFORMSIM_CACHE", str(tmp_path))
    spec = load_spec()
    names, value = entry_names(spec.simulation), [1.0]

    def simulate(spec_path, mesh, work, total, progress):
        entries = [{"name": n, "stats": {"seconds": 1.0}} for n in names]
        return entries, [np.full((4, 3), value[0], np.float32) for _ in names]

    monkeypatch.setattr(stage, "_simulate", simulate)
    final = stage.bake(spec, None, None, progress=False)
    assert is_complete(final, spec) and load_bank(final).positions.max() == 1.0
    value[0] = 2.0
    assert stage.bake(spec, None, None, progress=False) == final and load_bank(final).positions.max() == 1.0  # cached
    stage.bake(spec, None, None, progress=False, force=True)
    assert load_bank(final).positions.max() == 2.0  # replaced whole
    value[0] = 3.0
    asked = []  # the first check finds no bank; by the swap another process has baked it: kept

    def complete(path, spec):
        asked.append(path)
        return len(asked) > 1 and is_complete(path, spec)

    monkeypatch.setattr(stage, "is_complete", complete)
    stage.bake(spec, None, None, progress=False)
    assert len(asked) == 2
    assert load_bank(final).positions.max() == 2.0
    assert sorted(p.name for p in final.parent.iterdir()) == [final.name]  # no staging or old folder left
