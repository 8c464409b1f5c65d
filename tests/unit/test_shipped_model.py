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
