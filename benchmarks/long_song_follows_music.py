"""Does the window schedule change whether a dance follows its song? The held-out study of
``recipes/pretrain.py`` (:mod:`momu.generation.follows_music`: BAS and kinematic-beat F1 of each
generated dance against its own and another real Dance with Melody song, 3 seeds) with the ``two_pass``
and the ``sequential`` schedule, and the per-song difference between them with 95 % t-intervals.

    python benchmarks/long_song_follows_music.py [--model DIR] [--seconds 30] [--threads 2] [--out F.json]

Needs the real songs (``../shared/data/dance_with_melody`` or ``MOMU_SHARED_DATA``).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("bas_own_minus_other", "f1_own_minus_other")


def _pretrain() -> Any:
    spec = importlib.util.spec_from_file_location("pretrain", ROOT / "recipes" / "pretrain.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", type=Path)
    p.add_argument("--seconds", type=float, default=30.0)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    import torch

    torch.set_num_threads(args.threads)
    from momu.cli.generate_io import default_model_dir
    from momu.generation.follows_music import interval

    folder = args.model or default_model_dir("dance")
    studies: dict[str, Any] = {}
    for schedule in ("two_pass", "sequential"):
        start = time.perf_counter()
        study = _pretrain().evaluate(folder, args.seconds, schedule)
        if study is None:
            raise SystemExit("long_song_follows_music: the real Dance with Melody songs were not found")
        study["wall_time_s"] = round(time.perf_counter() - start, 1)
        studies[schedule] = study
    per_song = {s: studies[s]["generated"]["per_song"] for s in studies}
    differences = {}
    for key in ("bas_own", "bas_other", "f1_own", "f1_other"):
        diff = [a[key] - b[key] for a, b in zip(per_song["two_pass"], per_song["sequential"])]
        differences[f"{key}_two_pass_minus_sequential"] = interval(np.asarray(diff))
    result = {
        "model": str(folder),
        "seconds_per_song": args.seconds,
        "threads": args.threads,
        "summary": {s: {k: studies[s]["generated"]["summary"][k] for k in KEYS} for s in studies},
        "per_song_differences": differences,
        "studies": studies,
    }
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
