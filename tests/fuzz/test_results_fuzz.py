"""A fuzz test of the benchmark results file that ``bench merge``, ``mean``, ``bag`` and ``compare`` read: keys removed,
values of random types, NaN, infinite and huge numbers, ragged predictions, duplicated runs, deep nesting and corrupt
bytes. Each command exits 0 with a valid output, or 1 or 2 with one line, and leaves its inputs as they were
(:mod:`tests.fuzz.harness`). ``DEFORMSIM_FUZZ_CASES=K`` runs K times as many cases."""

from __future__ import annotations

import copy
import json
import math

import numpy as np

from tests.evaluate.test_combine import _results
from tests.fuzz.harness import Case, fuzz, fuzz_cases
from tests.fuzz.inputs import CORRUPTIONS, HUGE_TEXT

VALUES = ["abc", None, [], {}, True, 3, -1, 0.5, 1e308, math.nan, math.inf, -math.inf, 2**70, HUGE_TEXT, [0.5, "x"],
          {"runs": []}]


def _nodes(node, where=()):
    """The path of every value in a parsed JSON document, containers included."""
    yield where
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        if isinstance(v, list) and len(v) > 20:  # long prediction lists: their first few stand for the rest
            v = v[:3]
        yield from _nodes(v, (*where, k))


def _set(doc, where, value):
    node = doc
    for k in where[:-1]:
        node = node[k]
    node[where[-1]] = value


def _mutated(rng: np.random.Generator, doc: dict) -> tuple[str, str | None]:
    """Edit ``doc`` in place one random way; (its name, or None, and raw text to write instead of ``doc``)."""
    how = str(rng.choice(["key removed", "random value", "deep value", "ragged", "duplicated run", "bytes",
                          "deep file"]))
    paths = [p for p in _nodes(doc) if p]
    where = paths[int(rng.integers(len(paths)))]
    if how == "key removed":
        dicts = [p for p in paths if isinstance(p[-1], str)]
        where = dicts[int(rng.integers(len(dicts)))]
        node = doc
        for k in where[:-1]:
            node = node[k]
        del node[where[-1]]
    elif how == "random value":
        _set(doc, where, copy.deepcopy(VALUES[int(rng.integers(len(VALUES)))]))
    elif how == "deep value":  # written as text: json cannot write what it cannot read
        depth = int(rng.choice([50, 900, 5000]))
        _set(doc, where, "<deep>")
        return f"{how} at {'.'.join(map(str, where))[:60]}", json.dumps(doc).replace('"<deep>"', "[" * depth + "]" * depth)
    elif how == "ragged":
        run = doc["runs"][int(rng.integers(len(doc["runs"])))]
        run["real_predictions"] = run["real_predictions"][: int(rng.integers(0, len(run["real_predictions"])))]
    elif how == "duplicated run":
        doc["runs"].append(copy.deepcopy(doc["runs"][int(rng.integers(len(doc["runs"])))]))
    elif how == "bytes":
        how = f"bytes {rng.choice(sorted(CORRUPTIONS))}"
        return how, CORRUPTIONS[how[6:]](rng, json.dumps(doc).encode()).decode("latin-1")
    else:
        return how, "[" * 100_000 + "]" * 100_000
    return f"{how} at {'.'.join(map(str, where))[:60]}", None


def _valid_output(path):
    def check(out):
        from deformsim.evaluate.results import read_results

        try:
            read_results(path)
        except Exception as exc:  # noqa: BLE001 - any failure to read back is the finding
            return f"its results.json does not read back: {exc}"
        return None

    return check


def _compared(out):
    return None if "Difference to" in out["stdout"] else "no comparison table on stdout"


def test_results_files(child, tmp_path):
    rng = np.random.default_rng(55)
    y = (rng.random(12) < 0.5).astype(int)
    y[:2] = (0, 1)
    prob = rng.random((4, 12)).round(3)
    cases = []
    for i in range(fuzz_cases(48)):
        work = tmp_path / f"c{i}"
        work.mkdir()
        good = work / "good.json"
        good.write_text(json.dumps(_results(prob, y, data_seeds=(5, 6))))
        doc = _results(prob, y)
        how, raw = _mutated(rng, doc)
        bad = work / "bad.json"
        bad.write_text(raw if raw is not None else json.dumps(doc), encoding="latin-1" if raw is not None else "utf-8")
        out = work / "out"
        command = str(rng.choice(["merge", "mean", "bag", "compare"]))
        argv = {"merge": ["bench", "merge", bad, good, "--out", out], "mean": ["bench", "mean", good, bad, "--out", out],
                "bag": ["bench", "bag", bad, "--members", "2", "--out", out],
                "compare": ["bench", "compare", bad, "--baseline", good] if i % 2 else
                ["bench", "compare", good, "--baseline", bad]}[command]
        valid = _compared if command == "compare" else _valid_output(out / "results.json")
        cases.append(Case(f"bench {command}: results file", how, argv, keep=[bad, good], valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)
