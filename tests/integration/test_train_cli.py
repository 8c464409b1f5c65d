"""``momu train``: one method trained without a table, in the layout ``momu generate --model`` reads."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.shared_data import dance_with_melody_folders

from momu.cli import main

FAST = ["--preset", "smoke", "method.train_diffusion.steps=2"]


def test_train_on_synth_then_generate_with_it(tmp_path: Path) -> None:
    out = tmp_path / "run"
    assert main(["train", "momu", "--out", str(out), *FAST, "dataset.skeleton=dwm21"]) == 0
    (model,) = sorted((out / "models").glob("momu-*"))
    meta = json.loads((model / "momu.json").read_text())
    assert meta["skeleton"] == "dwm21"
    assert meta["config"]["encoder"]["num_joints"] == 21 and meta["config"]["encoder"]["joint_dims"] == 3
    prov = json.loads((model / "provenance.json").read_text())
    assert prov["seed"] == 0 and prov["git_commit"] and prov["preset"] == "smoke"
    assert len(prov["data_hashes"]["clips"]) == 9 and all(
        len(c["sha256"]) == 64 for c in prov["data_hashes"]["clips"].values()
    )
    assert (out / "config.yaml").is_file() and (out / "parts").is_dir()
    # `momu generate --model <out>` finds the model inside the run folder
    song = tmp_path / "s.wav"
    t = np.arange(32000) / 16000
    sf.write(str(song), (0.3 * np.sin(2 * np.pi * 2 * t) ** 8).astype(np.float32), 16000)
    code = main(
        ["generate", "dance", "--model", str(out), "--music", str(song), "--out", str(tmp_path / "d.npz")]
    )
    assert code == 0
    with np.load(tmp_path / "d.npz") as data:
        assert data["joints"].shape[1:] == (21, 3)
    # a second run reuses every trained stage
    assert main(["train", "momu", "--out", str(out), *FAST, "dataset.skeleton=dwm21"]) == 0
    assert set(json.loads((out / "train.json").read_text())["stages"].values()) == {"reused"}


def test_train_on_the_dance_with_melody_folder_out_of_the_box(tmp_path: Path, shared_data: Path) -> None:
    """Joint count, dimension and fps come from the data; every dance of the folder is trained on or held
    out (the hash split of a small folder gives val/test splits of one or two dances: they do not crash)."""
    root = shared_data / "dance_with_melody"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    out = tmp_path / "dwm"
    args = ["train", "momu", "--data", str(root), "--out", str(out), *FAST]
    assert main(args) == 0
    (model,) = sorted((out / "models").glob("momu-*"))
    meta = json.loads((model / "momu.json").read_text())
    assert meta["skeleton"] == "dwm21"
    assert meta["config"]["encoder"]["num_joints"] == 21
    clips = json.loads((model / "provenance.json").read_text())["data_hashes"]["clips"]
    assert sorted(clips) == [f.name for f in dance_with_melody_folders(root)]
    splits = [c["split"] for c in clips.values()]
    assert "train" in splits and set(splits) <= {"train", "val", "test"}


def test_train_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["train", "momu", "--out", str(tmp_path / "x"), "--preset", "huge"]) == 2
    assert "--preset huge" in capsys.readouterr().err
    assert main(["train", "momu", "--out", str(tmp_path / "x"), "--data", str(tmp_path / "none")]) == 2
    assert "dataset folder not found" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["train", "momu", "--out", str(tmp_path / "x"), "--data", str(tmp_path / "empty")]) == 2
    assert "layout not recognised" in capsys.readouterr().err
    assert main(["train", "momu", "--out", str(tmp_path / "x"), "method.nope=1"]) == 2
    assert "nope" in capsys.readouterr().err
