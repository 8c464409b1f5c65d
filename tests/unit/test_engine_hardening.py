"""Issue 13, the engine: crash-safe checkpoints, default interval, stage keys, trackers, threads, orphans."""

from __future__ import annotations

import dataclasses
import logging
import os
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch
from tests.unit.test_engine import CFG, _accelerator, _train

from momu.engine import TrainConfig
from momu.engine import signals as signals_mod
from momu.engine import state as state_mod
from momu.engine import trainer as trainer_mod
from momu.engine.context import stage_identity, stage_key_hash
from momu.engine.state import (
    COMPLETE_MARKER,
    checkpoint_dirs,
    incomplete_checkpoints,
    is_complete,
    latest_checkpoint,
    prune_checkpoints,
)
from momu.engine.trainer import ResumeError

FINISHED = dataclasses.replace(CFG, checkpoint_every=0)  # 12 steps, one checkpoint at the end


def _finished_stage(tmp_path: Path) -> tuple[object, Path]:
    acc = _accelerator(tmp_path)
    root = tmp_path / "ckpt"
    _train(acc, root, FINISHED)
    assert [p.name for p in checkpoint_dirs(root)] == ["step_00000012"]
    return acc, root


def _weights(model: torch.nn.Module) -> dict[str, torch.Tensor]:
    return {k: v.clone() for k, v in model.state_dict().items()}


def test_a_kill_between_the_two_renames_of_a_replace_loses_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Re-saving ``step_N``: killed after the old folder moved away, before the new one moved in."""
    acc, root = _finished_stage(tmp_path)
    reference = _weights(_train(acc, root, FINISHED, resume=True))  # nothing left to train: loads it
    real_rename = os.rename

    def killed(src: str | Path, dst: str | Path) -> None:
        if Path(src).name.startswith(".staging_"):
            raise KeyboardInterrupt  # the process dies here
        real_rename(src, dst)

    monkeypatch.setattr(state_mod.os, "rename", killed)
    with pytest.raises(KeyboardInterrupt):
        _train(acc, root, FINISHED, resume=True)  # the final save replaces step_12
    monkeypatch.setattr(state_mod.os, "rename", real_rename)
    assert not (root / "step_00000012").exists()  # old one renamed away, new one still staged
    resumed = _train(acc, root, FINISHED, resume=True)  # must not restart from step 0
    assert latest_checkpoint(root).name == "step_00000012"
    for key, value in _weights(resumed).items():
        assert torch.equal(value, reference[key]), key


def test_only_a_staging_copy_left_is_restored_not_a_silent_restart(tmp_path: Path) -> None:
    acc, root = _finished_stage(tmp_path)
    reference = _weights(_train(acc, root, FINISHED, resume=True))
    os.rename(root / "step_00000012", root / ".staging_00000012")
    resumed = _train(acc, root, FINISHED, model_seed=99, resume=True)
    assert (root / "step_00000012").is_dir() and not (root / ".staging_00000012").exists()
    for key, value in _weights(resumed).items():
        assert torch.equal(value, reference[key]), key


def test_a_half_written_step_folder_is_skipped_and_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    acc = _accelerator(tmp_path)
    root = tmp_path / "ckpt"
    reference = _weights(_train(acc, root, dataclasses.replace(CFG, keep_checkpoints=0)))  # step 4, 8, 12
    (root / "step_00000012" / "optimizer.json").unlink()  # the failure the fault run found
    assert not is_complete(root / "step_00000012")
    assert [p.name for p in incomplete_checkpoints(root)] == ["step_00000012"]
    caplog.set_level(logging.WARNING)
    resumed = _train(acc, root, CFG, model_seed=99, resume=True)  # resumes from step 8, retrains 9-12
    assert "skipping incomplete checkpoint" in caplog.text and "step_00000012" in caplog.text
    for key, value in _weights(resumed).items():  # a silent restart from step 0 would differ (seed 99)
        assert torch.equal(value, reference[key]), key


def test_resume_with_only_incomplete_checkpoints_refuses_to_start_over(tmp_path: Path) -> None:
    acc, root = _finished_stage(tmp_path)
    (root / "step_00000012" / COMPLETE_MARKER).unlink()
    with pytest.raises(ResumeError, match="no complete checkpoint.*step_00000012.*delete"):
        _train(acc, root, FINISHED, resume=True)


def test_a_truncated_file_makes_a_checkpoint_incomplete(tmp_path: Path) -> None:
    _, root = _finished_stage(tmp_path)
    tensors = root / "step_00000012" / "model.safetensors"
    tensors.write_bytes(tensors.read_bytes()[:-4])
    assert latest_checkpoint(root) is None


def test_pruning_renames_away_before_deleting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    acc = _accelerator(tmp_path)
    root = tmp_path / "ckpt"
    _train(acc, root, dataclasses.replace(CFG, keep_checkpoints=0))
    assert len(checkpoint_dirs(root)) == 3

    def killed_rmtree(path: str | Path, ignore_errors: bool = False) -> None:
        (Path(path) / "model.safetensors").unlink()  # half deleted, then the process dies
        raise KeyboardInterrupt

    monkeypatch.setattr(state_mod.shutil, "rmtree", killed_rmtree)
    with pytest.raises(KeyboardInterrupt):
        prune_checkpoints(root, keep=1)
    monkeypatch.undo()
    # the half-deleted folder is not named step_* any more: it cannot count as a checkpoint
    assert [p.name for p in checkpoint_dirs(root)] == ["step_00000008", "step_00000012"]
    assert all(is_complete(p) for p in root.glob("step_*"))
    state_mod.recover_checkpoints(root)
    assert not list(root.glob(".pruned_*"))


def test_checkpoints_are_written_by_default_during_a_long_stage(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert TrainConfig().checkpoint_minutes > 0 and TrainConfig().checkpoint_every == 0
    clock = {"t": 0.0}

    def fake_monotonic() -> float:
        clock["t"] += 121.0  # two minutes per call: the 10-minute default falls due every few steps
        return clock["t"]

    monkeypatch.setattr(trainer_mod.time, "monotonic", fake_monotonic)
    acc = _accelerator(tmp_path)
    root = tmp_path / "ckpt"
    _train(acc, root, TrainConfig(steps=12, batch_size=4, lr=1e-2, keep_checkpoints=0, seed=3))
    steps = [p.name for p in checkpoint_dirs(root)]
    assert len(steps) >= 3 and steps[-1] == "step_00000012"  # mid-stage checkpoints, then the final one


def test_checkpoint_tensor_files_get_default_permissions(tmp_path: Path) -> None:
    umask = os.umask(0o022)
    try:
        _, root = _finished_stage(tmp_path)
    finally:
        os.umask(umask)
    modes = {p.name: p.stat().st_mode & 0o777 for p in (root / "step_00000012").iterdir()}
    assert set(modes.values()) == {0o644}, modes


def _stub_accelerator(processes: int) -> SimpleNamespace:
    return SimpleNamespace(num_processes=processes, device=torch.device("cpu"), mixed_precision="no")


def test_the_stage_key_holds_process_count_effective_batch_and_threads() -> None:
    key = {"stage": "x", "train": dataclasses.asdict(TrainConfig(batch_size=8))}
    one = stage_identity(key, _stub_accelerator(1), TrainConfig(batch_size=8))  # type: ignore[arg-type]
    two = stage_identity(key, _stub_accelerator(2), TrainConfig(batch_size=8))  # type: ignore[arg-type]
    assert stage_key_hash(one) != stage_key_hash(two)
    assert two["run"]["num_processes"] == 2 and two["run"]["effective_batch"] == 16
    assert one["run"]["threads"] == torch.get_num_threads()
    accum = stage_identity(key, _stub_accelerator(1), TrainConfig(batch_size=8, grad_accum=2))  # type: ignore[arg-type]
    assert stage_key_hash(accum) != stage_key_hash(one)


def test_checkpoint_settings_do_not_change_the_stage_key() -> None:
    a = {"stage": "x", "train": dataclasses.asdict(TrainConfig(checkpoint_every=0, checkpoint_minutes=10))}
    b = {
        "stage": "x",
        "train": dataclasses.asdict(TrainConfig(checkpoint_every=50, checkpoint_minutes=1, log_every=5)),
    }
    acc = _stub_accelerator(1)
    assert stage_key_hash(stage_identity(a, acc, TrainConfig())) == stage_key_hash(
        stage_identity(b, acc, TrainConfig())
    )  # type: ignore[arg-type]


def test_tracker_steps_are_monotonic_across_stages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    acc = _accelerator(tmp_path)
    calls: list[tuple[dict[str, float], object]] = []
    monkeypatch.setattr(acc, "log", lambda values, step=None, **kw: calls.append((dict(values), step)))
    cfg = dataclasses.replace(FINISHED, log_every=4)
    _train(acc, tmp_path / "a", cfg, name="vae")
    _train(acc, tmp_path / "b", cfg, name="diffusion")
    assert calls and all(step is None for _, step in calls)  # the tracker's own step counts on
    assert [v["vae/step"] for v, _ in calls if "vae/step" in v] == [4, 8, 12]
    assert [v["diffusion/step"] for v, _ in calls if "diffusion/step" in v] == [4, 8, 12]


def test_wandb_is_quiet_unless_asked(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from momu.engine import RunConfig, finish_accelerator, make_accelerator

    monkeypatch.delenv("WANDB_SILENT", raising=False)
    monkeypatch.setenv("WANDB_MODE", "disabled")
    acc = make_accelerator(RunConfig(tracker="wandb"), tmp_path, "quiet", {})
    finish_accelerator(acc)
    assert os.environ["WANDB_SILENT"] == "true"
    monkeypatch.setenv("WANDB_SILENT", "false")  # asked for: left alone
    acc = make_accelerator(RunConfig(tracker="wandb"), tmp_path, "loud", {})
    finish_accelerator(acc)
    assert os.environ["WANDB_SILENT"] == "false"


def test_momu_sets_its_thread_count_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    from momu.engine.accelerate_setup import configure_threads

    before = torch.get_num_threads()
    try:
        monkeypatch.setenv("OMP_NUM_THREADS", "1")  # what accelerate launch sets for its children
        monkeypatch.setenv("MOMU_NUM_THREADS", "2")
        assert configure_threads() == 2 and torch.get_num_threads() == 2
        monkeypatch.delenv("MOMU_NUM_THREADS")
        monkeypatch.setenv("LOCAL_WORLD_SIZE", "1")
        import psutil

        assert configure_threads() == max(1, psutil.cpu_count(logical=False) or 1)  # OMP_NUM_THREADS ignored
        monkeypatch.setenv("MOMU_NUM_THREADS", "zero")
        with pytest.raises(ValueError, match="MOMU_NUM_THREADS"):
            configure_threads()
    finally:
        torch.set_num_threads(before)


def test_a_trainer_whose_launcher_died_checkpoints_and_stops(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An orphaned trainer (its ``accelerate launch`` killed) must not keep writing into ``--out``."""
    import momu.errors

    parent = os.getppid()
    monkeypatch.setattr(momu.errors, "launcher_pid", lambda: parent)
    calls = {"n": 0}

    def getppid() -> int:
        calls["n"] += 1
        return parent if calls["n"] < 4 else 1  # re-parented to init after a few steps

    monkeypatch.setattr(signals_mod.os, "getppid", getppid)
    acc = _accelerator(tmp_path)
    with pytest.raises(trainer_mod.Preempted, match="accelerate launcher") as err:
        _train(acc, tmp_path / "ckpt", FINISHED)
    assert is_complete(err.value.checkpoint)
