"""``recipes/mixing.py`` at ``--preset smoke``: every row end to end, and a bad loss name refused."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

from tests.helpers.launch import accelerate_launch

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "WANDB_MODE": "disabled", "PYTHONHASHSEED": "0"}
ROWS = ["base", "+kin", "+harmony", "+mfcc"]
FOLLOWING = ["input_sensitivity", "tempo_following", "tempo_match", "beat_phase_bailando", "matched_bailando"]


def test_mixing_smoke(tmp_path: Path) -> None:
    args = ("--preset", "smoke", "--out", str(tmp_path), "--tracker", "none")
    cmd = accelerate_launch(ROOT / "recipes" / "mixing.py", *args)
    proc = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-4000:]
    result = json.loads((tmp_path / "mixing" / "results.json").read_text())
    assert [r["id"] for r in result["rows"]] == ROWS
    for row in result["rows"]:
        for key in ("motion_fid", "motion_f1", "input_sensitivity", "bone_length_cv"):
            assert math.isfinite(row["metrics"][key]), (row["id"], key)
    rows = {r["id"]: r for r in result["rows"]}
    assert rows["+harmony"]["config"]["method"]["diffusion_losses"][0]["name"] == "harmony"
    assert rows["+mfcc"]["config"]["method"]["motion_condition"]["name"] == "mfcc"
    # the rows share the VAE stages and differ in the diffusion stage
    stages = result["provenance"]["stages"]
    assert sum(k.startswith("motion_vae-") for k in stages) == 1
    assert sum(k.startswith("diffusion-") for k in stages) == 4
    versus = result["versus_baseline"]
    assert versus["row"] == "base"
    assert [r["row"] for r in versus["columns"]["motion_f1"]] == ROWS[1:]
    assert all(k in result["calibration"][0]["metrics"] for k in FOLLOWING)
    md = (tmp_path / "mixing" / "results.md").read_text()
    assert "## Against the baseline row" in md and "+harmony (" in md


def test_mixing_bad_loss_name_is_one_line(tmp_path: Path) -> None:
    cmd = [
        sys.executable,
        str(ROOT / "recipes" / "mixing.py"),
        "--preset",
        "smoke",
        "--out",
        str(tmp_path),
        "--tracker",
        "none",
        "method.diffusion_losses=[{name: harmonyy}]",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=120, cwd=ROOT)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "method.diffusion_losses[0]" in lines[0], proc.stderr
    assert not (tmp_path / "mixing").exists()
