"""LORIS beat scores, kinematic beat scores, PFC and HarmoGAN harmony on hand-computable inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momu.metrics import (
    EmptyBeatsError,
    beat_scores,
    harmony_from_beats,
    harmony_score,
    hit_rate,
    kinematic_beat_frames,
    kinematic_beat_scores,
    onset_beat_bins,
    pair_beat_scores,
    pfc,
    pfc_sequence,
)
from momu.metrics.harmony import saliency_mask, visual_saliency_star
from momu.metrics.loris_scores import aggregate_beat_scores, second_bins
from momu.registry import METRICS

SR = 22050


def clicks(times: list[float], duration: float, sr: int = SR) -> np.ndarray:
    """Decaying noise bursts (10 ms) at ``times`` seconds."""
    y = np.zeros(int(round(duration * sr)), dtype=np.float32)
    rng = np.random.default_rng(0)
    n = int(0.01 * sr)
    for t in times:
        i = int(round(t * sr))
        y[i : i + n] += (0.8 * rng.standard_normal(n) * np.exp(-np.arange(n) / (0.002 * sr)))[: len(y) - i]
    return y


def bounce(fps: float, seconds: float, period: float) -> np.ndarray:
    """(T, 3, 3) motion: every joint moves along +x / -x, reversing direction every ``period`` seconds."""
    t = np.arange(int(round(seconds * fps))) / fps
    phase = (t % (2 * period)) / period
    x = np.where(phase < 1, phase, 2 - phase)  # triangle wave, reversals at k * period
    m = np.zeros((t.size, 3, 3))
    m[:, :, 0] = x[:, None]
    m[:, :, 1] = np.arange(3)[None, :]
    return m


# --------------------------------------------------------------------- LORIS
def test_second_bins_truncate_and_collapse() -> None:
    # 0.5 and 0.99 share bin 0; 1.01 -> bin 1; 2.5 -> bin 2; ceil(3.2) = 4 bins
    assert second_bins(np.array([0.5, 0.99, 1.01, 2.5]), 3.2).tolist() == [1, 1, 1, 0]
    assert second_bins(np.array([]), 2.0).tolist() == [0, 0]
    with pytest.raises(ValueError, match="past"):
        second_bins(np.array([5.0]), 3.0)


def test_second_bins_of_a_finer_width() -> None:
    # 0.25-s bins over 1.0 s: 0.1 -> 0, 0.3 -> 1, 0.49 -> 1, 0.99 -> 3; ceil(1.0 / 0.25) = 4 bins
    assert second_bins(np.array([0.1, 0.3, 0.49, 0.99]), 1.0, 0.25).tolist() == [1, 1, 0, 1]
    # 1 s is the reference's bins exactly; 4.0 s of 0.25-s bins is 16 bins (no float round-up to 17)
    times = np.array([0.5, 0.99, 1.01, 2.5])
    assert second_bins(times, 3.2, 1.0).tolist() == second_bins(times, 3.2).tolist()
    assert second_bins(np.array([3.99]), 4.0, 0.25).size == 16
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="bin_seconds"):
            second_bins(times, 3.2, bad)


def test_beat_score_metrics_take_the_bin_width() -> None:
    # onsets at 0.1 s and 1.1 s vs 0.4 s and 1.4 s: same one-second bins (F1 1), different 0.25-s bins (F1 0)
    gt, gen = clicks([0.1, 1.1], 2.0), clicks([0.4, 1.4], 2.0)
    one_second = beat_scores([gen, gen], [gt, gt], SR)
    quarter = beat_scores([gen, gen], [gt, gt], SR, bin_seconds=0.25)
    assert one_second["f1"] == pytest.approx(1.0) and quarter["f1"] == pytest.approx(0.0)
    with pytest.raises(ValueError, match="bin_seconds"):
        METRICS.build("beat_scores", {"bin_seconds": 0})
    with pytest.raises(ValueError, match="bin_seconds"):
        METRICS.build("kinematic_beat_scores", {"bin_seconds": -0.5})


def test_pair_beat_scores_by_hand() -> None:
    # gt truncated to len(syn) = 3 -> [1, 1, 0]; Nt = 2, Ns = 2, Nm = 1
    assert pair_beat_scores([1, 1, 0, 1], [1, 0, 1]) == (0.5, 0.5)
    assert pair_beat_scores([1, 1], [0, 0]) == (0, 0.0)  # Ns = 0 -> cover 0
    assert pair_beat_scores([0, 0], [1, 0]) == (0.0, 0)  # Nt = 0 -> hit 0
    with pytest.raises(ValueError, match="longer than the ground truth"):
        pair_beat_scores([1, 1], [1, 1, 1])
    assert pair_beat_scores([1, 1], [1, 1, 1], truncate="shortest") == (1.0, 1.0)
    # CDCD: cover = Ns / Nt (can exceed 1), hit = Nm / Nt, equal lengths required
    assert pair_beat_scores([1, 0, 0], [1, 1, 1], variant="cdcd") == (3.0, 1.0)
    with pytest.raises(ValueError, match="equal lengths"):
        pair_beat_scores([1, 0, 0, 1], [1, 1, 1], variant="cdcd")
    with pytest.raises(EmptyBeatsError):
        pair_beat_scores([0, 0], [1, 1], variant="cdcd")
    with pytest.raises(ValueError, match="0 and 1"):
        pair_beat_scores([2, 0], [1, 1])


def test_aggregate_ddof1_and_f1_of_means(caplog: pytest.LogCaptureFixture) -> None:
    out = aggregate_beat_scores([0.5, 1.0], [1.0, 0.25])
    assert out["bcs"] == 0.75 and out["bhs"] == 0.625
    assert out["csd"] == pytest.approx(math.sqrt(0.125))  # sample std of (0.5, 1.0)
    assert out["hsd"] == pytest.approx(math.sqrt(((0.375) ** 2) * 2))
    assert out["f1"] == pytest.approx(2 * 0.75 * 0.625 / 1.375)
    one = aggregate_beat_scores([0.5], [0.5])
    assert math.isnan(one["csd"]) and "undefined" in caplog.text
    assert aggregate_beat_scores([0.0, 0.0], [0.0, 0.0])["f1"] == 0.0
    assert set(aggregate_beat_scores([0.5], [0.5], variant="cdcd")) == {"bcs", "bhs", "n"}


def test_onset_bins_of_click_track() -> None:
    y = clicks([0.25, 1.25, 2.5], 4.0)
    assert onset_beat_bins(y, SR).tolist() == [1, 1, 1, 0]
    # the same clicks at 44.1 kHz stereo give the same bins (averaged, resampled like librosa.load)
    y2 = clicks([0.25, 1.25, 2.5], 4.0, sr=44100)
    assert onset_beat_bins(np.stack([y2, y2]), 44100).tolist() == [1, 1, 1, 0]


def test_beat_scores_dataset() -> None:
    gt = clicks([0.25, 1.25, 2.5], 4.0)
    good = clicks([0.3, 1.3, 2.6], 4.0)
    bad = clicks([3.5], 4.0)
    out = beat_scores([good, bad], [gt, gt], SR)
    # pair 1: cover 1, hit 1; pair 2: Nm = 0 -> cover 0, hit 0
    assert out["bcs"] == 0.5 and out["bhs"] == 0.5 and out["f1"] == 0.5
    assert out["csd"] == pytest.approx(math.sqrt(0.5))
    with pytest.raises(ValueError, match="2 generated but 1"):
        beat_scores([good, bad], [gt], SR)
    with pytest.raises(ValueError, match="pair 0"):
        beat_scores([clicks([0.3], 6.0)], [gt], SR)
    with pytest.raises(ValueError, match="float waveform"):
        beat_scores([np.zeros(100, dtype=np.int16)], [gt], SR)


# --------------------------------------------------------------------- kinematic beats
@pytest.mark.parametrize("fps", [25.0, 30.0, 60.0])
def test_kinematic_beats_at_direction_reversals(fps: float) -> None:
    m = bounce(fps, 5.0, 0.5)
    frames = kinematic_beat_frames(m, fps)
    expected = np.arange(1, 10) * 0.5 * fps
    assert frames.size == expected.size
    assert np.all(np.abs(frames - expected) <= 1)


def test_kinematic_beat_scores_against_music() -> None:
    fps = 30.0
    m = bounce(fps, 5.0, 0.5)  # reversals every 0.5 s: every one-second bin has a beat
    music_on = clicks([0.25, 1.25, 2.25, 3.25, 4.25], 5.0)
    music_half = clicks([0.25, 2.25], 5.0)
    out = kinematic_beat_scores([m, m], fps, [music_on, music_half], SR)
    # pair 1: Ns = 5, Nt = 5, Nm = 5; pair 2: Ns = 5, Nt = 2, Nm = 2
    assert out["bcs"] == pytest.approx((1 + 0.4) / 2)
    assert out["bhs"] == pytest.approx(1.0)
    static = np.zeros((150, 3, 3))
    assert kinematic_beat_frames(static, fps).size == 0
    assert kinematic_beat_scores([static], fps, [music_on], SR)["bcs"] == 0


# --------------------------------------------------------------------- PFC
def pfc_motion(T: int = 40, left: float = 0.01, right: float = 0.02, up: int = 2) -> np.ndarray:
    """Root accelerating uniformly along a horizontal axis; feet sliding at constant per-frame speed."""
    m = np.zeros((T, 24, 3))
    t = np.arange(T, dtype=np.float64)
    horizontal = 0 if up != 0 else 1
    m[:, 0, horizontal] = 0.5 * 0.001 * t**2
    for j, step in ((7, left), (10, left), (8, right), (11, right)):
        m[:, j, horizontal] = step * t
    return m


def test_pfc_by_hand() -> None:
    # normalised root acceleration = 1 on every frame; loss = 0.01 * 0.02 -> PFC = 2e-4 * 1e4 = 2
    assert pfc_sequence(pfc_motion()) == pytest.approx(2e-4)
    assert pfc([pfc_motion(), pfc_motion(left=0.0)]) == pytest.approx(1.0)
    # the same motion given y-up with up_axis=1 gives the same value
    y_up = pfc_motion()[:, :, [0, 2, 1]]
    assert pfc_sequence(y_up, up_axis=1) == pytest.approx(2e-4)
    # foot speed is a per-frame displacement: independent of the declared fps
    assert pfc_sequence(pfc_motion(), fps=60) == pytest.approx(2e-4)


def test_pfc_static_root_and_clamped_downward_acceleration() -> None:
    m = pfc_motion()
    m[:, 0] = 0.0
    with pytest.raises(ValueError, match="never accelerates"):
        pfc_sequence(m)
    assert pfc_sequence(m, static="zero") == 0.0
    down = pfc_motion()
    down[:, 0] = 0.0
    down[:, 0, 2] = -0.5 * 0.001 * np.arange(40.0) ** 2  # only downward z acceleration: clamped to 0
    with pytest.raises(ValueError, match="never accelerates"):
        pfc_sequence(down)
    with pytest.raises(ValueError, match="joints"):
        pfc_sequence(np.zeros((40, 5, 3)))


# --------------------------------------------------------------------- harmony
def test_harmony_by_hand() -> None:
    # audio beats 1, 2, 3 s with equal saliency (sigma 0: all salient); visual beats 1.1 s and 2.3 s,
    # s_v = (2, 1), j0 = 0 -> s* = (2, 1), std 0.5, lambda2 = 1: both salient.
    r = harmony_from_beats([1.0, 2.0, 3.0], [1.0, 1.0, 1.0], [1.1, 2.3], [2.0, 1.0], 0.0)
    # only 1.0 s is within 0.25 s (2.0 -> 2.3 is 0.3 s): h_s = 1, N' = 3, M' = 2
    assert (r.h_s, r.n_audio, r.n_visual, r.hits) == (1.0, 3, 2, 1)
    assert r.h == pytest.approx(5 / 14)
    assert r.hit_rate == pytest.approx(1 / 3)
    assert r.h_a == pytest.approx(1 / 3) and r.h_v == pytest.approx(1 / 2)
    # T_delay is strict: exactly 0.25 s away does not count
    assert harmony_from_beats([1.0], [1.0], [1.25], [1.0], 0.0).hits == 0


def test_harmony_saliency_masks_and_weights() -> None:
    # lambda1 * std: with saliencies (1, 1, 10), std = 4.24, lambda1 = 0.1 keeps all, lambda1 = 1 keeps 10
    assert saliency_mask(np.array([1.0, 1.0, 10.0]), 0.1).tolist() == [True, True, True]
    assert saliency_mask(np.array([1.0, 1.0, 10.0]), 1.0).tolist() == [False, False, True]
    assert visual_saliency_star(np.array([5.0, 2.0, 4.0]), 1.0).tolist() == [4.0, 3.0, 2.0]
    # saliencies normalised by the maximum: hitting the loud beat counts 1, the soft one 0.5
    loud = harmony_from_beats([1.0, 2.0], [2.0, 1.0], [1.0], [1.0], 0.0)
    soft = harmony_from_beats([1.0, 2.0], [2.0, 1.0], [2.0], [1.0], 0.0)
    assert loud.h_s == 1.0 and soft.h_s == 0.5
    raw = harmony_from_beats([1.0, 2.0], [2.0, 1.0], [1.0], [1.0], 0.0, normalize_saliency=False)
    assert raw.h_s == 2.0


def test_harmony_empty_sets() -> None:
    r = harmony_from_beats([1.0, 2.0], [1.0, 1.0], [], [], 0.0)  # static motion: no visual beats
    assert r.h == 0.0 and r.hit_rate == 0.0 and r.n_visual == 0
    with pytest.raises(EmptyBeatsError, match="no audio beats"):
        harmony_from_beats([], [], [1.0], [1.0], 0.0)
    with pytest.raises(ValueError, match="one saliency"):
        harmony_from_beats([1.0], [1.0, 2.0], [1.0], [1.0], 0.0)


def swing(fps: float, seconds: float, period: float = 2.0) -> np.ndarray:
    """(T, 3, 3) motion whose speed is ``1 + cos(2πt/period)``: velocity-sum extrema every period/2 s."""
    t = np.arange(int(round(seconds * fps))) / fps
    x = np.cumsum(1 + np.cos(2 * np.pi * t / period)) / fps
    m = np.zeros((t.size, 3, 3))
    m[:, :, 0] = x[:, None]
    m[:, :, 1] = np.arange(3)[None, :]
    return m


def test_harmony_score_end_to_end() -> None:
    fps = 30.0
    m = swing(fps, 5.0)  # velocity-sum maxima at 2, 4 s and minima at 1, 3 s (all equally salient)
    on_beat = clicks([1.0, 2.0, 3.0, 4.0], 5.0)
    off_beat = clicks([1.5, 2.5, 3.5, 4.5], 5.0)
    assert hit_rate(on_beat, SR, m, fps) == 1.0
    assert hit_rate(off_beat, SR, m, fps) == 0.0
    # every audio beat hit: h = 5 h_s / (4 N' + M') with h_s = the sum of normalised saliencies (<= N')
    h = harmony_score(on_beat, SR, m, fps)
    assert 0.5 < h <= 1.0
    assert harmony_score(off_beat, SR, m, fps) == 0.0
    assert harmony_score(on_beat, SR, np.zeros((150, 3, 3)), fps) == 0.0
    with pytest.raises(EmptyBeatsError):
        harmony_score(np.zeros(SR * 2, dtype=np.float32), SR, m, fps)


# --------------------------------------------------------------------- music-beat recipes (§1.5)
def test_music_beat_recipes_follow_the_reference_calls() -> None:
    import librosa

    from momu.metrics import music_beat_onehot, music_beats

    y = clicks([0.3, 0.8, 1.3, 1.8, 2.3, 2.8, 3.3], 4.0)  # 120 bpm
    y30 = librosa.resample(y, orig_sr=SR, target_sr=30720, res_type="soxr_hq")
    # Bailando: HPSS percussive part, median onset strength, beat_track defaults (start_bpm 120)
    env = librosa.onset.onset_strength(y=librosa.effects.hpss(y30)[1], aggregate=np.median, sr=30720)
    _, expected = librosa.beat.beat_track(onset_envelope=env, sr=30720)
    onehot = music_beat_onehot(y, SR)  # one entry per onset frame, as Bailando's music_array[:, 53]
    assert onehot.shape == env.shape and np.flatnonzero(onehot).tolist() == expected.tolist()
    # mint: full-signal mean onset strength, start_bpm prior, tightness 100
    env = librosa.onset.onset_strength(y=y30, sr=30720)
    _, expected = librosa.beat.beat_track(
        onset_envelope=env, sr=30720, hop_length=512, start_bpm=90, tightness=100
    )
    assert music_beats(y, SR, recipe="mint", start_bpm=90).tolist() == expected.tolist()
    # beats at 60 fps: 0.5 s apart = 30 frames
    assert np.all(np.abs(np.diff(music_beats(y, SR, recipe="mint")) - 30) <= 1)
    with pytest.raises(ValueError, match="recipe"):
        music_beats(y, SR, recipe="edge")  # type: ignore[arg-type]
