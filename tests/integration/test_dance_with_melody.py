"""The ``dance_with_melody`` loader and ``momu data check`` on the real 8-dance subset (skipped where absent).

Decoding and resampling the 8 MP3 excerpts takes about 3-5 s on a 2-core machine; the tests
that only need motion read with ``load_audio=false``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.cli import main
from momu.registry import DATASETS

DANCES = [
    "DANCE_C_2",
    "DANCE_C_4",
    "DANCE_R_2",
    "DANCE_R_3",
    "DANCE_T_5",
    "DANCE_W_1",
    "DANCE_W_3",
    "DANCE_W_4",
]
# T (skeleton frames) and end_position - start_position of each dance, read from its files.
FRAMES = {"DANCE_C_2": 1890, "DANCE_C_4": 1892, "DANCE_R_2": 2312, "DANCE_R_3": 2236,
          "DANCE_T_5": 2504, "DANCE_W_1": 1430, "DANCE_W_3": 1634, "DANCE_W_4": 1409}  # fmt: skip
SPAN = {"DANCE_C_2": 1900, "DANCE_C_4": 1900, "DANCE_R_2": 2318, "DANCE_R_3": 2245,
        "DANCE_T_5": 2560, "DANCE_W_1": 1439, "DANCE_W_3": 1647, "DANCE_W_4": 1428}  # fmt: skip


@pytest.fixture
def dwm_root(shared_data: Path) -> Path:
    root = shared_data / "dance_with_melody"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    return root


def test_data_check_passes_on_the_real_subset(dwm_root: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["data", "check", "dance_with_melody", "--root", str(dwm_root)]) == 0
    out = capsys.readouterr().out
    assert "items: 8 (8 ok, 0 bad)" in out and "result: OK" in out
    assert "fps: 25 8" in out and "skeleton: dwm21 (21 joints x 3D): 8" in out and "audio: 16000 Hz 8" in out
    assert "styles: cha-cha 2, rumba 2, tango 1, waltz 3" in out


def test_motion_is_the_paper_skeleton_in_metres(dwm_root: Path) -> None:
    ds = DATASETS.build("dance_with_melody", {"root": str(dwm_root), "load_audio": False})
    assert ds.ids == DANCES
    for i, name in enumerate(DANCES):
        clip = ds[i]
        assert clip.motion.shape == (FRAMES[name], 21, 3) and clip.trajectory.shape == (FRAMES[name], 3)
        assert clip.meta["length_mismatch_frames"] == SPAN[name] - FRAMES[name]
        assert np.isfinite(clip.motion).all()
        # Y up, metres: head (0) above the feet (10, 11, 19, 20) by a human height.
        height = np.median(clip.motion[:, 0, 1] - clip.motion[:, [10, 11, 19, 20], 1].min(axis=1))
        assert 1.2 < height < 2.2, (name, height)
        # Root-centred: the pelvis (2) stays near the origin while `center` travels.
        assert np.abs(clip.motion[:, 2]).max() < 0.5


def test_audio_is_the_dance_span_of_the_song(dwm_root: Path) -> None:
    ds = DATASETS.build(
        "dance_with_melody", {"root": str(dwm_root), "sample_rate": 8000, "window_seconds": 10.0}
    )
    clip = ds[DANCES.index("DANCE_T_5")]  # the dance whose span is 56 frames longer than its skeleton
    assert clip.sample_rate == 8000 and clip.motion.shape == (250, 21, 3) and len(clip.audio) == 80000
    assert clip.meta["audio_offset_seconds"] == 0.0 and np.abs(clip.audio).max() > 0.05
    c2 = ds[0]
    assert c2.meta["audio_offset_seconds"] == pytest.approx(156 / 25)  # start_position / 25
