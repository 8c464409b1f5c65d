"""HarmoGAN recipes at ``--preset smoke``: the real 8-dance subset where present, synth_dance otherwise."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.shared_data import shared_data_dir

from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.harmogan.recipes import table2_spec

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "WANDB_MODE": "disabled", "PYTHONHASHSEED": "0"}
DWM = shared_data_dir() / "dance_with_melody"
DATA = ("--data", str(DWM)) if DWM.is_dir() else ()
CALIBRATION = ["cal-shuffled", "cal-half-beat", "cal-static", "cal-fast"]


def _run(recipe: str, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, str(ROOT / "recipes" / f"{recipe}.py"), "--preset", "smoke", "--out", str(out)]
    cmd += ["--tracker", "none", *DATA, *extra]
    return subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=600, cwd=ROOT)


def _result(recipe: str, out: Path, *extra: str) -> dict:
    proc = _run(recipe, out, *extra)
    assert proc.returncode == 0, proc.stderr[-4000:]
    folder = out / recipe
    assert (folder / "results.md").read_text().count("## Pairwise comparisons of our rows") == 1
    assert (folder / "pairwise.json").is_file()
    return json.loads((folder / "results.json").read_text())


def test_tables_and_fig12_share_their_models(tmp_path: Path) -> None:
    if not DATA:  # synth_dance's styles are not ballroom genres: Tables I-II would have no columns
        pytest.skip(f"Tables I-II's genre columns need the real Dance with Melody subset ({DWM})")
    t1 = _result("harmogan_table1", tmp_path)
    assert [r["id"] for r in t1["rows"]] == ["harmogan", "wo-harmo", *CALIBRATION]
    row = t1["rows"][0]
    assert math.isfinite(row["metrics"]["h_average"]) and row["paper"]["h_average"] == 0.3527
    assert {"shuffled", "ground truth", "other condition"} <= set(row["comparisons"]["h_average"])
    assert [c["name"] for c in t1["calibration"]] == ["ground truth"]
    assert [b["name"] for b in t1["baselines"]] == ["Lee et al. [28]", "Ren et al. [18]"]
    assert "h_average" in t1["orderings"]  # HarmoGAN vs w/o L_harmo, paired per clip
    models = sorted((tmp_path / "harmogan_shared" / "models").iterdir())
    assert len(models) == 2 and all((m / "harmogan.json").is_file() for m in models)
    t2 = _result("harmogan_table2", tmp_path)
    assert t2["rows"][0]["paper"]["hit_rate_average"] == 75.73
    assert all(v == "reused" for k, v in t2["provenance"]["stages"].items())  # nothing trained twice
    f12 = _result("harmogan_fig12", tmp_path)
    assert {"h", "hit_rate"} <= set(f12["rows"][0]["metrics"])
    static = next(r for r in f12["rows"] if r["id"] == "cal-static")
    assert static["metrics"]["hit_rate"] > 50.0  # imperceptible jitter is full of salient visual beats
    assert (tmp_path / "harmogan_fig12" / "bars.png").is_file()


def test_fig9_and_fig11(tmp_path: Path) -> None:
    f9 = _result("harmogan_fig9", tmp_path)
    assert [r["id"] for r in f9["rows"]][:3] == ["gan", "gan-feat", "gan-feat-harmo"]
    gt = f9["calibration"][0]["metrics"]
    assert gt["mse"] == 0.0 and gt["foot_error"] == 0.0
    assert "ground truth" in f9["rows"][0]["comparisons"]["fid"]  # seed-level floor
    # like with like: the printed ground-truth pose FD is the floor every row is compared with
    assert gt["fid"] == pytest.approx(f9["rows"][0]["seed_values"]["fid"]["ground truth"][0])
    assert f9["rows"][0]["clip_ids"]["mse"][0] == f9["rows"][3]["clip_ids"]["mse"][0]  # paired by id
    f11 = _result("harmogan_fig11", tmp_path)
    pooled = next(r for r in f11["rows"] if r["id"] == "pooled")
    assert pooled["paper"] == {"agreement_h": 81.5} and 0.0 <= pooled["metrics"]["agreement_h"] <= 100.0
    assert f11["calibration"][0]["name"] == "ground truth"


def _ballroom(root: Path) -> Path:
    rng = np.random.default_rng(0)
    sr = 16000
    t = np.arange(7 * sr) / sr
    for folder in ("ChaChaCha", "Rumba-Misc", "VienneseWaltz"):
        (root / folder).mkdir(parents=True)
        for i in range(2):
            clicks = (np.sin(2 * np.pi * 2.0 * t + i) > 0.995).astype(np.float32)
            sf.write(
                str(root / folder / f"t{i}.wav"),
                clicks + 0.01 * rng.standard_normal(t.size).astype(np.float32),
                sr,
            )
    return root


def test_table1_ballroom_columns_and_bad_input(tmp_path: Path) -> None:
    root = _ballroom(tmp_path / "Ballroom")
    # cal-fast perturbs ground-truth dances: it stays on the Dance with Melody windows (their genres)
    rows = "harmogan,cal-static,cal-fast" if DATA else "harmogan,cal-static"
    result = _result("harmogan_table1", tmp_path / "out", f"ballroom.root={root}", "--rows", rows)
    cells = result["rows"][0]["metrics"]
    assert {"h_cha-cha", "h_rumba", "h_waltz"} <= set(cells) and "h_jive" not in cells
    assert "other condition" in result["rows"][0]["comparisons"]["h_waltz"]
    bad = _run("harmogan_table1", tmp_path / "bad", "method.weights.harmony=1")
    assert bad.returncode == 2 and "harmony" in bad.stderr.splitlines()[-1]
    assert not (tmp_path / "bad" / "harmogan_table1" / "results.json").exists()


def test_genre_tables_refuse_the_synthetic_stand_in(tmp_path: Path) -> None:
    """Tables I-II on synth_dance (no ballroom genre) fail before training, not with an empty table."""
    cmd = [sys.executable, str(ROOT / "recipes" / "harmogan_table2.py"), "--preset", "smoke"]
    proc = subprocess.run(
        [*cmd, "--out", str(tmp_path), "--tracker", "none"], capture_output=True, text=True, env=ENV, cwd=ROOT
    )
    last = proc.stderr.strip().splitlines()[-1]
    assert proc.returncode == 2 and "dance.synth_dataset.styles" in last and "--data" in last
    assert not (tmp_path / "harmogan_table2").exists()
    # a synthetic stand-in whose styles include a ballroom genre passes the check
    spec = table2_spec()
    styles = "dance.synth_dataset.styles=[waltz,hiphop]"
    configs = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "smoke", styles]))
    for cfg in configs.values():
        assert spec.check is not None
        spec.check(cfg)
