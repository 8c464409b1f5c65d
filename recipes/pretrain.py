"""Train, check and install the model shipped with momu (``nox -s pretrain``; non-default).

    python recipes/pretrain.py [--work outputs/pretrain] [--skip-train] [--eval-seconds 56]

1. ``momu train momu`` on ``synth_dance`` with the ``dwm21`` skeleton (3D, Dance with Melody's
   21 joints, 25 fps) at the ``cpu`` preset, seed 0 — data anyone can regenerate and check against the
   hashes in ``provenance.json``. The real Dance with Melody subset is research data for tests and
   evaluation only, so it is not trained on (and never shipped).
2. The model folder is copied to ``src/momu/pretrained/momu-dwm21/`` (safetensors + JSON) with its
   provenance, and ``index.json`` names it the default for both directions; the sampler is set to
   :data:`SHIPPED_SAMPLER` (fewer denoising steps than the cpu preset's 1000-step DDPM, so that a
   3-minute song takes under a minute on 2 cores; ``momu generate --model`` with a folder trained at
   the preset keeps the preset's sampler).
3. Where the real Dance with Melody songs are present (``../shared/data``), the held-out check of
   :mod:`momu.generation.follows_music` — does the dance score higher against its own song than
   against another — is written to ``evaluation.json`` beside the model, with 95 % intervals.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "src" / "momu" / "pretrained"
NAME = "momu-dwm21"
TRAIN_OVERRIDES = ["dataset.skeleton=dwm21"]
SHIPPED_SAMPLER = {
    "name": "cfg",
    "guidance_scale": 3.0,
    "num_inference_steps": 50,
    "scheduler": {"name": "ddim", "clip_sample": True, "clip_sample_range": 4.0},
}
"""The shipped model's music→motion and motion→music sampler (DDIM, 50 steps, MoMu §5.1)."""
SEEDS = (0, 1, 2)

log = logging.getLogger("pretrain")


def _install(model: Path) -> Path:
    dst = SHIPPED / NAME
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(model, dst)
    meta_path = dst / "momu.json"
    meta = json.loads(meta_path.read_text())
    for key in ("sampler", "music_sampler", "motion_sampler"):
        meta["config"][key] = dict(SHIPPED_SAMPLER)
    meta_path.write_text(json.dumps(meta, indent=2) + "\n")
    (SHIPPED / "index.json").write_text(json.dumps({"dance": NAME, "music": NAME}, indent=2) + "\n")
    size = sum(p.stat().st_size for p in dst.rglob("*") if p.is_file())
    log.info("installed %s (%.1f MB)", dst, size / 1e6)
    return dst


def _songs(seconds: float) -> list:
    from momu.config import build_component
    from momu.generation.follows_music import Song

    shared = Path(os.environ.get("MOMU_SHARED_DATA") or ROOT.parent / "shared" / "data")
    root = shared / "dance_with_melody"
    if not root.is_dir():
        return []
    ds = build_component({"name": "dance_with_melody", "root": str(root), "sample_rate": 16000}, "datasets")
    out = []
    for i in range(len(ds)):
        clip = ds[i]
        n = int(seconds * clip.sample_rate)
        frames = int(seconds * clip.fps)
        out.append(Song(clip.id, clip.audio[:n], int(clip.sample_rate), clip.motion[:frames], clip.fps))
    return out


def evaluate(model_dir: Path, seconds: float, schedule: str = "two_pass") -> dict | None:
    """The held-out follows-music study of the model in ``model_dir`` on ``seconds`` of each real song,
    long songs generated with the window ``schedule`` (:mod:`momu.generation.windows`)."""
    from momu.generation.follows_music import follow_music_study
    from momu.generation.momu_long import music_to_motion_long
    from momu.methods.momu import MoMuModel

    songs = _songs(seconds)
    if not songs:
        log.warning("real Dance with Melody songs not found: no held-out evaluation")
        return None
    model = MoMuModel.load(model_dir)

    def generate(song, seed: int):
        (motion,) = music_to_motion_long(model, [song.audio], song.sample_rate, [seed], schedule=schedule)
        return motion, model.rates.motion_fps

    start = time.time()
    result = follow_music_study(songs, generate, SEEDS)
    result["seconds_per_song"] = seconds
    result["window_schedule"] = schedule
    result["wall_time_s"] = round(time.time() - start, 1)
    result["data"] = "Dance with Melody (8 public dances, ../shared/data): songs held out from training"
    return result


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, default=ROOT / "outputs" / "pretrain")
    p.add_argument("--skip-train", action="store_true", help="reuse the model already in --work")
    p.add_argument(
        "--eval-seconds",
        type=float,
        default=56.0,
        help="seconds of each held-out song (the shortest dance: 56.4 s)",
    )
    args = p.parse_args(argv)
    from momu.training import find_model, train_method

    command = ["python", "recipes/pretrain.py", *(argv if argv is not None else sys.argv[1:])]
    if not args.skip_train:
        train_method("momu", args.work, preset="cpu", overrides=TRAIN_OVERRIDES, seed=0, command=command)
    installed = _install(find_model(args.work))
    result = evaluate(installed, args.eval_seconds)
    if result is not None:
        (installed / "evaluation.json").write_text(json.dumps(result, indent=2) + "\n")
        summary = result["generated"]["summary"]  # type: ignore[index]
        for key in ("bas_own_minus_other", "f1_own_minus_other"):
            s = summary[key]
            log.info("%s: %.4f [%.4f, %.4f]", key, s["mean"], s["low"], s["high"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
