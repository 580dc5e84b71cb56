"""A fuzz test of the command line: absurd numbers in every config field, corrupt configs, manifests, images,
checkpoints, specs, caches and state files, hostile paths and options. Each command exits 0 with valid output, or
1 or 2 with one line and no traceback, and leaves existing outputs as they were (:mod:`tests.fuzz.harness`).

The draws are seeded; ``DEFORMSIM_FUZZ_CASES=K`` runs K times as many random cases (the config-field grid is always
whole), ``DEFORMSIM_FUZZ_REPORT=FILE`` appends every outcome to FILE as JSON lines.
"""

from __future__ import annotations

import copy
import json
import math
import os
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from PIL import Image

from deformsim.config import TrainConfig
from tests.fuzz.conftest import TINY_TRAIN, TOKEN
from tests.fuzz.harness import Case, fuzz, fuzz_cases, problems, run_cli, tree_hash
from tests.fuzz.inputs import (
    BAD,
    CORRUPTIONS,
    HUGE_TEXT,
    WRONG,
    absurd,
    billion_laughs,
    corrupt,
    is_numeric,
    leaf_fields,
    mutated,
    set_key,
    set_leaf,
    spec_leaves,
    write_yaml,
)

pytestmark = pytest.mark.torch

ROOT = Path(__file__).resolve().parents[2]
CAN_SPEC = ROOT / "src" / "deformsim" / "spec" / "builtin" / "can.yaml"
TINY_GENERATE = {"generate": {"n": 4, "workers": 1, "preview": 0}, "render": {"resolution": 16, "samples": 1}}
ESCAPES = ("../SECRET.png", "the secret's absolute path", "../../(...)/etc/hostname")
NO_PROGRESS = "--no-progress"


# ---- checks of a successful command's output ----

def no_secret(root: Path) -> str | None:
    """None unless a file under ``root`` is a symlink or holds the bytes of the secret outside the dataset."""
    for p in sorted(root.rglob("*")) if root.is_dir() else [root]:
        if p.is_symlink():
            return f"{p.relative_to(root)} is a symlink"
        if p.is_file() and TOKEN.encode() in p.read_bytes():
            return f"{p.name} holds a file from outside the dataset"
    return None


def model_ok(out: Path):
    def check(_):
        import torch

        ckpt = torch.load(out / "model.pt", map_location="cpu", weights_only=True)
        bad = [k for k, t in ckpt["state_dict"].items() if t.is_floating_point() and not t.isfinite().all()]
        return f"non-finite weights {bad[:2]}" if bad else None
    return check


def csv_ok(csv: Path, n: int):
    def check(_):
        df = pd.read_csv(csv)
        p = df[[c for c in df.columns if c.startswith("p_")]].to_numpy(float)
        if len(df) != n:
            return f"{len(df)} rows for {n} images"
        return None if np.isfinite(p).all() and ((p >= 0) & (p <= 1)).all() else f"probabilities {p.ravel()[:3]}"
    return check


def metrics_ok(path: Path):
    def check(_):
        m = json.loads(path.read_text())["metrics"]
        values = [m[k] for k in ("accuracy", "f1", "precision", "recall")]
        return None if all(math.isfinite(v) and 0 <= v <= 1 for v in values) else f"metrics {values}"
    return check


def export_ok(out: Path):
    return lambda _: no_secret(out) or (None if (out / "README.txt").is_file() else "no README.txt")


def variant_ok(data: Path, name: str = "procedural"):
    def check(_):
        folder = data / "variants" / name
        return no_secret(folder) or (None if len(pd.read_parquet(folder / "manifest.parquet")) else "no rows")
    return check


def dataset_ok(out: Path, images: int):
    def check(_):
        n = len(pd.read_parquet(out / "manifest.parquet"))
        return None if n == images else f"manifest of {n} rows for {images} images"
    return check


def spec_ok(out: dict):
    return None if out["stdout"].startswith("ok") else f"stdout {out['stdout'][:80]!r}"


# ---- commands on a dataset copy ----

def dataset_command(rng, base, data: Path, work: Path, variant: str = "black", commands=None):
    """One of train, evaluate, export-data or composite on ``data``: (argv, keep, keep_on_fail, valid)."""
    name = commands[int(rng.integers(len(commands)))] if commands else str(
        rng.choice(["train", "evaluate", "export-data", "composite"]))
    if name == "train":
        out = base.copy("model", work / "model") if rng.random() < 0.5 else work / "model"
        argv = ["train", data, "--variant", variant, "--out", out, "-c", base.config, NO_PROGRESS]
        return argv, [data], [out] if out.exists() else [], model_ok(out)
    if name == "evaluate":
        out = work / "metrics.json"
        return ["evaluate", base.model, "--data", data, "--variant", variant, "--out", out], [data], [], metrics_ok(out)
    if name == "export-data":
        fmt = str(rng.choice(["imagefolder", "coco", "anomalib"]))
        out = base.copy("export", work / "export") if rng.random() < 0.5 else work / "export"
        argv = ["export-data", data, out, "--format", fmt, "--variant", variant, "--overwrite", NO_PROGRESS]
        return argv, [data], [out] if out.exists() else [], export_ok(out)
    return (["composite", data, "--workers", "1", NO_PROGRESS], [], [data], variant_ok(data))


def _numeric_columns(df: pd.DataFrame) -> list[str]:
    return [c for c in df.columns if pd.api.types.is_numeric_dtype(df[c]) and not pd.api.types.is_bool_dtype(df[c])]


def _path_columns(df: pd.DataFrame) -> list[str]:
    return [c for c in df.columns if df[c].dtype == object and df[c].astype(str).str.endswith(".png").all()]


def corrupt_manifest(rng, path: Path, data: Path, secret: Path) -> tuple[str, bool]:
    """Corrupt a manifest in one drawn way; its name and whether every command must refuse it."""
    df = pd.read_parquet(path)
    how = str(rng.choice([*CORRUPTIONS, "number", "number", "path escape", "path escape", "symlink escape",
                          *(["y as text"] if "y" in df.columns else []), "no column", "no rows", "ids repeated"]))
    if how in CORRUPTIONS:
        corrupt(path, how, rng)
        return how, how != "bytes flipped"
    row = int(rng.integers(len(df)))
    if how == "number":
        col = str(rng.choice(_numeric_columns(df)))
        value = str(rng.choice(["nan", "inf", "1e308", "-1", "2**70"]))
        df[col] = df[col].astype(float)
        df.loc[row if rng.random() < 0.7 else slice(None), col] = float(BAD[value])
        how = f"{col} = {value}"
        must = col == "y"
    elif how == "path escape":
        target = str(rng.choice(ESCAPES))
        value = {ESCAPES[1]: str(secret), ESCAPES[2]: os.path.relpath("/etc/hostname", data)}.get(target, target)
        for col in _path_columns(df):
            df[col] = df[col].astype(object)
            df.loc[row, col] = value
        how, must = f"paths {target}", True
    elif how == "symlink escape":
        for col in _path_columns(df):
            image = data / df.loc[row, col]
            image.unlink(missing_ok=True)
            image.symlink_to(secret)
        return how, True
    elif how == "y as text":
        df["y"] = df["y"].astype(str)
        must = False
    elif how == "no column":
        col = str(rng.choice(list(df.columns)))
        df = df.drop(columns=[col])
        how, must = f"no column {col}", False
    elif how == "no rows":
        df, must = df.iloc[:0], True
    else:
        df, must = pd.concat([df, df.iloc[:2]]), False
    df.to_parquet(path, index=False)
    return how, must


# ---- the tests ----

def test_config_fields(child, unchanged, base, tmp_path):
    """Every config field with NaN, infinities, 1e308, -1, 2**70 and a value of the wrong type (other fields: a
    mapping; text and paths also 100 kB of text, which may be accepted but never printed whole), read by
    ``generate``: refused in one line before any worker starts."""
    rng = np.random.default_rng(1)
    cases = []
    for f in leaf_fields():
        if is_numeric(f.kind):
            values = [(name, mutated(f.kind, f.default, v, int(rng.integers(2)))) for name, v in BAD.items()]
        else:
            values = [("wrong type", {"x": 1})] + ([("huge text", HUGE_TEXT)] if f.kind.startswith(("path", "text"))
                                                   else [])
        for name, value in values:
            work = tmp_path / f"c{len(cases)}"
            work.mkdir()
            cfg = write_yaml(work / "cfg.yaml", set_key(copy.deepcopy(TINY_GENERATE), f.key, value))
            out = base.copy("data", work / "data") if rng.random() < 0.1 else work / "data"
            cases.append(Case(f"generate --config: {f.key}", name, ["generate", "--config", cfg, "--out", out,
                                                                   NO_PROGRESS],
                              absurd=absurd(name) and name != "huge text", keep_on_fail=[out] if out.exists() else [],
                              timeout=10))
    fuzz(child, cases, tmp_path)


def test_config_fields_in_train_and_composite(child, unchanged, base, tmp_path):
    """Bad train.* and composite.* values read by the commands that use them."""
    rng = np.random.default_rng(2)
    grid = [(f, name) for f in leaf_fields() if is_numeric(f.kind) and f.key.startswith(("train.", "composite."))
            for name in BAD]
    cases = []
    for i in rng.choice(len(grid), min(len(grid), fuzz_cases(12)), replace=False):
        f, name = grid[i]
        work = tmp_path / f"c{len(cases)}"
        work.mkdir()
        value = mutated(f.kind, f.default, BAD[name], int(rng.integers(2)))
        cfg = write_yaml(work / "cfg.yaml", set_key(copy.deepcopy(TINY_TRAIN), f.key, value))
        if f.key.startswith("train."):
            out = work / "model"
            argv, valid, keep = ["train", base.data, "--variant", "black", "--out", out, "-c", cfg, NO_PROGRESS], \
                model_ok(out), []
        else:
            data = base.copy("data", work / "data")
            argv, valid, keep = ["composite", data, "-c", cfg, NO_PROGRESS], variant_ok(data), [data]
        cases.append(Case(f"{argv[0]} -c: {f.key}", name, argv, absurd=absurd(name), keep_on_fail=keep, valid=valid,
                          timeout=30))
    fuzz(child, cases, tmp_path)


def test_config_files(child, unchanged, base, tmp_path):
    """Config files of random bytes, truncated presets, alias bombs, deep nesting, unsafe tags, other documents."""
    rng = np.random.default_rng(3)
    preset = (ROOT / "src" / "deformsim" / "presets" / "quick.yaml").read_bytes()
    fixed = {"alias bomb": billion_laughs().encode(), "nested 10000 deep": b"generate: " + b"[" * 10_000,
             "python tag": b"generate: !!python/object/apply:os.system ['echo fuzz']\n", "a list": b"- 1\n- 2\n",
             "a number": b"5\n", "not utf-8": b"generate:\n  n: \xff\xfe\n", "keys repeated": b"generate: {n: 4}\n"
             b"generate: {n: 8}\n", "a huge key": b"x" * 100_000 + b": 1\n"}
    drawn = [("random bytes", rng.bytes(int(rng.integers(1, 400)))) for _ in range(fuzz_cases(4))]
    drawn += [("truncated preset", preset[: int(rng.integers(len(preset)))]) for _ in range(fuzz_cases(3))]
    cases = []
    for name, text in [*fixed.items(), *drawn]:
        work = tmp_path / f"c{len(cases)}"
        work.mkdir()
        (work / "cfg.yaml").write_bytes(text)
        command = str(rng.choice(["generate", "generate", "composite"]))  # train would train for real on a valid one
        if command == "generate":
            argv = ["generate", "--config", work / "cfg.yaml", "--out", work / "data", NO_PROGRESS]
        else:
            argv = ["composite", base.copy("data", work / "data"), "-c", work / "cfg.yaml", NO_PROGRESS]
        cases.append(Case(f"{command} --config: file", name, argv, absurd=name != "truncated preset", timeout=30))
    fuzz(child, cases, tmp_path)


def test_dataset_manifests(child, unchanged, base, tmp_path):
    """A dataset's manifest.parquet corrupted (bytes, numbers, paths out of the dataset, symlinks), read by
    train, evaluate, export-data and composite."""
    rng = np.random.default_rng(4)
    cases = []
    for i in range(fuzz_cases(16)):
        work = tmp_path / f"c{i}"
        data = base.copy("data", work / "data")
        secret = shutil.copy(base.secret, work / "SECRET.png")
        how, must = corrupt_manifest(rng, data / "manifest.parquet", data, Path(secret))
        argv, keep, keep_on_fail, valid = dataset_command(rng, base, data, work)
        cases.append(Case(f"{argv[0]}: dataset manifest", how, argv, absurd=must, keep=keep, keep_on_fail=keep_on_fail,
                          valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)


def test_variant_manifests(child, unchanged, base, tmp_path):
    """A composited variant's manifest.parquet corrupted, read by train, evaluate and export-data."""
    rng = np.random.default_rng(5)
    cases = []
    for i in range(fuzz_cases(8)):
        work = tmp_path / f"c{i}"
        data = base.copy("data", work / "data")
        secret = shutil.copy(base.secret, work / "SECRET.png")
        how, must = corrupt_manifest(rng, data / "variants" / "procedural" / "manifest.parquet", data, Path(secret))
        argv, keep, keep_on_fail, valid = dataset_command(rng, base, data, work, "procedural",
                                                          ["train", "evaluate", "export-data"])
        cases.append(Case(f"{argv[0]}: variant manifest", how, argv, absurd=must, keep=keep,
                          keep_on_fail=keep_on_fail, valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)


def png_bomb(path: Path, side: int = 40_000) -> None:
    """A tiny PNG whose header claims ``side`` x ``side`` pixels."""
    Image.new("RGB", (8, 8)).save(path)
    data = bytearray(path.read_bytes())
    data[16:24] = struct.pack(">II", side, side)  # IHDR's width and height, then its CRC
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))
    path.write_bytes(bytes(data))


def odd_image(path: Path, how: str) -> None:
    """``path`` rewritten as a valid but unusual image."""
    im = Image.open(path).convert("RGB")
    {"1x1 pixel": lambda: im.resize((1, 1)).save(path), "16-bit grey": lambda: im.convert("I;16").save(path),
     "palette": lambda: im.convert("P").save(path), "CMYK JPEG as .png": lambda: im.convert("CMYK").save(path, "JPEG"),
     "4000 px wide": lambda: im.resize((4000, 4)).save(path)}[how]()


def test_images(child, unchanged, base, tmp_path):
    """Images that are not what they claim (random bytes, truncated, empty, a pixel bomb) or unusual (1 px, 16-bit,
    palette, CMYK), read by train, evaluate, export-data, composite and predict."""
    rng = np.random.default_rng(6)
    broken, odd = [*CORRUPTIONS, "pixel bomb"], ["1x1 pixel", "16-bit grey", "palette", "CMYK JPEG as .png",
                                                  "4000 px wide"]
    cases = []
    for i in range(fuzz_cases(12)):
        work = tmp_path / f"c{i}"
        data = base.copy("data", work / "data")
        how = str(rng.choice(broken + odd))
        command = str(rng.choice(["train", "evaluate", "export-data", "composite", "predict", "predict"]))
        kinds = ["rgba", "green"] if command == "composite" else ["black"]
        image = sorted((data / "images" / kinds[0]).glob("*.png"))[int(rng.integers(8))]
        for kind in kinds:
            target = data / "images" / kind / image.name
            if how == "pixel bomb":
                png_bomb(target)
            elif how in odd:
                odd_image(target, how)
            else:
                corrupt(target, how, rng)
        if command == "predict":
            csv = work / "p.csv"
            argv, keep, keep_on_fail, valid = ["predict", base.model, image, "--csv", csv], [data], [], csv_ok(csv, 1)
        else:
            argv, keep, keep_on_fail, valid = dataset_command(rng, base, data, work, commands=[command])
        cases.append(Case(f"{command}: image", how, argv, absurd=how in broken and how != "bytes flipped"
                          and command != "export-data", keep=keep, keep_on_fail=keep_on_fail, valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)


def _checkpoint_edit(rng) -> tuple[str, object, bool]:
    """A drawn edit of a checkpoint dict: its name, the edit (in place) and whether the result must be refused."""
    import torch

    def on_tensors(fn, first_only=False):
        def edit(ckpt):
            for k, t in list(ckpt["state_dict"].items()):
                if t.is_floating_point():
                    ckpt["state_dict"][k] = fn(t)
                    if first_only:
                        return
        return edit

    grid = [(f, name) for f in leaf_fields(TrainConfig) if is_numeric(f.kind) for name in BAD]
    f, name = grid[int(rng.integers(len(grid)))]
    value = mutated(f.kind, f.default, BAD[name], int(rng.integers(2)))
    edits = [
        (f"config {f.key} = {name}", lambda c: c["config"].__setitem__(f.key, value), absurd(name)),
        ("config image_size = 1000000", lambda c: c["config"].__setitem__("image_size", 1_000_000), True),
        ("config missing", lambda c: c.pop("config"), True),
        ("config a list", lambda c: c.__setitem__("config", [1, 2]), True),
        ("config target bogus", lambda c: c["config"].__setitem__("target", "bogus"), True),
        ("weights NaN", on_tensors(lambda t: torch.full_like(t, math.nan)), True),
        ("weights inf", on_tensors(lambda t: torch.full_like(t, math.inf)), True),
        ("one tensor NaN", on_tensors(lambda t: torch.full_like(t, math.nan), first_only=True), True),
        ("weights 1e38", on_tensors(lambda t: torch.full_like(t, 1e38)), False),
        ("a tensor of the wrong shape", on_tensors(lambda t: torch.zeros(3), first_only=True), True),
        ("a tensor missing", lambda c: c["state_dict"].pop(next(iter(c["state_dict"]))), True),
        ("a tensor is text", lambda c: c["state_dict"].__setitem__(next(iter(c["state_dict"])), "x"), True),
        ("state_dict a list", lambda c: c.__setitem__("state_dict", [1]), True),
        ("classes of one", lambda c: c.__setitem__("classes", ["intact"]), False),
        ("a million outputs", lambda c: c.__setitem__("outputs", ["x"] * 1_000_000), True),
        ("history NaN", lambda c: c.__setitem__("history", [{"acc": math.nan}]), False),
    ]
    return edits[int(rng.integers(len(edits)))]


def test_checkpoints(child, unchanged, base, tmp_path):
    """model.pt truncated, random, flipped, or saved with absurd config values, NaN weights or foreign parts, read by
    predict, evaluate and export (ONNX)."""
    import torch

    rng = np.random.default_rng(7)
    cases = []
    for i in range(fuzz_cases(16)):
        work = tmp_path / f"c{i}"
        model = base.copy("model", work / "model")
        if rng.random() < 0.3:
            how = str(rng.choice(list(CORRUPTIONS)))
            corrupt(model / "model.pt", how, rng)
            must = how != "bytes flipped"
        else:
            how, edit, must = _checkpoint_edit(rng)
            ckpt = torch.load(model / "model.pt", map_location="cpu", weights_only=True)
            edit(ckpt)
            torch.save(ckpt, model / "model.pt")
        command = str(rng.choice(["predict", "predict", "evaluate", "export"]))
        if command == "predict":
            out = work / "p.csv"
            argv, valid = ["predict", model, base.image, "--csv", out], csv_ok(out, 1)
        elif command == "evaluate":
            out = work / "m.json"
            argv, valid = ["evaluate", model, "--data", base.data, "--variant", "black", "--out", out], metrics_ok(out)
        else:
            out = work / "m.onnx"
            argv, valid = ["export", model, "--onnx", out], lambda _, out=out: None if out.stat().st_size else "empty"
        cases.append(Case(f"{command}: model.pt", how, argv, absurd=must, keep=[model], valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)


def test_specs(child, unchanged, base, tmp_path):
    """The can's spec with a bad number at a drawn place, random values in its structure, random bytes or cut
    short, read by spec check (and generate)."""
    rng = np.random.default_rng(8)
    doc = yaml.safe_load(CAN_SPEC.read_text())
    leaves = list(spec_leaves(doc))
    nodes = [w for w in _all_nodes(doc) if w]
    cases = []
    for i in range(fuzz_cases(30)):
        work = tmp_path / f"c{i}"
        work.mkdir()
        spec = work / "spec.yaml"
        kind = rng.random()
        if kind < 0.6:
            where, name = leaves[int(rng.integers(len(leaves)))], str(rng.choice(list(BAD)))
            write_yaml(spec, set_leaf(doc, where, BAD[name]))
            how, must = f"{'.'.join(map(str, where))} = {name}", absurd(name)
        elif kind < 0.8:
            where = nodes[int(rng.integers(len(nodes)))]
            value = [None, WRONG, [], {}, 5, -1, [1, 2, 3], {"a": 1}][int(rng.integers(8))]
            write_yaml(spec, set_leaf(doc, where, value))
            how, must = f"{'.'.join(map(str, where))} = {value!r}", False
        else:
            spec.write_bytes(CAN_SPEC.read_bytes())
            how = str(rng.choice(["random bytes", "truncated"]))
            corrupt(spec, how, rng)
            must = how == "random bytes"
        if rng.random() < 0.25:
            cfg = write_yaml(work / "cfg.yaml", TINY_GENERATE)
            argv, valid = ["generate", "--config", cfg, "--spec", spec, "--out", work / "data", NO_PROGRESS], None
        else:
            argv, valid = ["spec", "check", spec], spec_ok
        cases.append(Case(f"{' '.join(argv[:2]) if argv[0] == 'spec' else 'generate --spec'}", how, argv,
                          absurd=must, valid=valid, timeout=20))
    fuzz(child, cases, tmp_path)


def _all_nodes(node, where=()):
    yield where
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield from _all_nodes(v, (*where, k))


def test_feature_cache(child, unchanged, base, tmp_path):
    """Cached features corrupted (bytes, another shape, NaN, a folder in place of a file), read by predict and train."""
    import torch

    rng = np.random.default_rng(9)
    ways = ["random bytes", "truncated", "empty", "another shape", "NaN", "a folder"]
    cases = []
    for i in range(fuzz_cases(6)):
        work = tmp_path / f"c{i}"
        cache = base.copy("cache", work / "cache")
        how = ways[i % len(ways)]
        for f in sorted((cache / "features").rglob("*.pt")):
            if how in CORRUPTIONS:
                corrupt(f, how, rng)
            elif how == "another shape":
                torch.save(torch.zeros(3, 2), f)
            elif how == "NaN":
                torch.save(torch.full_like(torch.load(f, weights_only=True), math.nan), f)
            else:
                f.unlink()
                f.mkdir()
        if rng.random() < 0.7:
            out = work / "p.csv"
            argv, valid = ["predict", base.model, base.data / "images" / "black", "--csv", out], csv_ok(out, 8)
        else:
            out = work / "model"
            argv, valid = ["train", base.data, "--variant", "black", "--out", out, "-c", base.config, NO_PROGRESS], \
                model_ok(out)
        cases.append(Case(f"{argv[0]}: feature cache", how, argv, env={"DEFORMSIM_CACHE": str(cache)}, valid=valid,
                          timeout=60))
    fuzz(child, cases, tmp_path)


def test_state_files(child, unchanged, base, tmp_path):
    """The records an output keeps of itself (a model's inputs.json and train.json, a variant's composite.json)
    corrupted, then the command that would replace or resume it."""
    rng = np.random.default_rng(10)
    cases = []
    for i in range(fuzz_cases(4)):
        work = tmp_path / f"c{i}"
        how = str(rng.choice(["random bytes", "truncated", "empty", "NaN in JSON"]))
        if i % 2:
            model = base.copy("model", work / "model")
            target = model / str(rng.choice(["inputs.json", "train.json"]))
            argv = ["train", base.data, "--variant", "black", "--out", model, "-c", base.config, NO_PROGRESS]
            keep, valid = model, model_ok(model)
        else:
            data = base.copy("data", work / "data")
            target = data / "variants" / "procedural" / "composite.json"
            argv, keep, valid = ["composite", data, "--workers", "1", NO_PROGRESS], data, variant_ok(data)
        if how == "NaN in JSON":
            target.write_text('{"kind": NaN, "inputs": {"n": Infinity}}')
        else:
            corrupt(target, how, rng)
        cases.append(Case(f"{argv[0]}: {target.name}", how, argv, keep_on_fail=[keep], valid=valid, timeout=60))
    fuzz(child, cases, tmp_path)


def test_outputs_of_other_kinds(child, unchanged, base, tmp_path):
    """``--out`` naming a folder of another kind (a dataset, a model, an export, a user's files) or the command's
    own input, with ``--overwrite``: refused, the folder untouched."""
    def folder(kind: str, work: Path) -> Path:
        if kind == "user files":
            (work / "mine").mkdir(parents=True)
            (work / "mine" / "notes.txt").write_text("mine")
            return work / "mine"
        return base.copy(kind, work / kind)

    runs = [("train", "data"), ("train", "export"), ("train", "user files"), ("train", "itself"),
            ("export-data", "data"), ("export-data", "model"), ("export-data", "user files"), ("generate", "model"),
            ("generate", "export"), ("report", "data"), ("report", "model")]
    cases = []
    for i, (command, kind) in enumerate(runs):
        work = tmp_path / f"c{i}"
        data = base.copy("data", work / "input")
        out = data if kind == "itself" else folder(kind, work)
        argv = {"train": ["train", data, "--variant", "black", "--out", out, "-c", base.config],
                "export-data": ["export-data", data, out, "--format", "imagefolder", "--variant", "black"],
                "generate": ["generate", "--config", write_yaml(work / "cfg.yaml", TINY_GENERATE), "--out", out],
                "report": ["report", data, "--out", out, "-c", base.config, "--variants", "black"]}[command]
        cases.append(Case(f"{command} --overwrite --out", kind, [*argv, "--overwrite", NO_PROGRESS], absurd=True,
                          keep=[out, data], timeout=60))
    fuzz(child, cases, tmp_path)


def test_options(child, unchanged, base, tmp_path):
    """Absurd numbers given as options (seeds, counts, sizes, thresholds)."""
    cfg = write_yaml(tmp_path / "cfg.yaml", TINY_GENERATE)
    big = str(2**70)

    cases = []
    for opts, is_absurd, render in [
        (("--seed", big), True, "fake"), (("--seed", "-1"), False, "fake"), (("--seed", str(2**64 - 1)), False, "fake"),
        (("--n", big), True, "stop"), (("--n", "10000000"), True, "stop"), (("--resolution", big), True, "stop"),
        (("--samples", big), True, "stop"), (("--workers", big), True, "stop"), (("--workers", "-1"), True, "stop"),
    ]:
        out = tmp_path / f"g{len(cases)}"
        argv = ["generate", "--config", cfg, "--out", out, NO_PROGRESS, *opts]
        valid = dataset_ok(out, 4) if render == "fake" else None
        cases.append(Case("generate option", " ".join(opts), argv, absurd=is_absurd, render=render, valid=valid,
                          timeout=60))
    for value in ("nan", "inf", "-1", "2", "1e308"):
        out = tmp_path / f"e{value}.json"
        cases.append(Case("evaluate --threshold", value, ["evaluate", base.model, "--data", base.data, "--variant",
                                                          "black", "--threshold", value, "--out", out], absurd=True))
    for value in (big, "-1"):
        data = base.copy("data", tmp_path / f"d{len(cases)}")
        cases.append(Case("composite --seed", value, ["composite", data, "--seed", value, "--workers", "1", NO_PROGRESS],
                          keep_on_fail=[data], valid=variant_ok(data)))
    data = base.copy("data", tmp_path / "dw")
    cases.append(Case("composite --workers", big, ["composite", data, "--workers", big, NO_PROGRESS], absurd=True,
                      keep_on_fail=[data]))
    for value in (big, "0"):
        cases.append(Case("train --epochs", value, ["train", base.data, "--variant", "black", "--out",
                                                    tmp_path / f"m{len(cases)}", "-c", base.config, "--epochs", value,
                                                    NO_PROGRESS], absurd=True))
    for opt, value in (("--resolution", big), ("--resolution", "0"), ("--samples", big), ("--samples", "-1")):
        cases.append(Case("spec preview", f"{opt} {value}", ["spec", "preview", "--out", tmp_path / "p.png", opt,
                                                             value], absurd=True))
    fuzz(child, cases, tmp_path)


def test_exit_code_at_interpreter_exit(unchanged, base, tmp_path):
    """``composite --backgrounds /nonexistent`` as a user runs it, in a fresh interpreter: exit 2 with one line, no
    abort at exit (pyarrow's thread pool after read_parquet)."""
    data = base.copy("data", tmp_path / "data")
    argv = ["composite", data, "--backgrounds", "/nonexistent", "--workers", "1", NO_PROGRESS]
    before = tree_hash(data)
    found = [problems(Case("composite", "", argv, absurd=True), run_cli([str(a) for a in argv], tmp_path))
             for _ in range(fuzz_cases(2))]
    assert not any(found) and tree_hash(data) == before, f"{len(found)} runs: {found}"


# ---- a hostile value in any manifest column ----

NAMING = ("id", "label")  # columns whose value becomes part of a file's name or folder


def hostile_value(rng, work: Path) -> tuple[str, object]:
    """A drawn hostile manifest value: its name and the value (a path out of the dataset aims at ``work/outside``)."""
    up = "../" * int(rng.integers(1, 7))
    values = {"../ path": f"{up}outside/pwn", "absolute path": str(work / "outside" / "pwn"), "NUL": "a\x00b",
              "backslash": "..\\..\\outside\\pwn", "dot-dot": "..", "empty text": "", "huge text": "x" * 5000,
              "<script>": "<script>alert(1)</script>", "NaN": math.nan, "inf": math.inf, "-inf": -math.inf,
              "1e308": 1e308, "-1": -1, "whole numbers": "ints", "a list": "list", "null": None}
    name = str(rng.choice(list(values)))
    return name, values[name]


def set_column(df: pd.DataFrame, col: str, value: object, row: int) -> pd.DataFrame:
    """``df`` with ``value`` in row ``row`` of ``col`` (the whole column when a column cannot mix its type with it)."""
    if value == "ints":
        return df.assign(**{col: range(len(df))})
    if value == "list":
        return df.assign(**{col: [[1, 2]] * len(df)})
    text_column = df[col].dtype == object
    if value is not None and text_column != isinstance(value, str):
        return df.assign(**{col: [value] * len(df)})  # a column holds one type
    df[col] = df[col].astype(object if text_column or value is None else float)
    df.loc[row, col] = value
    return df


def test_manifest_columns(child, unchanged, base, tmp_path):
    """Every manifest column with a hostile value (paths out of the dataset, NUL, text where numbers belong,
    NaN and infinities, another type), read by export-data, composite, train, evaluate and show: one line or a
    valid output, nothing written outside (``outside/`` stays empty) and a path-like id or label always refused."""
    rng = np.random.default_rng(11)
    columns = list(pd.read_parquet(base.data / "manifest.parquet").columns)
    cases = []
    for i in range(fuzz_cases(24)):
        work = tmp_path / f"c{i}"
        data = base.copy("data", work / "data")
        (work / "outside").mkdir()
        col = columns[int(rng.integers(len(columns)))] if i % 3 else NAMING[i % 2]
        how, value = hostile_value(rng, work)
        path = data / "manifest.parquet"
        set_column(pd.read_parquet(path), col, value, int(rng.integers(8))).to_parquet(path, index=False)
        command = str(rng.choice(["export-data", "export-data", "composite", "train", "evaluate", "show"]))
        if command == "show":
            out = work / "sheet.png"
            argv, keep, keep_on_fail, valid = (["show", data, "--variant", "black", "--out", out, "--count", "2"], [data],
                                               [], lambda _, out=out: None if out.is_file() else "no sheet")
        else:
            argv, keep, keep_on_fail, valid = dataset_command(rng, base, data, work, commands=[command])
        path_like = isinstance(value, str) and any(s in value for s in ("/", "\\", "\x00")) or value in ("..", "")
        cases.append(Case(f"{command}: manifest column", f"{col} = {how}", argv, keep=[*keep, work / "outside"],
                          keep_on_fail=keep_on_fail, valid=valid, absurd=col in NAMING and path_like, timeout=60))
    fuzz(child, cases, tmp_path)
