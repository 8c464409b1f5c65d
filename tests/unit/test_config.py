"""Config loading, validation, overrides and saving."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from omegaconf import OmegaConf
from omegaconf.errors import ReadonlyConfigError

from momu.config import (
    ConfigError,
    apply_overrides,
    build_component,
    component_kind,
    load_config,
    save_config,
)
from momu.registry import BACKBONES, METHODS


@dataclass
class NetAConfig:
    depth: int = 2
    width: int = 16


@dataclass
class NetBConfig:
    levels: int = 3


@dataclass
class PipeConfig:
    backbone: Any = field(default_factory=lambda: {"name": "cfgtest_net_a"})
    steps: int = 10


@pytest.fixture(autouse=True)
def parts():
    BACKBONES.register("cfgtest_net_a", config=NetAConfig)(lambda cfg: ("a", cfg.depth, cfg.width))
    BACKBONES.register("cfgtest_net_b", config=NetBConfig)(lambda cfg: ("b", cfg.levels))
    METHODS.register("cfgtest_pipe", config=PipeConfig)(lambda cfg: cfg)
    yield
    BACKBONES.unregister("cfgtest_net_a")
    BACKBONES.unregister("cfgtest_net_b")
    METHODS.unregister("cfgtest_pipe")


def test_component_kind_naming_rule() -> None:
    assert component_kind("backbone") == ("backbones", False)
    assert component_kind("music_encoder") == ("encoders", False)
    assert component_kind("loss") == ("losses", False)
    assert component_kind("aux_losses") == ("losses", True)
    assert component_kind("metrics") == ("metrics", True)
    assert component_kind("train") is None and component_kind("lr") is None


def test_defaults_are_filled_and_config_is_frozen() -> None:
    cfg = load_config({"backbone": {"name": "cfgtest_net_a", "depth": 4}, "train": {"lr": 0.1}})
    assert OmegaConf.to_container(cfg) == {
        "backbone": {"name": "cfgtest_net_a", "depth": 4, "width": 16},
        "train": {"lr": 0.1},
    }
    with pytest.raises(ReadonlyConfigError):
        cfg.backbone.depth = 9


def test_misspelled_key_names_the_valid_keys() -> None:
    with pytest.raises(ConfigError) as err:
        load_config({"backbone": {"name": "cfgtest_net_a"}}, ["backbone.depht=4"])
    assert (
        str(err.value) == "backbone.depht: unknown key for backbone 'cfgtest_net_a'; valid keys: depth, width"
    )


def test_wrong_type_names_the_key() -> None:
    with pytest.raises(ConfigError, match=r"backbone.depth: invalid value"):
        load_config({"backbone": {"name": "cfgtest_net_a", "depth": "deep"}})


def test_unknown_part_name_lists_registered_names() -> None:
    with pytest.raises(ConfigError, match=r"backbone: unknown backbone 'nope'; valid names: .*cfgtest_net_a"):
        load_config({"backbone": "nope"})


def test_bare_name_override_replaces_the_whole_node() -> None:
    cfg = load_config({"backbone": {"name": "cfgtest_net_a", "depth": 4}}, ["backbone=cfgtest_net_b"])
    assert OmegaConf.to_container(cfg.backbone) == {"name": "cfgtest_net_b", "levels": 3}


def test_dotted_override_sets_one_param_and_parses_types() -> None:
    cfg = load_config({"backbone": "cfgtest_net_a"}, ["backbone.width=32", "train.lr=1e-4", "seeds=[1,2]"])
    assert cfg.backbone.width == 32 and cfg.backbone.depth == 2
    assert cfg.train.lr == pytest.approx(1e-4)
    assert list(cfg.seeds) == [1, 2]


def test_nested_components_are_validated() -> None:
    cfg = load_config(
        {"method": {"name": "cfgtest_pipe", "backbone": {"name": "cfgtest_net_b", "levels": 5}}}
    )
    assert cfg.method.backbone.levels == 5 and cfg.method.steps == 10
    defaults = load_config({"method": "cfgtest_pipe"})
    assert OmegaConf.to_container(defaults.method.backbone) == {
        "name": "cfgtest_net_a",
        "depth": 2,
        "width": 16,
    }
    with pytest.raises(
        ConfigError, match=r"method.backbone.levles: unknown key for backbone 'cfgtest_net_b'"
    ):
        load_config({"method": {"name": "cfgtest_pipe", "backbone": {"name": "cfgtest_net_b", "levles": 1}}})


def test_component_lists() -> None:
    cfg = load_config({"backbones": ["cfgtest_net_a", {"name": "cfgtest_net_b", "levels": 1}]})
    assert [b.name for b in cfg.backbones] == ["cfgtest_net_a", "cfgtest_net_b"]
    with pytest.raises(ConfigError, match=r"backbones\[1\].x: unknown key"):
        load_config({"backbones": ["cfgtest_net_a", {"name": "cfgtest_net_b", "x": 1}]})


def test_build_component_from_node() -> None:
    cfg = load_config({"backbone": {"name": "cfgtest_net_a", "depth": 7}})
    assert build_component(cfg.backbone, "backbones") == ("a", 7, 16)
    assert build_component("cfgtest_net_b", "backbones") == ("b", 3)


def test_schema_validates_top_level() -> None:
    @dataclass
    class Top:
        seed: int = 0
        backbone: Any = None

    assert load_config({"backbone": "cfgtest_net_b"}, schema=Top).seed == 0
    with pytest.raises(ConfigError, match="sede: unknown key; valid keys: seed, backbone"):
        load_config({"sede": 1}, schema=Top)


def test_bad_override_syntax_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="expected key=value"):
        apply_overrides({}, ["backbone"])
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1, 2\n")
    with pytest.raises(ConfigError, match="bad.yaml: cannot parse YAML"):
        load_config(bad)


def test_save_config_round_trips_yaml_and_json(tmp_path: Path) -> None:
    cfg = load_config({"backbone": "cfgtest_net_a", "train": {"lr": 0.5}})
    save_config(cfg, tmp_path / "run" / "config.yaml")
    again = load_config(tmp_path / "run" / "config.yaml")
    assert OmegaConf.to_container(again) == OmegaConf.to_container(cfg)
    save_config(cfg, tmp_path / "config.json")
    assert json.loads((tmp_path / "config.json").read_text())["backbone"]["width"] == 16
    assert not list(tmp_path.glob("**/.*"))  # no temporary files left behind


def test_written_files_get_default_permissions(tmp_path: Path) -> None:
    import os

    from momu.io import write_json

    umask = os.umask(0o022)
    try:
        path = write_json(tmp_path / "r.json", {"a": 1})
    finally:
        os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o644


def test_override_reaches_interpolations_and_mapping_with_name_replaces() -> None:
    base = {
        "backbone": {"name": "cfgtest_net_a", "depth": 4},
        "method": {"name": "cfgtest_pipe", "backbone": "${backbone}"},
    }
    cfg = load_config(base, ["backbone=cfgtest_net_b"])
    assert OmegaConf.to_container(cfg.method.backbone) == {"name": "cfgtest_net_b", "levels": 3}
    cfg = load_config(base, ["backbone={name: cfgtest_net_b, levels: 7}"])
    assert OmegaConf.to_container(cfg.backbone) == {"name": "cfgtest_net_b", "levels": 7}
    cfg = load_config(base, ["backbone={width: 8}"])
    assert OmegaConf.to_container(cfg.backbone) == {"name": "cfgtest_net_a", "depth": 4, "width": 8}


def test_unparsable_override_value_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="cannot parse value"):
        apply_overrides({}, ["x={a: [1, 2"])
    with pytest.raises(ConfigError, match="cannot resolve"):
        load_config({"a": "${missing}"})
