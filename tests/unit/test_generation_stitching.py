"""Long sequences by latent inpainting (momu.generation): window plans (two-pass and sequential
schedules), batching, the seam statistic."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st
from tests.helpers.tiny_models import tiny_3d_model

from momu.generation import plan_windows, seam_jumps, stitched_sample, velocity_jumps
from momu.generation.momu_long import music_to_motion_long, window_frames
from momu.generation.windows import window_seed


@given(length=st.integers(1, 2000), window=st.integers(2, 200), data=st.data())
def test_windows_cover_the_sequence_and_overlap_by_the_overlap(length: int, window: int, data) -> None:
    overlap = data.draw(st.integers(1, window - 1))
    plan = plan_windows(length, window, overlap, "sequential")
    assert plan.starts[0] == 0 and plan.ends[-1] == length
    for k in range(1, len(plan.starts)):
        assert plan.starts[k] == plan.ends[k - 1] - overlap  # each window takes O frames from the last
        assert plan.ends[k] > plan.ends[k - 1]  # and adds at least one new frame
    assert all(e - s <= window for s, e in zip(plan.starts, plan.ends))
    assert plan.boundaries == tuple(s + overlap for s in plan.starts[1:])


@given(length=st.integers(1, 3000), window=st.integers(3, 200), data=st.data())
def test_two_pass_bridges_lie_between_their_anchors(length: int, window: int, data) -> None:
    """Anchors (even windows) and bridges (odd windows) cover the sequence; a bridge's first and last
    O frames lie inside the anchors before and after it and no bridge reaches into another bridge's new
    frames, so every bridge knows frames that its neighbours generated and that the output keeps."""
    overlap = data.draw(st.integers(1, (window - 1) // 2))
    plan = plan_windows(length, window, overlap, "two_pass")
    n = len(plan.starts)
    assert n % 2 == 1 and plan.starts[0] == 0 and plan.ends[-1] == length
    assert all(e - s == min(window, length) and 0 <= s < e <= length for s, e in zip(plan.starts, plan.ends))
    assert plan.passes() == ((tuple(range(0, n, 2)), tuple(range(1, n, 2))) if n > 1 else ((0,),))
    covered = np.zeros(length, dtype=bool)
    for k in range(0, n, 2):
        covered[plan.starts[k] : plan.ends[k]] = True
        assert plan.known(k) == (0, 0)
    for k in range(1, n, 2):
        s, e = plan.starts[k], plan.ends[k]
        assert plan.known(k) == (overlap, overlap)
        assert s + overlap < e - overlap  # at least one new frame
        assert plan.starts[k - 1] <= s and s + overlap <= plan.ends[k - 1]  # known head: the anchor before
        assert plan.starts[k + 1] <= e - overlap and e <= plan.ends[k + 1]  # known tail: the anchor after
        if k + 2 < n:  # this bridge ends before the next bridge's new frames begin
            assert e <= plan.starts[k + 2] + overlap
        covered[s:e] = True
    assert covered.all()
    # as many windows as one after another (at most one more)
    assert n <= len(plan_windows(length, window, overlap, "sequential").starts) + 1
    assert plan.boundaries == tuple(
        b for k in range(1, n, 2) for b in (plan.starts[k] + overlap, plan.ends[k] - overlap)
    )


def test_two_pass_needs_a_window_longer_than_both_overlaps() -> None:
    with pytest.raises(ValueError, match="window > 2"):
        plan_windows(100, 10, 5, "two_pass")
    with pytest.raises(ValueError, match="schedule"):
        plan_windows(100, 10, 2, "parallel")


def test_window_seeds_start_with_the_item_seed_and_differ_per_window() -> None:
    assert window_seed(7, 0) == 7
    seeds = {window_seed(s, k) for s in range(5) for k in range(1, 50)}
    assert len(seeds) == 5 * 49 and all(0 <= x < 2**63 for x in seeds)


def test_velocity_jumps_are_zero_on_constant_velocity_and_see_a_step() -> None:
    t = np.arange(50, dtype=np.float64)
    motion = np.stack([t, 2 * t, -t], axis=-1)[:, None, :].repeat(3, axis=1)  # (T, 3 joints, 3)
    assert np.allclose(velocity_jumps(motion, fps=10.0), 0.0)
    motion[25:] += 1.0  # a jump of 1 unit at frame 25
    jumps = seam_jumps(motion, [25], fps=10.0)
    assert jumps[0] == pytest.approx(100.0 * np.sqrt(3.0))  # |Δ²x| · fps² = √3 · 100
    assert seam_jumps(motion, [10], fps=10.0)[0] == pytest.approx(0.0)


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory):
    from momu.methods.momu import MoMuModel

    return MoMuModel.load(tiny_3d_model(tmp_path_factory.mktemp("tiny")))


def _song(seconds: float, sr: int = 16000, bpm: float = 120.0) -> np.ndarray:
    t = np.arange(int(seconds * sr)) / sr
    return (0.5 * np.exp(-((t % (60 / bpm)) / 0.01)) * np.sin(2 * np.pi * 800 * t)).astype(np.float32)


def test_a_song_within_one_window_is_plain_cfg_sampling(model) -> None:
    window, _ = window_frames(model, "motion")
    seconds = (window - 1) / model.rates.latent_rate
    song = _song(seconds)
    (long,) = music_to_motion_long(model, [song], 16000, [3])
    (plain,) = model.music_to_motion([song], 16000, [3])
    assert np.array_equal(long, plain)


def test_an_item_does_not_depend_on_its_batch(model) -> None:
    songs = [_song(7.0), _song(4.5, bpm=90.0)]
    together = music_to_motion_long(model, songs, 16000, [0, 1])
    alone = music_to_motion_long(model, [songs[1]], 16000, [1])
    # padded batches change only the summation order: under 1 cm after every window of DDIM sampling
    assert np.abs(together[1] - alone[0]).max() < 1e-2
    assert together[0].shape[0] == model.rates.latent_frames(7.0) * model.rates.motion_frames_per_latent


def test_each_window_continues_the_previous_one_exactly(model, monkeypatch: pytest.MonkeyPatch) -> None:
    """Window k's first O latent frames are the last O that window k − 1 generated, kept exactly."""
    from momu.samplers.inpainting import InpaintingSampler

    calls: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = []
    original = InpaintingSampler.sample

    def spy(self, backbone, known, known_mask=None, cond=None, **kwargs):
        out = original(self, backbone, known, known_mask, cond, **kwargs)
        calls.append((known.clone(), known_mask.clone(), out.clone()))
        return out

    monkeypatch.setattr(InpaintingSampler, "sample", spy)
    window, overlap = window_frames(model, "motion")
    cond = model.encode_music(_song(9.0), 16000)
    (z,) = stitched_sample(
        model.sampler_for("motion"), model.motion_backbone, [cond], [0], model.latent_channels,
        window=window, overlap=overlap, schedule="sequential",
    )  # fmt: skip
    plan = plan_windows(cond.shape[0], window, overlap, "sequential")
    assert len(calls) == len(plan.starts) - 1 >= 2
    for k, (known, mask, out) in enumerate(calls, start=1):
        assert int(mask.sum()) == overlap and bool(mask[0, :overlap].all())
        assert torch.equal(out[0, :overlap], known[0, :overlap])  # kept exactly
        s, e = plan.starts[k], plan.ends[k]
        assert torch.equal(z[s:e], out[0, : e - s])
    # the known frames were the previous window's output
    prev_end = plan.ends[0]
    assert torch.equal(calls[0][0][0, :overlap], z[prev_end - overlap : prev_end])


def test_two_pass_bridges_join_the_anchors_they_were_inpainted_on(
    model, monkeypatch: pytest.MonkeyPatch
) -> None:
    """All bridges are one inpainting batch; each knows the last O frames of the anchor before it and the
    first O of the anchor after it (soft weights, 1 at its outer edges); the stitched latent is the anchors'
    frames outside the bridges and the bridges' own output inside them."""
    from momu.samplers.cfg import CFGSampler
    from momu.samplers.inpainting import InpaintingSampler

    anchors: list[torch.Tensor] = []
    bridges: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = []
    cfg_sample, inpaint_sample = CFGSampler.sample, InpaintingSampler.sample

    def spy_cfg(self, backbone, noise, cond=None, **kwargs):
        out = cfg_sample(self, backbone, noise, cond, **kwargs)
        anchors.append(out.clone())
        return out

    def spy_inpaint(self, backbone, known, known_mask=None, cond=None, **kwargs):
        out = inpaint_sample(self, backbone, known, known_mask, cond, **kwargs)
        bridges.append((known.clone(), known_mask.clone(), out.clone()))
        return out

    monkeypatch.setattr(CFGSampler, "sample", spy_cfg)
    monkeypatch.setattr(InpaintingSampler, "sample", spy_inpaint)
    window, overlap = window_frames(model, "motion")
    cond = model.encode_music(_song(12.0), 16000)
    (z,) = stitched_sample(
        model.sampler_for("motion"), model.motion_backbone, [cond], [0], model.latent_channels,
        window=window, overlap=overlap,
    )  # fmt: skip
    plan = plan_windows(cond.shape[0], window, overlap, "two_pass")
    assert len(anchors) == 1 and len(bridges) == 1  # two batched passes
    n = len(plan.starts)
    assert anchors[0].shape[0] == (n + 1) // 2 and bridges[0][0].shape[0] == n // 2 >= 3
    known, weights, out = bridges[0]
    O = overlap  # noqa: N806
    for j, k in enumerate(range(1, n, 2)):
        s, e = plan.starts[k], plan.ends[k]
        before, after = anchors[0][j], anchors[0][j + 1]
        assert torch.equal(known[j, :O], before[s - plan.starts[k - 1] :][:O])
        assert torch.equal(known[j, -O:], after[e - O - plan.starts[k + 1] :][:O])
        assert weights[j, 0] == 1 and weights[j, -1] == 1 and bool((weights[j, O:-O] == 0).all())
        assert bool((weights[j, 1:O] < 1).all() & (weights[j, 1:O] > 0).all())
        assert torch.equal(out[j, 0], known[j, 0]) and torch.equal(out[j, -1], known[j, -1])  # outer edges
        assert torch.equal(z[s:e], out[j])
    for j, k in enumerate(range(0, n, 2)):  # outside the bridges: the anchor's own frames
        lo = plan.ends[k - 1] if k else 0
        hi = plan.starts[k + 1] if k + 1 < n else plan.length
        assert torch.equal(z[lo:hi], anchors[0][j][lo - plan.starts[k] : hi - plan.starts[k]])


def test_two_pass_with_hard_edges_keeps_every_known_frame(model, monkeypatch: pytest.MonkeyPatch) -> None:
    from momu.samplers.inpainting import InpaintingSampler

    calls: list[tuple[torch.Tensor, torch.Tensor, torch.Tensor]] = []
    original = InpaintingSampler.sample

    def spy(self, backbone, known, known_mask=None, cond=None, **kwargs):
        out = original(self, backbone, known, known_mask, cond, **kwargs)
        calls.append((known.clone(), known_mask.clone(), out.clone()))
        return out

    monkeypatch.setattr(InpaintingSampler, "sample", spy)
    window, overlap = window_frames(model, "motion")
    cond = model.encode_music(_song(9.0), 16000)
    stitched_sample(
        model.sampler_for("motion"), model.motion_backbone, [cond], [0], model.latent_channels,
        window=window, overlap=overlap, soft_edges=False,
    )  # fmt: skip
    ((known, mask, out),) = calls
    assert mask.dtype == torch.bool and int(mask[0].sum()) == 2 * overlap
    assert torch.equal(out[mask], known[mask])


def test_two_pass_starts_like_one_window_after_another_and_ignores_batching(model) -> None:
    """Same seed, same first window as the sequential schedule (the noise of window 0 is the item
    seed's); splitting the windows into smaller batches changes only the summation order."""
    window, overlap = window_frames(model, "motion")
    cond = model.encode_music(_song(12.0), 16000)
    args = (model.sampler_for("motion"), model.motion_backbone, [cond], [5], model.latent_channels)
    (seq,) = stitched_sample(*args, window=window, overlap=overlap, schedule="sequential")
    (two,) = stitched_sample(*args, window=window, overlap=overlap)
    (small,) = stitched_sample(*args, window=window, overlap=overlap, max_batch_frames=window)
    first = plan_windows(cond.shape[0], window, overlap, "two_pass").starts[1]  # where bridge 1 starts
    assert torch.allclose(two[:first], seq[:first], atol=1e-5)
    assert not torch.allclose(two[window:], seq[window:], atol=1e-2)  # the rest is a different draw
    assert torch.allclose(small, two, atol=1e-5)


def test_motion_to_music_of_any_length_uses_the_two_pass_windows(model) -> None:
    from momu.generation.momu_long import motion_to_music_long, plan_for_seconds

    fps = 25.0
    motion = np.random.default_rng(0).normal(size=(int(9 * fps), 21, 3)).astype(np.float32) * 0.1
    counted: list[int] = []
    (audio,) = motion_to_music_long(model, [motion], fps, [0], progress=counted.append)
    plan = plan_for_seconds(model, 9.0, "music")
    assert plan.schedule == "two_pass" and sum(counted) == len(plan.starts) >= 5
    assert audio.ndim == 1 and np.isfinite(audio).all()
    assert abs(len(audio) / model.rates.sample_rate - 9.0) < 0.2


def test_stitching_refuses_windows_longer_than_the_backbone(model) -> None:
    cond = torch.zeros(300, model.latent_channels)
    with pytest.raises(ValueError, match="max_length"):
        stitched_sample(
            model.sampler_for("motion"), model.motion_backbone, [cond], [0], model.latent_channels,
            window=1000, overlap=10,
        )  # fmt: skip


@pytest.mark.parametrize("schedule", ["two_pass", "sequential"])
def test_seam_statistic_on_the_shipped_model(schedule: str) -> None:
    """On a 20-s song the velocity jumps at the window boundaries stay within the 95th percentile of
    the training data's own jumps (the synth_dance config the shipped model was trained on, its
    ``training_data.json``, at the data's frame rate) or of the dance's own jumps away from the
    boundaries, whichever is larger, and so do the jumps anywhere across the frames a window was
    inpainted on."""
    import dataclasses
    import json

    from momu.cli.generate_io import GenerateInputError, default_model_dir
    from momu.config import build_component
    from momu.data.synth.dataset import generate_clip
    from momu.generation.momu_long import plan_for_seconds
    from momu.methods.momu import MoMuModel

    try:
        folder = default_model_dir("dance")
    except GenerateInputError:
        pytest.skip("no shipped model in this installation (nox -s pretrain)")
    shipped = MoMuModel.load(folder)
    trained_on = build_component(json.loads((folder / "training_data.json").read_text()), "datasets").cfg
    clip = generate_clip(
        dataclasses.replace(trained_on, num_clips=1, min_seconds=20.0, max_seconds=20.0, seed=1), 0
    )
    (motion,) = music_to_motion_long(shipped, [clip.audio], clip.sample_rate, [0], schedule=schedule)
    fps, per_latent = shipped.rates.motion_fps, shipped.rates.motion_frames_per_latent
    plan = plan_for_seconds(shipped, 20.0, schedule=schedule)
    data_clips = [generate_clip(dataclasses.replace(trained_on, num_clips=4, seed=9), i) for i in range(4)]
    p95 = float(np.percentile(np.concatenate([velocity_jumps(c.motion, c.fps) for c in data_clips]), 95))
    boundaries = [b * per_latent for b in plan.boundaries]
    jumps = seam_jumps(motion, boundaries, fps)
    assert len(jumps) >= 5
    every = velocity_jumps(motion, fps)
    away = np.ones(len(every), dtype=bool)
    for b in boundaries:
        away[max(0, b - 3) : b + 3] = False
    # the dance's own jumps away from the seams: the shipped model's motion is jerkier than its
    # training data (p95 ~11 against ~8 m/s² over four 8-s songs of its training config; ~50 on the
    # 155-BPM waltz this test uses), and stitching must add nothing to it
    p95 = max(p95, float(np.percentile(every[away], 95)))
    # typical seams lie within the data's own 95th percentile; none is far beyond it
    assert np.median(jumps) <= p95, f"seam jumps {np.round(jumps, 2)} vs p95 {p95:.2f}"
    assert jumps.max() <= 1.5 * p95, f"seam jumps {np.round(jumps, 2)} vs p95 {p95:.2f}"
    limit = max(1.5 * p95, float(every[away].max()))  # no worse than the dance away from seams
    for k, (s, e) in enumerate(zip(plan.starts, plan.ends)):  # across every inpainted edge zone
        head, tail = plan.known(k)
        zones = ([(s, s + head + 1)] if head else []) + ([(e - tail - 1, e)] if tail else [])
        for lo, hi in zones:
            zone = every[max(0, lo * per_latent - 1) : hi * per_latent - 1]
            assert zone.max() <= limit, f"window {k}: jumps up to {zone.max():.2f} vs {limit:.2f}"
