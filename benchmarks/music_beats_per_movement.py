"""Does the shipped music match the song's tempo when told how many beats a dancer's movement spans?
(issue 32, the dance → music direction's tempo match)

    python benchmarks/music_beats_per_movement.py [--data ../shared/data/dance_with_melody] [--split val]
        [--seconds 15] [--rule style|ballroom] [--model DIR]
        [--out benchmarks/results/music_beats_per_movement/val]

θ_a (the shipped music model) reads a dance's rhythm as ``motion_rhythm`` does: beats at the dominant
period of its kinematic onsets. The Dance with Melody dancers move once per bar in a waltz (3 beats) and
once per half bar otherwise (2 beats) (``benchmarks/dance_tempo_vs_song.py``, its ``xstyle`` ceiling),
and the music θ_a writes keeps the dance's period, so its tempo does not match the song's. Here θ_a's
condition is split into N beats per movement (``motion_rhythm``'s ``subdivide``, as ``momu generate
music --beats-per-movement`` does). ``--rule style``: N is 3 for a waltz and 2 otherwise, taken from the
dance's id — the style is *given*, so this answers "would θ_a's music match the song once the style is
known?". ``--rule ballroom``: N is read from the motion by
:func:`momu.features.ballroom_metre.ballroom_beats_per_movement` (``--beats-per-movement ballroom``), a
generator of the motion alone. The benchmark's music direction (the same tests, seeds 0 1 2, no
controls) runs on the split with it; the calibration rows are the benchmark's own. Writes
``results.{json,md}`` like ``recipes/music_following.py``.
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
from momu.features.ballroom_metre import ballroom_beats_per_movement
from momu.following import run_benchmark, write_results
from momu.following.adapters import from_model_dir, shipped
from momu.following.pairs import Pair, dataset_node, load_pairs

log = logging.getLogger("music_beats_per_movement")


class BeatsPerMovement:
    """The shipped music generator with θ_a's condition split into N beats per movement.

    ``rule="style"``: N is each dance's :func:`style_multiple`, given. The benchmark hands a generator
    the motion only; the dance is recognised by its first pose, which every input derived from an
    excerpt keeps (stretched, delayed, the excerpt itself). ``rule="ballroom"``: N is read from the
    motion it is given (:func:`momu.features.ballroom_metre.ballroom_beats_per_movement`, as ``momu
    generate music --beats-per-movement ballroom`` does): a dance → music generator of the motion alone.
    """

    def __init__(self, pairs: list[Pair], rule: str = "style", model: Path | None = None) -> None:
        self.inner = shipped("music") if model is None else from_model_dir(model, "music")
        self.model = self.inner.model  # type: ignore[attr-defined]
        self.rule = rule
        self.skeleton = pairs[0].skeleton
        self.beats = {self._key(p.excerpt_motion()): style_multiple(p.id) for p in pairs}

    @staticmethod
    def _key(motion: np.ndarray) -> bytes:
        return np.round(np.asarray(motion[0], dtype=np.float64), 4).tobytes()

    def generate(self, motion: np.ndarray, fps: float, seed: int) -> tuple[np.ndarray, int]:
        if self.rule == "ballroom":
            beats: int | None = ballroom_beats_per_movement(motion, fps, self.skeleton)
        else:
            beats = self.beats.get(self._key(motion))
        if beats is None:
            raise KeyError("an input that is not one of the split's excerpts (did the benchmark change?)")
        self.model.use_beats_per_movement(beats)
        return self.inner.generate(motion, fps, seed)  # type: ignore[no-any-return]


ROWS = {"style": "shipped, beats per movement by style", "ballroom": "shipped, beats per movement: ballroom"}
SETTINGS = {
    "style": "shipped, subdivide 3 (waltz) / 2",
    "ballroom": "shipped, subdivide read by the ballroom rule",
}


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default=DEFAULT_DATA)
    p.add_argument("--split", default="val", choices=("train", "val", "test"))
    p.add_argument("--seconds", type=float, default=DEFAULT_SECONDS)
    p.add_argument(
        "--songs", type=int, default=100, help="at most this many songs (synth: 7 as its reproduction)"
    )
    p.add_argument("--rule", default="style", choices=tuple(ROWS), help="how N is chosen (class docstring)")
    p.add_argument("--model", type=Path, help="a MoMu model folder (default: the shipped model)")
    p.add_argument("--out", type=Path, default=Path("benchmarks/results/music_beats_per_movement/val"))
    args = p.parse_args()
    start, commit = time.time(), git_commit()
    node = dataset_node(args.data, args.split, "dwm21", args.seconds, args.songs)
    pairs = load_pairs(node, args.seconds, args.songs)
    result = run_benchmark(
        pairs,
        {ROWS[args.rule]: BeatsPerMovement(pairs, args.rule, args.model)},
        direction="music",
        controls=False,
    )
    results = {
        "benchmark": "music_following",
        "data": f"{'synth_dance' if args.data == 'synth' else Path(args.data).name} ({args.split} split)",
        "settings": {
            "generator": SETTINGS[args.rule] + ("" if args.model is None else f" ({args.model})"),
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
