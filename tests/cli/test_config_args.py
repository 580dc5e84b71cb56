"""`ConfigArgs`, the one place where a command's flags become config keys, and the `--set` parser."""

from __future__ import annotations

import pytest

from deformsim.cli.common import ConfigArgs, parse_sets
from deformsim.errors import UserError


def test_flags_and_overrides_set_config_keys():
    engine = ConfigArgs("quick", {"--n": ("generate.n", 16), "--seed": ("generate.seed", None)},
                        overrides={"generate.seed": 7, "generate.n": 8}).engine(progress=False)
    cfg = engine.config
    assert cfg.generate.n == 16 and cfg.generate.seed == 7  # a given flag wins; one not given leaves the override
    assert engine.progress is False


def test_set_null_turns_a_setting_off(tmp_path):
    """`--set composite.effects.blur=null` switches the blur off (it was silently ignored); the other effects stay."""
    config = tmp_path / "config.yaml"
    config.write_text("composite:\n  effects: {}\n")
    effects = ConfigArgs(config, sets=["composite.effects.blur=null"]).engine().config.composite.effects
    assert effects.blur is None and effects.noise == ConfigArgs(config).engine().config.composite.effects.noise


def test_a_bad_value_is_named_by_its_flag_or_its_key():
    with pytest.raises(UserError, match=r"^--n 3: .*multiple of the 4 cameras"):
        ConfigArgs("quick", {"--n": ("generate.n", 3)}).engine()
    with pytest.raises(UserError, match=r"^override train.epochs 0: invalid train.epochs"):
        ConfigArgs("quick", overrides={"train.epochs": 0}).engine()


def test_parse_sets_reads_yaml_values_and_refuses_bad_items():
    assert parse_sets(["train.epochs=5", "composite.variants=[black, green]"]) == {
        "train.epochs": 5, "composite.variants": ["black", "green"]}
    with pytest.raises(UserError, match="expected KEY=VALUE"):
        parse_sets(["train.epochs"])
    with pytest.raises(UserError, match="not valid YAML"):
        parse_sets(["train.epochs=["])


def test_a_bad_set_is_refused_though_a_flag_overrides_it():
    """`generate --resolution 32 --set render.resolution=0` ran: the flag won and the bad --set was never checked."""
    with pytest.raises(UserError, match=r"^--set render.resolution 0: invalid render.resolution"):
        ConfigArgs("quick", {"--resolution": ("render.resolution", 32)}, sets=["render.resolution=0"]).engine()
    with pytest.raises(UserError, match=r"^override generate.n -4: invalid generate.n"):
        ConfigArgs("quick", overrides={"generate.n": -4}, sets=["generate.n=8"]).engine()
    cfg = ConfigArgs("quick", {"--resolution": ("render.resolution", 32)}, sets=["render.resolution=64"]).engine().config
    assert cfg.render.resolution == 32  # a good one still yields to the flag


def test_train_variants_are_plain_names_and_not_empty():
    """`--set train.variants=[]` was an IndexError in train; a name with a folder in it became a path."""
    with pytest.raises(UserError, match=r"^--set train.variants \[\]: .*train.variants is empty"):
        ConfigArgs("quick", sets=["train.variants=[]"]).engine()
    for name in ("../../x", "a/b", ".hidden", ""):
        with pytest.raises(UserError, match="train.variants"):
            ConfigArgs("quick", sets=[f"train.variants=['{name}']"]).engine()
    with pytest.raises(UserError, match="composite.variants"):
        ConfigArgs("quick", sets=["composite.variants=['../up']"]).engine()
