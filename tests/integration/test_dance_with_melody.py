"""The ``dance_with_melody`` loader and ``momu data check`` on the real subset (skipped where absent).

Every expectation is read from the folder itself (its ``DANCE_*`` folders, their ``config.json`` and
``skeletons.json``) and checked per dance, so the tests hold for any version of the subset (8
dances, then 23). Decoding the songs takes about 4 s for 23 dances on a 2-core machine; the test
that only needs motion reads with ``load_audio=false``.
"""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.shared_data import DWM_STYLES, dance_with_melody_folders

from momu.cli import main
from momu.registry import DATASETS

FPS = 25  # config.json positions and skeleton frames (shared/data/README.md)


@pytest.fixture
def dwm_root(shared_data: Path) -> Path:
    root = shared_data / "dance_with_melody"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    return root


def read_json(path: Path) -> dict:
    return json.loads(path.read_text())


def test_data_check_passes_on_the_real_subset(dwm_root: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folders = dance_with_melody_folders(dwm_root)
    n = len(folders)
    seconds = sum(read_json(f / "skeletons.json")["length"] for f in folders) / FPS
    styles = Counter(DWM_STYLES[f.name.split("_")[1]] for f in folders)
    assert main(["data", "check", "dance_with_melody", "--root", str(dwm_root)]) == 0
    out = capsys.readouterr().out
    assert f"items: {n} ({n} ok, 0 bad)" in out and "result: OK" in out
    assert f"duration: total {seconds:.1f} s" in out
    assert f"fps: 25 {n}\n" in out and f"skeleton: dwm21 (21 joints x 3D): {n}\n" in out
    assert f"audio: 16000 Hz {n}\n" in out
    assert "styles: " + ", ".join(f"{s} {c}" for s, c in sorted(styles.items())) + "\n" in out
    splits = re.search(r"^splits: (.*)$", out, re.MULTILINE)
    assert splits is not None and sum(int(part.split()[-1]) for part in splits[1].split(", ")) == n


def test_motion_is_the_paper_skeleton_in_metres(dwm_root: Path) -> None:
    folders = dance_with_melody_folders(dwm_root)
    ds = DATASETS.build("dance_with_melody", {"root": str(dwm_root), "load_audio": False})
    assert ds.ids == [f.name for f in folders]
    for i, folder in enumerate(folders):
        clip = ds[i]
        data, config = read_json(folder / "skeletons.json"), read_json(folder / "config.json")
        skeletons = np.asarray(data["skeletons"], dtype=np.float64)
        center = np.asarray(data["center"], dtype=np.float64)
        frames = data["length"]
        assert clip.motion.shape == (frames, 21, 3) and clip.trajectory.shape == (frames, 3), folder.name
        assert clip.style == DWM_STYLES[folder.name.split("_")[1]]
        span = config["end_position"] - config["start_position"]
        assert clip.meta["length_mismatch_frames"] == span - frames
        assert np.isfinite(clip.motion).all() and np.isfinite(clip.trajectory).all()
        # The first 21 points, centimetres -> metres (where the file has values; gaps are interpolated).
        known = np.isfinite(skeletons[:, :21])
        np.testing.assert_allclose(clip.motion[known], skeletons[:, :21][known] / 100, rtol=1e-5, atol=1e-6)
        known = np.isfinite(center)
        np.testing.assert_allclose(clip.trajectory[known], center[known] / 100, rtol=1e-5, atol=1e-6)
        # Y up, metres: head (0) above the feet (10, 11, 19, 20) by a human height (1.39-1.58 m measured
        # over the 23 dances).
        height = np.median(clip.motion[:, 0, 1] - clip.motion[:, [10, 11, 19, 20], 1].min(axis=1))
        assert 1.2 < height < 2.2, (folder.name, height)
        # Root-centred: the pelvis (2) stays near the origin (within 0.37 m measured) while `center`
        # travels (its horizontal range is 3.3-9.7 m measured).
        assert np.abs(clip.motion[:, 2]).max() < 0.5, folder.name
        assert np.ptp(clip.trajectory[:, [0, 2]], axis=0).max() > 1.0, folder.name


def test_audio_is_the_dance_span_of_the_song(dwm_root: Path) -> None:
    """Each dance's audio is its song from ``start_position / 25`` s for as long as the dance lasts."""
    folders = dance_with_melody_folders(dwm_root)
    ds = DATASETS.build("dance_with_melody", {"root": str(dwm_root), "sample_rate": None})
    assert ds.ids == [f.name for f in folders]
    mismatch, offsets = [], []
    for i, folder in enumerate(folders):
        clip = ds[i]
        config = read_json(folder / "config.json")
        offset = config["start_position"] / FPS
        info = sf.info(str(folder / "audio.mp3"))
        sr = int(info.samplerate)
        assert clip.sample_rate == sr and clip.meta["audio_offset_seconds"] == pytest.approx(offset)
        start = round(offset * sr)
        # The whole dance, unless the song ends first (by at most length_tolerance_frames).
        skeleton_frames = (config["end_position"] - config["start_position"]) - clip.meta[
            "length_mismatch_frames"
        ]
        frames = min(skeleton_frames, int(np.floor((info.frames - start) / sr * FPS + 1e-6)))
        assert clip.motion.shape[0] == frames, folder.name
        assert len(clip.audio) == round(frames / FPS * sr), folder.name
        # The same samples as the song read from its first sample on (no seek), channels averaged.
        song, _ = sf.read(str(folder / "audio.mp3"), frames=start + 2 * sr, dtype="float32", always_2d=True)
        np.testing.assert_allclose(
            clip.audio[: 2 * sr], song[start:].mean(axis=1), atol=1e-3, err_msg=folder.name
        )
        assert np.abs(clip.audio).max() > 0.05, folder.name
        mismatch.append(abs(clip.meta["length_mismatch_frames"]))
        offsets.append(offset)
    # A window of the dance whose config span differs most from its skeleton (DANCE_T_5: 56 frames):
    # motion and audio are cut alike, at the requested rate.
    worst = int(np.argmax(mismatch))
    windowed = DATASETS.build(
        "dance_with_melody", {"root": str(dwm_root), "sample_rate": 8000, "window_seconds": 10.0}
    )[worst]
    assert (
        windowed.sample_rate == 8000
        and windowed.motion.shape == (250, 21, 3)
        and len(windowed.audio) == 80000
    )
    assert windowed.meta["audio_offset_seconds"] == pytest.approx(offsets[worst])
    assert np.abs(windowed.audio).max() > 0.05
