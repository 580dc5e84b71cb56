"""Hostile inputs: bad numbers for every config field and spec value, and corrupted file bytes (seeded draws)."""

from __future__ import annotations

import copy
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import yaml
from pydantic import BaseModel

from deformsim.config import Config
from deformsim.config_reference import fields, sections

WRONG = "abc"
HUGE_TEXT = "x" * 100_000
# name -> value; all but -1 are absurd anywhere a number is asked for
BAD = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf, "1e308": 1e308, "-1": -1, "2**70": 2**70, "wrong type": WRONG}


def absurd(name: str) -> bool:
    return name != "-1"


def leaf_fields(model: type[BaseModel] = Config, prefix: str = "") -> Iterator:
    """Every field of ``model`` that holds a value (not a section), as :class:`FieldDoc`, depth first."""
    for section_key, section in [(prefix, model), *sections(model, prefix)]:
        yield from (f for f in fields(section, section_key) if f.section is None)


def is_numeric(kind: str) -> bool:
    return kind.startswith(("integer", "number", "[min, max]", "list of [min, max]", "[integer", "[number"))


def mutated(kind: str, default: object, value: object, slot: int) -> object:
    """``value`` put into a field of ``kind`` whose default is ``default``: the field itself for a scalar, else the
    ``slot``-th number of its pair (the first pair of a list of ranges)."""
    if kind.startswith(("integer", "number")):
        return value
    if kind.startswith("list of [min, max]"):
        out = copy.deepcopy(default) if default is not None else [[0.5, 0.5]]
        out[0][slot % 2] = value
        return out
    out = list(default) if default is not None else [0.5, 0.5]
    out[slot % len(out)] = value
    return out


def set_key(data: dict, key: str, value: object) -> dict:
    """``data`` with the dotted ``key`` set to ``value`` (sections made as needed)."""
    node = data
    *parents, leaf = key.split(".")
    for p in parents:
        node = node.setdefault(p, {})
    node[leaf] = value
    return data


def write_yaml(path: Path, data: object) -> Path:
    path.write_text(yaml.safe_dump(data, sort_keys=False, width=float("inf")))
    return path


def spec_leaves(node: object, where: tuple = ()) -> Iterator[tuple]:
    """The path (keys and list indices) of every number in a parsed YAML document."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield from spec_leaves(v, (*where, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from spec_leaves(v, (*where, i))
    elif isinstance(node, int | float) and not isinstance(node, bool):
        yield where


def set_leaf(doc: object, where: tuple, value: object) -> object:
    out = copy.deepcopy(doc)
    node = out
    for k in where[:-1]:
        node = node[k]
    node[where[-1]] = value
    return out


# corruptions of a file's bytes: name -> f(rng, bytes) -> bytes
def _random(rng: np.random.Generator, data: bytes) -> bytes:
    return rng.bytes(int(rng.integers(1, max(2, 2 * len(data)))))


def _truncated(rng: np.random.Generator, data: bytes) -> bytes:
    return data[: int(rng.integers(0, max(1, len(data) - 12)))]  # a PNG keeps no pixel data in its last 12 bytes


def _flipped(rng: np.random.Generator, data: bytes) -> bytes:
    out = bytearray(data)
    for i in rng.integers(0, len(out), int(rng.integers(1, 9))):
        out[i] ^= int(rng.integers(1, 256))
    return bytes(out)


CORRUPTIONS = {"random bytes": _random, "truncated": _truncated, "empty": lambda rng, data: b"",
               "bytes flipped": _flipped}


def corrupt(path: Path, how: str, rng: np.random.Generator) -> None:
    """Rewrite ``path`` as corruption ``how`` (a key of :data:`CORRUPTIONS`) of its bytes."""
    path.write_bytes(CORRUPTIONS[how](rng, path.read_bytes()))


def billion_laughs(levels: int = 7, width: int = 9) -> str:
    """YAML whose aliases expand to ``width ** levels`` strings under one config key."""
    anchors = ['&a0 ["lol"]', *(f"&a{i} [{', '.join([f'*a{i - 1}'] * width)}]" for i in range(1, levels + 1))]
    return f"generate:\n  n: [{', '.join(anchors)}]\n"
