"""BAS separates ground-truth from shuffled music/dance pairs on momu's synthetic dances."""

from __future__ import annotations

import numpy as np

from momu.data.synth import SynthConfig, SynthDance
from momu.data.types import Clip
from momu.metrics import bas, music_beats
from momu.metrics.beats import MUSIC_FPS, resample_beat_frames
from momu.registry import METRICS


def test_bas_gt_pairs_beat_shuffled_pairs_on_synth() -> None:
    data = SynthDance(SynthConfig(num_clips=6, min_seconds=6.0, max_seconds=6.0, seed=3))
    clips = [data[i] for i in range(len(data))]
    beats = [
        resample_beat_frames(music_beats(c.audio, c.sample_rate, recipe="mint"), MUSIC_FPS, c.fps)
        for c in clips
    ]
    n = len(clips)
    scores = np.array([[bas(clips[i].motion, beats[j]) for j in range(n)] for i in range(n)])
    gt = float(np.mean(np.diag(scores)))
    shuffled = float(np.mean(scores[~np.eye(n, dtype=bool)]))
    assert gt > shuffled + 0.2, (gt, shuffled)
    # the registered metric on the same clips, music beats from meta (the generator's beat times)
    assert METRICS.build("bas", {"music_beats": "meta"})(clips)["bas"] > shuffled + 0.2
    # and a shuffled pairing through the registered metric (music of the next clip)
    swapped = [
        Clip(id=c.id, motion=c.motion, fps=c.fps, meta={"beat_times": clips[(k + 1) % n].meta["beat_times"]})
        for k, c in enumerate(clips)
    ]
    assert METRICS.build("bas", {"music_beats": "meta"})(swapped)["bas"] < gt - 0.2
