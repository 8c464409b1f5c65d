"""The differentiable harmony loss (HarmoGAN Eq. 16): its hard limit is the numpy metric, exactly."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st
from tests.helpers.shared_data import shared_data_dir

from momu.losses.harmony import HarmonyLoss, HarmonyLossConfig, audio_targets, harmony_terms, pad_targets
from momu.metrics.harmony import harmony, harmony_from_beats, motion_beats_harmogan
from momu.registry import DATASETS, LOSSES

HARD = HarmonyLossConfig(beat_temperature=0.0, mask_temperature=0.0)
SR = 16000


def _terms(
    motion: np.ndarray, fps: float, times: list[float], sal: list[float], cfg: HarmonyLossConfig = HARD
):
    t = torch.tensor([times], dtype=torch.float64)
    s = torch.tensor([sal], dtype=torch.float64)
    m = torch.ones_like(t, dtype=torch.bool)
    out = harmony_terms(torch.tensor(motion[None], dtype=torch.float64), fps, t, s, m, cfg)
    return {k: float(v[0]) for k, v in out.items()}


def _metric(motion: np.ndarray, fps: float, times: list[float], sal: list[float]):
    tv, sv, j0 = motion_beats_harmogan(motion, fps)
    return harmony_from_beats(times, sal, tv, sv, j0, normalize_saliency=False)


def _check_equal(motion: np.ndarray, fps: float, times: list[float], sal: list[float]) -> None:
    got = _terms(motion, fps, times, sal)
    ref = _metric(motion, fps, times, sal)
    assert got["h_s"] == pytest.approx(ref.h_s, abs=1e-9)
    assert got["n_visual"] == ref.n_visual and got["n_audio"] == ref.n_audio and got["hits"] == ref.hits
    assert got["h"] == pytest.approx(ref.h, abs=1e-9)


def test_hard_limit_by_hand() -> None:
    # one joint moving 1, 3, 1, 0.5, 2, 2, 1 units per frame: j = 10, 30, 10, 5, 20, 20, 10 at 10 fps has a
    # maximum at j[1] (frame 2), a minimum at j[3] (frame 4) and a plateau at j[4..5] that Eq. 3 ignores.
    steps = np.array([1.0, 3.0, 1.0, 0.5, 2.0, 2.0, 1.0])
    x = np.concatenate([[0.0], np.cumsum(steps)])
    motion = np.zeros((len(x), 1, 3))
    motion[:, 0, 0] = x
    fps = 10.0
    tv, sv, j0 = motion_beats_harmogan(motion, fps)
    assert np.allclose(tv, [0.2, 0.4]) and np.allclose(sv, [30.0, 5.0])  # frames 2 and 4 (j = 30, 5)
    # S* = |30 - 10|, |5 - 30| = 20, 25: std 2.5, λ2 = 1 -> both salient; beats at 0.2 s and 0.4 s
    got = _terms(motion, fps, [0.1, 0.5, 0.8], [1.0, 0.5, 0.25])
    assert got["n_visual"] == 2 and got["hits"] == 2  # 0.8 s is 0.4 s from the nearest visual beat
    assert got["h_s"] == pytest.approx(1.5)
    _check_equal(motion, fps, [0.1, 0.5, 0.8], [1.0, 0.5, 0.25])
    # T_delay is strict, as in the metric: an audio beat exactly 0.25 s away is a miss
    _check_equal(motion, fps, [0.65], [1.0])
    assert _terms(motion, fps, [0.65], [1.0])["hits"] == 0


def test_static_motion_has_no_visual_beat() -> None:
    still = np.zeros((30, 3, 3))
    got = _terms(still, 15.0, [0.5, 1.0], [1.0, 1.0])
    assert got["n_visual"] == 0 and got["h"] == 0.0
    _check_equal(still, 15.0, [0.5, 1.0], [1.0, 1.0])


@given(
    st.integers(0, 10_000),
    st.integers(5, 60),
    st.lists(st.floats(0.0, 3.0), min_size=1, max_size=8),
)
def test_hard_limit_equals_metric_on_random_motion(seed: int, frames: int, times: list[float]) -> None:
    rng = np.random.default_rng(seed)
    motion = np.cumsum(rng.normal(size=(frames, 4, 3)), axis=0)
    sal = list(rng.uniform(0.1, 1.0, len(times)))
    _check_equal(motion, 15.0, times, sal)


def _real_window() -> tuple[np.ndarray, np.ndarray, int] | None:
    root = shared_data_dir() / "dance_with_melody"
    if not root.is_dir():
        return None
    ds = DATASETS.build("dance_with_melody", {"root": str(root), "target_fps": 15.0, "window_seconds": 20.0})
    clip = ds[3]
    return clip.motion, clip.audio, clip.sample_rate


def test_hard_limit_equals_metric_on_real_and_synthetic_pairs() -> None:
    synth = DATASETS.build(
        "synth_dance",
        {"num_clips": 2, "skeleton": "dwm21", "fps": 15.0, "min_seconds": 6.0, "max_seconds": 6.0},
    )
    pairs = [(c.motion, c.audio, c.sample_rate) for c in synth]
    real = _real_window()
    if real is not None:
        motion, audio, sr = real
        pairs += [(motion[k * 90 : (k + 1) * 90], audio[k * 6 * sr : (k + 1) * 6 * sr], sr) for k in range(3)]
    for motion, audio, sr in pairs:
        ref = harmony(audio, sr, motion, 15.0)
        target = audio_targets(audio, sr)
        t, s, m = pad_targets([target], dtype=torch.float64)
        got = harmony_terms(torch.tensor(motion[None], dtype=torch.float64), 15.0, t, s, m, HARD)
        assert float(got["h_s"][0]) == pytest.approx(ref.h_s, abs=1e-9)
        assert (float(got["n_visual"][0]), float(got["n_audio"][0]), float(got["hits"][0])) == (
            ref.n_visual,
            ref.n_audio,
            ref.hits,
        )
        assert float(got["h"][0]) == pytest.approx(ref.h, abs=1e-9)
        # the soft surrogate approaches the hard one as the temperatures go to 0
        errors = []
        for tau in (0.1, 0.01, 0.001):
            soft = harmony_terms(
                torch.tensor(motion[None], dtype=torch.float64),
                15.0,
                t,
                s,
                m,
                HarmonyLossConfig(beat_temperature=tau, mask_temperature=tau),
            )
            errors.append(abs(float(soft["h"][0]) - ref.h))
        assert errors[-1] < 0.02 and errors[-1] <= errors[0] + 1e-9


def test_loss_forms_gradients_and_registry() -> None:
    rng = np.random.default_rng(0)
    motion = torch.tensor(np.cumsum(rng.normal(size=(2, 30, 5, 3)), axis=1) * 0.05, requires_grad=True)
    times = torch.tensor([[0.3, 0.9, 1.5], [0.2, 0.0, 0.0]])
    sal = torch.tensor([[1.0, 0.5, 0.8], [1.0, 0.0, 0.0]])
    mask = torch.tensor([[True, True, True], [True, False, False]])
    loss = LOSSES.build("harmony")
    assert isinstance(loss, HarmonyLoss) and loss.cfg.form == "paper"
    value = loss(motion.float(), 15.0, times, sal, mask)
    value.backward()
    assert motion.grad is not None and torch.isfinite(motion.grad).all() and motion.grad.abs().sum() > 0
    terms = harmony_terms(motion.detach().float(), 15.0, times, sal, mask, loss.cfg)
    paper = (-terms["h_s"] + (terms["n_visual"] - terms["n_audio"]).abs()).mean()
    assert float(value.detach()) == pytest.approx(float(paper), rel=1e-5)
    h_form = LOSSES.build("harmony", {"form": "h"})(motion.detach().float(), 15.0, times, sal, mask)
    assert float(h_form) == pytest.approx(-float(terms["h"].mean()), rel=1e-5)
    normalized = LOSSES.build("harmony", {"normalize": True})(motion.detach().float(), 15.0, times, sal, mask)
    per_item = (-terms["h_s"] + (terms["n_visual"] - terms["n_audio"]).abs()) / terms["n_audio"]
    assert float(normalized) == pytest.approx(float(per_item.mean()), rel=1e-5)
    with pytest.raises(ValueError, match="form"):
        HarmonyLossConfig(form="other")
    with pytest.raises(ValueError, match="motion must be"):
        harmony_terms(motion.detach()[0], 15.0, times, sal, mask)
