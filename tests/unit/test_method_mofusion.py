"""The ``mofusion`` method: training through the engine's stage cache, the generation API (per-item
seeds, forecasting keeps the seed exactly, in-betweening and editing keep what they must), save/load."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.data.synth.captions import caption_window, move_phrase
from momu.engine import RunConfig, make_accelerator
from momu.engine.context import RunContext
from momu.methods.mofusion.data import resample_motion
from momu.methods.mofusion.model import MoFusionModel
from momu.registry import DATASETS, METHODS

_UNET = {"name": "unet1d", "base_channels": 8, "heads": 2, "cross_attention_dim": 16, "norm_groups": 4}
_DDIM = {"name": "ddim", "num_inference_steps": 3}


def _method(task: str) -> object:
    backbone = {**_UNET, **({"cond_proj": "mlp", "context_positions": False} if task == "text" else {})}
    return METHODS.build(
        "mofusion",
        {
            "task": task,
            "window_seconds": 2.0,
            "window_hop_seconds": 1.0,
            "backbone": backbone,
            "text_encoder": {"name": "text_transformer", "width": 8, "heads": 2, "depth": 1},
            "sampler": {"name": "cfg", "guidance_scale": 1.0, "scheduler": _DDIM},
            "inpainting_sampler": {"name": "inpainting", "guidance_scale": 1.0, "scheduler": _DDIM},
            "train": {"steps": 2, "batch_size": 4},
            "evaluation": {"num_clips": 2},
        },
    )


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[MoFusionModel, object, RunContext]]:
    out = tmp_path_factory.mktemp("mofusion")
    ctx = RunContext(accelerator=make_accelerator(RunConfig(tracker="none"), out, "t", {}), out_dir=out)
    models = {}
    for task, skeleton in (("music", "smpl24"), ("text", "humanml22")):
        ds = DATASETS.build(
            "synth_dance", {"num_clips": 15, "min_seconds": 3.0, "max_seconds": 3.0, "skeleton": skeleton}
        )
        model, _ = _method(task).fit(ctx, ds, {"task": task, "skeleton": skeleton}, 0)
        models[task] = (model, ds, ctx)
    return models


def test_fit_trains_once_then_reuses_the_stage(trained) -> None:
    model, ds, ctx = trained["music"]
    assert model.backbone.in_channels == 72 and model.backbone.cond_channels == 80
    assert trained["text"][0].backbone.in_channels == 66  # 22 joints
    again, name = _method("music").fit(ctx, ds, {"task": "music", "skeleton": "smpl24"}, 0)
    assert ctx.trained[name] == "trained"  # the second fit reused it (the record keeps "trained")
    assert (ctx.parts_dir / name / "model.safetensors").is_file()


def test_music_generation_depends_on_its_seed_only(trained) -> None:
    model, ds, _ = trained["music"]
    a, b = ds[0], ds[1]
    music = [(a.audio, a.sample_rate), (b.audio, b.sample_rate)]
    pair = model.music_to_dance(music, [2.0, 1.5], [7, 8])
    alone = model.music_to_dance(music[1:], [1.5], [8])
    assert pair[0].shape == (40, 24, 3) and pair[1].shape == (30, 24, 3)
    np.testing.assert_allclose(pair[1], alone[0], atol=1e-5)
    other = model.music_to_dance(music[1:], [1.5], [9])
    assert not np.allclose(other[0], alone[0])


def test_forecast_keeps_the_seed_frames_exactly(trained) -> None:
    model, ds, _ = trained["music"]
    clip = ds[2]
    out = model.forecast(
        [clip.motion], [(clip.audio, clip.sample_rate)], [2.5], [3], seed_seconds=1.0, fps=clip.fps
    )
    seed = resample_motion(clip.motion, clip.fps, 20.0)[:20]
    np.testing.assert_allclose(out[0][:20], seed, atol=1e-5)
    assert not np.allclose(out[0][20:], resample_motion(clip.motion, clip.fps, 20.0)[20:50], atol=1e-3)


def test_inbetween_keeps_keyframes(trained) -> None:
    model, ds, _ = trained["music"]
    clip = ds[3]
    motion = resample_motion(clip.motion, clip.fps, 20.0)[:40]
    keys = [0, 13, 26, 39]
    out = model.inbetween([motion], [keys], [(clip.audio, clip.sample_rate)], [5])[0]
    np.testing.assert_allclose(out[keys], motion[keys], atol=1e-5)


def test_text_generation_and_editing_keep_the_unedited_part(trained, tmp_path: Path) -> None:
    model, ds, _ = trained["text"]
    clip = ds[0]
    first = model.text_to_motion([clip.text[0]], [2.0], [1])[0]
    region = np.zeros((40, 22), dtype=bool)
    region[20:, :] = True  # regenerate the second second
    region[:20, 20] = True  # and one joint (the left wrist) in the first
    edited = model.edit([first], [region], ["a person dances: a glide."], [2])[0]
    keep = ~region
    np.testing.assert_allclose(edited[keep], first[keep], atol=1e-5)
    with pytest.raises(ValueError, match="text-conditioned"):
        trained["music"][0].edit([first], [region], ["x"], [1])
    folder = model.save(tmp_path / "m")
    reloaded = MoFusionModel.load(folder)
    np.testing.assert_allclose(reloaded.text_to_motion([clip.text[0]], [2.0], [1])[0], first, atol=1e-6)
    with pytest.raises(FileNotFoundError, match="mofusion.json"):
        MoFusionModel.load(tmp_path)


def test_bad_condition_kind_is_named(trained) -> None:
    with pytest.raises(ValueError, match="music-conditioned"):
        trained["music"][0].text_to_motion(["a person"], [1.0], [0])
    with pytest.raises(ValueError, match="text-conditioned"):
        trained["text"][0].music_to_dance([(np.zeros(16000, np.float32), 16000)], [1.0], [0])


def test_captions_follow_the_recorded_moves() -> None:
    ds = DATASETS.build("synth_dance", {"num_clips": 6, "min_seconds": 6.0, "max_seconds": 6.0})
    for i in range(6):
        clip = ds[i]
        moves = clip.meta["moves"]
        assert moves and clip.text == [caption_window(moves, 0.0, clip.duration, clip.style)]
        assert all(m["name"].replace("_", " ") in clip.text[0] for m in moves)
        assert clip.text[0].startswith(f"a person dances {clip.style}: ")
        assert ds[i].text == clip.text  # deterministic
    assert move_phrase({"name": "pirouette", "mirrored": True, "turn": -3.1}) == (
        "a pirouette with the left arm turning right"
    )
    assert move_phrase({"name": "arabesque", "mirrored": False, "turn": 0.0}).startswith("an arabesque")


def test_method_config_errors_name_the_key() -> None:
    with pytest.raises(ValueError, match="method.task"):
        METHODS.build("mofusion", {"task": "video"})
    with pytest.raises(ValueError, match="seed_seconds"):
        METHODS.build("mofusion", {"evaluation": {"mode": "forecast", "seconds": 2.0, "seed_seconds": 2.0}})
