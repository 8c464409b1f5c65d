"""HarmoGAN's table specs and presets: the paper preset is the paper YAML alone, every spec resolves."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from momu.config import ConfigError, load_config, to_container
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.harmogan.recipes import (
    BASE_CONFIG,
    PAPER_CONFIG,
    fig9_spec,
    fig11_spec,
    fig12_spec,
    table1_spec,
    table2_spec,
)

SPECS = (table1_spec, table2_spec, fig9_spec, fig11_spec, fig12_spec)


def _rows(spec_fn, preset: str, *extra: str) -> dict:  # type: ignore[no-untyped-def]
    spec = spec_fn()
    return resolve_row_configs(spec, parse_table_args(spec, ["--preset", preset, *extra]))


@pytest.mark.parametrize("spec_fn", SPECS)
def test_every_row_resolves(spec_fn) -> None:  # type: ignore[no-untyped-def]
    assert set(_rows(spec_fn, "smoke")) == {r.id for r in spec_fn().rows}


@pytest.mark.parametrize("preset", ["cpu", "paper"])
def test_every_preset_resolves(preset: str) -> None:
    configs = _rows(table1_spec, preset, "--rows", "harmogan,cal-static")
    assert configs["cal-static"].calibration_row == "static"


def test_the_paper_preset_is_the_paper_yaml_alone() -> None:
    paper = to_container(load_config(PAPER_CONFIG))
    row = to_container(_rows(table1_spec, "paper")["harmogan"])
    assert row == paper  # nothing of the cpu YAML survives
    without = to_container(_rows(table1_spec, "paper")["wo-harmo"])
    assert without["method"]["weights"]["harmo"] == 0.0
    assert {**without["method"]["weights"], "harmo": 1.0} == paper["method"]["weights"]


def test_the_paper_yaml_pins_the_papers_numbers() -> None:
    raw = OmegaConf.to_container(OmegaConf.load(PAPER_CONFIG))
    m = raw["method"]  # type: ignore[index]
    assert m["fps"] == 15.0 and raw["dance"]["real_dataset"]["joints"] == 21  # type: ignore[index]
    assert m["pretrain"] == {
        "epochs": 225, "batch_size": 10, "lr": 1e-3, "decay_every": 50, "decay_factors": [0.5, 0.2, 0.2, 0.5],
        "cycle_factors": False, "max_grad_norm": 0.0,
    }  # fmt: skip
    adv = m["adversarial"]
    assert (adv["epochs"], adv["batch_size"], adv["lr"], adv["decay_every"], adv["decay_factors"]) == (
        45, 10, 1e-4, 5, [0.5, 0.2],
    )  # fmt: skip
    assert adv["cycle_factors"] and (adv["generator_weight_decay"], adv["discriminator_weight_decay"]) == (
        1e-4,
        1e-3,
    )
    assert m["weights"] == {"kl": 1e-4, "mse": 1e-3, "feat": 1e-3, "harmo": 1.0, "gan": 1e-3}
    assert (m["pretrain_weights"]["kl"], m["pretrain_weights"]["mse"]) == (0.1, 1.0)
    h = m["harmony_loss"]
    assert (h["lambda1"], h["lambda2"], h["t_delay"], h["beta"]) == (0.1, 1.0, 0.25, 2.0)
    assert raw["ballroom"]["fraction"] == 0.1 and m["evaluation"]["clip_seconds"] == 6.0  # type: ignore[index]


def test_bad_overrides_fail_before_training() -> None:
    with pytest.raises(ConfigError, match="method"):
        _rows(table1_spec, "cpu", "method.weights.harmony=1")
    cfg = load_config(BASE_CONFIG)
    assert cfg.dance.root is None and cfg.method.name == "harmogan"
