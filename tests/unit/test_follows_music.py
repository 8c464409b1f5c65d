"""The own-song vs other-song study (momu.generation.follows_music) on data whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from momu.data.synth.dataset import SynthConfig, generate_clip
from momu.generation.follows_music import Song, follow_music_study, interval


def test_interval_is_a_student_t_interval() -> None:
    got = interval([1.0, 2.0, 3.0, 4.0])
    assert got["mean"] == 2.5 and got["n"] == 4
    # t_{0.975, 3} = 3.182; s = 1.291; half = 3.182 * 1.291 / 2
    assert got["high"] - got["mean"] == pytest.approx(3.1824 * 1.2910 / 2, rel=1e-3)


def test_real_dances_score_higher_against_their_own_song() -> None:
    """synth_dance dances move on their own song's beats: own > other, the interval above 0."""
    clips = [
        generate_clip(SynthConfig(num_clips=4, min_seconds=8.0, max_seconds=8.0, skeleton="dwm21"), i)
        for i in range(4)
    ]
    songs = [Song(c.id, c.audio, c.sample_rate) for c in clips]
    by_id = {c.id: c for c in clips}
    result = follow_music_study(songs, lambda song, seed: (by_id[song.id].motion, by_id[song.id].fps), [0])
    gen = result["generated"]["summary"]
    assert gen["f1_own_minus_other"]["mean"] > 0
    assert gen["bas_own"]["mean"] > gen["bas_other"]["mean"]
    assert "ground_truth" not in result  # no real dances given
    assert np.isfinite(gen["bas_own_minus_other"]["low"])
