"""Output folders: replaced whole or not at all, and only by an output of their own kind; the cache's place."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from deformsim import outputs
from deformsim.errors import UserError
from deformsim.outputs import check_file_target, check_folder_target, claim, read_inputs, replacing
from deformsim.parallel import owner_tag
from tests.util import dead_tag


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _outputs(root: Path) -> dict[str, Path]:
    """One folder of each kind as deformsim writes it now, and as older versions wrote it (no recorded kind)."""
    made = {}
    for kind, files in {"dataset": ["config.yaml", "samples/000000.json", "manifest.parquet"],
                        "model": ["model.pt", "train.json"], "report": ["report.html", "metrics.json"],
                        "export": ["README.txt", "labels.csv"]}.items():
        for era in ("now", "old"):
            folder = root / f"{kind}-{era}"
            for name in files:
                (folder / name).parent.mkdir(parents=True, exist_ok=True)
                (folder / name).write_text("x")
            if kind == "export":
                (folder / "export.json").write_text(json.dumps({"kind": "export"} if era == "now" else {}))
            elif era == "now":
                (folder / "inputs.json").write_text(json.dumps({"kind": kind, "inputs": {}}))
            made[f"{kind}-{era}"] = folder
    return made


def test_replacing_swaps_in_whole_or_leaves_the_old_folder(tmp_path):
    out = tmp_path / "model"
    with replacing(out, {"settings": 1}, "model") as tmp:
        (tmp / "model.pt").write_text("one")
        (tmp / "extra.txt").write_text("only in the first")
    assert read_inputs(out) == {"kind": "model", "settings": 1}
    with pytest.raises(KeyboardInterrupt), replacing(out, {"settings": 2}, "model") as tmp:
        (tmp / "model.pt").write_text("two")
        raise KeyboardInterrupt  # Ctrl-C halfway: the old model stays as it was
    assert (out / "model.pt").read_text() == "one" and read_inputs(out)["settings"] == 1
    with replacing(out, {"settings": 2}, "model") as tmp:
        (tmp / "model.pt").write_text("two")
    assert sorted(p.name for p in out.iterdir()) == ["inputs.json", "model.pt"]  # nothing stale
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model"]  # no staging or old copy


def test_claim_refuses_other_settings_unless_overwrite(tmp_path):
    out = tmp_path / "m"
    assert claim(out, "model", {"settings": 1}, overwrite=False) is False
    with replacing(out, {"settings": 1}, "model") as tmp:
        (tmp / "model.pt").write_text("x")
    assert claim(out, "model", {"settings": 1}, overwrite=False) is True
    with pytest.raises(UserError, match=r"other settings \(settings: 1 there, 2 now\).*--overwrite"):
        claim(out, "model", {"settings": 2}, overwrite=False)
    assert claim(out, "model", {"settings": 2}, overwrite=True) is True
    with pytest.raises(UserError, match="holds a report whose settings were not recorded"):
        (tmp_path / "r").mkdir()
        (tmp_path / "r" / "report.html").write_text("old")
        (tmp_path / "r" / "metrics.json").write_text("{}")
        claim(tmp_path / "r", "report", {}, overwrite=False)


def test_paths_are_checked(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(UserError, match="is a file, not a folder"):
        check_folder_target(tmp_path / "f", "--out")
    with pytest.raises(UserError, match="f is a file, not a folder"):
        check_folder_target(tmp_path / "f" / "g" / "h", "--out")
    with pytest.raises(UserError, match="is a folder"):
        check_file_target(tmp_path, "-o")
    assert check_file_target(tmp_path / "new" / "x.json", "-o") == tmp_path / "new" / "x.json"
    assert not (tmp_path / "new").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_overwrite_replaces_only_an_output_of_the_same_kind(tmp_path):
    made = _outputs(tmp_path)
    for name, folder in made.items():
        kind = name.split("-")[0]
        before = _files(folder)
        for other in ("dataset", "model", "report"):
            if other == kind:
                assert claim(folder, other, {}, overwrite=True) is True
                continue
            for overwrite in (False, True):
                with pytest.raises(UserError, match=f"holds a deformsim {kind}, not an? {other}: .*never replaced"):
                    claim(folder, other, {}, overwrite=overwrite)
        assert _files(folder) == before and outputs.kinds_in(folder) == {kind}, name
    # a copy of a dataset with an inputs.json of a model's shape is still a dataset
    (made["dataset-old"] / "inputs.json").write_text(json.dumps({"inputs": {}}))
    with pytest.raises(UserError, match="holds a deformsim dataset, not a model"):
        claim(made["dataset-old"], "model", {}, overwrite=True)


def test_a_mixed_or_foreign_folder_is_never_replaced(tmp_path):
    mixed = _outputs(tmp_path)["model-now"]
    (mixed / "config.yaml").write_text("x")
    (mixed / "samples").mkdir()
    assert outputs.kinds_in(mixed) == {"dataset", "model"}
    with pytest.raises(UserError, match="holds the files of a dataset and a model, not a model"):
        claim(mixed, "model", {}, overwrite=True)
    lone = tmp_path / "mine"
    lone.mkdir()
    (lone / "model.pt").write_text("another tool's")  # one generic name is not a model's files
    with pytest.raises(UserError, match="holds files but no deformsim model"):
        claim(lone, "model", {}, overwrite=True)


def test_an_output_is_never_an_input(tmp_path):
    data = tmp_path / "runs" / "data"
    data.mkdir(parents=True)
    with pytest.raises(UserError, match="--out .*data is the training data"):
        outputs.check_apart(data, "--out", {"training data": data})
    with pytest.raises(UserError, match="--out .*runs contains the dataset .*data, which replacing it would remove"):
        outputs.check_apart(tmp_path / "runs", "--out", {"dataset": data, "real photos": None})
    outputs.check_apart(data / "report", "--out", {"dataset": data})  # inside a dataset is fine
    with pytest.raises(UserError, match="lies inside the real photos"):
        outputs.check_outside(data / "report", "--out", {"real photos": data})


def test_what_a_killed_run_left_beside_an_output_is_removed(tmp_path):
    dead = dead_tag()
    out = tmp_path / "model"
    with replacing(out, {"settings": 1}, "model") as tmp:
        (tmp / "model.pt").write_text("one")
    left = [tmp_path / f".model.{what}-{dead}-1a2b3c4d" for what in ("staging", "removing")]
    live = tmp_path / f".model.staging-{owner_tag()}-5e6f7a8b"  # a run still going: kept
    host, pid, start = dead.rsplit("-", 2)
    elsewhere = tmp_path / f".model.staging-{host}x-{pid}-{start}-0a1b2c3d"  # another host's run on a shared disk: kept
    other = tmp_path / f".model2.staging-{dead}-1a2b3c4d"  # another output's: not this one's to remove
    for folder in (*left, live, elsewhere, other):
        folder.mkdir()
        (folder / "part.bin").write_text("half")
    with replacing(out, {"settings": 2}, "model") as tmp:
        (tmp / "model.pt").write_text("two")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["model", live.name, elsewhere.name, other.name])
    # killed between moving the old output aside and moving the new one in: the old one comes back
    out.rename(tmp_path / f".model.old-{dead}-9c8d7e6f")
    outputs.sweep(out)
    assert (out / "model.pt").read_text() == "two" and read_inputs(out)["settings"] == 2


def test_a_replacement_can_keep_what_another_process_made_meanwhile(tmp_path):
    out = tmp_path / "bank"
    with replacing(out) as tmp:
        (tmp / "bank.json").write_text("first")
    with replacing(out, keep=lambda: (out / "bank.json").is_file()) as tmp:
        (tmp / "bank.json").write_text("second")
    assert (out / "bank.json").read_text() == "first" and [p.name for p in tmp_path.iterdir()] == ["bank"]


def test_the_cache_is_an_absolute_folder(tmp_path, monkeypatch):
    import pwd

    for var in ("DEFORMSIM_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("HOME", "")
    try:
        home = Path(pwd.getpwuid(os.getuid()).pw_dir)
    except KeyError:
        pytest.skip("this user has no passwd entry")
    assert outputs.cache_dir() == home / ".cache" / "deformsim"
    monkeypatch.setenv("HOME", "relative/home")
    assert outputs.cache_dir() == home / ".cache" / "deformsim"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative")  # ignored, as the XDG spec says
    assert outputs.cache_dir() == home / ".cache" / "deformsim"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert outputs.cache_dir() == tmp_path / "xdg" / "deformsim"
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DEFORMSIM_CACHE", "cache")
    assert outputs.cache_dir() == tmp_path / "cache"
    for var in ("DEFORMSIM_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(var)

    def no_entry(uid):
        raise KeyError(uid)

    monkeypatch.setattr(pwd, "getpwuid", no_entry)
    with pytest.raises(UserError, match="HOME is 'relative/home'.*set DEFORMSIM_CACHE to an absolute folder") as err:
        outputs.cache_dir()
    assert "\n" not in str(err.value)


def test_a_file_output_is_never_one_of_the_command_inputs(tmp_path):
    """`export MODEL --onnx MODEL/model.pt`, `predict ... --csv IMAGE` and the like would overwrite an input."""
    from deformsim.outputs import check_file_target

    model = tmp_path / "m"
    model.mkdir()
    (model / "model.pt").write_bytes(b"weights")
    image = tmp_path / "a.png"
    image.write_bytes(b"png")
    for target, inputs in ((model / "model.pt", [model]), (tmp_path / "m" / ".." / "a.png", [model, image])):
        with pytest.raises(UserError, match="is an input of this command"):
            check_file_target(target, "--out", inputs)
    assert check_file_target(model / "model.onnx", "--onnx", [model]) == model / "model.onnx"
    assert (model / "model.pt").read_bytes() == b"weights" and image.read_bytes() == b"png"
