"""Issue 13, configs: every key known to a schema, the innermost node named, overrides blamed, no env."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from momu.cli import main
from momu.config import ConfigError, load_config
from momu.config.schema import RecipeConfig
from momu.engine.table import Row, TableSpec, run_table
from momu.registry import METHODS

CONFIGS = Path(__file__).resolve().parents[2] / "recipes" / "configs"


def _recipe(overrides: list[str], path: Path = CONFIGS / "momu.yaml") -> object:
    return load_config(path, overrides, schema=RecipeConfig, fill_defaults=False)


@pytest.mark.parametrize(
    ("override", "key"), [("zz=1", "zz"), ("evaluation.zz=1", "evaluation"), ("sed=3", "sed")]
)
def test_an_unknown_top_level_key_names_itself_and_the_valid_keys(override: str, key: str) -> None:
    with pytest.raises(ConfigError) as err:
        _recipe([override])
    assert str(err.value).startswith(
        f"{key}: unknown key; valid keys: seed, mixed_precision, dataset, method"
    )


def test_every_shipped_config_key_is_known_to_the_schema() -> None:
    from momu.methods.momu.tables_setup import table_base_config

    for source in (CONFIGS / "momu.yaml", CONFIGS / "example.yaml", table_base_config()):
        cfg = load_config(source, schema=RecipeConfig, fill_defaults=False)  # type: ignore[arg-type]
        assert cfg.keys()
    assert {f.name for f in dataclasses.fields(RecipeConfig)} >= {
        "seed",
        "mixed_precision",
        "dataset",
        "method",
        "real_data",
        "subsets",
        "learnable_encoder",
        "learnable_train",
        "learnable_frames_per_latent",
    }


def test_a_schema_check_adds_no_keys() -> None:
    cfg = _recipe([])
    assert set(cfg) == set(OmegaConf.load(CONFIGS / "momu.yaml"))


def test_a_nested_typo_names_the_innermost_node_and_its_keys() -> None:
    with pytest.raises(ConfigError) as err:
        _recipe(["method.train_diffusion.stpes=10"])
    message = str(err.value)
    assert message.startswith(
        "method.train_diffusion.stpes: unknown key for method.train_diffusion (TrainConfig)"
    )
    assert "valid keys: steps, batch_size, lr" in message and "music_backbone" not in message
    with pytest.raises(ConfigError, match=r"subsets.aist.zz: unknown key for subsets.aist \(SubsetConfig\)"):
        from momu.methods.momu.tables_setup import table_base_config

        load_config(table_base_config(), ["subsets.aist.zz=1"], schema=RecipeConfig)


@dataclass
class _NarrowConfig:
    width: int = 4


@dataclass
class _OtherConfig:
    depth: int = 1


@pytest.fixture
def toy_methods():
    METHODS.register("h13_narrow", config=_NarrowConfig)(lambda cfg: cfg)
    METHODS.register("h13_other", config=_OtherConfig)(lambda cfg: cfg)
    yield
    METHODS.unregister("h13_narrow")
    METHODS.unregister("h13_other")


def _spec() -> TableSpec:
    return TableSpec(
        name="h13_table",
        title="t",
        base_config={"method": {"name": "h13_narrow"}, "seed": 0},
        presets={"smoke": [], "cpu": [], "paper": []},
        columns=[],
        rows=[Row("#1", "narrow"), Row("#2", "other", ("method=h13_other",))],
        evaluate=lambda ctx, cfg, seed: {},
    )


def test_a_global_override_is_blamed_as_an_override_not_row_1(
    toy_methods: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_table(_spec(), ["--out", str(tmp_path), "--tracker", "none", "method.widht=3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("h13_table: error: override 'method.widht=3': method.widht: unknown key")
    assert "row #1" not in err


def test_an_override_that_fails_only_with_one_row_names_both(
    toy_methods: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_table(_spec(), ["--out", str(tmp_path), "--tracker", "none", "method.width=3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("h13_table: error: row #2 (other) with override 'method.width=3': method.width")


def test_env_interpolation_is_refused_and_never_printed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("H13_TOKEN", "s3cr3t-token-value")
    yaml = tmp_path / "c.yaml"
    yaml.write_text(
        "seed: 0\nmethod: {name: momu, vocoder: {name: griffin_lim, weights: '${oc.env:H13_TOKEN}'}}\n"
    )
    for argv in (
        ["config", "show", str(yaml)],
        ["config", "show", str(CONFIGS / "momu.yaml"), "seed=${oc.env:H13_TOKEN}"],
        [
            "config",
            "show",
            str(CONFIGS / "momu.yaml"),
            "method.sampler.scheduler.name=${oc.env:H13_TOKEN,ddpm}",
        ],
    ):
        assert main(argv) == 2
        out, err = capsys.readouterr()
        assert "oc.env" in err and "disabled" in err and "s3cr3t" not in out + err
    with pytest.raises(ConfigError, match="interpolation is disabled"):
        load_config({"a": "x-${oc.env:H13_TOKEN}"})


def test_a_run_never_writes_an_environment_value(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, toy_methods: None
) -> None:
    monkeypatch.setenv("H13_TOKEN", "s3cr3t-token-value")
    spec = dataclasses.replace(_spec(), rows=[Row("#1", "narrow")])
    assert run_table(spec, ["--out", str(tmp_path), "--tracker", "none", "seed=${oc.env:H13_TOKEN}"]) == 2
    assert not (tmp_path / "h13_table").exists()
    assert run_table(spec, ["--out", str(tmp_path), "--tracker", "none", "seed=5"]) == 0
    text = (tmp_path / "h13_table" / "results.json").read_text()
    assert "s3cr3t" not in text and json.loads(text)["provenance"]["threads"] >= 1
