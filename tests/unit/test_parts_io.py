"""`momu.parts_io`: config.json + model.safetensors round trips and strict loading."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import torch

from momu.parts_io import CONFIG_FILE, WEIGHTS_FILE, load_part, read_part_config, save_part
from momu.registry import registry_for

# Small configs of every nn.Module part this area registers (other areas add theirs).
PARTS: list[tuple[str, str, dict[str, Any]]] = [
    (
        "backbones",
        "dit",
        {"in_channels": 4, "cond_channels": 3, "cond_embed_dim": 8, "hidden": 16, "heads": 2, "depth": 1},
    ),
    (
        "backbones",
        "unet1d",
        {
            "in_channels": 4,
            "cond_channels": 3,
            "base_channels": 8,
            "heads": 2,
            "cross_attention_dim": 8,
            "norm_groups": 2,
        },
    ),
    (
        "vocoders",
        "bigvgan",
        {
            "mel": {"hop_length": 16, "n_fft": 64, "n_mels": 8},
            "upsample_rates": [4, 4],
            "upsample_kernel_sizes": [8, 8],
            "upsample_initial_channel": 16,
            "resblock_kernel_sizes": [3],
            "resblock_dilation_sizes": [[1]],
        },
    ),
]


@pytest.mark.parametrize("kind, name, params", PARTS, ids=[p[1] for p in PARTS])
def test_round_trip(kind: str, name: str, params: dict[str, Any], tmp_path: Path) -> None:
    torch.manual_seed(0)
    part = registry_for(kind).build(name, params)
    save_part(part, kind, name, part.cfg, tmp_path)
    assert (tmp_path / CONFIG_FILE).is_file() and (tmp_path / WEIGHTS_FILE).is_file()
    record = read_part_config(tmp_path)
    assert (record["kind"], record["name"], record["source"]) == (kind, name, "momu")
    torch.manual_seed(1)  # a different init: equality below must come from the file
    loaded = load_part(tmp_path)
    assert type(loaded) is type(part)
    for (k1, v1), (k2, v2) in zip(part.state_dict().items(), loaded.state_dict().items()):
        assert k1 == k2 and torch.equal(v1, v2)


def test_save_accepts_a_params_mapping_and_validates_it(tmp_path: Path) -> None:
    kind, name, params = PARTS[0]
    part = registry_for(kind).build(name, params)
    save_part(part, kind, name, params, tmp_path)
    assert json.loads((tmp_path / CONFIG_FILE).read_text())["config"]["hidden"] == 16
    with pytest.raises(ValueError, match="unknown key"):
        save_part(part, kind, name, {**params, "hiden": 3}, tmp_path / "bad")


def test_mismatched_weights_are_an_error_naming_the_keys(tmp_path: Path) -> None:
    kind, name, params = PARTS[0]
    save_part(registry_for(kind).build(name, params), kind, name, params, tmp_path)
    record = json.loads((tmp_path / CONFIG_FILE).read_text())
    record["config"]["depth"] = 2
    (tmp_path / CONFIG_FILE).write_text(json.dumps(record))
    with pytest.raises(ValueError, match=r"missing keys \['blocks\.1\.") as exc:
        load_part(tmp_path)
    assert WEIGHTS_FILE in str(exc.value)
    record["config"]["depth"], record["config"]["hidden"] = 1, 32
    (tmp_path / CONFIG_FILE).write_text(json.dumps(record))
    with pytest.raises(ValueError, match="shape mismatches"):
        load_part(tmp_path)


def test_missing_and_malformed_files(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="config.json missing"):
        load_part(tmp_path)
    kind, name, params = PARTS[0]
    save_part(registry_for(kind).build(name, params), kind, name, params, tmp_path)
    (tmp_path / WEIGHTS_FILE).write_bytes(b"garbage")
    with pytest.raises(ValueError, match="cannot read safetensors"):
        load_part(tmp_path)
    (tmp_path / WEIGHTS_FILE).unlink()
    with pytest.raises(FileNotFoundError, match="weights file missing"):
        load_part(tmp_path)
    (tmp_path / CONFIG_FILE).write_text('{"kind": "gadgets", "name": "x", "config": {}}')
    with pytest.raises(ValueError, match="unknown kind 'gadgets'"):
        load_part(tmp_path)


def test_save_rejects_non_modules_and_unknown_kinds(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="module"):
        save_part(object(), "backbones", "dit", None, tmp_path)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="kind"):
        save_part(torch.nn.Linear(1, 1), "widgets", "dit", None, tmp_path)
