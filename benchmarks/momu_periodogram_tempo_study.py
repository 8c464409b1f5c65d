"""Does ``motion_rhythm`` with ``tempo: periodogram`` make the shipped model's music follow a dance's tempo?
(issue 32, the dance → music direction; the Dance with Melody *validation* split only.)

    python benchmarks/momu_periodogram_tempo_study.py [--work outputs/periodogram_tempo] [--data DIR]

Trains the shipped config (``recipes/pretrain.py``: synth_dance ballroom styles, its METHOD_OVERRIDES,
training seed 0) with the music condition ``{name: motion_rhythm, tempo: periodogram}`` into ``--work``
(put the shipped run's ``parts/`` there first to reuse its VAE stages), sets the shipped samplers, and
runs the music-following benchmark on the dance → music direction (15-s excerpts, seeds 0 1 2). The
model is never installed. Results: ``<work>/evaluation/music_following/results.{json,md}``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "recipes"))

CONDITION = "method.music_condition={name: motion_rhythm, tempo: periodogram}"


def main() -> int:
    import pretrain

    from momu.following.run import main as benchmark
    from momu.training import train_method

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--work", type=Path, default=ROOT / "outputs" / "periodogram_tempo")
    p.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "dance_with_melody"))
    args = p.parse_args()
    kept = [o for o in pretrain.METHOD_OVERRIDES if not o.startswith("method.music_condition=")]
    result = train_method(
        "momu",
        args.work,
        data="synth",
        preset="cpu",
        overrides=[*pretrain.SYNTH_OVERRIDES, *kept, CONDITION],
        seed=0,
        command=["python", "benchmarks/momu_periodogram_tempo_study.py", *sys.argv[1:]],
    )
    model = Path(result.model)
    pretrain._set_samplers(model)
    argv = ["--generator", str(model), "--direction", "music", "--data", args.data, "--split", "val"]
    argv += ["--songs", "8", "--seconds", "15", "--seeds", "0", "1", "2", "--no-controls"]
    return benchmark([*argv, "--out", str(args.work / "evaluation")])


if __name__ == "__main__":
    raise SystemExit(main())
