"""The registered beat/harmony metrics over Clip sequences (momu.metrics.base.Metric protocol)."""

from __future__ import annotations

import numpy as np
import pytest
from tests.unit.test_metrics_beats import dip_speed, speed_motion
from tests.unit.test_metrics_beats_audio import SR, clicks, swing

from momu.data.types import Clip
from momu.metrics import bas
from momu.metrics.base import Metric
from momu.registry import METRICS

NAMES = ("bas", "beat_scores", "kinematic_beat_scores", "harmony", "hit_rate", "pfc")


def test_all_registered_and_follow_the_protocol() -> None:
    for name in NAMES:
        assert name in METRICS.names()
        metric = METRICS.build(name)
        assert isinstance(metric, Metric)
        assert metric.name == name
        prov = metric.provenance()
        assert prov["name"] == name and "METRICS.md" in prov["spec"] and isinstance(prov["config"], dict)
    assert METRICS.build("beat_scores").needs_reference and not METRICS.build("bas").needs_reference


def test_bas_metric_from_meta_beat_times_and_sigma_seconds() -> None:
    motion = speed_motion(dip_speed(200, [40, 90, 150]))
    clip = Clip(id="a", motion=motion, fps=60.0, meta={"beat_times": [40 / 60, 90 / 60, 150 / 60]})
    out = METRICS.build("bas", {"music_beats": "meta"})([clip])
    assert out == {"bas": 1.0}
    off = Clip(id="b", motion=motion, fps=60.0, meta={"beat_times": [43 / 60]})
    # sigma_seconds = 0.1 s -> 6 frames at 60 fps
    got = METRICS.build("bas", {"music_beats": "meta", "sigma_seconds": 0.1})([off])["bas"]
    assert got == pytest.approx(bas(motion, [43], sigma=6.0))
    with pytest.raises(ValueError, match="beat_times"):
        METRICS.build("bas", {"music_beats": "meta"})([Clip(id="c", motion=motion, fps=60.0)])
    with pytest.raises(ValueError, match="no audio"):
        METRICS.build("bas")([Clip(id="c", motion=motion, fps=60.0)])
    with pytest.raises(ValueError, match="variant"):
        METRICS.build("bas", {"variant": "edge"})
    static = Clip(id="still", motion=np.zeros((100, 3, 3)), fps=60.0, meta={"beat_times": [0.5]})
    with pytest.raises(ValueError, match="clip 'still'.*static"):
        METRICS.build("bas", {"music_beats": "meta"})([static])


def test_harmony_and_hit_rate_metrics() -> None:
    fps = 30.0
    clip = Clip(
        id="x", motion=swing(fps, 5.0), fps=fps, audio=clicks([1.0, 2.0, 3.0, 4.0], 5.0), sample_rate=SR
    )
    assert METRICS.build("hit_rate")([clip]) == {"hit_rate": 1.0}
    h = METRICS.build("harmony")([clip])["harmony"]
    assert 0.5 < h <= 1.0
    strict = METRICS.build("hit_rate", {"t_delay": 0.001})([clip])["hit_rate"]
    assert strict < 1.0


def test_beat_scores_metrics_need_pairs() -> None:
    fps = 30.0
    gt = Clip(id="g", motion=swing(fps, 5.0), fps=fps, audio=clicks([0.5, 1.5, 2.5], 5.0), sample_rate=SR)
    gen = Clip(id="g", motion=swing(fps, 5.0), fps=fps, audio=clicks([0.6, 1.6, 3.5], 5.0), sample_rate=SR)
    out = METRICS.build("beat_scores")([gen, gen], [gt, gt])
    assert out["beat_scores.bcs"] == pytest.approx(2 / 3) and out["beat_scores.bhs"] == pytest.approx(2 / 3)
    assert out["beat_scores.csd"] == 0.0 and out["beat_scores.f1"] == pytest.approx(2 / 3)
    with pytest.raises(ValueError, match="reference"):
        METRICS.build("beat_scores")([gen])
    kb = METRICS.build("kinematic_beat_scores")([gen], [gt])
    assert set(kb) == {f"kinematic_beat_scores.{k}" for k in ("bcs", "csd", "bhs", "hsd", "f1")}


def test_pfc_metric_uses_y_up_clips() -> None:
    from tests.unit.test_metrics_beats_audio import pfc_motion

    y_up = pfc_motion()[:, :, [0, 2, 1]]
    assert METRICS.build("pfc")([Clip(id="p", motion=y_up, fps=30.0)])["pfc"] == pytest.approx(2.0)
    z_up = pfc_motion()
    assert METRICS.build("pfc", {"up_axis": 2})([Clip(id="p", motion=z_up, fps=30.0)])[
        "pfc"
    ] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="never accelerates"):
        METRICS.build("pfc")([Clip(id="s", motion=np.zeros((30, 24, 3)), fps=30.0)])
