"""Issue 13, plugins and saved parts: name clashes, sys.exit at import, header checks before building."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file
from tests.helpers.fake_dist import install_fake_dist
from torch import nn

from momu.cli import main
from momu.parts_io import load_part, save_part
from momu.registry import BACKBONES, PluginError, RegistryError
from momu.weights_io import read_header, save_module, write_safetensors


def test_an_entry_point_named_like_a_built_in_is_an_error_naming_both(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    install_fake_dist(
        tmp_path / "site",
        monkeypatch,
        dist="momu-clash",
        version="0.1.0",
        module="momu_clash_plugin",
        source="def build(cfg=None):\n    return None\n",
        entry_points={"momu.backbones": {"dit": "momu_clash_plugin:build"}},
    )
    with pytest.raises(RegistryError) as err:
        BACKBONES.get("dit")
    assert "registered twice" in str(err.value) and "momu.backbones.dit" in str(err.value)
    assert "momu-clash==0.1.0" in str(err.value)
    assert main(["list", "backbones"]) == 0  # listing still works and shows the clash
    assert "CONFLICT: also momu-clash==0.1.0" in capsys.readouterr().out


def test_a_plugin_calling_sys_exit_at_import_is_isolated(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    install_fake_dist(
        tmp_path / "site",
        monkeypatch,
        dist="momu-exits",
        version="0.0.1",
        module="momu_exiting_plugin",
        source="import sys\nsys.exit(3)\n",
        entry_points={"momu.backbones": {"exiting_net": "momu_exiting_plugin:build"}},
    )
    with pytest.raises(PluginError, match=r"momu-exits==0.0.1.*called sys.exit\(3\)"):
        BACKBONES.get("exiting_net")
    assert "dit" in BACKBONES.names()


@dataclass
class _WideConfig:
    width: int = 4


_BUILD_DEVICES: list[str] = []


def _build_wide(cfg: _WideConfig) -> nn.Module:
    module = nn.Linear(cfg.width, cfg.width)
    _BUILD_DEVICES.append(module.weight.device.type)
    return module


@pytest.fixture
def wide_part():
    BACKBONES.register("h13_wide", config=_WideConfig)(_build_wide)
    _BUILD_DEVICES.clear()
    yield
    BACKBONES.unregister("h13_wide")


def test_a_config_that_would_build_a_huge_part_is_refused_before_allocating(
    wide_part: None, tmp_path: Path
) -> None:
    save_part(_build_wide(_WideConfig(4)), "backbones", "h13_wide", {"width": 4}, tmp_path / "p")
    record = json.loads((tmp_path / "p" / "config.json").read_text())
    record["config"]["width"] = 200_000  # 40 G parameters: 160 GB if it were built
    (tmp_path / "p" / "config.json").write_text(json.dumps(record))
    _BUILD_DEVICES.clear()
    with pytest.raises(
        ValueError, match=r"shape mismatches.*weight: saved \(4, 4\) vs part \(200000, 200000\)"
    ):
        load_part(tmp_path / "p")
    assert _BUILD_DEVICES == ["meta"]  # only the meta-device build ran


def test_integer_and_non_finite_weights_are_refused(wide_part: None, tmp_path: Path) -> None:
    module = _build_wide(_WideConfig(4))
    save_part(module, "backbones", "h13_wide", {"width": 4}, tmp_path / "p")
    weights = tmp_path / "p" / "model.safetensors"
    good = load_file(str(weights))
    write_safetensors(weights, {**good, "weight": good["weight"].to(torch.int32)})
    with pytest.raises(ValueError, match="dtype mismatches.*weight: saved I32 vs part F32"):
        load_part(tmp_path / "p")
    bad = good["weight"].clone()
    bad[0, 0] = float("nan")
    write_safetensors(weights, {**good, "weight": bad})
    with pytest.raises(ValueError, match="NaN or infinite weights in weight"):
        load_part(tmp_path / "p")
    write_safetensors(weights, good)
    assert isinstance(load_part(tmp_path / "p"), nn.Linear)


def test_a_truncated_weights_file_is_named(wide_part: None, tmp_path: Path) -> None:
    save_part(_build_wide(_WideConfig(4)), "backbones", "h13_wide", {"width": 4}, tmp_path / "p")
    weights = tmp_path / "p" / "model.safetensors"
    weights.write_bytes(weights.read_bytes()[:-8])
    with pytest.raises(ValueError, match="model.safetensors.*truncated or corrupt"):
        load_part(tmp_path / "p")


def test_saved_weights_are_byte_identical_and_world_readable(tmp_path: Path) -> None:
    torch.manual_seed(0)
    module = nn.Sequential(nn.Linear(3, 3), nn.Linear(3, 3))
    module[1].weight = module[0].weight  # tied: stored once, alias in the metadata
    umask = os.umask(0o022)
    try:
        paths = []
        for i in range(3):
            meta = {f"k{j}": str(j) for j in ([5, 1, 9, 3] if i % 2 else [3, 9, 1, 5])}
            paths.append(save_module(module, tmp_path / f"m{i}.safetensors", meta))
    finally:
        os.umask(umask)
    blobs = {p.read_bytes() for p in paths}
    assert len(blobs) == 1
    infos, metadata = read_header(paths[0])
    assert list(metadata) == sorted(metadata) and metadata["1.weight"] == "0.weight"
    assert {p.stat().st_mode & 0o777 for p in paths} == {0o644}
    assert "1.weight" not in infos
