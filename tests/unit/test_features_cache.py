"""FeatureCache: keyed by feature config and source identity, atomic npz writes, no recomputation."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from momu.features.audio import MoFusionMelConfig, MoMuMelConfig, momu_mel
from momu.features.cache import FeatureCache, cache_key, clip_identity, file_identity


class Counter:
    def __init__(self, value: np.ndarray | dict[str, np.ndarray]) -> None:
        self.calls = 0
        self.value = value

    def __call__(self) -> np.ndarray | dict[str, np.ndarray]:
        self.calls += 1
        return self.value


def test_second_run_does_not_recompute(tmp_path: Path) -> None:
    compute = Counter(np.arange(6.0).reshape(2, 3))
    first = FeatureCache(tmp_path).get_or_compute("mel", MoMuMelConfig(), "clip-1", compute)
    # A fresh cache object on the same folder (a second run) loads from disk.
    cache = FeatureCache(tmp_path)
    second = cache.get_or_compute("mel", MoMuMelConfig(), "clip-1", compute)
    assert compute.calls == 1 and cache.hits == 1 and cache.misses == 0
    np.testing.assert_array_equal(first, second)
    assert second.dtype == np.float64


def test_config_and_source_changes_are_new_entries(tmp_path: Path) -> None:
    cache = FeatureCache(tmp_path)
    compute = Counter(np.zeros(3))
    cache.get_or_compute("mel", MoMuMelConfig(), "clip-1", compute)
    cache.get_or_compute("mel", MoMuMelConfig(n_mels=64), "clip-1", compute)  # one field differs
    cache.get_or_compute("mel", MoFusionMelConfig(), "clip-1", compute)
    cache.get_or_compute("mel", MoMuMelConfig(), "clip-2", compute)
    cache.get_or_compute("mfcc", MoMuMelConfig(), "clip-1", compute)
    assert compute.calls == 5
    cache.get_or_compute("mel", MoMuMelConfig(n_mels=64), "clip-1", compute)
    assert compute.calls == 5
    # Mapping configs are canonical: key order does not matter.
    assert cache_key("f", {"a": 1, "b": 2}, "s") == cache_key("f", {"b": 2, "a": 1}, "s")
    assert cache_key("f", {"a": 1}, "s") != cache_key("f", {"a": 1.5}, "s")


def test_file_identity_follows_rewrites(tmp_path: Path) -> None:
    wav = tmp_path / "song.wav"
    y = (0.1 * np.sin(np.arange(8000) / 5)).astype(np.float32)
    sf.write(wav, y, 16000)
    cache = FeatureCache(tmp_path / "cache")
    calls = []

    def compute() -> np.ndarray:
        calls.append(1)
        audio, sr = sf.read(wav, dtype="float32")
        return momu_mel(audio, sr)

    a = cache.get_or_compute("momu_mel", MoMuMelConfig(), file_identity(wav), compute)
    cache.get_or_compute("momu_mel", MoMuMelConfig(), file_identity(wav), compute)
    assert len(calls) == 1 and a.shape == (80, 1 + 8000 // 256)
    sf.write(wav, y[:4000], 16000)  # the source changes: size (and mtime) differ
    os.utime(wav, ns=(1, 1))
    b = cache.get_or_compute("momu_mel", MoMuMelConfig(), file_identity(wav), compute)
    assert len(calls) == 2 and b.shape == (80, 1 + 4000 // 256)
    with pytest.raises(FileNotFoundError, match="nope.wav"):
        file_identity(tmp_path / "nope.wav")


def test_dict_features_and_clip_identity(tmp_path: Path) -> None:
    cache = FeatureCache(tmp_path)
    value = {"directogram": np.ones((4, 8)), "q": np.linspace(0, 1, 4)}
    source = clip_identity("synth-0003", "synth_dance", {"seed": 0, "seconds": 10.0})
    path = cache.put("kinematics", {"bins": 8}, source, value)
    assert path is not None and path.suffix == ".npz"
    got = cache.get("kinematics", {"bins": 8}, source)
    assert isinstance(got, dict) and set(got) == {"directogram", "q"}
    np.testing.assert_array_equal(got["q"], value["q"])
    other = clip_identity("synth-0003", "synth_dance", {"seed": 1, "seconds": 10.0})
    assert cache.get("kinematics", {"bins": 8}, other) is None
    with zipfile.ZipFile(path) as z:  # only plain arrays, no pickled objects
        assert all(n.endswith(".npy") for n in z.namelist())
    with pytest.raises(TypeError, match="object"):
        cache.put("bad", {}, "s", np.array([{"a": 1}], dtype=object))


def test_writes_are_atomic_and_corrupt_entries_recomputed(tmp_path: Path) -> None:
    cache = FeatureCache(tmp_path)
    compute = Counter(np.arange(4.0))
    cache.get_or_compute("f", {}, "s", compute)
    files = sorted(p for p in tmp_path.rglob("*") if p.is_file())
    assert len(files) == 1 and not files[0].name.startswith(".")  # no temporary left behind
    files[0].write_bytes(b"truncated")  # e.g. a crash of another tool
    np.testing.assert_array_equal(cache.get_or_compute("f", {}, "s", compute), np.arange(4.0))
    assert compute.calls == 2
    np.testing.assert_array_equal(FeatureCache(tmp_path).get("f", {}, "s"), np.arange(4.0))


def test_failed_compute_writes_nothing(tmp_path: Path) -> None:
    cache = FeatureCache(tmp_path)

    def boom() -> np.ndarray:
        raise RuntimeError("decoder failed")

    with pytest.raises(RuntimeError, match="decoder failed"):
        cache.get_or_compute("f", {}, "s", boom)
    assert not any(p.is_file() for p in tmp_path.rglob("*"))


def test_disabled_cache_always_computes(tmp_path: Path) -> None:
    compute = Counter(np.zeros(2))
    for cache in (FeatureCache(None), FeatureCache(tmp_path, enabled=False)):
        cache.get_or_compute("f", {}, "s", compute)
        cache.get_or_compute("f", {}, "s", compute)
    assert compute.calls == 4
    assert not any(tmp_path.iterdir())


def test_clear(tmp_path: Path) -> None:
    cache = FeatureCache(tmp_path)
    cache.put("a", {}, "1", np.zeros(1))
    cache.put("a", {}, "2", np.zeros(1))
    cache.put("b", {}, "1", np.zeros(1))
    assert cache.clear("a") == 2
    assert cache.get("b", {}, "1") is not None
    assert cache.clear() == 1
