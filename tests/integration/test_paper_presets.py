"""Every recipe's ``paper`` preset end to end at tiny size, through calibration and results (issue 33).

Each recipe runs in-process with ``--preset paper --seeds 0`` on a small stand-in in its dataset's
published layout (:mod:`tests.fixtures.layouts`) or, where the paper preset's own dataset is the
synthetic stand-in, on that; the only overrides are sizes — widths, depths, steps, clip counts and
lengths, sampling steps, extractor epochs — never a switch of a part, a loss or a code path. Recipes
that share stages run into one output folder, in the order of ``nox -s reproduce``, so the tests
also see the sharing. A crash anywhere after training (calibration, results) fails here.

* MoFusion Table 1 and supp. Tables 1–2: AIST++ (SMPL-24 by forward kinematics of a random SMPL
  file) with 3-s sequences, shorter than the paper's 20-s training windows: they train whole.
* MoFusion Table 2: HumanML3D with clips of 1.5–4.5 s, a tiny CLIP text tower from a local file;
  T2M's evaluator paths unset, so the preset's fallback (the from-scratch evaluator) runs.
* MoMu Tables 7 and 10: the paper preset's synthetic stand-in (its own ``dataset`` node).
* MoMu Tables 2–4: LORIS (dance, floor exercise, figure skating; 25-s and 50-s segments).
* MoMu Tables 5–6: their synthetic stand-ins; the BHS Dance layout (``d2m``) ships no waveform, so
  with ``--data`` these tables stop before training by design (``tests/integration/test_momu_tables_2_6.py``).
* HarmoGAN Tables I–II and Figs. 9, 11, 12: Dance with Melody (a cha-cha and a waltz of 40 s).
"""

from __future__ import annotations

import dataclasses
import gzip
import json
import math
import pickle
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch
from safetensors.torch import save_file
from tests.fixtures.layouts import (
    AISTPP_GOOD,
    smooth_motion,
    write_aistpp,
    write_dance_with_melody,
    write_humanml3d,
    write_loris,
    write_wav,
)
from tests.fixtures.smpl_files import random_smpl, write_smpl_npz

from momu.data.common import hash_split
from momu.encoders.clip_bpe import CLIPTokenizer
from momu.encoders.clip_text import CLIPTextConfig, CLIPTextTower
from momu.engine.table import TableSpec, run_table
from momu.methods.harmogan import recipes as harmogan
from momu.methods.mofusion.tables import supp_table1_spec, supp_table2_spec, table1_spec
from momu.methods.mofusion.tables_text import table2_spec as mofusion_table2_spec
from momu.methods.momu.recipes import table7_spec, table10_spec
from momu.methods.momu.tables import TABLE_SPECS

FLAGS = ["--preset", "paper", "--seeds", "0", "--tracker", "none"]

# ------------------------------------------------------------------------------------------- sizes
MOFUSION_SIZE = [
    "method.backbone.base_channels=8",
    "method.backbone.heads=2",
    "method.backbone.cross_attention_dim=16",
    "method.backbone.norm_groups=4",
    "method.backbone.time_freq_dim=16",
    "method.train.steps=2",
    "method.train.batch_size=2",
    "method.sampler.scheduler.num_inference_steps=3",
    "method.inpainting_sampler.scheduler.num_inference_steps=3",
    "method.evaluation.multimodality_clips=1",
    "method.evaluation.multimodality_samples=2",
]
MOFUSION_MUSIC_SIZE = [
    *MOFUSION_SIZE,
    "method.evaluation.num_clips=2",
    "lengths.short=2.0",  # the paper's 10 s and 20 s
    "lengths.long=3.0",
    "method.evaluation.seed_seconds=0.4",  # the paper's 2 s: 20 % of the short length
]
TINY_CLIP = {"vocab_size": 600, "context_length": 16, "width": 16, "layers": 1, "heads": 2, "embed_dim": 8}
MOFUSION_TEXT_SIZE = [
    *MOFUSION_SIZE,
    "method.evaluation.num_clips=4",
    "method.evaluation.r_precision_batch=4",
    "method.evaluation.evaluator={embed_dim: 8, width: 8, train: {steps: 2, batch_size: 2}}",
    *(f"method.text_encoder.{k}={v}" for k, v in TINY_CLIP.items()),
]


def _momu_method_size() -> list[str]:
    out = []
    for part in ("motion", "music"):
        node = f"method.encoder.{part}"
        out += [
            f"{node}.latent_channels=4",
            f"{node}.base_channels=8",
            f"{node}.channel_mult=[1,2]",
            f"{node}.num_res_blocks=1",
            f"{node}.attention_layers=1",
            f"{node}.attention_heads=2",
            f"{node}.norm_groups=4",
        ]
    for stage in ("train_music_vae", "train_motion_vae", "train_diffusion"):
        out += [f"method.{stage}.steps=2", f"method.{stage}.batch_size=2"]
    return [
        *out,
        "method.train_diffusion.warmup_steps=1",
        "method.window_seconds=2.0",
        "method.window_hop_seconds=1.0",
        "method.train_min_seconds=1.0",
        "method.discriminator_encoder.channels=4",
        "method.discriminator_encoder.num_layers=1",
        "method.discriminator_encoder.max_channels=8",
        "method.discriminator_encoder.norm_groups=4",
        "method.contrastive_loss.num_clips=4",
        "method.contrastive_loss.num_categories=2",
        "method.contrastive_loss.num_samples=2",
        "method.contrastive_loss.clip_length=2",
        "method.sampler.num_inference_steps=2",
        "method.sampler.scheduler.num_inference_steps=2",
        "method.evaluation.num_clips=2",
        "method.evaluation.seconds=2.0",
        "method.evaluation.min_seconds=1.0",
        "method.evaluation.extractor_epochs=1",
        "method.evaluation.extractor_samples_per_clip=1",
    ]


def _dit_size() -> list[str]:
    return [
        f"method.{b}.{k}={v}"
        for b in ("music_backbone", "motion_backbone")
        for k, v in (("hidden", 16), ("heads", 2), ("depth", 1), ("cond_embed_dim", 16), ("max_length", 512))
    ]


TINY_UNET = "{base_channels: 8, heads: 2, cross_attention_dim: 16, norm_groups: 4, time_freq_dim: 16}"
SYNTH_SIZE = {"num_clips": 20, "min_seconds": 3.0, "max_seconds": 3.5}
LEARNABLE_SIZE = [
    "learnable_encoder.dim_feat=16",
    "learnable_encoder.dim_rep=8",
    "learnable_encoder.depth=1",
    "learnable_encoder.num_heads=2",
    "learnable_train.steps=2",
    "learnable_train.batch_size=2",
    "learnable_train.warmup_steps=1",
]
SUBSET_SECONDS = {"25": 2.0, "50": 3.0}  # Tables 3-4's 25-s and 50-s columns
HARMOGAN_SIZE = [
    "method.generator_encoder.hidden=16",
    "method.generator_encoder.noise_dim=4",
    "method.cross_modal_discriminator_encoder.hidden=16",
    "method.spatiotemporal_discriminator_encoder.hidden=16",
    "method.pretrain.epochs=1",
    "method.adversarial.epochs=1",
]


def with_sizes(
    spec: TableSpec, sizes: Sequence[str], row_sizes: dict[str, Sequence[str]] | None = None
) -> TableSpec:
    """``spec`` whose ``paper`` preset ends with ``sizes`` (applied before each row's overrides, so a row
    that replaces a node whole gets the paper's node) and rows ``row_sizes[id]`` after their own."""
    rows = []
    for row in spec.rows:
        extra = tuple((row_sizes or {}).get(row.id, ()))
        if extra:
            row = dataclasses.replace(
                row, preset_overrides={**row.preset_overrides, "paper": (*row.overrides_for("paper"), *extra)}
            )
        rows.append(row)
    return dataclasses.replace(
        spec, presets={**spec.presets, "paper": [*spec.presets["paper"], *sizes]}, rows=rows
    )


# -------------------------------------------------------------------------------------- stand-ins
def _aistpp(root: Path, seconds: float = 3.0) -> Path:
    """AIST++ with 3 train, 2 val and 2 test sequences of moving SMPL motion; returns the SMPL file."""
    write_aistpp(root, seconds=seconds)
    rng = np.random.default_rng(0)
    frames = int(seconds * 60)
    splits: dict[str, list[str]] = {"train": [], "val": [], "test": []}
    for k, split in enumerate(["train"] * 3 + ["val"] * 2 + ["test"] * 2):
        seq = f"gBR_sBM_cAll_d0{k}_mBR{k}_ch0{k}"
        for sub in ("keypoints3d", "keypoints2d"):
            shutil.copy(root / sub / f"{AISTPP_GOOD[0]}.pkl", root / sub / f"{seq}.pkl")
        motion = {
            "smpl_poses": rng.normal(scale=0.3, size=(frames, 72)).astype(np.float32),
            "smpl_trans": (np.cumsum(rng.normal(size=(frames, 3)), 0) + [0, 90, 0]).astype(np.float32),
            "smpl_scaling": np.array([93.0]),
            "smpl_loss": np.float64(1.0),
        }
        with open(root / "motions" / f"{seq}.pkl", "wb") as f:
            pickle.dump(motion, f, protocol=4)
        write_wav(root / "wavs" / f"mBR{k}.wav", seconds + 1.0)
        splits[split].append(seq)
    for split, names in splits.items():
        (root / "splits" / f"crossmodal_{split}.txt").write_text("\n".join(names) + "\n")
    return write_smpl_npz(root / "SMPL_MALE.npz", random_smpl())


HUMANML_TEST_FRAMES = (30, 50, 70, 90)  # 1.5-4.5 s at 20 fps: all shorter than the paper's 9.8 s


def _humanml3d(root: Path) -> list[str]:
    """HumanML3D with test clips of :data:`HUMANML_TEST_FRAMES` frames, a tiny CLIP text tower and its
    BPE merges; returns the overrides naming those files."""
    write_humanml3d(root, frames=40)
    test = []
    for k, frames in enumerate(HUMANML_TEST_FRAMES):
        item = f"01000{k}"
        np.save(root / "new_joints" / f"{item}.npy", smooth_motion(frames, 22, 3, seed=20 + k))
        word = ("left", "forward", "back", "around")[k]
        (root / "texts" / f"{item}.txt").write_text(
            f"a person walks {word}.#a/DET person/NOUN walk/VERB#0.0#0.0\n"
        )
        test.append(item)
    (root / "test.txt").write_text("".join(f"{i}\n" for i in test))
    with open(root / "all.txt", "a") as f:
        f.write("".join(f"{i}\n" for i in test))
    merges = root / "bpe_simple_vocab.txt.gz"
    with gzip.open(merges, "wt", encoding="utf-8") as f:
        f.write("#version: test\nh e\nl l\nhe ll\nhell o</w>\n")
    torch.manual_seed(0)
    tower = CLIPTextTower(CLIPTextConfig(**TINY_CLIP), tokenizer=CLIPTokenizer(merges, context_length=16))
    save_file({k: v.clone() for k, v in tower.state_dict().items()}, str(root / "clip.safetensors"))
    return [
        f"method.text_encoder.checkpoint={root / 'clip.safetensors'}",
        f"method.text_encoder.bpe_path={merges}",
    ]


def _hash_named(prefix: str, counts: dict[str, int]) -> dict[str, list[str]]:
    """Segment names whose MoMu hash split (90/5/5) lands ``counts[split]`` of them in each split."""
    out: dict[str, list[str]] = {s: [] for s in counts}
    k = 0
    while any(len(out[s]) < n for s, n in counts.items()):
        name = f"{prefix}_sFM_c01_d04_m{prefix[1:3]}{k}_ch{k:02d}"
        split = hash_split(name)
        if len(out[split]) < counts[split]:
            out[split].append(name)
        k += 1
    return out


def _loris(root: Path) -> None:
    """LORIS under ``root/loris``: dance (25 s), floor exercise and figure skating (25 s and 50 s)."""
    counts = {"train": 2, "val": 2, "test": 2}
    write_loris(root / "loris", fps=4.0, seconds=25, subset="dance", names=_hash_named("gBR", counts))
    for subset in ("fe", "fs"):
        for seconds in (25, 50):
            write_loris(
                root / "loris", fps=4.0, seconds=seconds, subset=subset, names=_hash_named("gPO", counts)
            )


# ------------------------------------------------------------------------------------------ groups
@dataclasses.dataclass(frozen=True)
class Run:
    """One recipe of a group: its spec (sizes applied where rows need them), runner and arguments."""

    spec: TableSpec
    argv: list[str]
    runner: Callable[[TableSpec, list[str]], int] = run_table


def _mofusion_music(tmp: Path) -> list[Run]:
    smpl = _aistpp(tmp / "aist")
    argv = ["--data", str(tmp / "aist"), f"dataset.smpl_model={smpl}", *MOFUSION_MUSIC_SIZE]
    return [Run(spec(), argv) for spec in (table1_spec, supp_table1_spec, supp_table2_spec)]


def _mofusion_text(tmp: Path) -> list[Run]:
    files = _humanml3d(tmp / "hml")
    return [Run(mofusion_table2_spec(), ["--data", str(tmp / "hml"), *MOFUSION_TEXT_SIZE, *files])]


def _momu_table7_10(tmp: Path) -> list[Run]:
    sizes = [*_momu_method_size(), *_dit_size(), *(f"dataset.{k}={v}" for k, v in SYNTH_SIZE.items())]
    # row #4 replaces both denoisers by the registered unet1d (the paper gives no U-Net size)
    unet = [f"method.{b}={TINY_UNET}" for b in ("music_backbone", "motion_backbone")]
    return [Run(with_sizes(factory(), sizes, {"#4": unet}), []) for factory in (table7_spec, table10_spec)]


def _tables_sizes(subsets: Sequence[str]) -> list[str]:
    out = [*_momu_method_size(), *_dit_size(), *LEARNABLE_SIZE]
    for sid in subsets:
        length = SUBSET_SECONDS.get(sid[-2:])
        if length is None:
            out += [f"subsets.{sid}.synth_dataset.{k}={v}" for k, v in SYNTH_SIZE.items()]
        else:
            out += [f"subsets.{sid}.seconds={length}", f"subsets.{sid}.synth_dataset.num_clips=20"]
    return out


def _momu_tables(names: Sequence[str], data: Callable[[Path], str]) -> Callable[[Path], list[Run]]:
    def runs(tmp: Path) -> list[Run]:
        where = data(tmp)
        specs = [TABLE_SPECS[name]() for name in names]
        return [Run(s, ["--data", where, *_tables_sizes(s.base_config["subsets"])]) for s in specs]  # type: ignore[index]

    return runs


def _loris_data(tmp: Path) -> str:
    _loris(tmp / "real")
    return str(tmp / "real")


def _harmogan(tmp: Path) -> list[Run]:
    write_dance_with_melody(tmp / "dwm", seconds=40.0)
    argv = ["--data", str(tmp / "dwm"), *HARMOGAN_SIZE]
    factories = (
        harmogan.table1_spec,
        harmogan.table2_spec,
        harmogan.fig12_spec,
        harmogan.fig9_spec,
        harmogan.fig11_spec,
    )
    return [Run(f(), argv, harmogan.run_harmogan) for f in factories]


GROUPS: dict[str, Callable[[Path], list[Run]]] = {
    "mofusion_music": _mofusion_music,
    "mofusion_text": _mofusion_text,
    "momu_table7_10": _momu_table7_10,
    "momu_tables_2_4": _momu_tables(("momu_table2", "momu_table3", "momu_table4"), _loris_data),
    "momu_tables_5_6": _momu_tables(("momu_table5", "momu_table6"), lambda tmp: "synth"),
    "harmogan": _harmogan,
}

ABSENT_GENRES = ("jive", "quickstep", "rumba", "samba", "tango")
"""Ballroom genre columns the Dance with Melody stand-in (cha-cha, waltz) leaves empty."""


def _expect_complete(result: dict[str, Any], spec: TableSpec, md: str) -> None:
    """Every row of the spec, every column of each finite, the calibration rows, ``results.md``."""
    assert result["preset"] == "paper" and result["seeds"] == [0]
    assert [r["id"] for r in result["rows"]] == [r.id for r in spec.rows]
    keys = [c["key"] for c in result["columns"] if not c["key"].endswith(ABSENT_GENRES)]
    for row in result["rows"]:
        missing = [k for k in keys if not math.isfinite(row["metrics"].get(k, math.nan))]
        assert not missing, (spec.name, row["id"], missing)
        assert row["name"] in md, (spec.name, row["id"])
    assert result["calibration"] and all(c["metrics"] for c in result["calibration"]), spec.name


@pytest.mark.parametrize("group", list(GROUPS))
def test_paper_preset_runs_end_to_end(group: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    results = {}
    for run in GROUPS[group](tmp_path):
        name = run.spec.name
        assert run.runner(run.spec, [*FLAGS, "--out", str(out), *run.argv]) == 0, name
        result = json.loads((out / name / "results.json").read_text())
        _expect_complete(result, run.spec, (out / name / "results.md").read_text())
        if not name.startswith("harmogan"):  # MoMu and MoFusion rows carry clip ids (docs/statistics.md)
            for row in result["rows"]:
                assert set(row["clip_ids"]) == set(row["per_clip"]), (name, row["id"])
        results[name] = result
    CHECKS.get(group, lambda r: None)(results)


def _mofusion_music_checks(results: dict[str, Any]) -> None:
    s1, s2 = results["mofusion_supp_table1"], results["mofusion_supp_table2"]
    # the paper's 20-s windows over 3-s sequences: every sequence trained whole (A9), none dropped
    assert {r["config"]["method"]["window_seconds"] for r in s1["rows"]} == {20.0}
    assert set(s2["provenance"]["stages"].values()) == {"reused"}  # supp. A: no retraining
    ids = {r["id"]: r["clip_ids"]["bas"][0] for r in s1["rows"]}
    assert all(i.endswith("@0-2s") for i in ids["#1"]) and all(i.endswith("@0-3s") for i in ids["#2"])
    pairing = {tuple(p["rows"]): p["pairing"] for p in s1["orderings"]["bas"]["pairs"]}
    assert pairing[("#1", "#2")] == "per seed (the rows' clip ids differ)"  # 10-s vs 20-s crops
    assert pairing[("#2", "#3")] == "per clip (clip ids)"
    for row in s2["rows"]:
        assert row["config"]["method"]["evaluation"]["mode"] == "forecast"
        assert row["metrics"]["seed_error_cm"] < 1e-3  # the seed is kept exactly


def _mofusion_text_checks(results: dict[str, Any]) -> None:
    (row,) = results["mofusion_table2"]["rows"]
    lengths = sorted(float(i.rsplit("@0-", 1)[1][:-1]) for i in row["clip_ids"]["r_precision"][0])
    assert lengths == [f / 20.0 for f in HUMANML_TEST_FRAMES]  # each caption at its clip's length
    assert "from scratch" in row["artifacts"][0]["text_evaluator"]  # T2M's files unset: the fallback


CHECKS: dict[str, Callable[[dict[str, Any]], None]] = {
    "mofusion_music": _mofusion_music_checks,
    "mofusion_text": _mofusion_text_checks,
}
