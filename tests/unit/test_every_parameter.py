"""``with_every_parameter``: one process and several processes give the same gradients, bit for bit."""

from __future__ import annotations

import pytest
import torch
from torch import nn

import momu.engine.every_parameter as every_parameter
from momu.config import build_component
from momu.engine.every_parameter import with_every_parameter
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.momu.config import backbone_node
from momu.methods.momu.recipes import table7_spec
from momu.methods.momu.stages import DiffusionStage


class TwoParts(nn.Module):
    def __init__(self) -> None:
        super().__init__()
        self.used = nn.Linear(3, 2)
        self.unused = nn.Parameter(torch.ones(4))  # e.g. a null condition no item of the batch dropped to
        self.frozen = nn.Parameter(torch.ones(2), requires_grad=False)


def _zero_term_form(monkeypatch: pytest.MonkeyPatch, several: bool) -> None:
    monkeypatch.setattr(every_parameter, "_several_processes", lambda: several)


def test_unused_parameters_get_zero_gradients_and_used_ones_their_own(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    torch.manual_seed(0)
    module, x = TwoParts(), torch.randn(5, 3)
    grads = {}
    for several in (False, True):  # one process: a callback fills zeros; several: loss + 0 · Σ params
        _zero_term_form(monkeypatch, several)
        module.zero_grad(set_to_none=True)
        loss = with_every_parameter(module, (module.used(x) ** 2).sum())
        assert float(loss.detach()) == float((module.used(x) ** 2).sum().detach())  # the loss itself
        loss.backward()
        grads[several] = {n: p.grad.clone() for n, p in module.named_parameters() if p.requires_grad}
        assert module.frozen.grad is None
    assert torch.equal(grads[False]["unused"], torch.zeros(4))
    for name in grads[True]:
        assert torch.equal(grads[False][name], grads[True][name]), name


def test_a_loss_that_reaches_no_parameter_still_gives_every_parameter_a_gradient() -> None:
    module = TwoParts()
    loss = with_every_parameter(module, torch.tensor(2.0))  # e.g. a step where every term was masked out
    loss.backward()
    assert all(torch.equal(p.grad, torch.zeros_like(p)) for p in module.parameters() if p.requires_grad)


@pytest.mark.parametrize("row", ["#7", "#4"])  # the DiT and the 1D U-Net denoisers
def test_diffusion_stage_trains_bit_for_bit_the_same_on_one_process_as_with_the_zero_term(
    monkeypatch: pytest.MonkeyPatch, row: str
) -> None:
    spec = table7_spec()
    rows = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "smoke", "--rows", row]))
    method = rows[row].method
    d = int(method.encoder.motion.latent_channels)
    loss = build_component(
        method.diffusion_loss, "losses", scheduler=build_component(method.scheduler, "schedulers")
    )
    weights = {}
    for several in (False, True):
        _zero_term_form(monkeypatch, several)
        torch.manual_seed(0)
        stage = DiffusionStage(
            build_component(backbone_node(method.music_backbone, d), "backbones"),
            build_component(backbone_node(method.motion_backbone, d), "backbones"),
            loss,
            d,
            min_frames=4,
        ).train()
        params = [p for p in stage.parameters() if p.requires_grad]
        optimizer = torch.optim.AdamW(params, lr=1e-3, weight_decay=0.01)
        for _ in range(4):
            batch = {"z_music": torch.randn(6, 16, d), "z_motion": torch.randn(6, 16, d)}
            stage(batch)[0].backward()
            assert all(p.grad is not None for p in params)
            torch.nn.utils.clip_grad_norm_(params, 0.5)
            optimizer.step()
            optimizer.zero_grad(set_to_none=True)
        weights[several] = {k: v.clone() for k, v in stage.state_dict().items()}
    assert all(torch.equal(weights[False][k], weights[True][k]) for k in weights[True])
