"""The model shipped in ``momu/pretrained`` is the one ``recipes/pretrain.py`` describes."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

import momu

ROOT = Path(__file__).resolve().parents[2]
PRETRAINED = Path(momu.__file__).parent / "pretrained"


def _recipe() -> object:
    spec = importlib.util.spec_from_file_location("pretrain_recipe", ROOT / "recipes" / "pretrain.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not (PRETRAINED / "index.json").exists(), reason="no shipped model in this installation")
def test_the_shipped_model_samples_as_the_recipe_says() -> None:
    """``momu generate`` samples the shipped model with the recipe's :data:`SHIPPED_SAMPLERS` (a sampler
    chosen in a study is installed through the recipe, not by editing the model folder alone)."""
    recipe = _recipe()
    index = json.loads((PRETRAINED / "index.json").read_text())
    assert index == {"dance": recipe.NAME, "music": recipe.NAME}  # type: ignore[attr-defined]
    config = json.loads((PRETRAINED / recipe.NAME / "momu.json").read_text())["config"]  # type: ignore[attr-defined]
    for key, node in recipe.SHIPPED_SAMPLERS.items():  # type: ignore[attr-defined]
        assert config[key] == node, key


def test_training_on_dance_with_melody_keeps_the_validation_songs_out(tmp_path: Path) -> None:
    """``pretrain.py --data DIR`` trains on the project's agreed split (0.6/0.2/0.2), the one its
    held-out evaluation scores on; the loader's default (0.9 train) would train on the validation songs."""
    from momu.data.common import hash_split
    from momu.following.pairs import DWM_SPLIT
    from momu.training import train_config

    recipe = _recipe()
    (tmp_path / "DANCE_W_1").mkdir()
    overrides = recipe.data_overrides(str(tmp_path))  # type: ignore[attr-defined]
    cfg = train_config("momu", data=str(tmp_path), overrides=[*overrides, *recipe.METHOD_OVERRIDES])  # type: ignore[attr-defined]
    assert list(cfg.dataset.split_ratios) == DWM_SPLIT["split_ratios"]
    assert cfg.dataset.split_seed == DWM_SPLIT["split_seed"]
    names = [f"DANCE_W_{i}" for i in range(200)]
    held_out = [n for n in names if hash_split(n, DWM_SPLIT["split_ratios"], 0) == "val"]
    assert held_out and all(hash_split(n, list(cfg.dataset.split_ratios), 0) != "train" for n in held_out)
    assert recipe.data_overrides("synth") == recipe.SYNTH_OVERRIDES  # type: ignore[attr-defined]


def test_a_missing_data_folder_is_one_line_and_status_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    recipe = _recipe()
    work = tmp_path / "work"
    status = recipe.run(["--data", str(tmp_path / "missing"), "--work", str(work)])  # type: ignore[attr-defined]
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "missing" in err[0] and "not found" in err[0]
    assert not work.exists()
