"""Registry behaviour: registration, duplicates, lazy entry-point plugins, failure isolation."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from tests.helpers.fake_dist import install_fake_dist

from momu.registry import KINDS, PluginError, Registry, RegistryError, registry_for


@dataclass
class ToyConfig:
    width: int = 3
    scale: float = 1.0


def test_register_get_and_build_with_defaults_and_params() -> None:
    reg: Registry = Registry("toys")

    @reg.register("toy", config=ToyConfig)
    def build_toy(cfg: ToyConfig, offset: int = 0) -> tuple[int, float]:
        return cfg.width + offset, cfg.scale

    entry = reg.get("toy")
    assert entry.source == f"local ({__name__})"  # a part registered outside momu and its plugins
    assert entry.config is ToyConfig
    assert "test_registry" in entry.origin
    assert reg.build("toy") == (3, 1.0)
    assert reg.build("toy", {"width": 5}, offset=2) == (7, 1.0)
    assert reg.build("toy", ToyConfig(width=1, scale=2.0)) == (1, 2.0)
    assert reg.names() == ["toy"] and "toy" in reg


def test_build_rejects_unknown_param_naming_valid_keys() -> None:
    reg: Registry = Registry("toys")
    reg.register("toy", config=ToyConfig)(lambda cfg: cfg)
    from momu.config import ConfigError

    with pytest.raises(ConfigError, match=r"widht.*valid keys: width, scale"):
        reg.build("toy", {"widht": 4})


def test_duplicate_name_names_both_definitions() -> None:
    reg: Registry = Registry("toys")

    @reg.register("toy")
    def first() -> None: ...

    with pytest.raises(RegistryError) as err:

        @reg.register("toy")
        def second() -> None: ...

    message = str(err.value)
    assert "first" in message and "second" in message and "registered twice" in message


def test_unknown_name_lists_valid_names() -> None:
    reg: Registry = Registry("toys")
    reg.register("alpha")(lambda: 1)
    reg.register("beta")(lambda: 2)
    with pytest.raises(RegistryError, match="unknown toy 'gamma'; valid names: alpha, beta"):
        reg.get("gamma")


def test_config_must_be_a_dataclass() -> None:
    reg: Registry = Registry("toys")
    with pytest.raises(RegistryError, match="must be a dataclass"):
        reg.register("toy", config=dict)


def test_all_nine_kinds_exist() -> None:
    assert set(KINDS) == {
        "encoders",
        "backbones",
        "losses",
        "samplers",
        "schedulers",
        "vocoders",
        "metrics",
        "datasets",
        "methods",
    }
    with pytest.raises(RegistryError, match="valid kinds"):
        registry_for("widgets")


PLUGIN_SOURCE = """
from dataclasses import dataclass
from momu.registry import BACKBONES, METRICS

@dataclass
class WideConfig:
    width: int = 8

@BACKBONES.register("fake_wide", config=WideConfig)
def build_wide(cfg):
    return ("wide", cfg.width)

@METRICS.register("fake_count")
def build_count():
    return "count"
"""


@pytest.fixture
def fake_plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    install_fake_dist(
        tmp_path / "site",
        monkeypatch,
        dist="momu-fake-plugin",
        version="1.2.3",
        module="momu_fake_plugin",
        source=PLUGIN_SOURCE,
        entry_points={
            "momu.backbones": {"fake_wide": "momu_fake_plugin:build_wide"},
            "momu.metrics": {"fake_count": "momu_fake_plugin"},
        },
    )
    yield
    for kind, name in (("backbones", "fake_wide"), ("metrics", "fake_count")):
        registry_for(kind).unregister(name)


def test_entry_point_names_listed_without_import(fake_plugin: None) -> None:
    backbones = registry_for("backbones")
    assert "fake_wide" in backbones.names()
    assert backbones.sources()["fake_wide"] == "momu-fake-plugin==1.2.3"
    assert "momu_fake_plugin" not in sys.modules


def test_get_imports_only_that_plugin_and_records_source(fake_plugin: None) -> None:
    entry = registry_for("backbones").get("fake_wide")
    assert "momu_fake_plugin" in sys.modules
    assert entry.source == "momu-fake-plugin==1.2.3"
    assert registry_for("backbones").build("fake_wide", {"width": 2}) == ("wide", 2)
    # the second part of the same module gets the same distribution as its source
    assert registry_for("metrics").get("fake_count").source == "momu-fake-plugin==1.2.3"


def test_plugin_usable_by_name_in_a_config(fake_plugin: None) -> None:
    from momu.config import build_component, load_config

    cfg = load_config({"backbone": {"name": "fake_wide", "width": 5}})
    assert cfg.backbone.width == 5
    assert build_component(cfg.backbone, "backbones") == ("wide", 5)


def test_broken_plugin_is_isolated(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    install_fake_dist(
        tmp_path / "site",
        monkeypatch,
        dist="momu-broken",
        version="0.0.1",
        module="momu_broken_plugin",
        source="raise RuntimeError('boom at import')\n",
        entry_points={"momu.backbones": {"broken_net": "momu_broken_plugin:build"}},
    )
    backbones = registry_for("backbones")
    assert "broken_net" in backbones.names()  # listing never imports
    with pytest.raises(PluginError) as err:
        backbones.get("broken_net")
    message = str(err.value)
    assert "momu-broken==0.0.1" in message and "broken_net = momu_broken_plugin:build" in message
    assert "boom at import" in message
    # other parts and `momu list` keep working
    from momu.cli import main

    assert main(["list", "backbones"]) == 0


def test_entry_point_that_registers_nothing_is_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    install_fake_dist(
        tmp_path / "site",
        monkeypatch,
        dist="momu-empty",
        version="2.0",
        module="momu_empty_plugin",
        source="def build():\n    return 1\n",
        entry_points={"momu.losses": {"empty_loss": "momu_empty_plugin:build"}},
    )
    with pytest.raises(PluginError, match="registered no losses part named 'empty_loss'"):
        registry_for("losses").get("empty_loss")
