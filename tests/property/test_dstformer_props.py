"""Hypothesis: DSTformer / learnable_motion outputs on valid frames ignore padding length and content."""

from __future__ import annotations

import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from momu.encoders.dstformer import DSTformer, DSTformerConfig
from momu.encoders.learnable_motion import LearnableMotionConfig, LearnableMotionEncoder

with torch.random.fork_rng():
    torch.manual_seed(0)
    _NET = DSTformer(
        DSTformerConfig(num_joints=4, dim_in=3, dim_feat=8, dim_rep=4, depth=1, num_heads=2)
    ).eval()
    _ENC = LearnableMotionEncoder(
        LearnableMotionConfig(
            num_joints=4, dim_in=3, dim_feat=8, dim_rep=4, depth=1, num_heads=2, downsample=2
        )
    ).eval()


@settings(deadline=None)
@given(
    valid=st.integers(1, 6),
    pad=st.integers(0, 5),
    fill=st.floats(-1e3, 1e3, allow_nan=False),
    seed=st.integers(0, 2**16),
)
def test_padding_length_and_content_do_not_change_valid_output(
    valid: int, pad: int, fill: float, seed: int
) -> None:
    gen = torch.Generator().manual_seed(seed)
    x = torch.randn(1, valid, 4, 3, generator=gen)
    padded = torch.cat([x, torch.full((1, pad, 4, 3), fill)], dim=1)
    mask = torch.zeros(1, valid + pad, dtype=torch.bool)
    mask[:, :valid] = True
    with torch.no_grad():
        torch.testing.assert_close(_NET(padded, mask)[:, :valid], _NET(x), atol=1e-4, rtol=1e-4)
        # learnable_motion pools pairs of frames: only windows inside the valid part are comparable
        full_windows = valid // 2
        out_pad = _ENC(padded, mask)[:, :full_windows]
        torch.testing.assert_close(out_pad, _ENC(x)[:, :full_windows], atol=1e-4, rtol=1e-4)
