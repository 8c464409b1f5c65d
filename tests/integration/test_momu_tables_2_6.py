"""MoMu-Diffusion Tables 2–6 recipes at ``--preset smoke`` (every row, calibration and paper row).

All five recipes run in-process into ONE output folder, in the order of ``nox -s reproduce``, so
Tables 5 and 6 reuse the AIST++ stand-in model Table 2 trained (``<out>/momu_shared``) — the test
checks that sharing too. The numbers of the smoke preset mean nothing; the tests check structure,
finiteness, the paper's numbers, the by-construction calibration values, and failures before training.
"""

from __future__ import annotations

import json
import math
import runpy
import sys
from pathlib import Path
from typing import Any

import pytest
from safetensors.torch import load_file

from momu.config import ConfigError
from momu.engine.table import parse_table_args, resolve_row_configs, run_table
from momu.methods.momu.tables import (
    TABLE_SPECS,
    table2_spec,
    table3_spec,
    table4_spec,
    table5_spec,
    table6_spec,
)
from momu.methods.momu.tables_setup import PAPER, SHARED_DIR, beat_percent, check_subsets, subset_config

REPO = Path(__file__).resolve().parents[2]
CONFIGS = REPO / "recipes" / "configs"
# keep the smoke runs small: 2 evaluation clips per subset
FLAGS = ["--preset", "smoke", "--tracker", "none"]
SMALL = ["method.evaluation.num_clips=2"]  # overrides go last (one positional list)


def _spec(name: str) -> Any:
    return TABLE_SPECS[name](CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")


@pytest.fixture(scope="module")
def smoke_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    out = tmp_path_factory.mktemp("tables_2_6")
    results = {}
    for name in ("momu_table2", "momu_table5", "momu_table6", "momu_table3", "momu_table4"):
        status = run_table(_spec(name), [*FLAGS, "--out", str(out), *SMALL])
        assert status == 0, name
        results[name] = json.loads((out / name / "results.json").read_text())
        results[name]["_dir"] = out / name
    return results


def _finite(values: dict[str, float], keys: list[str], where: str) -> None:
    for key in keys:
        assert key in values, f"{where}: {key} missing"
        assert math.isfinite(values[key]), f"{where}: {key} = {values[key]}"


@pytest.mark.parametrize("name", ["momu_table2", "momu_table3", "momu_table4", "momu_table5", "momu_table6"])
def test_every_cell_present_and_finite(smoke_runs: dict[str, dict[str, Any]], name: str) -> None:
    result = smoke_runs[name]
    keys = [c["key"] for c in result["columns"]]
    [ours] = result["rows"]
    assert ours["id"] == "ours"
    _finite(ours["metrics"], keys, f"{name} ours")
    assert {c["name"] for c in result["calibration"]} == {
        "ground truth",
        "ground truth, music and motion shuffled",
    }
    for cal in result["calibration"]:
        _finite(cal["metrics"], keys, f"{name} {cal['name']}")
    # our row carries the paper's "Ours" numbers; the baselines are the paper's, not re-run
    assert ours["paper"] == PAPER[name]["Ours"]
    assert [b["name"] for b in result["baselines"]] == [n for n in PAPER[name] if n != "Ours"]
    assert all(b["re_run"] is False for b in result["baselines"])
    md = (result["_dir"] / "results.md").read_text()
    assert "not re-run" in md and "(calibration)" in md
    assert result["preset"] == "smoke" and result["provenance"]["num_processes"] == 1


@pytest.mark.parametrize("name", ["momu_table2", "momu_table3", "momu_table4"])
def test_music_ground_truth_calibration_is_perfect(smoke_runs: dict[str, dict[str, Any]], name: str) -> None:
    """Ground-truth music against itself: BCS = BHS = F1 = onset F1 = 100, CSD = HSD = 0 (by construction)."""
    gt = next(c for c in smoke_runs[name]["calibration"] if c["name"] == "ground truth")["metrics"]
    for col in smoke_runs[name]["columns"]:
        metric = col["key"].split("_", 1)[1]
        expected = 0.0 if metric in ("csd", "hsd") else 100.0
        assert gt[col["key"]] == pytest.approx(expected), col["key"]


def test_length_tables_have_both_length_columns(smoke_runs: dict[str, dict[str, Any]]) -> None:
    assert [c["key"] for c in smoke_runs["momu_table3"]["columns"]][:6] == [
        "fe25_bcs", "fe25_csd", "fe25_bhs", "fe25_hsd", "fe25_f1", "fe25_onset_f1",
    ]  # fmt: skip
    assert {c["key"][:4] for c in smoke_runs["momu_table4"]["columns"]} == {"fs25", "fs50"}
    # Table 3–4 train the learnable motion encoder stage, not the motion VAE
    stages = smoke_runs["momu_table3"]["provenance"]["stages"]
    assert any(s.startswith("learnable_motion2music-") for s in stages)
    assert not any(s.startswith("motion_vae-") for s in stages)
    # the encoder's input standardisation was fitted on the training motion and saved with the weights
    shared = smoke_runs["momu_table3"]["_dir"].parent / SHARED_DIR / "parts"
    for stage in (s for s in stages if s.startswith("learnable_motion2music-")):
        weights = load_file(str(shared / stage / "model.safetensors"))
        assert not bool((weights["encoder.input_std"] == 1).all()), stage
        assert not bool((weights["encoder.input_mean"] == 0).all()), stage


def test_tables_5_and_6_reuse_the_shared_models(smoke_runs: dict[str, dict[str, Any]]) -> None:
    """Table 2 trains the AIST++ stand-in; Table 5 reuses it and trains BHS; Table 6 reuses both."""
    t2 = smoke_runs["momu_table2"]["provenance"]["stages"]
    t5 = smoke_runs["momu_table5"]["provenance"]["stages"]
    t6 = smoke_runs["momu_table6"]["provenance"]["stages"]
    aist = {k for k, v in t2.items() if v == "trained"}
    assert aist and all(t5[k] == "reused" for k in aist)
    assert sorted(k for k, v in t5.items() if v == "trained")  # the BHS stand-in
    assert all(v == "reused" for k, v in t6.items() if not k.startswith("extractor-"))
    shared = smoke_runs["momu_table2"]["_dir"].parent / SHARED_DIR / "parts"
    assert all((shared / k / "model.safetensors").is_file() for k in aist)


def test_table6_quality_calibration(smoke_runs: dict[str, dict[str, Any]]) -> None:
    cal = {c["name"]: c["metrics"] for c in smoke_runs["momu_table6"]["calibration"]}
    gt, shuf = cal["ground truth"], cal["ground truth, music and motion shuffled"]
    for sid in ("aist", "bhs"):
        # FID and Diversity are distributional: shuffling the pairs does not change them
        assert shuf[f"{sid}_fid"] == gt[f"{sid}_fid"]
        assert shuf[f"{sid}_diversity"] == gt[f"{sid}_diversity"]
        assert shuf[f"{sid}_mean_kld"] >= 0.0


def test_plots_written(smoke_runs: dict[str, dict[str, Any]]) -> None:
    assert (smoke_runs["momu_table2"]["_dir"] / "aist_beats.png").is_file()
    assert (smoke_runs["momu_table5"]["_dir"] / "bhs_beats.png").is_file()


# ------------------------------------------------------------------------------------------ fast checks
def test_paper_cells_match_columns() -> None:
    """Every printed paper number has a column, and every beat/quality column has a printed number."""
    for name, factory in TABLE_SPECS.items():
        spec = factory(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")
        keys = {c.key for c in spec.columns}
        paper_keys = {k for k in keys if not k.endswith("onset_f1")}
        for row, cells in PAPER[name].items():
            assert set(cells) == paper_keys, (name, row)
    assert PAPER["momu_table2"]["Ours"]["aist_f1"] == 98.1
    assert PAPER["momu_table6"]["Ours"]["bhs_diversity"] == 67.4
    # the paper's Table 4 block repeats Table 3's baselines verbatim (reported as printed)
    for row in ("Foley", "CMT", "D2MGAN", "CDCD", "LORIS"):
        t3 = {k[2:]: v for k, v in PAPER["momu_table3"][row].items()}
        t4 = {k[2:]: v for k, v in PAPER["momu_table4"][row].items()}
        assert t3 == t4


def test_beat_percent_scales_and_names() -> None:
    scores = {
        "beat_scores.bcs": 0.5,
        "beat_scores.csd": 0.1,
        "beat_scores.bhs": 0.25,
        "beat_scores.hsd": 0.0,
        "beat_scores.f1": 1 / 3,
    }
    out = beat_percent("aist", scores)
    assert out == pytest.approx(
        {"aist_bcs": 50.0, "aist_csd": 10.0, "aist_bhs": 25.0, "aist_hsd": 0.0, "aist_f1": 100 / 3}
    )
    with pytest.raises(KeyError, match="f1"):
        beat_percent("aist", {"bcs": 1.0, "csd": 0.0, "bhs": 1.0, "hsd": 0.0})


def test_subset_config_lengths_and_real_data(tmp_path: Path) -> None:
    spec = table3_spec(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")
    cfg = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "cpu"]))["ours"]
    fe50 = subset_config(cfg, "fe50")
    assert fe50.dataset.name == "synth_dance"
    assert fe50.dataset.min_seconds == fe50.dataset.max_seconds == 8.0
    assert fe50.method.evaluation.seconds == 8.0 and fe50.method.window_seconds == 8.0
    assert fe50.method.window_hop_seconds == 4.0
    smoke = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "smoke"]))["ours"]
    assert subset_config(smoke, "fe25").method.evaluation.seconds == 2.0
    with pytest.raises(ConfigError, match="subsets.nope"):
        subset_config(cfg, "nope")
    # --data DIR: the real loader under DIR, COCO-17 keypoints for the VAE; a missing folder fails early
    real = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "cpu", "--data", str(tmp_path)]))[
        "ours"
    ]
    fe25 = subset_config(real, "fe25")
    assert fe25.dataset.name == "loris" and fe25.dataset.subset == "fe" and fe25.dataset.seconds == 25
    assert fe25.dataset.root == f"{tmp_path.resolve()}/loris"
    assert fe25.method.encoder.num_joints == 17
    with pytest.raises(FileNotFoundError, match="loris"):
        check_subsets(real, ["fe25"])


def test_bad_arguments_fail_before_training(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = table2_spec(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")
    cases = [
        (["--rows", "nope"], []),
        (["--data", str(tmp_path / "missing")], []),
        ([], ["learnable_encoder.depthh=2"]),
    ]
    for flags, overrides in cases:
        assert run_table(spec, [*FLAGS, "--out", str(tmp_path), *flags, *SMALL, *overrides]) == 2
    err = capsys.readouterr().err
    assert "unknown row nope" in err and "missing" in err and "depthh" in err
    assert not (tmp_path / "momu_shared").exists()
    for factory in (table4_spec, table5_spec, table6_spec):
        assert factory(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml").presets.keys() == {
            "smoke",
            "cpu",
            "paper",
        }


def test_recipe_scripts_print_help(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for n in range(2, 7):
        monkeypatch.setattr(sys, "argv", [f"momu_table{n}.py", "--help"])
        with pytest.raises(SystemExit) as exc:
            runpy.run_path(str(REPO / "recipes" / f"momu_table{n}.py"), run_name="__main__")
        assert exc.value.code == 0
        assert f"Table {n}" in capsys.readouterr().out


def test_real_bhs_dance_without_audio_fails_before_training(tmp_path: Path) -> None:
    """BHS Dance (d2m layout) ships MFCC features only: the row stops, naming the missing variant."""
    from tests.fixtures import layouts

    layouts.write_d2m(tmp_path / "d2m")
    spec = table5_spec(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")
    cfg = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "smoke", "--data", str(tmp_path)]))[
        "ours"
    ]
    assert subset_config(cfg, "bhs").dataset.root == str(tmp_path.resolve() / "d2m")
    with pytest.raises(ValueError, match="no raw audio.*not implemented"):
        check_subsets(cfg, ["bhs"])
