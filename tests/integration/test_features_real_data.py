"""Features on the real Dance with Melody subset (../shared/data; skipped where absent)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
import torch

from momu.features.audio import MfccConfig, MoMuMelConfig, log_mel, mfcc, onset_beats, resample
from momu.features.audio_torch import MelSpectrogram
from momu.features.bones import bone_lengths, correct_bone_lengths, mean_bone_lengths
from momu.features.kinematics import motion_kinematic_amplitude, velocity_sum, visual_beats
from momu.features.skeletons import get_skeleton

FPS = 25.0


def load_dance(folder: Path, seconds: float = 8.0) -> tuple[np.ndarray, np.ndarray, int]:
    """First ``seconds`` of a dance: (motion (T, 21, 3) metres, mono audio aligned to it, sample rate)."""
    skel = json.loads((folder / "skeletons.json").read_text())
    start = json.loads((folder / "config.json").read_text())["start_position"]
    motion = np.asarray(skel["skeletons"], dtype=np.float64)[: int(seconds * FPS), :21]
    with sf.SoundFile(folder / "audio.mp3") as f:
        f.seek(int(start / FPS * f.samplerate))
        audio = f.read(int(seconds * f.samplerate), dtype="float32", always_2d=True).mean(axis=1)
        sr = f.samplerate
    return motion, audio, sr


@pytest.fixture
def dances(shared_data: Path) -> list[Path]:
    folders = sorted(p for p in (shared_data / "dance_with_melody").glob("DANCE_*") if p.is_dir())
    if not folders:
        pytest.skip("no dances in the shared data folder")
    return folders


def test_audio_features_line_up_with_the_motion(dances: list[Path]) -> None:
    motion, audio, sr = load_dance(dances[0])
    assert sr == 44100
    mel = log_mel(audio, sr, MoMuMelConfig())
    assert mel.shape == (80, 1 + 8 * 16000 // 256)
    # The torch front end on the same (resampled) waveform agrees with librosa.
    y16 = resample(audio, sr, 16000)
    torch_mel = MelSpectrogram()(torch.from_numpy(y16)).numpy()
    np.testing.assert_allclose(torch_mel, mel, atol=1e-3)
    # MFCC frames at the motion rate: one per motion frame (+1 for the centred last frame).
    feats = mfcc(audio, sr, MfccConfig(frame_rate=FPS))
    assert feats.shape[1] == motion.shape[0] + 1
    times, strength = onset_beats(audio, sr)
    assert 4 <= len(times) <= 80 and np.all(strength > 0) and np.all(np.diff(times) > 0)


def test_motion_features_on_real_mocap(dances: list[Path]) -> None:
    sk = get_skeleton("dwm21")
    motions = [load_dance(d, seconds=6.0)[0] for d in dances[:3]]
    for motion in motions:
        j = velocity_sum(motion, FPS)
        assert j.shape == (motion.shape[0] - 1,) and np.all(j >= 0)
        frames, saliency = visual_beats(motion, FPS)
        assert len(frames) > 0 and np.all(np.diff(frames) > 0)
        np.testing.assert_allclose(saliency, j[frames - 1])
        q = motion_kinematic_amplitude(motion)
        assert q.max() == 1.0 and q.min() >= 0.0
    # MoMu App. E on real mocap: after correction no bone exceeds 1.3x the dataset mean, and bones
    # within the threshold keep their lengths.
    mean = mean_bone_lengths(motions, sk.bones)
    for motion in motions:
        before = bone_lengths(motion, sk.bones)
        after = bone_lengths(correct_bone_lengths(motion, sk.bones, mean), sk.bones)
        assert np.all(after <= 1.3 * mean + 1e-9)
        ok = before <= 1.3 * mean
        np.testing.assert_allclose(after[ok], before[ok], atol=1e-9)
