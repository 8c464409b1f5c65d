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


def _twin(root: Path, monkeypatch: pytest.MonkeyPatch, dist: str) -> None:
    module = dist.replace("-", "_")
    install_fake_dist(
        root / dist,
        monkeypatch,
        dist=dist,
        version="1.0",
        module=module,
        source=f"from momu.registry import BACKBONES\n\n@BACKBONES.register('twin_net')\ndef build():\n"
        f"    return {dist!r}\n",
        entry_points={"momu.backbones": {"twin_net": f"{module}:build"}},
    )


def test_two_plugins_declaring_one_name_is_an_error_naming_both(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 34 item 9: the second plugin was silently ignored (the first one's part was built)."""
    _twin(tmp_path, monkeypatch, "momu-twin-a")
    _twin(tmp_path, monkeypatch, "momu-twin-b")
    backbones = registry_for("backbones")
    try:
        assert backbones.names().count("twin_net") == 1  # listed once, without importing either
        assert backbones.sources()["twin_net"] == "CONFLICT: momu-twin-a==1.0, momu-twin-b==1.0"
        with pytest.raises(RegistryError) as err:
            backbones.get("twin_net")
        message = str(err.value)
        for part in ("twin_net = momu_twin_a:build", "momu-twin-a==1.0", "twin_net = momu_twin_b:build"):
            assert part in message
        assert "momu-twin-b==1.0" in message and "\n" not in message
        assert "momu_twin_a" not in sys.modules and "momu_twin_b" not in sys.modules
        from momu.cli import main

        assert main(["list", "backbones"]) == 0  # listing still works and shows the conflict
        assert "CONFLICT" in capsys.readouterr().out
    finally:
        backbones.unregister("twin_net")


def test_plugin_import_deadline_setting(monkeypatch: pytest.MonkeyPatch) -> None:
    from momu.plugin_import import DEFAULT_PLUGIN_TIMEOUT_S, import_within, plugin_timeout

    monkeypatch.delenv("MOMU_PLUGIN_TIMEOUT", raising=False)
    assert plugin_timeout() == DEFAULT_PLUGIN_TIMEOUT_S
    monkeypatch.setenv("MOMU_PLUGIN_TIMEOUT", "2.5")
    assert plugin_timeout() == 2.5
    monkeypatch.setenv("MOMU_PLUGIN_TIMEOUT", "0")
    assert plugin_timeout() == 0.0
    for bad in ("-1", "nan", "inf", "soon"):
        monkeypatch.setenv("MOMU_PLUGIN_TIMEOUT", bad)
        with pytest.raises(ValueError, match="MOMU_PLUGIN_TIMEOUT"):
            plugin_timeout()
    # a quick import returns its value and stops its watchdog
    import threading

    before = threading.active_count()
    assert import_within(lambda: 7, 30.0, "x") == 7
    assert import_within(lambda: 8, 0.0, "x") == 8
    time_left = 5.0
    while threading.active_count() > before and time_left > 0:
        import time

        time.sleep(0.05)
        time_left -= 0.05
    assert threading.active_count() == before


def test_a_bad_plugin_deadline_is_a_plugin_error(fake_plugin: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MOMU_PLUGIN_TIMEOUT", "soon")
    with pytest.raises(PluginError, match="MOMU_PLUGIN_TIMEOUT='soon'"):
        registry_for("backbones").get("fake_wide")
