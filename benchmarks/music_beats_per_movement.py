"""Does the shipped music match the song's tempo when told how many beats a dancer's movement spans?
(issue 32, the dance → music direction's tempo match; validation split only)

    python benchmarks/music_beats_per_movement.py [--data ../shared/data/dance_with_melody] [--split val]
        [--seconds 15] [--out benchmarks/results/music_beats_per_movement_val]

θ_a (the shipped music model) reads a dance's rhythm as ``motion_rhythm`` does: beats at the dominant
period of its kinematic onsets. The Dance with Melody dancers move once per bar in a waltz (3 beats) and
once per half bar otherwise (2 beats) (``benchmarks/dance_tempo_vs_song.py``, its ``xstyle`` ceiling),
and the music θ_a writes keeps the dance's period, so its tempo does not match the song's. Here θ_a's
condition is split into that many beats (``motion_rhythm``'s ``subdivide``, as ``momu generate music
--beats-per-movement N`` does): 3 for a waltz, 2 otherwise, taken from the dance's id — the style is
*given*, not read from the motion, so this is not a dance → music model that passes, but the answer to
"would θ_a's music match the song once the style is known?". The benchmark's music direction (the
same tests, seeds 0 1 2, no controls) runs on the split with this generator; the calibration rows are
the benchmark's own. Writes ``results.{json,md}`` like ``recipes/music_following.py``.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from dance_tempo_vs_song import style_multiple  # benchmarks/dance_tempo_vs_song.py
from study_common import DEFAULT_DATA, DEFAULT_SECONDS  # benchmarks/study_common.py

from momu.engine.provenance import git_commit, package_versions
from momu.following import run_benchmark, write_results
from momu.following.adapters import shipped
from momu.following.pairs import Pair, dataset_node, load_pairs

log = logging.getLogger("music_beats_per_movement")


class BeatsPerMovement:
    """The shipped music generator with θ_a's condition split into each dance's :func:`style_multiple`.

    The benchmark hands a generator the motion only; the dance is recognised by its first pose, which
    every input derived from an excerpt keeps (stretched, delayed, the excerpt itself)."""

    def __init__(self, pairs: list[Pair]) -> None:
        self.inner = shipped("music")
        self.model = self.inner.model  # type: ignore[attr-defined]
        self.beats = {self._key(p.excerpt_motion()): style_multiple(p.id) for p in pairs}

    @staticmethod
    def _key(motion: np.ndarray) -> bytes:
        return np.round(np.asarray(motion[0], dtype=np.float64), 4).tobytes()

    def generate(self, motion: np.ndarray, fps: float, seed: int) -> tuple[np.ndarray, int]:
        beats = self.beats.get(self._key(motion))
        if beats is None:
            raise KeyError("an input that is not one of the split's excerpts (did the benchmark change?)")
        self.model.use_beats_per_movement(beats)
        return self.inner.generate(motion, fps, seed)  # type: ignore[no-any-return]


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=DEFAULT_DATA)
    p.add_argument("--split", default="val", choices=("train", "val", "test"))
    p.add_argument("--seconds", type=float, default=DEFAULT_SECONDS)
    p.add_argument("--out", type=Path, default=Path("benchmarks/results/music_beats_per_movement_val"))
    args = p.parse_args()
    start, commit = time.time(), git_commit()
    node = dataset_node(args.data, args.split, "dwm21", args.seconds, 100)
    pairs = load_pairs(node, args.seconds, None)
    result = run_benchmark(
        pairs,
        {"shipped, beats per movement by style": BeatsPerMovement(pairs)},
        direction="music",
        controls=False,
    )
    results = {
        "benchmark": "music_following",
        "data": f"{Path(args.data).name} ({args.split} split)",
        "settings": {
            "generator": "shipped, subdivide 3 (waltz) / 2",
            "split": args.split,
            "songs": len(pairs),
            "seconds": args.seconds,
            "seeds": "0 1 2",
        },
        "dataset": node,
        "directions": {"music": result},
        "provenance": {
            "command": ["python", "benchmarks/music_beats_per_movement.py", *sys.argv[1:]],
            "git_commit": commit,
            "versions": package_versions(),
            "wall_time_s": round(time.time() - start, 1),
        },
    }
    js, md = write_results(results, args.out)
    log.info("wrote %s and %s (%.0f s)", js, md, time.time() - start)


if __name__ == "__main__":
    main()
