"""The table runner: early validation, shared-stage caching, results and provenance."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
import torch
from omegaconf import DictConfig
from torch import nn
from torch.utils.data import TensorDataset

from momu.engine import TrainConfig
from momu.engine.context import RunContext
from momu.engine.provenance import git_commit
from momu.engine.table import Column, PaperRow, Row, TableSpec, run_table
from momu.registry import METHODS


@dataclass
class ToyMethodConfig:
    width: int = 4
    steps: int = 3


@pytest.fixture(autouse=True)
def toy_method():
    METHODS.register("table_toy", config=ToyMethodConfig)(lambda cfg: cfg)
    yield
    METHODS.unregister("table_toy")


def _evaluate(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, float]:
    torch.manual_seed(seed)
    x = torch.randn(16, 2)
    data = TensorDataset(x, x.sum(1, keepdim=True))
    model = nn.Sequential(nn.Linear(2, cfg.method.width), nn.Linear(cfg.method.width, 1))
    trained = ctx.stage(
        "toy",
        {"width": cfg.method.width, "seed": seed},
        model,
        data,
        lambda m, b: ((m(b[0]) - b[1]) ** 2).mean(),
        TrainConfig(steps=cfg.method.steps, batch_size=4),
    )
    with torch.no_grad():
        return {
            "mse": float(((trained(x) - x.sum(1, keepdim=True)) ** 2).mean()),
            "width": float(cfg.method.width),
        }


SPEC = TableSpec(
    name="toy_table",
    title="Toy table",
    base_config={"method": {"name": "table_toy"}, "seed": 0},
    presets={"smoke": ["method.steps=2"], "cpu": [], "paper": ["method.steps=50"]},
    columns=[Column("mse", "MSE↓", False), Column("width", "W", True)],
    rows=[Row("#1", "narrow", ("method.width=2",), {"mse": 0.5}), Row("#2", "wide", ("method.width=8",))],
    evaluate=_evaluate,
    calibrate=lambda ctx, cfg, seed: {"ground truth": {"mse": 0.0}},
    baselines=[PaperRow("Someone et al.", {"mse": 0.9})],
)


def test_full_run_writes_results_with_paper_numbers_and_provenance(tmp_path: Path) -> None:
    assert (
        run_table(SPEC, ["--preset", "smoke", "--out", str(tmp_path), "--tracker", "none", "--seeds", "0,1"])
        == 0
    )
    result = json.loads((tmp_path / "toy_table" / "results.json").read_text())
    assert [r["id"] for r in result["rows"]] == ["#1", "#2"]
    assert result["rows"][0]["paper"] == {"mse": 0.5}
    assert result["rows"][1]["metrics"]["width"] == 8.0 and len(result["rows"][1]["per_seed"]) == 2
    assert result["rows"][0]["config"]["method"] == {"name": "table_toy", "width": 2, "steps": 2}
    assert [(c["name"], c["metrics"]) for c in result["calibration"]] == [("ground truth", {"mse": 0.0})]
    assert result["baselines"][0]["re_run"] is False
    prov = result["provenance"]
    assert prov["num_processes"] == 1 and prov["versions"]["torch"].startswith("2.")
    assert len(prov["stages"]) == 4 and set(prov["stages"].values()) == {"trained"}
    md = (tmp_path / "toy_table" / "results.md").read_text()
    assert "| #1 | narrow |" in md and "not re-run" in md and "ground truth (calibration)" in md


def test_rerunning_one_row_reuses_its_trained_stage(tmp_path: Path) -> None:
    args = ["--preset", "smoke", "--out", str(tmp_path), "--tracker", "none"]
    assert run_table(SPEC, args) == 0
    assert run_table(SPEC, [*args, "--rows", "#2"]) == 0
    result = json.loads((tmp_path / "toy_table" / "results.json").read_text())
    assert [r["id"] for r in result["rows"]] == ["#2"]
    assert set(result["provenance"]["stages"].values()) == {"reused"}
    assert "Stages from other commits" not in (tmp_path / "toy_table" / "results.md").read_text()


def test_a_stage_reused_from_another_commit_is_named_in_the_results(tmp_path: Path) -> None:
    args = ["--preset", "smoke", "--out", str(tmp_path), "--tracker", "none", "--rows", "#2"]
    assert run_table(SPEC, args) == 0
    (record,) = (tmp_path / "toy_table" / "parts").glob("toy-*/stage.json")
    meta = json.loads(record.read_text())
    assert meta["git_commit"] == git_commit()  # the commit that trained it
    record.write_text(json.dumps({**meta, "git_commit": "0123abc"}))
    assert run_table(SPEC, args) == 0
    result = json.loads((tmp_path / "toy_table" / "results.json").read_text())
    assert list(result["provenance"]["stages"].values()) == ["reused, trained at 0123abc"]
    md = (tmp_path / "toy_table" / "results.md").read_text()
    assert f"1 reused stage(s) were trained at another commit than this run's ({record.parent.name};" in md
    del meta["git_commit"]  # a stage written before commits were recorded
    record.write_text(json.dumps(meta))
    assert run_table(SPEC, args) == 0
    result = json.loads((tmp_path / "toy_table" / "results.json").read_text())
    assert list(result["provenance"]["stages"].values()) == ["reused, trained at an unrecorded commit"]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--rows", "#9"], "--rows: unknown row #9; valid rows: #1, #2"),
        (
            ["method.widht=3"],
            "override 'method.widht=3': method.widht: unknown key for method 'table_toy'; "
            "valid keys: width, steps",
        ),
        (["--data", "/no/such/dir"], "--data /no/such/dir: dataset folder not found"),
    ],
)
def test_bad_arguments_fail_before_training(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    assert run_table(SPEC, ["--out", str(tmp_path), "--tracker", "none", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"toy_table: error: {message}"
    assert not (tmp_path / "toy_table").exists()


def test_overrides_may_sit_between_flags() -> None:
    from momu.engine.table import parse_table_args

    args = parse_table_args(SPEC, ["method.width=3", "--preset", "smoke", "seed=2", "--rows", "#1"])
    assert args.overrides == ["method.width=3", "seed=2"] and args.preset == "smoke" and args.rows == ["#1"]


def test_a_bare_row_number_names_the_hash_row() -> None:
    from momu.engine.table import parse_table_args

    assert parse_table_args(SPEC, ["--rows", "2,#1"]).rows == ["#2", "#1"]
    assert parse_table_args(SPEC, ["--rows", "9"]).rows == ["9"]  # still unknown, reported as given


def test_seeds_accept_spaces_or_commas_and_overrides_after_them() -> None:
    from momu.engine.table import parse_table_args

    assert parse_table_args(SPEC, ["--seeds", "0", "1"]).seeds == [0, 1]
    assert parse_table_args(SPEC, ["--seeds", "0,1,2"]).seeds == [0, 1, 2]
    args = parse_table_args(SPEC, ["--seeds", "3", "4", "method.width=5"])
    assert args.seeds == [3, 4] and args.overrides == ["method.width=5"]


def test_default_seeds_follow_the_preset(tmp_path: Path) -> None:
    from momu.engine.table import _seeds, parse_table_args, resolve_row_configs

    for preset, expected in (("smoke", [0]), ("cpu", [0, 1, 2])):
        args = parse_table_args(SPEC, ["--preset", preset])
        first = next(iter(resolve_row_configs(SPEC, args).values()))
        assert _seeds(SPEC, args, first) == expected


def test_cells_print_mean_and_interval_over_seeds(tmp_path: Path) -> None:
    argv = ["--preset", "smoke", "--out", str(tmp_path), "--tracker", "none", "--seeds", "0", "1", "2"]
    assert run_table(SPEC, argv) == 0
    result = json.loads((tmp_path / "toy_table" / "results.json").read_text())
    row = result["rows"][0]
    mses = [s["mse"] for s in row["per_seed"]]
    from momu.engine.statistics import t_interval

    assert row["metrics"]["mse"] == pytest.approx(sum(mses) / 3)
    assert row["interval"]["mse"] == pytest.approx(t_interval(mses).half_width)
    md = (tmp_path / "toy_table" / "results.md").read_text()
    assert "± the half-width of the 95 % Student-t interval" in md
    assert f"| #1 | narrow | {row['metrics']['mse']:.3g} ± {row['interval']['mse']:.3g} |" in md


def test_worker_arguments_drop_the_parent_only_flags() -> None:
    from momu.engine.table_units import Unit
    from momu.engine.table_workers import worker_argv

    argv = ["--preset", "cpu", "--jobs", "2", "--seeds", "0", "1,2", "seed=3", "--rows=#7", "--threads", "1"]
    assert worker_argv(argv) == ["--preset", "cpu", "seed=3"]
    assert Unit.parse("#7:2") == Unit("#7", 2) and Unit("Tc=0.5T", 0).token == "Tc=0.5T:0"
    with pytest.raises(ValueError, match="ROW:SEED"):
        Unit.parse("#7")


def test_resume_reuses_finished_units_without_evaluating_them(tmp_path: Path) -> None:
    argv = ["--preset", "smoke", "--out", str(tmp_path), "--tracker", "none", "--rows", "#1"]
    assert run_table(SPEC, argv) == 0
    cells = list((tmp_path / "toy_table" / "cells").glob("1-seed0-*.json"))
    assert len(cells) == 1
    calls: list[int] = []

    def counting(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, float]:
        calls.append(seed)
        return _evaluate(ctx, cfg, seed)

    from dataclasses import replace

    assert run_table(replace(SPEC, evaluate=counting), [*argv, "--resume"]) == 0
    assert calls == []  # the finished unit came from its cell
    assert run_table(replace(SPEC, evaluate=counting), argv) == 0
    assert calls == [0]  # without --resume the unit is evaluated again (its stages are reused)


_FAKE_WORKER = """
import os, sys
while line := sys.stdin.readline():
    token, log = line.rstrip("\\n").split("\\t")
    with open(log, "w") as f:
        f.write(f"pid {os.getpid()}\\n")
    if token == "#2:0":
        sys.exit(3)  # dies without reporting
    status = 1 if token == "#1:1" else 0
    if token == "#3:0":  # stray output, sent in one piece with the report
        sys.stdout.write("not a report\\n")
    print(f"{token}\\t{status}", flush=True)
    if status:
        sys.exit(status)
"""


def test_workers_start_after_librosa_kernels_are_cached(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Workers started together must find numba's cache filled (numba/numba#10128 crashes otherwise)."""
    from momu.engine import table_workers
    from momu.engine.table_units import Unit
    from momu.engine.table_workers import run_units_in_workers

    events: list[str] = []
    monkeypatch.setattr(table_workers, "warm_librosa_kernels", lambda: events.append("warm"))
    real_popen = table_workers.subprocess.Popen

    def popen(*args: object, **kwargs: object) -> object:
        events.append("worker")
        return real_popen(*args, **kwargs)  # type: ignore[call-overload]

    monkeypatch.setattr(table_workers.subprocess, "Popen", popen)
    script = tmp_path / "worker.py"
    script.write_text(_FAKE_WORKER)
    units = [Unit("#1", 0), Unit("#3", 0)]
    failed = run_units_in_workers(str(script), [], units, jobs=2, threads=1, logs=tmp_path / "logs", name="t")
    assert failed == []
    assert events == ["warm", "worker", "worker"]


def test_workers_run_several_units_each_and_failures_end_only_their_worker(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from momu.engine.table_units import Unit
    from momu.engine.table_workers import run_units_in_workers

    script = tmp_path / "worker.py"
    script.write_text(_FAKE_WORKER)
    units = [Unit("#1", 0), Unit("#1", 1), Unit("#2", 0), Unit("#3", 0), Unit("#3", 1), Unit("#3", 2)]
    logs = tmp_path / "logs"
    failed = run_units_in_workers(str(script), [], units, jobs=2, threads=1, logs=logs, name="t")
    assert sorted(failed, key=str) == sorted([Unit("#1", 1), Unit("#2", 0)], key=str)
    pids = {(logs / f"{u.row[1:]}-seed{u.seed}.log").read_text() for u in units}  # every unit ran
    # at most 2 workers + one replacement per failure: some worker ran several units
    assert len(pids) <= 4 < len(units)
    assert "unexpected output of a worker: b'not a report'" in caplog.text


def test_a_worker_sends_each_units_output_to_its_log_and_stops_at_a_failure(tmp_path: Path) -> None:
    script = tmp_path / "serve.py"
    script.write_text(
        "import sys\n"
        "from momu.engine.table_workers import serve_units\n"
        "def run(unit, progress):\n"
        "    print('stdout of', unit.token)\n"
        "    sys.stderr.write(f'stderr of {unit.token}\\n')\n"
        "    if unit.seed == 1:\n"
        "        raise RuntimeError('broken unit')\n"
        "sys.exit(serve_units(run, {'#7'}))\n"
    )
    feed = "".join(f"#7:{k}\t{tmp_path / f'u{k}.log'}\n" for k in range(3))
    proc = subprocess.run(
        [sys.executable, str(script)], input=feed, capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 1
    assert proc.stdout == "#7:0\t0\n#7:1\t1\n"  # reports only; unit #7:2 never ran
    assert (tmp_path / "u0.log").read_text() == "stdout of #7:0\nstderr of #7:0\n"
    assert "RuntimeError: broken unit" in (tmp_path / "u1.log").read_text()
    assert not (tmp_path / "u2.log").exists()


def test_warming_fills_numba_cache_with_the_beat_kernels() -> None:
    """tests/conftest.py warms this worker's own cache folder: beat_track's kernels are in it."""
    import os

    cached = [p.name for p in Path(os.environ["NUMBA_CACHE_DIR"]).rglob("*.nbi")]
    assert any("beat" in name for name in cached), cached


def test_a_worker_trains_the_extractor_nobody_is_training_and_waits_only_to_score(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two --jobs workers that need both FID/FAD extractors train one each instead of queueing."""
    import threading
    from contextlib import ExitStack

    from omegaconf import OmegaConf

    from momu.engine import RunConfig, make_accelerator
    from momu.methods.momu import scoring

    accelerator = make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {})
    ctx = RunContext(accelerator=accelerator, out_dir=tmp_path)
    digest = scoring.stage_key_hash({"data": {"name": "d"}, "epochs": 1, "samples_per_clip": 1, "seed": 0})
    motion = ctx.parts_dir / f"extractor-motion-{digest}.safetensors"
    other_worker = ExitStack()
    assert other_worker.enter_context(ctx.lock(motion.stem)) is True  # it is training the motion extractor
    with ctx.lock(motion.stem, wait=False) as held:
        assert held is False  # a lock another job holds is refused at once
    trained: list[str] = []

    def train(kind: str, clips: object, path: Path, **kwargs: object) -> None:
        trained.append(kind)
        path.write_bytes(b"")

    monkeypatch.setattr("momu.methods.momu.data.select_split", lambda dataset, split: [0])
    monkeypatch.setattr(scoring, "train_extractor", train)
    monkeypatch.setattr(scoring, "load_extractor", lambda path: path.name.split("-")[1])
    ev = OmegaConf.create({"extractor_epochs": 1, "extractor_samples_per_clip": 1})
    give_up = threading.Timer(10.0, other_worker.close)  # a worker that waits fails the test, not hangs
    give_up.start()
    try:
        # a unit starts the extractors before it trains its own stages
        scoring.start_extractors(ctx, ["clip"], {"name": "d"}, ev, ("motion", "audio"))
        assert trained == ["audio"]  # it trained the audio extractor instead of waiting for the motion one
        motion.write_bytes(b"")  # the other worker finishes the motion extractor
        other_worker.close()
        got = scoring.trained_extractors(ctx, ["clip"], {"name": "d"}, ev)  # when it scores
    finally:
        give_up.cancel()
    assert trained == ["audio"]
    assert got == {"motion": "motion", "audio": "audio"}
    assert ctx.trained[motion.stem].startswith("reused")


def test_every_process_passes_one_barrier_per_extractor_whatever_it_finds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Under ``accelerate launch`` with 2 processes the main process may finish a small extractor before
    another process looks for it: that process must still pass the same barriers (one per extractor),
    or it pairs with the next extractor's barrier and the processes hang (seen in the two-process Table 7
    smoke test)."""
    from types import SimpleNamespace

    from omegaconf import OmegaConf

    from momu.methods.momu import scoring

    barriers: list[str] = []
    ctx = RunContext(
        accelerator=SimpleNamespace(  # type: ignore[arg-type]
            num_processes=2, is_main_process=False, wait_for_everyone=lambda: barriers.append("barrier")
        ),
        out_dir=tmp_path,
    )
    ev = OmegaConf.create({"extractor_epochs": 1, "extractor_samples_per_clip": 1})
    paths = scoring._extractor_paths(ctx, {"name": "d"}, ev, ("motion", "audio"))
    paths["motion"].parent.mkdir(parents=True, exist_ok=True)
    paths["motion"].write_bytes(b"")  # the main process has already written the motion extractor
    monkeypatch.setattr(
        scoring, "train_extractor", lambda *a, **k: pytest.fail("only the main process trains")
    )
    scoring._train_missing_extractors(ctx, None, ev, paths, wait=True)
    assert barriers == ["barrier", "barrier"]
    assert ctx.trained[paths["motion"].stem].startswith("reused")
