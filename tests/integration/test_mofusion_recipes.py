"""MoFusion recipes at ``--preset smoke``: Table 1, supp. Tables 1–2 (sharing one output folder, so
supp. Table 2 reuses supp. Table 1's models), Table 2 (text)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "WANDB_MODE": "disabled", "PYTHONHASHSEED": "0"}


def _run(recipe: str, out: Path) -> dict:
    cmd = [
        sys.executable,
        str(ROOT / "recipes" / recipe),
        "--preset",
        "smoke",
        "--out",
        str(out),
        "--tracker",
        "none",
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads((out / recipe.removesuffix(".py") / "results.json").read_text())


def _finite(row: dict, keys: list[str]) -> None:
    for key in keys:
        assert math.isfinite(row["metrics"][key]), (row.get("id"), key)


def test_table1_smoke(tmp_path: Path) -> None:
    result = _run("mofusion_table1.py", tmp_path)
    (row,) = result["rows"]
    _finite(row, ["bas", "fid_k", "div_k", "multimodality"])
    assert row["paper"] == {"bas": 0.253, "fid_k": 50.31, "div_k": 9.09, "multimodality": 11.38}
    assert set(row["comparisons"]["bas"]) == {"shuffled", "ground truth", "other condition"}
    assert set(row["comparisons"]["fid_k"]) == {"ground truth"}
    names = [c["name"] for c in result["calibration"]]
    assert names == ["ground truth", "ground truth, music and motion shuffled"]
    assert len(result["baselines"]) == 6 and not result["baselines"][0]["re_run"]
    model = tmp_path / "mofusion_table1" / row["artifacts"][0]["model"] / "mofusion.json"
    assert model.is_file()


def test_supp_tables_smoke_share_models(tmp_path: Path) -> None:
    s1 = _run("mofusion_supp_table1.py", tmp_path)
    assert [r["id"] for r in s1["rows"]] == ["#1", "#2", "#3", "#4"]
    for row in s1["rows"]:
        _finite(row, ["bas", "bone_std_cm", "asym_cm"])
        assert set(row["comparisons"]["bone_std_cm"]) == {"ground truth"}
    assert sum(k.startswith("mofusion-") for k in s1["provenance"]["stages"]) == 3  # #1 and #2 share
    s2 = _run("mofusion_supp_table2.py", tmp_path)
    assert set(s2["provenance"]["stages"].values()) == {"reused"}  # no retraining (supp. A)
    for row in s2["rows"]:
        _finite(row, ["bas", "bas_after_seed", "seed_error_cm", "boundary_jump"])
        assert row["metrics"]["seed_error_cm"] < 1e-3  # the seed is kept exactly


def test_table2_text_smoke(tmp_path: Path) -> None:
    result = _run("mofusion_table2.py", tmp_path)
    (row,) = result["rows"]
    _finite(row, ["diversity", "multimodality", "r_precision", "mm_dist"])
    assert set(row["comparisons"]["r_precision"]) == {"shuffled", "ground truth", "other condition"}
    assert set(row["comparisons"]["diversity"]) == {"ground truth", "shuffled"}
    assert result["columns"][0]["closer_to"] == "ground truth"
    assert [c["name"] for c in result["calibration"]] == [
        "real text–motion pairs",
        "text and motion shuffled",
    ]
    md = (tmp_path / "mofusion_table2" / "results.md").read_text()
    assert "Diversity→ closer to ground truth is better" in md
