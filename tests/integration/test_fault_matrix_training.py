"""Issue 34, training: nothing lost, nothing hangs — kills, signals, resume, corrupt input, secrets.

One table of cases. Process-level ones start real ``momu train`` / recipe processes and send them
SIGKILL, SIGTERM or SIGINT (:mod:`tests.helpers.processes`); the others run in-process. The
resume cases compare every trained weight file byte for byte with one uninterrupted run
(:class:`Reference`, trained once per module). Bad input must be one line, exit status 2, and
nothing written.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch
from tests.helpers import processes as proc
from tests.unit.test_engine import CFG, _accelerator, _train

from momu.cli import main
from momu.engine.state import COMPLETE_MARKER, checkpoint_dirs, is_complete
from momu.engine.trainer import ResumeError

SMOKE = ("--preset", "smoke", "method.train_diffusion.steps=60")
"""A tiny ``momu train``: three stages, the last long enough to be interrupted in the middle."""

NO_CHECKPOINTS = ("method.train_diffusion.checkpoint_every=0", "method.train_diffusion.checkpoint_minutes=0")
EVERY_10 = ("method.train_diffusion.checkpoint_every=10",)
SECRET = "s3cr3t-value-34"


def _train_argv(out: Path, *extra: str) -> list[str]:
    return proc.momu_argv("-v", "train", "momu", "--out", str(out), *SMOKE, *extra)  # -v: "resumed from"


def _weights(out: Path) -> dict[str, bytes]:
    """Every trained weight file of a ``momu train`` folder (stages and model), by relative path."""
    files = [*out.glob("parts/*/model.safetensors"), *out.glob("models/*/*/model.safetensors")]
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(files)}


class Reference:
    """One uninterrupted ``momu train`` in a process (as the interrupted runs are), made when first used."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self._out: Path | None = None

    @property
    def out(self) -> Path:
        if self._out is None:
            out = self.root / "reference"
            done = proc.run(_train_argv(out))
            assert done.status == 0, done.stderr[-3000:]
            self._out = out
        return self._out

    @property
    def weights(self) -> dict[str, bytes]:
        found = _weights(self.out)
        assert len([k for k in found if k.startswith("parts/")]) == 3 and len(found) == 6, sorted(found)
        return found


def _assert_same_weights(out: Path, ref: Reference) -> None:
    got = _weights(out)
    assert sorted(got) == sorted(ref.weights)
    differ = [k for k in got if got[k] != ref.weights[k]]
    assert not differ, f"differ from the uninterrupted run: {differ}"


def _one_line(done: proc.Finished, status: int, *needles: str) -> str:
    assert done.status == status, done.stderr[-3000:]
    assert "Traceback" not in done.stderr, done.stderr[-3000:]
    lines = done.error_lines()
    assert len(lines) == 1, lines
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*")}


# ----------------------------------------------------------------------------- process-level cases


def sigkill_before_the_first_checkpoint(tmp: Path, ref: Reference) -> None:
    """Killed when stage 2 is saved, before the diffusion stage wrote anything: --resume reuses stages
    1-2 from the cache and trains the diffusion stage exactly as the uninterrupted run did."""
    out = tmp / "run"
    killed = proc.run_and_signal(
        _train_argv(out, *NO_CHECKPOINTS),
        proc.exists("parts/motion_vae-*/model.safetensors", out),
        proc.SIGKILL,
    )
    assert killed.status == 137
    assert not any(out.glob("parts/diffusion-*/model.safetensors")) and not any(out.glob("models/*"))
    done = proc.run(_train_argv(out, *NO_CHECKPOINTS, "--resume"))
    assert done.status == 0, done.stderr[-3000:]
    _assert_same_weights(out, ref)


def disk_fills_during_training_is_one_line_then_resume_finishes(tmp: Path, ref: Reference) -> None:
    """The disk fills when the diffusion stage saves its weights: status 1 and one line naming the file,
    no traceback, the first two stages kept; the same command with --resume, once there is space,
    reuses them and ends with the uninterrupted run's weights."""
    import contextlib
    import errno
    import io
    from unittest import mock

    import momu.engine.context as context

    real = context.write_safetensors

    def full(path: Path, *args: object, **kwargs: object) -> Path:
        if "diffusion-" in str(path):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, *args, **kwargs)  # type: ignore[arg-type]

    out = tmp / "run"
    err = io.StringIO()
    with mock.patch.object(context, "write_safetensors", full), contextlib.redirect_stderr(err):
        status = main(["train", "momu", "--out", str(out), *SMOKE, *NO_CHECKPOINTS])
    assert status == 1
    assert "Traceback" not in err.getvalue()
    lines = [line for line in err.getvalue().splitlines() if "error:" in line]
    assert len(lines) == 1 and "No space left on device" in lines[0] and "diffusion-" in lines[0], lines
    assert len(list(out.glob("parts/*/model.safetensors"))) == 2 and not any(out.glob("models/*"))
    done = proc.run(_train_argv(out, *NO_CHECKPOINTS, "--resume"))
    assert done.status == 0, done.stderr[-3000:]
    _assert_same_weights(out, ref)


def sigkill_after_a_checkpoint(tmp: Path, ref: Reference) -> None:
    out = tmp / "run"
    killed = proc.run_and_signal(
        _train_argv(out, *EVERY_10),
        proc.exists("parts/diffusion-*/checkpoints/step_00000020", out),
        proc.SIGKILL,
    )
    assert killed.status == 137
    done = proc.run(_train_argv(out, *EVERY_10, "--resume"))
    assert done.status == 0 and "resumed from" in done.stderr, done.stderr[-3000:]
    _assert_same_weights(out, ref)


def sigterm_checkpoints_then_resume_continues(tmp: Path, ref: Reference) -> None:
    out = tmp / "run"
    stopped = proc.run_and_signal(
        _train_argv(out, *EVERY_10),
        proc.exists("parts/diffusion-*/checkpoints/step_00000010", out),
        proc.SIGTERM,
    )
    line = _one_line(stopped, 143, "momu train: stopped by SIGTERM; checkpoint written to", "--resume")
    checkpoint = Path(line.split("checkpoint written to ", 1)[1].split(";", 1)[0])
    assert is_complete(checkpoint)
    done = proc.run(_train_argv(out, *EVERY_10, "--resume"))
    assert done.status == 0, done.stderr[-3000:]
    assert f"resumed from {checkpoint}" in done.stderr
    _assert_same_weights(out, ref)


def ctrl_c_is_one_line_and_status_130(tmp: Path, ref: Reference) -> None:
    out = tmp / "run"
    stopped = proc.run_and_signal(
        _train_argv(out, *EVERY_10),
        proc.exists("parts/diffusion-*/checkpoints/step_00000010", out),
        proc.SIGINT,
    )
    line = _one_line(stopped, 130, "momu train: stopped by SIGINT; checkpoint written to")
    assert is_complete(Path(line.split("checkpoint written to ", 1)[1].split(";", 1)[0]))


def table_sigterm_during_extractor_training_checkpoints_it(tmp: Path, ref: Reference) -> None:
    """The main job's first minutes train the learned-metric extractors: SIGTERM there keeps their
    progress (a checkpoint) and exits 143 with one line."""
    out = tmp / "out"
    argv = proc.recipe_argv(
        "momu_table7", "--preset", "smoke", "--rows", "1", "--tracker", "none", "--out", str(out),
        "method.evaluation.extractor_epochs=5000",
    )  # fmt: skip
    stopped = proc.run_and_signal(
        argv, proc.exists("momu_shared/parts/.locks/extractor-*.lock", out), proc.SIGTERM, delay=8.0
    )
    line = _one_line(stopped, 143, "momu_table7: stopped by SIGTERM; checkpoint written to", "--resume")
    checkpoint = Path(line.split("checkpoint written to ", 1)[1].split(";", 1)[0])
    assert checkpoint.parent.name.startswith("extractor-") and is_complete(checkpoint)


def launch_sigterm_to_the_trainer_ends_with_its_one_line(tmp: Path, ref: Reference) -> None:
    """Under ``accelerate launch`` the launcher turns the trainer's 143 into 1 and prints a
    ``CalledProcessError`` traceback after the trainer's line; the line is repeated last."""
    import signal
    import subprocess

    import psutil
    from tests.helpers.launch import LAUNCHER, accelerate_launch

    if not LAUNCHER.exists():
        pytest.skip("accelerate's launcher is not installed")
    out = tmp / "out"
    argv = accelerate_launch(
        proc.RECIPES / "momu_table7.py", "--preset", "smoke", "--rows", "1", "--tracker", "none",
        "--out", str(out), "method.evaluation.extractor_epochs=5000",
    )  # fmt: skip
    launcher = subprocess.Popen(
        argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        deadline = time.monotonic() + 300
        while not any(out.glob("momu_shared/parts/.locks/extractor-*.lock")):
            if launcher.poll() is not None:
                raise AssertionError(f"ended before the signal: {launcher.communicate()[1][-3000:]}")
            assert time.monotonic() < deadline, "the extractors never started"
            time.sleep(0.05)
        time.sleep(8.0)  # inside the extractor's training steps
        (trainer,) = [
            c for c in psutil.Process(launcher.pid).children() if "momu_table7" in " ".join(c.cmdline())
        ]
        trainer.send_signal(signal.SIGTERM)
        _, err = launcher.communicate(timeout=300)  # also waits for the epilogue (it holds stderr)
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
    assert launcher.returncode == 1  # the launcher's, whatever the child's
    assert "CalledProcessError" in err and "returned non-zero exit status 143" in err, err[-3000:]
    last = err.strip().splitlines()[-1]
    assert last.startswith("momu_table7: stopped by SIGTERM; checkpoint written to "), err[-3000:]
    assert err.count(last) == 2  # printed when it stopped, and again after the traceback
    assert is_complete(Path(last.split("checkpoint written to ", 1)[1].split(";", 1)[0]))


# ----------------------------------------------------------------------------- in-process cases


def diffusion_stage_removed_from_the_cache_retrains_identically(tmp: Path, ref: Reference) -> None:
    """The issue's reproduction: stages 1-2 loaded from the cache, the diffusion stage retrained."""
    out = tmp / "copy"
    shutil.copytree(ref.out, out)
    for folder in [*out.glob("parts/diffusion-*"), out / "models"]:
        shutil.rmtree(folder)
    torch.manual_seed(12345)  # whatever the process did before
    assert main(["train", "momu", "--out", str(out), *SMOKE]) == 0
    _assert_same_weights(out, ref)


def checkpoint_settings_keep_every_stage_folder(tmp: Path, ref: Reference) -> None:
    """Checkpoint and logging settings do not change the weights, so no stage folder (and no later
    stage's ``after`` hash) depends on them."""
    from momu.config import build_component, to_container
    from momu.engine.context import RunContext
    from momu.training import train_config

    acc = SimpleNamespace(num_processes=1, device=torch.device("cpu"), mixed_precision="no")
    ctx = RunContext(accelerator=acc, out_dir=tmp)  # type: ignore[arg-type]

    def folders(*overrides: str) -> list[str]:
        cfg = train_config("momu", preset="smoke", overrides=overrides)
        method = build_component(cfg.method, "methods")
        c = method.cfg
        train = {
            "music_vae": c.train_music_vae,
            "motion_vae": c.train_motion_vae,
            "diffusion": c.train_diffusion,
        }
        keys = method.stage_keys(to_container(cfg.dataset), 0)
        return [ctx.stage_folder_name(name, key, train[name]) for name, key in keys.items()]

    base = folders()
    assert folders("method.train_music_vae.checkpoint_every=7", "method.train_motion_vae.log_every=3") == base
    assert (
        folders("method.train_music_vae.checkpoint_minutes=1", "method.train_motion_vae.keep_checkpoints=5")
        == base
    )
    assert folders("method.train_music_vae.steps=3")[1:] != base[1:]  # a real change still renames them


def corrupt_same_size_checkpoint_is_skipped_for_the_last_good_one(tmp: Path, ref: Reference) -> None:
    acc = _accelerator(tmp)
    reference = _train(acc, tmp / "a", CFG, name="ref")  # 12 steps, checkpoints at 4, 8 and 12
    short = dataclasses.replace(CFG, steps=8, keep_checkpoints=0)
    _train(acc, tmp / "b", short)
    assert [p.name for p in checkpoint_dirs(tmp / "b")] == ["step_00000004", "step_00000008"]
    weights = tmp / "b" / "step_00000008" / "model.safetensors"
    data = bytearray(weights.read_bytes())
    data[-4:] = bytes(b ^ 0x55 for b in data[-4:])  # same size, other bytes (a tensor value)
    weights.write_bytes(bytes(data))
    assert is_complete(weights.parent)  # the size check alone cannot see it
    resumed = _train(acc, tmp / "b", CFG, model_seed=99, resume=True)  # from step 4, not the corrupt 8
    for (name, a), (_, b) in zip(reference.state_dict().items(), resumed.state_dict().items()):
        assert torch.equal(a, b), name


def no_intact_checkpoint_refuses_to_resume(tmp: Path, ref: Reference) -> None:
    acc = _accelerator(tmp)
    _train(acc, tmp / "b", dataclasses.replace(CFG, steps=4))
    (only,) = checkpoint_dirs(tmp / "b")
    weights = only / "optimizer.safetensors"
    data = bytearray(weights.read_bytes())
    data[-1] ^= 0xFF
    weights.write_bytes(bytes(data))
    with pytest.raises(ResumeError, match=r"no complete checkpoint.*intact.*step_00000004"):
        _train(acc, tmp / "b", CFG, resume=True)
    assert (only / COMPLETE_MARKER).is_file()  # nothing deleted


def stage_weights_do_not_depend_on_what_ran_before(tmp: Path, ref: Reference) -> None:
    """RunContext.stage seeds the builder, the data and the loop from (run seed, stage name)."""
    from tests.unit.test_engine import _data, _loss

    from momu.engine.context import RunContext

    def build() -> torch.nn.Module:
        return torch.nn.Sequential(torch.nn.Linear(3, 8), torch.nn.Tanh(), torch.nn.Linear(8, 1))

    cfg = dataclasses.replace(CFG, checkpoint_every=0, seed=5)
    trained = []
    for i, burn in enumerate((0, 7)):
        torch.rand(burn)  # another history of the global RNG
        ctx = RunContext(accelerator=_accelerator(tmp), out_dir=tmp / f"run{i}")
        trained.append(ctx.stage("toy", {"stage": "toy"}, build, _data(), _loss, cfg).state_dict())
    for name, value in trained[0].items():
        assert torch.equal(value, trained[1][name]), name


def extractor_training_resumes_bit_identically(tmp: Path, ref: Reference) -> None:
    import signal

    import momu.metrics.extractors.training as extractor_training
    from momu.data.synth import SynthConfig, SynthDance
    from momu.encoders.dstformer import DSTformerConfig
    from momu.engine.trainer import Preempted
    from momu.metrics.extractors import MotionClassifierConfig
    from momu.metrics.extractors.training import Checkpointing, TrainConfig, train_motion_classifier

    synth = SynthDance(
        SynthConfig(num_clips=8, min_seconds=3.0, max_seconds=3.0, skeleton="openpose14", fps=15.0)
    )
    clips = [synth[i] for i in range(len(synth))]
    cfg = MotionClassifierConfig(
        hidden=16, dstformer=DSTformerConfig(dim_feat=8, dim_rep=8, depth=1, num_heads=2)
    )
    train = TrainConfig(epochs=3, batch_size=4, samples_per_clip=2, val_fraction=0.0)
    reference, _ = train_motion_classifier(clips, cfg, train)
    calls = {"n": 0}
    real = extractor_training.F.cross_entropy

    def cross_entropy(*args: object, **kwargs: object) -> torch.Tensor:
        calls["n"] += 1
        if calls["n"] == 5:  # a step inside the second epoch
            os.kill(os.getpid(), signal.SIGTERM)
        return real(*args, **kwargs)  # type: ignore[arg-type]

    checkpoints = Checkpointing(tmp / "ckpt", resume=False, minutes=0)
    extractor_training.F.cross_entropy = cross_entropy  # type: ignore[assignment]
    try:
        with pytest.raises(Preempted, match="SIGTERM") as err:
            train_motion_classifier(clips, cfg, train, checkpoints)
    finally:
        extractor_training.F.cross_entropy = real
    assert is_complete(err.value.checkpoint)  # written after the step the signal arrived in
    torch.manual_seed(777)
    resumed, summary = train_motion_classifier(
        clips, cfg, train, dataclasses.replace(checkpoints, resume=True)
    )
    assert len(summary["loss_history"]) == 3
    for name, value in reference.state_dict().items():
        assert torch.equal(value, resumed.state_dict()[name]), name


def job_progress_has_an_eta_from_the_first_steps(tmp: Path, ref: Reference) -> None:
    from momu.engine.progress import JobProgress, planned_steps
    from momu.training import train_config

    cfg = train_config("momu", preset="smoke")
    from momu.config import to_container

    assert planned_steps(to_container(cfg)) == 2 + 2 + 3  # smoke: music VAE, motion VAE, diffusion
    progress = JobProgress("table", units=4, enabled=False)
    assert progress.eta() is None
    progress.start_unit("row #1 seed 0", planned=100)
    progress.stage_done("music_vae", 20, "reused")
    time.sleep(0.05)
    progress.stage_step("diffusion", 5, 80)  # a quarter of the first unit
    eta = progress.eta()
    assert eta is not None and eta > 0
    progress.finish_unit()
    assert progress.done == 1
    progress.close()


_STEPPING_WORKER = """
import sys, time
from momu.engine.table_workers import serve_units

def run(unit, progress):
    progress.planned = 30
    for step in range(1, 31):
        time.sleep(0.1)
        progress.stage_step("diffusion", step, 30)
    progress.stage_done("diffusion", 30, "trained")

sys.exit(serve_units(run, {"#1", "#2"}))
"""


def jobs_parent_has_an_eta_from_the_first_steps(tmp: Path, ref: Reference) -> None:
    """``--jobs 2``: the parent's one progress line follows both workers' steps and has an ETA long
    before the first unit ends (it used to log an ETA only as units finished)."""
    from momu.engine.progress import JobProgress
    from momu.engine.table_units import Unit
    from momu.engine.table_workers import run_units_in_workers

    seen: list[tuple[int, float | None, str]] = []

    class Watched(JobProgress):
        def unit_steps(self, label: str, steps_done: int, planned: int, stage: str) -> None:
            super().unit_steps(label, steps_done, planned, stage)
            seen.append((self.done, self.eta(), self._stage_text()))

    script = tmp / "worker.py"
    script.write_text(_STEPPING_WORKER)
    progress = Watched("t", units=2, enabled=False)
    units = [Unit("#1", 0), Unit("#2", 0)]
    assert run_units_in_workers(str(script), [], units, 2, 1, tmp / "logs", "t", progress) == []
    progress.close()
    early = [(eta, text) for done, eta, text in seen if done == 0 and eta is not None]
    assert early, seen  # an ETA while no unit had finished
    assert any("row #1 seed 0: diffusion" in text and "row #2 seed 0: diffusion" in text for _, text in early)
    assert progress.done == 2 and progress.eta() == 0.0


# ----------------------------------------------------------------------------- bad input: one line, 2


def _bad_train(
    *overrides: str, data: Callable[[Path], list[str]] | None = None
) -> Callable[[Path], list[str]]:
    def argv(tmp: Path) -> list[str]:
        extra = data(tmp) if data is not None else []
        return ["train", "momu", "--preset", "smoke", "--out", str(tmp / "o"), *extra, *overrides]

    return argv


def _train_out(out: Callable[[Path], str]) -> Callable[[Path], list[str]]:
    """``momu train`` into the ``--out`` that ``out(tmp)`` names (checked before any work)."""
    return lambda tmp: ["train", "momu", "--preset", "smoke", "--out", out(tmp)]


def _table(*args: str) -> Callable[[Path], list[str]]:
    """A table recipe (run in-process below), its arguments after ``--preset smoke --tracker none``."""
    return lambda tmp: ["momu_table7", "--preset", "smoke", "--tracker", "none", *args]


def _corrupt_dance(tmp: Path) -> list[str]:
    from tests.fixtures import layouts

    layouts.write_dance_with_melody(tmp / "dwm", bad=["bad_json"])
    return ["--data", str(tmp / "dwm")]


def _show(*overrides: str) -> Callable[[Path], list[str]]:
    return lambda tmp: ["config", "show", str(proc.RECIPES / "configs" / "momu.yaml"), *overrides]


DECODE = "real_data.root=${oc.decode:'$\\{oc.env:MOMU_TEST_SECRET\\}'}"
PIECES = ("ballroom.root=$", "real_data.root=${ballroom.root}{oc.env:MOMU_TEST_SECRET}")


@dataclass(frozen=True)
class BadInput:
    argv: Callable[[Path], list[str]]
    names: str


BAD_INPUT = {
    "train-corrupt-data-file": BadInput(_bad_train(data=_corrupt_dance), "DANCE_R_10/skeletons.json"),
    "train-unknown-top-level-key": BadInput(_bad_train("sed=3"), "sed: unknown key"),
    "train-env-through-decode": BadInput(_bad_train(DECODE), "real_data.root: resolver 'oc.decode'"),
    "train-env-from-pieces": BadInput(_bad_train(*PIECES), "real_data.root: resolves to text holding"),
    "config-env-through-decode": BadInput(_show(DECODE), "real_data.root: resolver 'oc.decode'"),
    "config-env-from-pieces": BadInput(_show(*PIECES), "real_data.root: resolves to text holding"),
    "config-env-create": BadInput(_show("real_data.root=${oc.create:'x'}"), "resolver 'oc.create'"),
    "config-resolver-name-built": BadInput(_show("real_data.root=${${seed}:HOME}"), "real_data.root"),
    # --out: a probe file is created and removed (os.access says yes to root, also in /proc)
    "train-out-on-a-read-only-file-system": BadInput(
        _train_out(lambda tmp: "/proc/momu-out/o"), "--out /proc/momu-out/o: cannot write in /proc"
    ),
    "train-out-folder-name-too-long": BadInput(
        _train_out(lambda tmp: str(tmp / ("x" * 300))), "folder name too long"
    ),
    "train-out-is-a-file": BadInput(
        _train_out(lambda tmp: str(proc.RECIPES / "configs" / "momu.yaml")), "exists and is a file"
    ),
    "table-out-on-a-read-only-file-system": BadInput(
        _table("--out", "/proc/momu-out"), "--out /proc/momu-out: cannot write in /proc"
    ),
}


def _main(argv: list[str]) -> int:
    """``momu ARGV``, or a table recipe (``momu_table7 ARGS``) run in-process as its script runs it."""
    if argv[0] != "momu_table7":
        return main(argv)
    from momu.engine.table import run_table
    from momu.methods.momu.recipes import table7_spec

    return run_table(table7_spec(proc.RECIPES / "configs" / "momu.yaml"), argv[1:])


def _bad_input_case(case: BadInput) -> Callable[[Path, Reference], None]:
    def check(tmp: Path, ref: Reference) -> None:
        argv = case.argv(tmp)
        before = _snapshot(tmp)
        os.environ["MOMU_TEST_SECRET"] = SECRET
        try:
            status = _main(argv)
        finally:
            del os.environ["MOMU_TEST_SECRET"]
        assert status == 2
        assert _snapshot(tmp) == before  # nothing written (no --out folder, no config.yaml)

    check.names = case.names  # type: ignore[attr-defined]
    return check


CASES: dict[str, Callable[[Path, Reference], None]] = {
    "sigkill-before-the-first-checkpoint": sigkill_before_the_first_checkpoint,
    "sigkill-after-a-checkpoint": sigkill_after_a_checkpoint,
    "disk-fills-during-training": disk_fills_during_training_is_one_line_then_resume_finishes,
    "sigterm-checkpoints-then-resume-continues": sigterm_checkpoints_then_resume_continues,
    "ctrl-c-one-line-130": ctrl_c_is_one_line_and_status_130,
    "table-sigterm-during-extractor-training": table_sigterm_during_extractor_training_checkpoints_it,
    "launch-sigterm-one-line-last": launch_sigterm_to_the_trainer_ends_with_its_one_line,
    "diffusion-removed-from-the-cache": diffusion_stage_removed_from_the_cache_retrains_identically,
    "checkpoint-settings-keep-stage-folders": checkpoint_settings_keep_every_stage_folder,
    "corrupt-same-size-checkpoint": corrupt_same_size_checkpoint_is_skipped_for_the_last_good_one,
    "no-intact-checkpoint-refuses": no_intact_checkpoint_refuses_to_resume,
    "stage-seeding-ignores-history": stage_weights_do_not_depend_on_what_ran_before,
    "extractor-resume-bit-identical": extractor_training_resumes_bit_identically,
    "job-progress-eta-from-the-start": job_progress_has_an_eta_from_the_first_steps,
    "jobs-parent-progress-eta-from-the-start": jobs_parent_has_an_eta_from_the_first_steps,
    **{name: _bad_input_case(case) for name, case in BAD_INPUT.items()},
}


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Reference:
    return Reference(tmp_path_factory.mktemp("reference"))


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_fault_matrix(
    case: str, tmp_path: Path, reference: Reference, capsys: pytest.CaptureFixture[str]
) -> None:
    check = CASES[case]
    check(tmp_path, reference)
    names = getattr(check, "names", None)
    if names is not None:  # a bad-input case: one line naming the culprit, no secret anywhere
        out, err = capsys.readouterr()
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and "error:" in lines[0], err
        assert names in lines[0], lines[0]
        assert SECRET not in out + err
