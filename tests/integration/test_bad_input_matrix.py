"""Bad input across the commands (issue 13): exit status, one line naming the file or key, nothing written.

Each case builds its inputs under ``tmp_path``, snapshots the folder, runs the command in-process
(``momu ...`` through :func:`momu.cli.main`, the Table 7 recipe through :func:`run_table` at
``--preset smoke``, which must fail before training), and checks

* the exit status (2: usage or input error; 1: ``data check`` found a bad file);
* one ``error:`` line (``data check``: one ``BAD`` line) that names the file or the key;
* that no file under ``tmp_path`` was created or changed (no output, no ``wandb/`` folder).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.unit.test_metrics_beats_audio import SR, clicks

from momu.cli import main
from momu.export import write_motion_npz

RECIPES = Path(__file__).resolve().parents[2] / "recipes"


def _swing(frames: int, joints: int, dims: int = 3) -> np.ndarray:
    t = np.arange(frames)[:, None, None] / 30.0
    base = np.random.default_rng(0).normal(size=(1, joints, dims))
    return (base + 0.1 * np.sin(2 * np.pi * 2 * t)).astype(np.float32)


def _pairs(root: Path, *, gen_audio: bool = False, gen_joints: int = 24, seconds: float = 5.0) -> None:
    gen, gt = root / "gen", root / "gt"
    gen.mkdir(parents=True)
    gt.mkdir(parents=True)
    for i in range(2):
        np.save(gen / f"c{i}.npy", _swing(int(30 * seconds), gen_joints))
        np.save(gt / f"c{i}.npy", _swing(int(30 * seconds), 24))
        sf.write(gt / f"c{i}.wav", clicks([1.0, 2.0, 3.0, 4.0], seconds), SR)
        if gen_audio:
            sf.write(gen / f"c{i}.wav", clicks([1.5, 2.5, 3.5], seconds), SR)


def _eval(root: Path, metrics: str, *extra: str) -> list[str]:
    return [
        "eval",
        "--gen",
        str(root / "gen"),
        "--gt",
        str(root / "gt"),
        "--metrics",
        metrics,
        "--fps",
        "30",
        *extra,
    ]


def _wav(path: Path, seconds: float = 1.0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    sf.write(path, clicks([0.5], seconds), SR)
    return path


@dataclass
class Case:
    id: str
    setup: Callable[[Path], list[str]]  # builds inputs, returns argv (recipe: "recipe" first)
    names: str  # what the one-line message must contain
    status: int = 2


MOMU_YAML = str(RECIPES / "configs" / "momu.yaml")
TRAIN_SMOKE = ("train", "momu", "--preset", "smoke", "--out", "ROOT/o")
EXTRACTOR = ("extractor", "train", "--kind", "motion")


def _show(*overrides: str) -> Callable[[Path], list[str]]:
    return lambda root: ["config", "show", MOMU_YAML, *overrides]


def _recipe(*argv: str) -> Callable[[Path], list[str]]:
    return lambda root: [
        "recipe",
        "--preset",
        "smoke",
        "--tracker",
        "wandb",
        "--out",
        str(root / "out"),
        *argv,
    ]


def _momu(*argv: str) -> Callable[[Path], list[str]]:
    """``momu ARGV``, ``ROOT`` in an argument standing for the test's folder."""
    return lambda root: [a.replace("ROOT", str(root)) for a in argv]


def _bad_yaml(root: Path) -> list[str]:
    (root / "bad.yaml").write_text("seed: [1, 2\n")
    return ["config", "show", str(root / "bad.yaml")]


def _corrupt_npy(root: Path) -> list[str]:
    _pairs(root)
    data = (root / "gen" / "c0.npy").read_bytes()
    (root / "gen" / "c0.npy").write_bytes(data[:6] + b"\x09\x00" + data[8:])  # format version 9.0
    return _eval(root, "bas")


def _fps_sidecar(root: Path) -> list[str]:
    _pairs(root)
    (root / "gen" / "c1.json").write_text('{"fps": 60}')
    return _eval(root, "fid_k")


def _unpaired(root: Path) -> list[str]:
    _pairs(root)
    np.save(root / "gen" / "extra.npy", _swing(30, 24))
    return _eval(root, "bas")


def _with_pairs(metrics: str, *extra: str, **kw: object) -> Callable[[Path], list[str]]:
    def setup(root: Path) -> list[str]:
        _pairs(root, **kw)  # type: ignore[arg-type]
        return _eval(root, metrics, *[e.replace("ROOT", str(root)) for e in extra])

    return setup


def _generate(*argv: str, model: bool = True, wav: bool = True) -> Callable[[Path], list[str]]:
    def setup(root: Path) -> list[str]:
        if model:
            (root / "model").mkdir()
        if wav:
            _wav(root / "song.wav")
        (root / "afile").write_text("x")
        (root / "adir").mkdir()
        write_motion_npz(root / "motion.npz", _swing(30, 24), 20.0, "smpl24")  # 1.5 s
        args = [a.replace("ROOT", str(root)) for a in argv]
        return ["generate", *args[:1], "--model", str(root / "model"), *args[1:]]

    return setup


def _method_model(method: str, task: str, *argv: str) -> Callable[[Path], list[str]]:
    """``momu generate`` with a MoFusion / HarmoGAN model folder that holds only its record."""

    def setup(root: Path) -> list[str]:
        inner = _generate(*argv)(root)
        skeleton = {"harmogan": "dwm21", "music": "smpl24", "text": "humanml22"}[
            task if method == "mofusion" else method
        ]
        record = {"format": 1, "method": method, "skeleton": skeleton, "config": {"task": task}}
        (root / "model" / f"{method}.json").write_text(json.dumps(record))
        return inner

    return setup


_OUT = ("--out", "ROOT/o")
_MOTION = ("--motion", "ROOT/motion.npz")
_SONG_OUT = ("--music", "ROOT/song.wav", *_OUT)


def _dwm_bad(root: Path) -> list[str]:
    from tests.fixtures import layouts

    layouts.write_dance_with_melody(root / "dwm", bad=["nan_beyond"])
    return ["data", "check", "dance_with_melody", "--root", str(root / "dwm"), "--no-progress"]


def _synth_nonempty(root: Path) -> list[str]:
    (root / "data").mkdir()
    (root / "data" / "keep.txt").write_text("mine")
    return ["data", "synth", "--out", str(root / "data"), "--clips", "2", "--seconds", "1", "--no-progress"]


def _empty_dir(root: Path) -> str:
    (root / "empty").mkdir()
    return str(root / "empty")


CASES = [
    # config show
    Case("config-unknown-top-key", _show("zz=1"), "zz: unknown key"),
    Case("config-unknown-evaluation-node", _show("evaluation.zz=1"), "evaluation: unknown key"),
    Case("config-typo-seed", _show("sed=3"), "sed: unknown key"),
    Case("config-innermost-node", _show("method.train_diffusion.stpes=10"), "(TrainConfig)"),
    Case("config-missing-file", lambda root: ["config", "show", str(root / "nope.yaml")], "nope.yaml"),
    Case("config-bad-yaml", _bad_yaml, "bad.yaml"),
    Case("config-env-interpolation", _show("method.vocoder.n_iter=${oc.env:HOME}"), "method.vocoder.n_iter"),
    Case("config-override-syntax", _show("novalue"), "'novalue'"),
    Case("config-unknown-part", _show("method.music_backbone=nope"), "method.music_backbone"),
    # eval
    Case("eval-missing-folder", lambda root: _eval(root, "bas"), "gen"),
    Case("eval-unpaired", _unpaired, "extra"),
    Case("eval-unknown-metric", _with_pairs("bas,not_a_metric"), "not_a_metric"),
    Case("eval-scored-modality-missing", _with_pairs("beat_scores"), "beat_scores"),
    Case("eval-skeleton-mismatch", _with_pairs("bas", gen_joints=17), "c0.npy"),
    Case("eval-corrupt-npy", _corrupt_npy, "c0.npy: not a valid .npy file"),
    Case("eval-out-is-a-folder", _with_pairs("bas", "--out", "ROOT"), "--out"),
    Case("eval-unknown-metric-key", _with_pairs("bas", "--set", "bas.nope=1"), "bas.nope"),
    Case("eval-fps-mismatch", _fps_sidecar, "c1.npy"),
    # generate
    Case(
        "generate-out-suffix", _generate("dance", "--music", "ROOT/song.wav", "--out", "ROOT/o.xyz"), "o.xyz"
    ),
    Case("generate-input-missing", _generate("dance", "--music", "ROOT/no.wav", "--out", "ROOT/o"), "no.wav"),
    Case(
        "generate-out-parent-is-a-file",
        _generate("dance", "--music", "ROOT/song.wav", "--out", "ROOT/afile/o.npz"),
        "afile",
    ),
    Case(
        "generate-out-is-a-file",
        _generate("dance", "--music", "ROOT/song.wav", "--out", "ROOT/afile"),
        "--out",
    ),
    Case(
        "generate-model-not-saved",
        _generate("dance", "--music", "ROOT/song.wav", "--out", "ROOT/o"),
        "--model",
    ),
    Case("generate-input-not-audio", _generate("dance", "--music", "ROOT/afile", "--out", "ROOT/o"), "afile"),
    Case(
        "generate-motion-unknown-type",
        _generate("music", "--motion", "ROOT/afile", "--out", "ROOT/o"),
        "afile",
    ),
    Case(
        "generate-joint-with-a-harmogan-model",
        _method_model("harmogan", "music", "joint", "--out", "ROOT/o"),
        "--model",
    ),
    Case(
        "generate-text-with-a-music-model",
        _method_model("mofusion", "music", "text", "--caption", "a person jumps", "--out", "ROOT/o"),
        "--model",
    ),
    Case(
        "generate-dance-with-a-text-model",
        _method_model("mofusion", "text", "dance", "--music", "ROOT/song.wav", "--out", "ROOT/o"),
        "generate text",
    ),
    Case(
        "generate-guidance-with-mofusion",
        _method_model(
            "mofusion", "music", "dance", "--music", "ROOT/song.wav", "--out", "ROOT/o", "--guidance", "3"
        ),
        "--guidance",
    ),
    # generate forecast / inbetween / edit (MoFusion's inpainting tasks)
    Case(
        "generate-forecast-with-a-harmogan-model",
        _method_model("harmogan", "music", "forecast", "--motion", "ROOT/motion.npz", *_SONG_OUT),
        "--model",
    ),
    Case(
        "generate-edit-with-a-music-model",
        _method_model("mofusion", "music", "edit", *_MOTION, "--caption", "x", "--time", "0:1", *_OUT),
        "`momu generate edit`",
    ),
    Case(
        "generate-forecast-caption-to-a-music-model",
        _method_model("mofusion", "music", "forecast", *_MOTION, "--caption", "a person jumps", *_OUT),
        "--caption",
    ),
    Case(
        "generate-forecast-seed-longer-than-the-motion",
        _method_model("mofusion", "text", "forecast", *_MOTION, "--caption", "a person jumps", *_OUT),
        "--seed-seconds 2",
    ),
    Case(
        "generate-inbetween-motion-unreadable",
        _method_model(
            "mofusion", "music", "inbetween", "--motion", "ROOT/afile", "--keyframes", "0", *_SONG_OUT
        ),
        "afile",
    ),
    Case(
        "generate-inbetween-bad-keyframes",
        _method_model("mofusion", "music", "inbetween", *_MOTION, "--keyframes", "0,x", *_SONG_OUT),
        "--keyframes",
    ),
    Case(
        "generate-edit-bad-time",
        _method_model("mofusion", "text", "edit", *_MOTION, "--caption", "x", "--time", "1:0.5", *_OUT),
        "--time 1:0.5",
    ),
    Case(
        "generate-edit-unknown-joint",
        _method_model("mofusion", "text", "edit", *_MOTION, "--caption", "x", "--joints", "tail", *_OUT),
        "--joints",
    ),
    # data check / data synth
    Case(
        "data-check-unknown-dataset",
        lambda root: ["data", "check", "nope_set", "--root", str(root)],
        "nope_set",
    ),
    Case(
        "data-check-unknown-option",
        lambda root: ["data", "check", "dance_with_melody", "--root", str(root), "--set", "loda_audio=false"],
        "loda_audio",
    ),
    Case("data-check-bad-file", _dwm_bad, "dwm", status=1),
    Case(
        "data-synth-out-is-a-file",
        lambda root: (root / "f").write_text("x") and ["data", "synth", "--out", str(root / "f")],
        "--out",
    ),
    Case(
        "data-synth-bad-option",
        lambda root: ["data", "synth", "--out", str(root / "d"), "--clips", "-3"],
        "num_clips",
    ),
    Case("data-synth-non-empty-out", _synth_nonempty, "--overwrite"),
    # momu train / momu extractor train: a bad option fails before anything is written
    Case("train-bad-dataset-option", _momu(*TRAIN_SMOKE, "dataset.num_clips=-3"), "num_clips"),
    Case("train-unknown-key", _momu(*TRAIN_SMOKE, "method.zz=1"), "method.zz"),
    Case(  # a value the method's own check_config rejects (was a traceback, exit 1, --out made)
        "train-bad-method-value",
        _momu(*TRAIN_SMOKE, "method.scheduler.prediction_type=v_prediction"),
        "method.sampler.scheduler.prediction_type",
    ),
    Case("train-data-folder-missing", _momu(*TRAIN_SMOKE, "--data", "ROOT/nope"), "nope"),
    Case("extractor-bad-out-suffix", _momu(*EXTRACTOR, "--data", "synth", "--out", "ROOT/x.bin"), "--out"),
    Case(
        "extractor-data-not-a-folder",
        _momu(*EXTRACTOR, "--data", "ROOT/nope", "--out", "ROOT/x.safetensors"),
        "--data ",
    ),
    # a recipe (MoMu Table 7, smoke preset): every failure comes before training
    Case(
        "recipe-out-is-a-file",
        lambda root: (root / "f").write_text("x") and _recipe()(root)[:-2] + ["--out", str(root / "f")],
        "--out",
    ),
    Case("recipe-bad-dataset-option", _recipe("dataset.num_clips=-3"), "num_clips"),
    Case(
        "recipe-real-data-missing",
        lambda root: _recipe("--data", _empty_dir(root), "dataset=dance_with_melody")(root),
        "dance_with_melody",
    ),
    Case("recipe-unknown-top-key", _recipe("zz=1"), "zz: unknown key"),
    Case(
        "recipe-global-override",
        _recipe("method.train_diffusion.stpes=10"),
        "override 'method.train_diffusion.stpes=10'",
    ),
    Case("recipe-unknown-row", _recipe("--rows", "99"), "--rows"),
    Case(
        "recipe-bad-preset",
        lambda root: ["recipe", "--preset", "bogus", "--out", str(root / "out")],
        "--preset",
    ),
]


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in root.rglob("*")
        if not p.is_dir() or not any(p.iterdir())
    }


def _run(argv: list[str]) -> int:
    if argv[0] != "recipe":
        return main(argv)
    from momu.engine.table import run_table
    from momu.methods.momu.recipes import table7_spec

    try:
        return run_table(table7_spec(RECIPES / "configs" / "momu.yaml"), argv[1:])
    except SystemExit as exc:  # argparse errors exit through momu.errors.fail
        return int(exc.code or 0)


def test_the_matrix_is_wide_enough() -> None:
    commands = {c.id.split("-")[0] for c in CASES}
    assert len(CASES) >= 25 and commands >= {
        "config",
        "eval",
        "generate",
        "data",
        "train",
        "extractor",
        "recipe",
    }


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_one_line_with_its_status_and_writes_nothing(
    case: Case, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("WANDB_MODE", "offline")  # a tracker that would leave wandb/ behind if started
    monkeypatch.setenv("HOME", "/secret-home-value")
    argv = case.setup(tmp_path)
    capsys.readouterr()
    before = _snapshot(tmp_path)
    status = _run(argv)
    out, err = capsys.readouterr()
    assert status == case.status, err
    if case.status == 2:
        lines = [line for line in err.splitlines() if "error:" in line]
        assert len(lines) == 1, err
        assert err.strip().splitlines()[-1] == lines[0]  # the reason is the last line
        assert case.names in lines[0], lines[0]
    else:
        bad = [line for line in out.splitlines() if line.startswith("BAD ")]
        assert len(bad) == 1 and case.names in bad[0], out
    assert "/secret-home-value" not in out + err
    assert _snapshot(tmp_path) == before
    assert not list(tmp_path.rglob("wandb"))
    assert not [p for p in tmp_path.rglob(".*") if ".staging" in p.name or p.suffix == ".lock"]


def test_the_real_dance_with_melody_folder_gets_past_validation(shared_data: Path, tmp_path: Path) -> None:
    """``--data DIR dataset=dance_with_melody`` keeps the root (it used to be dropped by the bare name)."""
    from momu.engine.table import parse_table_args, resolve_row_configs
    from momu.methods.momu.recipes import table7_spec

    root = shared_data / "dance_with_melody"
    spec = table7_spec(RECIPES / "configs" / "momu.yaml")
    args = parse_table_args(spec, ["--preset", "smoke", "--data", str(root), "dataset=dance_with_melody"])
    configs = resolve_row_configs(spec, args)
    assert {c.dataset.root for c in configs.values()} == {str(root.resolve())}
    assert os.path.isdir(next(iter(configs.values())).dataset.root)
