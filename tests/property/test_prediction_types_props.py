"""Hypothesis properties of the schedulers' prediction types (``epsilon``, ``sample``, ``v_prediction``).

A denoiser trained on ``target(x0, noise, t)`` that predicts its target exactly must give back
``x0`` and ``noise`` through ``x0_of`` / ``eps_of``, and diffusers' reverse step must read that output
as the same ẑ₀ whichever type it is: a wrong sign or a swapped ᾱ in the v formulas breaks both.
"""

from __future__ import annotations

import functools

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from momu.config import build_component
from momu.schedulers.diffusers_schedulers import PREDICTION_TYPES, NoiseScheduler

timesteps = st.integers(min_value=0, max_value=999)
seeds = st.integers(min_value=0, max_value=2**31 - 1)


@functools.cache
def scheduler(name: str, prediction_type: str) -> NoiseScheduler:
    return build_component({"name": name, "prediction_type": prediction_type}, "schedulers")


def tensors(seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    gen = torch.Generator().manual_seed(seed)
    x0 = torch.randn(2, 5, 3, generator=gen, dtype=torch.float64) * 2.0
    noise = torch.randn(2, 5, 3, generator=gen, dtype=torch.float64)
    return x0, noise


@pytest.mark.parametrize("name", ["ddpm", "ddim"])
@pytest.mark.parametrize("prediction_type", PREDICTION_TYPES)
@given(t=timesteps, seed=seeds)
def test_x0_of_and_eps_of_invert_the_target(name: str, prediction_type: str, t: int, seed: int) -> None:
    sched = scheduler(name, prediction_type)
    assert sched.prediction_type == prediction_type
    x0, noise = tensors(seed)
    ts = torch.full((2,), t)
    x_t = sched.add_noise(x0, noise, ts)
    output = sched.target(x0, noise, ts)
    torch.testing.assert_close(sched.x0_of(x_t, output, ts), x0, rtol=1e-6, atol=1e-6)
    torch.testing.assert_close(sched.eps_of(x_t, output, ts), noise, rtol=1e-6, atol=1e-6)


@given(t=timesteps, seed=seeds)
def test_targets_are_the_noise_the_sample_and_the_velocity(t: int, seed: int) -> None:
    x0, noise = tensors(seed)
    ts = torch.full((2,), t)
    abar = scheduler("ddpm", "epsilon").alphas_cumprod[t].double()
    assert torch.equal(scheduler("ddpm", "epsilon").target(x0, noise, ts), noise)
    assert torch.equal(scheduler("ddpm", "sample").target(x0, noise, ts), x0)
    v = abar.sqrt() * noise - (1 - abar).sqrt() * x0  # Salimans & Ho 2022
    torch.testing.assert_close(scheduler("ddpm", "v_prediction").target(x0, noise, ts), v)


@pytest.mark.parametrize("prediction_type", ["sample", "v_prediction"])
@given(step=st.integers(min_value=0, max_value=49), seed=seeds)
def test_diffusers_reverse_step_reads_every_target_as_the_same_x0(
    prediction_type: str, step: int, seed: int
) -> None:
    """DDIM (η = 0) from z_t given the exact target of each type lands on the same z_{t-Δ}."""
    x0, noise = tensors(seed)
    eps_run = scheduler("ddim", "epsilon").begin()
    other = scheduler("ddim", prediction_type)
    run = other.begin()
    t = int(run.timesteps[step])
    ts = torch.full((2,), t)
    x_t = other.add_noise(x0, noise, ts)
    expected = eps_run.step(noise, t, x_t)
    torch.testing.assert_close(run.step(other.target(x0, noise, ts), t, x_t), expected, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("name", ["ddpm", "ddim"])
def test_unknown_prediction_type_is_rejected_in_one_line_naming_the_key(name: str) -> None:
    with pytest.raises(ValueError) as err:
        build_component({"name": name, "prediction_type": "velocity"}, "schedulers")
    message = str(err.value)
    assert "\n" not in message and message.startswith(f"{name}.prediction_type 'velocity'")
    assert all(kind in message for kind in PREDICTION_TYPES)
