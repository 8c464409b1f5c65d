"""Cross-method mixing: other methods' pose losses on MoMu's decoded x̂₀, a foreign condition encoder,
and the comparisons of every row with a baseline row (``recipes/mixing.py``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from tests.unit.test_method_momu import TINY_VAE

from momu.config import ConfigError, build_component, load_config
from momu.encoders.mfcc import MfccEncoder, MfccEncoderConfig
from momu.engine.scores import ROW, Scores
from momu.engine.table import Column
from momu.engine.table_report import baseline_lines
from momu.engine.table_results import summarise_seeds, versus_baseline
from momu.losses.decoded import DecodedMotion
from momu.losses.harmony import AudioTargets, HarmonyLoss, pad_targets
from momu.losses.scheduled_kinematic import ScheduledKinematicLoss, skeleton_consistency
from momu.methods.momu import MoMu, backbone_node
from momu.methods.momu.conditions import Conditions
from momu.methods.momu.decoded_losses import DecodedLosses, build_decoded_losses, loss_nodes
from momu.methods.momu.stages import DiffusionStage

TINY_DIT = {"name": "dit", "hidden": 16, "heads": 2, "depth": 1, "cond_embed_dim": 16, "max_length": 64}
JOINTS = 21  # dwm21, 3D


def _stage(nodes: list[dict], weights: list[float]) -> DiffusionStage:
    """A tiny MoMu diffusion stage (fixed weights) with ``nodes`` as its decoded pose losses."""
    torch.manual_seed(0)
    vae = build_component(
        {"name": "bicor_vae", "num_joints": JOINTS, "joint_dims": 3, "motion": TINY_VAE, "music": TINY_VAE},
        "encoders",
    )
    scheduler = build_component("ddpm", "schedulers")
    decoded = None
    if nodes:
        losses = build_decoded_losses(
            [{**n, "skeleton": "dwm21"} if n["name"] != "harmony" else n for n in nodes]
        )
        mean, std = np.zeros((JOINTS, 3)), np.full((JOINTS, 3), 0.3)
        decoded = DecodedLosses(losses, weights, vae.motion_vae, mean, std, "dwm21", 20.0)
    torch.manual_seed(1)
    return DiffusionStage(
        build_component(backbone_node(TINY_DIT, 4), "backbones"),
        build_component(backbone_node(TINY_DIT, 4), "backbones"),
        build_component({"name": "diffusion", "cond_drop_prob": 0.0}, "losses", scheduler=scheduler),
        4,
        decoded=decoded,
    )


def _batch() -> dict[str, torch.Tensor]:
    g = torch.Generator().manual_seed(2)
    times, saliency, mask = pad_targets(
        [
            AudioTargets(np.array([0.3, 0.8, 1.4]), np.array([1.0, 0.6, 0.9])),
            AudioTargets(np.array([0.5]), np.ones(1)),
        ]
    )
    return {
        "z_music": torch.randn(2, 8, 4, generator=g),
        "z_motion": torch.randn(2, 8, 4, generator=g),
        "beat_times": times,
        "beat_saliency": saliency,
        "beat_mask": mask,
    }


def _motion_grads(stage: DiffusionStage) -> torch.Tensor:
    torch.manual_seed(3)  # the same t and ε for every stage
    stage.train()
    loss, _ = stage(_batch())
    loss.backward()
    return torch.cat([p.grad.flatten() for p in stage.motion_backbone.parameters() if p.grad is not None])


@pytest.mark.parametrize(
    "node",
    [{"name": "scheduled_kinematic"}, {"name": "harmony", "normalize": True}],
    ids=["kinematic", "harmony"],
)
def test_a_decoded_pose_loss_changes_the_denoisers_gradient(node: dict) -> None:
    plain = _motion_grads(_stage([], []))
    off = _motion_grads(_stage([node], [0.0]))
    on = _motion_grads(_stage([node], [1.0]))
    assert torch.equal(plain, off)  # weight 0: exactly MoMu Eq. 6
    assert not torch.allclose(plain, on)  # the term reaches θ_m through the frozen decoder
    stage = _stage([node], [1.0])
    stage.train()
    stage(_batch())[0].backward()
    assert all(p.grad is None for p in stage.decoded.decoder.parameters())  # type: ignore[union-attr]
    assert not stage.decoded.decoder.training  # type: ignore[union-attr]


def test_kinematic_decoded_loss_is_its_eq4_terms_on_the_positions() -> None:
    (loss,) = build_decoded_losses([{"name": "scheduled_kinematic", "skeleton": "dwm21"}])
    assert isinstance(loss, ScheduledKinematicLoss)
    g = torch.Generator().manual_seed(0)
    pred = torch.randn(3, 10, JOINTS, 3, generator=g)
    target = torch.randn(3, 10, JOINTS, 3, generator=g)
    t = torch.tensor([0, 500, 999])
    abar = loss.scheduler.alphas_cumprod
    value, logs = loss.decoded_loss(DecodedMotion(pred, target, 20.0, t, abar, "dwm21"))
    ls = skeleton_consistency(pred, loss.skeleton.bones)
    assert torch.allclose(logs["l_s"], ls.mean())
    assert value.shape == (3,) and value[2] < value[0]  # ᾱ_t: noisier items weigh less (Eq. 4)
    with pytest.raises(ValueError, match="joints x dims"):
        loss.decoded_loss(DecodedMotion(pred[..., :2], target[..., :2], 20.0, t, abar, "dwm21"))


def test_harmony_decoded_loss_needs_beats_and_masks_those_past_the_motion() -> None:
    loss = HarmonyLoss()
    g = torch.Generator().manual_seed(0)
    pred = torch.cumsum(torch.randn(1, 40, 5, 3, generator=g), dim=1) * 0.05
    t = torch.zeros(1, dtype=torch.long)
    with pytest.raises(ValueError, match="music beats"):
        loss.decoded_loss(DecodedMotion(pred, pred, 20.0, t, torch.ones(1000), "dwm21"))
    inside = pad_targets([AudioTargets(np.array([0.5, 1.0]), np.array([1.0, 1.0]))])
    extra = pad_targets([AudioTargets(np.array([0.5, 1.0, 1.9]), np.array([1.0, 1.0, 1.0]))])
    half = torch.arange(40)[None] < 30  # valid to 1.5 s: the beat at 1.9 s is not this item's
    a, _ = loss.decoded_loss(DecodedMotion(pred, pred, 20.0, t, torch.ones(1000), "dwm21", half, inside))
    b, _ = loss.decoded_loss(DecodedMotion(pred, pred, 20.0, t, torch.ones(1000), "dwm21", half, extra))
    assert torch.allclose(a, b)


def test_audio_targets_window_cuts_and_shifts() -> None:
    targets = AudioTargets(np.array([0.5, 1.2, 2.0, 3.5]), np.array([0.1, 0.2, 0.3, 0.4]))
    w = targets.window(1.0, 2.0)
    assert np.allclose(w.times, [0.2, 1.0]) and np.allclose(w.saliency, [0.2, 0.3])


def _momu(**method: object) -> dict:
    return {"method": {"name": "momu", **method}}


def test_bad_diffusion_losses_are_one_line_config_errors() -> None:
    with pytest.raises(ConfigError, match=r"method\.diffusion_losses\[0\]") as exc:
        load_config(_momu(), ["method.diffusion_losses=[{name: no_such_loss}]"])
    assert "\n" not in str(exc.value)
    with pytest.raises(ConfigError, match=r"method\.diffusion_losses\[0\].*unknown key"):
        load_config(_momu(), ["method.diffusion_losses=[{name: harmony, wieght: 2}]"])
    cfg = load_config(_momu(), ["method.diffusion_losses=[diffusion]"])
    with pytest.raises(
        ValueError, match=r"method\.diffusion_losses\[0\]: loss 'diffusion' cannot be applied"
    ):
        build_component(cfg.method, "methods")
    cfg = load_config(_momu(), ["method.diffusion_losses=[harmony]", "method.diffusion_loss_weights=[1, 2]"])
    with pytest.raises(ValueError, match="method.diffusion_loss_weights: 2 weight"):
        build_component(cfg.method, "methods")
    cfg = load_config(
        _momu(), ["method.diffusion_losses=[harmony]", "method.motion_representation=root_velocity"]
    )
    with pytest.raises(ValueError, match="needs motion_representation 'positions'"):
        build_component(cfg.method, "methods")


def test_kinematic_loss_on_a_2d_dataset_fails_before_training() -> None:
    cfg = load_config(
        {
            "dataset": {
                "name": "synth_dance",
                "skeleton": "openpose14",
                "num_clips": 9,
                "min_seconds": 2.0,
                "max_seconds": 2.0,
            },
            **_momu(diffusion_losses=[{"name": "scheduled_kinematic"}]),
        }
    )
    method = build_component(cfg.method, "methods")
    with pytest.raises(ValueError, match="2D"):
        method.for_dataset(build_component(cfg.dataset, "datasets"))


def test_diffusion_losses_change_only_the_diffusion_stage_key() -> None:
    base = build_component(load_config(_momu()).method, "methods").stage_keys({"name": "d"}, 0)
    cfg = load_config(
        _momu(), ["method.diffusion_losses=[{name: harmony}]", "method.diffusion_loss_weights=[0.1]"]
    )
    mixed = build_component(cfg.method, "methods").stage_keys({"name": "d"}, 0)
    assert mixed["music_vae"] == base["music_vae"] and mixed["motion_vae"] == base["motion_vae"]
    assert mixed["diffusion"] != base["diffusion"] and mixed["diffusion"]["diffusion_loss_weights"] == [0.1]
    assert "skeleton" not in loss_nodes(cfg.method, "dwm21")[0]  # no skeleton field: untouched
    kin = load_config(_momu(), ["method.diffusion_losses=[scheduled_kinematic]"]).method
    assert loss_nodes(kin, "dwm21")[0]["skeleton"] == "dwm21"  # the data's joints


def test_mfcc_is_a_condition_track_for_another_method() -> None:
    sr = 16000
    t = np.arange(2 * sr) / sr
    audio = (np.sin(2 * np.pi * 220 * t) * (t < 1.0) + 0.1 * np.sin(2 * np.pi * 880 * t)).astype(np.float32)
    enc = MfccEncoder(MfccEncoderConfig())
    track = enc.track(audio, sr)
    frames = track.features(8, 4.0)  # 8 frames of 0.25 s
    assert frames.shape == (8, enc.out_channels)
    a, b = int(round(0.25 * track.rate)), int(round(0.5 * track.rate))
    assert np.allclose(frames[1], track.coeffs[a:b].mean(axis=0), atol=1e-5)  # mean of covered frames
    assert not np.allclose(frames[0], frames[-1])  # the tone stops at 1 s: the features see it
    assert np.allclose(track.features(2, 4.0, start=0.25)[0], frames[1])
    cond = Conditions.of(load_config(_momu(motion_condition={"name": "mfcc"})).method, "dwm21")
    assert cond.cond_width("motion", 16) == 16 + 20 and cond.cond_width("music", 16) == 16
    assert isinstance(build_component(load_config(_momu(motion_condition="mfcc")).method, "methods"), MoMu)


def _scores(row: np.ndarray, ids: list[str]) -> Scores:
    s = Scores(metrics={"x": float(row.mean())})
    s.add_clips("x", ROW, row, ids=ids)
    return s


def test_versus_baseline_pairs_by_clip_and_needs_every_seed() -> None:
    ids = [f"c{i}" for i in range(12)]
    rng = np.random.default_rng(0)
    base = [rng.normal(size=12) for _ in range(3)]
    better = [b + 1.0 + rng.normal(scale=0.1, size=12) for b in base]
    signs = (1.0, -1.0, 1.0)  # one seed reverses it
    mixed = [b + s + rng.normal(scale=0.1, size=12) for b, s in zip(base, signs)]
    rows = [
        {"id": rid, "name": rid, "paper": {}, **summarise_seeds([_scores(v, ids) for v in values])}
        for rid, values in (("base", base), ("good", better), ("mixed", mixed))
    ]
    col = Column("x", "X↑", True)
    out = versus_baseline(rows, [col], "base")
    good, mix = out["columns"]["x"]
    assert out["row"] == "base" and good["row"] == "good" and good["verdict"] == "better"
    assert good["pairing"].startswith("per clip") and good["low"] > 0
    assert mix["verdict"] == "not distinguishable" and "disagree" in mix["reason"]
    lower = versus_baseline(rows, [Column("x", "X↓", False)], "base")["columns"]["x"][0]
    assert lower["verdict"] == "worse"
    text = "\n".join(
        baseline_lines({"rows": rows, "columns": [{"key": "x", "label": "X↑"}], "versus_baseline": out})
    )
    assert "good (good): better than base" in text and "seeds disagree" in text
    with pytest.raises(ValueError, match="no row 'nope'"):
        versus_baseline(rows, [col], "nope")
