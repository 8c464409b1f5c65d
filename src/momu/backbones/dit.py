"""``dit``: the Transformer denoiser of MoMu-Diffusion (the paper's "FFT", MoMu §4, Table 9).

MoMu §4: "concatenating the noisy input with the embedded conditional inputs and the embedded
diffusion timesteps along the temporal dimension. This fused input is then padded to match a
specified maximum length and combined with positional embeddings prior to being processed by
the DiT model. The DiT output is subsequently truncated to the original temporal length and
mapped to the output latent space."

Token layout of one item (``L_x`` valid latent frames, ``L_c`` valid condition frames)::

    [ x_0 … x_{L_x-1} | c_0 … c_{L_c-1} | t ]      positions 0 … L_x + L_c

Positions are those of this per-item concatenation, so an item's tokens see the same positional
embeddings whether it is batched with longer items or alone; padded tokens are excluded as
attention keys, so neither the amount nor the content of padding changes the valid output
(tested as a property). A dropped condition (classifier-free guidance, MoMu Eq. 7) is one
learned null token in place of the condition frames, so ``drop_cond=True`` and ``cond=None``
are the same call.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from momu.backbones.blocks import (
    TimestepEmbedder,
    TransformerBlock,
    _init_linear,
    check_backbone_inputs,
    check_prefix_mask,
    condition_tokens,
    scaled_init_std,
    sinusoidal_embedding,
)
from momu.registry import BACKBONES

__all__ = ["DiTConfig", "DiT", "build_dit"]


@dataclass
class DiTConfig:
    """Hyperparameters of the FFT/DiT denoiser; defaults are MoMu Table 9.

    Attributes:
        in_channels: latent channels of the noisy input (Table 9 "Input channels" 20).
        cond_channels: channels of the condition sequence (the other modality's latent, 20);
            0 builds an unconditional model.
        cond_embed_dim: width of the condition embedding MLP (Table 9 "Dimension of
            conditional embedding" 1024).
        hidden: transformer width (Table 9 "Dimension of Hidden representation" 576).
        heads: attention heads (Table 9: 8).
        depth: transformer blocks (Table 9: 4).
        mlp_ratio: feed-forward width / hidden (not in the paper; the usual 4).
        proj_kernel_size: kernel of the Conv1d input/output projections (Table 9: 5). Table 9's
            "padding 3" with kernel 5 yields T+2 frames; cropping them back to T (as §4 does)
            equals "same" padding 2, which is what is used.
        max_length: positional-embedding table size: the longest fused sequence L_x + L_c + 1 with
            ``positions="concat"`` (MoMu's 31.25 Hz latents: 30 s of both modalities is
            2 × 937 + 1 = 1875 tokens, so the paper preset uses 2048; 1024 holds 16.3 s), or the
            longest of L_x and L_c with ``positions="aligned"``.
        pad_to_max: physically pad every batch to ``max_length`` (static shapes, as the paper
            describes). Padded tokens are masked, so this changes cost, never the result.
        time_freq_dim: sinusoidal frequencies fed to the timestep MLP.
        positions: ``concat`` (MoMu §4 read literally): positions of the fused sequence
            ``[x | cond | t]``, so condition frame k sits at position L_x + k; ``aligned``:
            condition frame k shares latent frame k's position (the latents of MoMu's aligned
            space have the same frame rate) and the timestep token sits at 0, which makes the
            frame-to-frame correspondence directly visible to attention. Requires
            ``segment_embeddings``. ``max_length`` then bounds each of L_x and L_c.
        time_to_all_tokens: also add the timestep embedding to every token (not in the paper).
        cond_add: also add the embedded condition frame ⌊p·L_c/L_x⌋ to latent frame p, on top
            of the condition tokens (not in the paper; the frame-aligned shortcut that lets a
            small model use a time-aligned condition from the first steps of training).
        cond_tokens: put the embedded condition frames into the token sequence ``[x | cond | t]``
            (MoMu §4). ``False`` (needs ``cond_add``) conditions by the frame-aligned addition
            alone: the sequence is ``[x | t]``, half as long, and a dropped condition is the null
            token added to every frame (not in the paper; the cpu preset's cost saving,
            docs/presets.md).
        cond_every_block: with ``cond_add``, also add the aligned condition frames to the latent
            tokens before every block, each block through its own zero-initialised linear map
            (not in the paper; FiLM-like per-layer conditioning as in EDGE, so the condition is not
            diluted by depth). Zero-initialised, a fresh model starts as the ``False`` one.
        segment_embeddings: add a learned type embedding (latent / condition / timestep) to
            each token, so the model need not infer the segment from content (not in the paper).
        dropout: dropout in attention and feed-forward layers.
    """

    in_channels: int = 20
    cond_channels: int = 20
    cond_embed_dim: int = 1024
    hidden: int = 576
    heads: int = 8
    depth: int = 4
    mlp_ratio: float = 4.0
    proj_kernel_size: int = 5
    max_length: int = 1024
    pad_to_max: bool = False
    positions: str = "concat"
    time_to_all_tokens: bool = False
    cond_add: bool = False
    cond_tokens: bool = True
    cond_every_block: bool = False
    time_freq_dim: int = 256
    segment_embeddings: bool = True
    dropout: float = 0.0


class DiT(nn.Module):
    """Transformer denoiser following the backbone call protocol (docs/protocols.md).

    ``forward(x (B,T,C), t (B,), cond (B,Tc,Cc) | None, *, x_mask, cond_mask, drop_cond) -> (B,T,C)``;
    output frames where ``x_mask`` is False are zero.
    """

    def __init__(self, cfg: DiTConfig) -> None:
        super().__init__()
        for field in ("in_channels", "hidden", "heads", "depth", "max_length", "time_freq_dim"):
            if getattr(cfg, field) <= 0:
                raise ValueError(f"dit.{field} must be positive, got {getattr(cfg, field)}")
        if cfg.cond_channels < 0:
            raise ValueError(f"dit.cond_channels must be >= 0, got {cfg.cond_channels}")
        if cfg.proj_kernel_size <= 0 or cfg.proj_kernel_size % 2 == 0:
            raise ValueError(
                f"dit.proj_kernel_size must be a positive odd number, got {cfg.proj_kernel_size}"
            )
        if cfg.hidden % cfg.heads:
            raise ValueError(f"dit.hidden={cfg.hidden} is not divisible by dit.heads={cfg.heads}")
        if cfg.positions not in ("concat", "aligned"):
            raise ValueError(f"dit.positions must be 'concat' or 'aligned', got {cfg.positions!r}")
        if cfg.positions == "aligned" and not cfg.segment_embeddings:
            raise ValueError(
                "dit.positions='aligned' needs dit.segment_embeddings=True (tokens share positions)"
            )
        if not cfg.cond_tokens and cfg.cond_channels > 0 and not cfg.cond_add:
            raise ValueError("dit.cond_tokens=false needs dit.cond_add=true (the condition would be unused)")
        if cfg.cond_every_block and not cfg.cond_add:
            raise ValueError("dit.cond_every_block=true needs dit.cond_add=true (it repeats that addition)")
        if cfg.time_freq_dim % 2:
            raise ValueError(f"dit.time_freq_dim must be even, got {cfg.time_freq_dim}")
        self.cfg = cfg
        self.in_channels = cfg.in_channels
        self.cond_channels = cfg.cond_channels
        self.max_length: int | None = cfg.max_length
        h, k = cfg.hidden, cfg.proj_kernel_size
        self.in_proj = nn.Conv1d(cfg.in_channels, h, k, padding=k // 2)
        self.out_norm = nn.LayerNorm(h)
        self.out_proj = nn.Conv1d(h, cfg.in_channels, k, padding=k // 2)
        self.time_embed = TimestepEmbedder(h, cfg.time_freq_dim)
        self.cond_embed: nn.Module | None = None
        self.null_cond: nn.Parameter | None = None
        if cfg.cond_channels > 0:
            self.cond_embed = nn.Sequential(
                nn.Linear(cfg.cond_channels, cfg.cond_embed_dim), nn.GELU(), nn.Linear(cfg.cond_embed_dim, h)
            )
            self.null_cond = nn.Parameter(torch.randn(h) * scaled_init_std(h))
        # learned positions, initialised with the sinusoidal table (DiT's fixed sin-cos embedding)
        self.pos_embed = nn.Parameter(sinusoidal_embedding(torch.arange(cfg.max_length), h))
        self.segment_embed = nn.Embedding(3, h) if cfg.segment_embeddings else None
        self.blocks = nn.ModuleList(
            [TransformerBlock(h, cfg.heads, None, cfg.mlp_ratio, cfg.dropout) for _ in range(cfg.depth)]
        )
        _init_linear(self.blocks)
        self.block_cond: nn.ModuleList | None = None
        if cfg.cond_every_block and cfg.cond_channels > 0:
            maps = [nn.Linear(h, h, bias=False) for _ in range(cfg.depth)]
            for proj in maps:
                nn.init.zeros_(proj.weight)
            self.block_cond = nn.ModuleList(maps)

    # ------------------------------------------------------------------ condition tokens
    def _cond_tokens(
        self, b: int, cond: Tensor | None, cond_mask: Tensor | None, drop_cond: Tensor | None, ref: Tensor
    ) -> tuple[Tensor | None, Tensor | None]:
        """``(tokens (B, Lc, H), mask (B, Lc))``; dropped items get one learned null token."""
        if self.cond_embed is None or self.null_cond is None:
            return None, None
        return condition_tokens(self.cond_embed, self.null_cond, b, cond, cond_mask, drop_cond, ref)

    # ------------------------------------------------------------------ forward
    def forward(
        self,
        x: Tensor,
        t: Tensor,
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        drop_cond: Tensor | None = None,
    ) -> Tensor:
        """Predict the noise ε of ``x`` at timesteps ``t`` (MoMu Eq. 6).

        Args:
            x: ``(B, T, in_channels)`` noisy latent.
            t: ``(B,)`` integer timesteps in ``[0, num_train_timesteps)``.
            cond: ``(B, Tc, cond_channels)`` condition sequence, or ``None`` (null condition).
            x_mask: ``(B, T)`` bool, True = valid frame (valid frames first).
            cond_mask: ``(B, Tc)`` bool, True = valid condition frame (valid frames first).
            drop_cond: ``(B,)`` bool; True replaces that item's condition by the null token.

        Returns:
            ``(B, T, in_channels)``; zero where ``x_mask`` is False.
        """
        check_backbone_inputs(x, t, cond, x_mask, cond_mask, drop_cond, self.in_channels, self.cond_channels)
        b, length, _ = x.shape
        dev = x.device
        x_mask_given = x_mask
        if x_mask is None:
            x_mask = torch.ones(b, length, dtype=torch.bool, device=dev)
        len_x = check_prefix_mask(x_mask, "x_mask")
        if cond_mask is not None:
            check_prefix_mask(cond_mask, "cond_mask")
        keep = x_mask[..., None].to(x.dtype)

        # latent tokens: masked so padded content never reaches a valid frame through the conv
        hx = self.in_proj((x * keep).transpose(1, 2)).transpose(1, 2)  # (B, T, H)
        c_tok, c_mask = self._cond_tokens(b, cond, cond_mask, drop_cond, hx)
        t_tok = self.time_embed(t)[:, None, :].to(hx.dtype)  # (B, 1, H)

        len_c = torch.zeros_like(len_x)
        aligned_cond: Tensor | None = None
        if c_tok is not None and c_mask is not None:
            len_c = c_mask.sum(dim=1)
            if self.cfg.cond_add:  # latent frame p also gets condition frame ⌊p·L_c/L_x⌋ added
                src = (torch.arange(length, device=dev)[None, :] * len_c[:, None]) // len_x[:, None]
                src = src.clamp_max(c_tok.shape[1] - 1)
                aligned_cond = torch.gather(c_tok, 1, src[..., None].expand(-1, -1, c_tok.shape[-1])) * keep
                hx = hx + aligned_cond
        parts, masks = [hx], [x_mask]
        if not self.cfg.cond_tokens:  # the condition entered by addition only
            c_tok, c_mask, len_c = None, None, torch.zeros_like(len_x)
        if c_tok is not None and c_mask is not None:
            parts.append(c_tok)
            masks.append(c_mask)
        parts.append(t_tok)
        masks.append(torch.ones(b, 1, dtype=torch.bool, device=dev))
        tokens = torch.cat(parts, dim=1)  # (B, T + Lc + 1, H)
        mask = torch.cat(masks, dim=1)

        total = len_x + len_c + 1
        aligned = self.cfg.positions == "aligned"
        needed = torch.maximum(len_x, len_c) if aligned else total
        if not torch.compiler.is_compiling() and int(needed.max()) > self.cfg.max_length:
            what = (
                "latent or condition length"
                if aligned
                else "fused length (latent + condition + 1 timestep token)"
            )
            raise ValueError(
                f"x/cond: {what} {int(needed.max())} exceeds dit.max_length={self.cfg.max_length}; "
                "raise max_length or shorten the sequence"
            )
        pos = [torch.arange(length, device=dev).expand(b, -1)]
        if aligned:  # condition frame k sits at the position of latent frame k; t token at 0
            if c_tok is not None:
                pos.append(torch.arange(c_tok.shape[1], device=dev).expand(b, -1))
            pos.append(torch.zeros(b, 1, dtype=torch.long, device=dev))
        else:  # positions of the per-item concatenation [x valid | cond valid | t] (MoMu §4)
            if c_tok is not None:
                pos.append(len_x[:, None] + torch.arange(c_tok.shape[1], device=dev)[None, :])
            pos.append(total[:, None] - 1)
        pos_ids = torch.cat(pos, dim=1).clamp_max(self.cfg.max_length - 1)
        tokens = tokens + self.pos_embed[pos_ids].to(tokens.dtype)
        if self.cfg.time_to_all_tokens:  # additive time conditioning on every token (not in the paper)
            tokens = tokens + t_tok
        if self.segment_embed is not None:
            seg = [torch.zeros(length, dtype=torch.long, device=dev)]
            if c_tok is not None:
                seg.append(torch.ones(c_tok.shape[1], dtype=torch.long, device=dev))
            seg.append(torch.full((1,), 2, dtype=torch.long, device=dev))
            tokens = tokens + self.segment_embed(torch.cat(seg))[None].to(tokens.dtype)

        capacity = 2 * self.cfg.max_length + 1 if aligned else self.cfg.max_length
        padded = self.cfg.pad_to_max and tokens.shape[1] < capacity
        if padded:
            extra = capacity - tokens.shape[1]
            tokens = F.pad(tokens, (0, 0, 0, extra))
            mask = F.pad(mask, (0, extra), value=False)
        # Every token valid (known without reading the mask back from the device): no attention
        # mask at all, so SDPA may use its flash kernel (which takes none); otherwise the boolean
        # key-padding mask, which the memory-efficient and math kernels take (docs/performance.md).
        cond_masked = c_tok is not None and (cond_mask is not None or drop_cond is not None)
        dense = x_mask_given is None and not cond_masked and not padded
        attn_mask = None if dense else mask

        if self.block_cond is not None and aligned_cond is not None:
            # zero rows for the condition/timestep/padding tokens: only latent tokens get it
            aligned_cond = F.pad(aligned_cond, (0, 0, 0, tokens.shape[1] - length))
            for block, proj in zip(self.blocks, self.block_cond, strict=True):
                tokens = block(tokens + proj(aligned_cond), attn_mask)
        else:
            for block in self.blocks:
                tokens = block(tokens, attn_mask)

        # truncate to the latent frames and project back (MoMu §4)
        out = self.out_norm(tokens[:, :length]) * keep
        out = self.out_proj(out.transpose(1, 2)).transpose(1, 2)
        return out * keep


@BACKBONES.register("dit", config=DiTConfig)
def build_dit(cfg: DiTConfig, **deps: object) -> DiT:
    """Build the MoMu FFT/DiT denoiser (MoMu §4, Table 9)."""
    return DiT(cfg)
