"""MoMu App. A.2's two-step GAN update under two-process DDP (gloo, CPU): runs and keeps replicas in sync."""

from __future__ import annotations

import gc
import os
import socket

import pytest
import torch
import torch.distributed as dist
import torch.multiprocessing as mp


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _worker(rank: int, world: int, port: int) -> None:
    from tests.helpers.encoders import tiny_vae_config
    from torch.nn.parallel import DistributedDataParallel as DDP

    from momu.encoders.bicor_vae import MelVAE
    from momu.encoders.discriminator import MelDiscriminator, MelDiscriminatorConfig
    from momu.losses.gan import GANLoss, two_step_update
    from momu.losses.vae import VAELoss

    os.environ["MASTER_ADDR"] = "127.0.0.1"
    os.environ["MASTER_PORT"] = str(port)
    dist.init_process_group("gloo", rank=rank, world_size=world)
    try:
        torch.set_num_threads(1)
        torch.manual_seed(0)  # identical initial replicas
        cfg = tiny_vae_config()
        vae = DDP(MelVAE(16, cfg))
        disc = DDP(MelDiscriminator(MelDiscriminatorConfig(mel_bins=16, channels=4, num_layers=2)))
        opt_v = torch.optim.AdamW(vae.parameters(), lr=1e-3)
        opt_d = torch.optim.AdamW(disc.parameters(), lr=1e-3)
        for step in range(3):
            x = torch.randn(
                2, 16, 8, generator=torch.Generator().manual_seed(100 * rank + step)
            )  # per-rank data
            log = two_step_update(
                vae,
                disc,
                x,
                vae_loss=VAELoss(),
                gan_loss=GANLoss(),
                vae_optimizer=opt_v,
                discriminator_optimizer=opt_d,
                step=step,
            )
            assert log["generator_weight"] > 0 and log["discriminator"] > 0
        for module in (vae, disc):
            for p in module.parameters():
                mean = p.detach().clone()
                dist.all_reduce(mean)
                torch.testing.assert_close(mean / world, p.detach(), atol=1e-6, rtol=0)
        # Free the DDP reducers while the process group is alive: if they are only collected at
        # interpreter exit, the reducer's destructor joins gloo's worker thread while holding the
        # GIL the worker needs, and the process hangs (seen under pytest-xdist).
        del vae, disc, opt_v, opt_d
        gc.collect()
        dist.barrier()
    finally:
        dist.destroy_process_group()


@pytest.mark.skipif(not dist.is_available(), reason="torch.distributed unavailable")
def test_two_step_update_under_two_process_ddp() -> None:
    mp.spawn(_worker, args=(2, _free_port()), nprocs=2, join=True)
