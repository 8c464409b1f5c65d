"""Beat metrics on hand-computable inputs: BAS (both variants), D2M coverage/hit, motion beats."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momu.metrics import (
    EmptyBeatsError,
    aistpp_tempo,
    bas,
    bas_dataset,
    beat_align_score,
    beat_coverage_scores,
    motion_beats,
    motion_envelope,
    select_aligned,
)
from momu.metrics.beats import frames_to_onehot, resample_beat_frames


def speed_motion(speed: np.ndarray, joints: int = 2) -> np.ndarray:
    """(T, J, 3) motion whose every joint moves along x with per-frame displacement ``speed[t-1]``."""
    x = np.concatenate([[0.0], np.cumsum(speed)])
    m = np.zeros((x.size, joints, 3))
    m[:, :, 0] = x[:, None]
    m[:, :, 1] = np.arange(joints)[None, :]
    return m


def dip_speed(T: int, dips: list[int]) -> np.ndarray:
    """Per-frame displacement 1 everywhere except V-shaped dips (minimum 0.1 at each dip frame)."""
    s = np.ones(T - 1)
    for d in dips:
        for k in range(-5, 6):
            if 0 <= d + k < T - 1:
                s[d + k] = min(s[d + k], 0.1 + 0.18 * abs(k))
    return s


# --------------------------------------------------------------------- beat_align_score
def test_beat_align_score_over_music_and_motion_by_hand() -> None:
    # music 10 -> nearest motion 10 (d=0); music 20 -> nearest motion 23 (d=3): exp(-9/18)
    assert beat_align_score([10, 20], [10, 23]) == pytest.approx((1 + math.exp(-0.5)) / 2, abs=1e-15)
    # over music: the lone music beat coincides -> 1; over motion: 40 is 30 frames from music 10
    assert beat_align_score([10], [10, 40], over="music") == 1.0
    assert beat_align_score([10], [10, 40], over="motion") == pytest.approx((1 + math.exp(-900 / 18)) / 2)
    assert beat_align_score([10], [16], sigma=6.0) == pytest.approx(math.exp(-36 / 72))


def test_beat_align_score_accepts_onehot() -> None:
    onehot = frames_to_onehot([3, 9], 12)
    assert onehot.tolist().count(True) == 2
    assert beat_align_score(onehot, np.array([3, 9])) == 1.0


def test_beat_align_score_matches_reference_loops() -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        music = np.unique(rng.integers(0, 400, 15))
        motion = np.unique(rng.integers(0, 400, 25))
        # Bailando BA(): python loop over music beats, float64
        ba = 0.0
        for bb in music:
            ba += np.exp(-np.min((motion - bb) ** 2) / 2 / 9)
        assert beat_align_score(music, motion) == ba / len(music)
        # mint alignment_score(): loop over motion beats, float32 distances and sum
        scores = []
        for idx in motion:
            dists = np.abs(music - idx).astype(np.float32)
            scores.append(np.exp(-(dists[np.argmin(dists)] ** 2) / 2 / 3**2))
        assert beat_align_score(music, motion, over="motion") == float(sum(scores) / len(scores))


def test_beat_align_score_empty_sets() -> None:
    with pytest.raises(EmptyBeatsError, match="no music beats"):
        beat_align_score([], [1, 2])
    with pytest.raises(EmptyBeatsError, match="no motion beats"):
        beat_align_score([1, 2], [])
    assert beat_align_score([1, 2], [], over="motion") == 0.0  # mint's documented value
    with pytest.raises(EmptyBeatsError):
        beat_align_score([], [1], over="motion")
    with pytest.raises(ValueError, match="sigma"):
        beat_align_score([1], [1], sigma=0)
    with pytest.raises(ValueError, match="integers"):
        beat_align_score([1.5], [1])
    with pytest.raises(ValueError, match=">= 0"):
        beat_align_score([-1], [1])


# --------------------------------------------------------------------- motion beats
def test_mint_motion_beats_are_the_speed_dips() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))
    # velocity_t = p_t - p_{t-1}: displacement speed[t-1] shows at envelope index t
    assert motion_beats(motion, variant="mint").tolist() == [41, 91, 151]
    env = motion_envelope(motion, variant="mint")
    assert env.shape == (200,) and env[0] == 0 and env.dtype == np.float32
    assert env[41] == pytest.approx(2 * 0.1, rel=1e-6)  # two joints, 0.1 each


def test_bailando_motion_beats_smoothed_minima() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))
    env = motion_envelope(motion, variant="bailando")
    assert env.shape == (199,)
    assert motion_beats(motion, variant="bailando").tolist() == [40, 90, 150]


def test_static_motion_has_no_beats() -> None:
    static = np.zeros((100, 3, 3))
    assert motion_beats(static).size == 0 and motion_beats(static, variant="mint").size == 0
    with pytest.raises(EmptyBeatsError, match="static"):
        bas(static, [10, 20])
    assert bas(static, [10, 20], variant="mint") == 0.0


def test_motion_validation_messages() -> None:
    with pytest.raises(ValueError, match=r"\(T, J, D\)"):
        motion_beats(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="wrong order"):
        motion_beats(np.zeros((3, 24, 100)))
    bad = np.zeros((10, 2, 3))
    bad[4, 1, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        motion_beats(bad)
    with pytest.raises(ValueError, match="variant"):
        motion_beats(np.zeros((10, 2, 3)), variant="edge")  # type: ignore[arg-type]


# --------------------------------------------------------------------- bas
def test_bas_bailando_perfect_and_truncated_music() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))
    assert bas(motion, [40, 90, 150]) == 1.0
    # music beats at or past T-1 = 199 frames are dropped (Bailando truncates to the envelope length)
    assert bas(motion, [40, 90, 150, 199, 250]) == 1.0
    # one music beat 3 frames off: (1 + 1 + exp(-1/2)) / 3
    assert bas(motion, [40, 90, 153]) == pytest.approx((2 + math.exp(-0.5)) / 3)


def test_bas_mint_over_motion_beats_and_seed_frames() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))  # mint beats 41, 91, 151
    assert bas(motion, [41, 91, 151], variant="mint") == 1.0
    # an extra music beat does not lower the mint score (it averages over motion beats)
    assert bas(motion, [41, 91, 120, 151], variant="mint") == 1.0
    # but lowers Bailando's (averaged over music beats)
    assert bas(motion, [40, 90, 120, 150]) < 1.0
    # seed frames drop the first motion beat and the far music beat before it
    s = bas(motion, [10, 91, 151], variant="mint")
    assert s == pytest.approx((np.float32(np.exp(-(31**2) / 18)) + 2) / 3, rel=1e-6)
    assert bas(motion, [10, 91, 151], variant="mint", seed_frames=60) == 1.0


def test_bas_dataset_mean() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))
    a, b = bas(motion, [40, 90, 150]), bas(motion, [43])
    assert bas_dataset([motion, motion], [[40, 90, 150], [43]]) == pytest.approx((a + b) / 2)
    with pytest.raises(ValueError, match="2 motions but 1"):
        bas_dataset([motion, motion], [[1]])


def test_resample_beat_frames_and_tempo() -> None:
    assert resample_beat_frames([60, 120, 150], 60, 30).tolist() == [30, 60, 75]
    assert resample_beat_frames([60, 120], 60, 60).tolist() == [60, 120]
    assert aistpp_tempo("mBR3") == 110
    assert aistpp_tempo("gHO_sBM_cAll_d19_mHO2_ch01") == 120
    with pytest.raises(ValueError, match="music id"):
        aistpp_tempo("nothing")


# --------------------------------------------------------------------- D2M coverage / hit
def test_select_aligned_greedy_one_to_one() -> None:
    music, motion = select_aligned([10, 12], [11, 13])
    # motion 11: tie between 10 and 12 -> lower index (10); motion 13: 10 used -> 12
    assert music.tolist() == [10, 12] and motion.tolist() == [11, 13]
    music, motion = select_aligned([10], [11, 12])  # 10 used by 11; nothing left for 12
    assert music.tolist() == [10] and motion.tolist() == [11]
    music, motion = select_aligned([10], [30], tol=12)  # 20 frames away: rejected, 10 stays unused
    assert music.size == 0 and motion.size == 0
    music, motion = select_aligned([10], [30, 11], tol=12)
    assert music.tolist() == [10] and motion.tolist() == [11]
    with pytest.raises(EmptyBeatsError):
        select_aligned([], [5])


def test_beat_coverage_scores_by_hand() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))  # mint motion beats 41, 91, 151
    # music beats: 45 (4 from 41: hit), 120 (29 from 91: miss), 160 (9 from 151: hit), 190
    out = beat_coverage_scores(motion, [45, 120, 160, 190], num_music_frames=300)
    assert out["beat_coverage"] == pytest.approx(3 / (4 + 1e-6))
    assert out["beat_hit"] == pytest.approx(2 / (3 + 1e-6))
    expected = (np.exp(-16 / 18) + np.exp(-(29**2) / 18) + np.exp(-81 / 18)) / 3
    assert out["beat_alignment"] == pytest.approx(expected, rel=1e-6)
    # end_id = min(T, music frames) = 100 drops the motion beat at 151 and music beyond 100
    short = beat_coverage_scores(motion, [45, 120, 160, 190], num_music_frames=100)
    assert short["beat_coverage"] == pytest.approx(2 / (1 + 1e-6))
