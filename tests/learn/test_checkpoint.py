"""Loading a saved model checks it as a config file is checked: its saved config within the config's ranges,
finite weights, and the parts `restore` relies on; one line naming the file, before anything is built or allocated."""

from __future__ import annotations

import math

import pytest
import torch

from deformsim.config import TrainConfig
from deformsim.errors import UserError
from deformsim.learn.checkpoint import read_checkpoint, restore, save
from deformsim.learn.models import build
from deformsim.learn.predict import load


@pytest.fixture(scope="module")
def saved(tmp_path_factory) -> dict:
    """A small untrained model's checkpoint dict, as ``save`` writes it."""
    cfg = TrainConfig(backbone="mobilenet_v2", weights="none", image_size=32)
    model, _ = build(cfg, load_weights=False)
    path = tmp_path_factory.mktemp("model") / "model.pt"
    save(path, model, cfg, "none", [], {"train": [], "val": []})
    return torch.load(path, weights_only=True)


def write(tmp_path, ckpt: dict):
    path = tmp_path / "model.pt"
    torch.save(ckpt, path)
    return path


def test_a_saved_model_loads(saved, tmp_path):
    predictor = load(write(tmp_path, saved))
    assert predictor.cfg.image_size == 32 and predictor.classes == ["intact", "deformed"]


@pytest.mark.parametrize("change, needle", [
    ({"image_size": 1_000_000}, "train.image_size: Input should be less than or equal to 1024 (got 1000000)"),
    ({"batch_size": 10**9}, "train.batch_size: Input should be less than or equal to 4096"),
    ({"hidden": [256, 2**40]}, "train.hidden.1: Input should be less than or equal to 8192"),
    ({"threshold": math.nan}, "train.threshold: Input should be a finite number"),
    ({"seed": 2**64}, "train.seed: Input should be less than or equal to 9223372036854775807"),
    ({"backbone": "x" * 10**6}, "train.backbone: Input should be"),
])
def test_a_saved_config_out_of_range_is_one_line_naming_the_file(saved, tmp_path, change, needle):
    """A model.pt whose saved config is out of range (train.image_size 1000000 would allocate until killed) is
    refused when loaded, in one line naming the file."""
    path = write(tmp_path, {**saved, "config": {**saved["config"], **change}})
    with pytest.raises(UserError) as exc:
        load(path)
    line = str(exc.value)
    assert line.startswith(f"{path}: its saved config is invalid: ") and needle in line and len(line) < 400, line


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_weights_are_refused(saved, tmp_path, bad):
    """A model whose weights are NaN predicted "intact"."""
    state = dict(saved["state_dict"])
    name = next(k for k, v in state.items() if v.is_floating_point() and k.startswith("head"))
    state[name] = state[name].clone()
    state[name].view(-1)[0] = bad
    path = write(tmp_path, {**saved, "state_dict": state})
    with pytest.raises(UserError, match=f"{path} holds non-finite weights \\(NaN or infinity\\) in {name}"):
        read_checkpoint(path)


@pytest.mark.parametrize("change, needle", [
    ({"state_dict": {"head.0.weight": [1.0, 2.0]}}, "state_dict entry head.0.weight is no tensor"),
    ({"state_dict": [1, 2]}, "no state_dict/config"),
    ({"config": [1, 2]}, "its config is no mapping"),
    ({"outputs": ["f"] * 10**5}, "its outputs are not 1 to 1024 names"),
    ({"outputs": []}, "its outputs are not 1 to 1024 names"),
    ({"classes": ["intact"]}, "its classes are not two names"),
])
def test_a_malformed_checkpoint_is_one_line(saved, tmp_path, change, needle):
    path = write(tmp_path, {**saved, **change})
    with pytest.raises(UserError, match=needle):
        read_checkpoint(path)


def test_a_state_dict_of_another_model_names_the_file(saved, tmp_path):
    ckpt = {**saved, "config": {**saved["config"], "hidden": [64, 32]}}
    with pytest.raises(UserError, match="model.pt does not match its saved config"):
        restore(read_checkpoint(write(tmp_path, ckpt))[0], tmp_path / "model.pt")


@pytest.mark.parametrize("name, value, needle", [
    ("std", torch.zeros(1, 3, 1, 1), r"its input std \[0.0, 0.0, 0.0\] is not mobilenet_v2's"),
    ("std", torch.full((1, 3, 1, 1), 1e-30), "its input std"),
    ("mean", torch.full((1, 3, 1, 1), 9.0), "its input mean"),
    ("features.1.conv.0.1.running_var", None, "holds a negative variance"),
])
def test_a_model_whose_fixed_buffers_were_changed_is_refused(saved, tmp_path, name, value, needle):
    """A model with std = 0 predicted `nan ... intact` and exited 0."""
    state = dict(saved["state_dict"])
    state[name] = value if value is not None else -torch.ones_like(state[name])
    path = write(tmp_path, {**saved, "state_dict": state})
    with pytest.raises(UserError, match=needle) as err:
        load(path)
    assert str(err.value).startswith(f"{path} is not a deformsim model")
