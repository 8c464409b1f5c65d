"""``recipes/music_following.py``: the music-following benchmark from the command line.

    python recipes/music_following.py [--generator shipped|ground_truth_only|DIR]
        [--direction dance|music|both] [--data synth|DIR] [--split val] [--seeds 0 1 2]
        [--songs 8] [--seconds 10] [--out outputs]

writes ``<out>/music_following/results.json`` and ``results.md``. Every option is checked — the model
folder's record, what it can generate, the data folder, the output folder — before any model is loaded
or any song generated; a problem prints one line ``music_following: error: ...`` and exits with
status 2, writing nothing.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Any

from momu.cli.generate_io import GenerateInputError, default_model_dir, model_record
from momu.errors import UsageParser, fail

__all__ = ["main", "build_parser"]

log = logging.getLogger("music_following")
SPLITS = ("train", "val", "test", "all")


class BenchmarkInputError(ValueError):
    """A bad option of the benchmark recipe (one line, exit status 2)."""


def build_parser() -> argparse.ArgumentParser:
    p = UsageParser(
        prog="music_following", description="Does a generator follow its input? (docs/following.md)"
    )
    p.add_argument(
        "--generator",
        default="shipped",
        help="shipped (the model shipped with momu), ground_truth_only (calibration rows only), or a "
        "saved model folder (momu / mofusion / harmogan)",
    )
    p.add_argument(
        "--direction",
        choices=("dance", "music", "both"),
        default="dance",
        help="dance: music → dance; music: dance → music; both",
    )
    p.add_argument(
        "--data",
        default="synth",
        help="synth (synth_dance), a Dance with Melody folder, or a folder of "
        "pairs in momu eval's layout (<stem>.wav + <stem>.npy|.npz)",
    )
    p.add_argument("--split", choices=SPLITS, default="val", help="the split of --data (default val)")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--songs", type=int, default=8, help="number of songs (the first N of the split by id)")
    p.add_argument("--seconds", type=float, default=10.0, help="excerpt length in seconds")
    p.add_argument(
        "--fps",
        type=float,
        default=30.0,
        help="frame rate of .npy motions in a pair folder without a sidecar",
    )
    p.add_argument(
        "--generated",
        type=Path,
        default=None,
        help="a folder of outputs generated elsewhere, one per song id (<id>.npy|.npz dances for music → "
        "dance, <id>.wav music for dance → music, generated from the start of the whole song or dance): "
        "a row scored on the tests that need no generator",
    )
    p.add_argument(
        "--beats-per-movement",
        default=None,
        metavar="N|ballroom|auto",
        help="dance → music with a MoMu model: music beats per movement of the dance, as momu generate "
        "music --beats-per-movement (default auto, as there)",
    )
    p.add_argument(
        "--no-controls", action="store_true", help="skip the control inputs (silence, noise, clicks ...)"
    )
    p.add_argument("--out", type=Path, default=Path("outputs"))
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def _check(args: argparse.Namespace) -> tuple[list[str], str | None, str]:
    """Directions, model folder (None: none) and the synthetic skeleton; raises one-line errors."""
    from momu.following.pairs import MIN_SECONDS
    from momu.io import check_output_dir

    if args.songs < 2:
        raise BenchmarkInputError(
            f"--songs must be >= 2 (each song is compared with another), got {args.songs}"
        )
    if not args.seconds >= MIN_SECONDS or args.seconds != args.seconds:
        raise BenchmarkInputError(
            f"--seconds must be >= {MIN_SECONDS:g} (tempo needs a few periods), got {args.seconds}"
        )
    if len(set(args.seeds)) != len(args.seeds):
        raise BenchmarkInputError(f"--seeds: repeated seed in {args.seeds}")
    if not args.fps > 0:
        raise BenchmarkInputError(f"--fps must be > 0, got {args.fps}")
    if args.data != "synth":
        root = Path(args.data)
        if not root.is_dir():
            raise BenchmarkInputError(
                f"--data {root}: not a folder (give synth, a Dance with Melody folder or a pair folder)"
            )
    try:
        check_output_dir(args.out / "music_following")
    except ValueError as exc:
        raise BenchmarkInputError(str(exc)) from None
    directions = ["dance", "music"] if args.direction == "both" else [args.direction]
    from momu.features.ballroom_metre import parse_beats_per_movement

    given = args.beats_per_movement is not None
    try:
        args.beats_per_movement = parse_beats_per_movement(args.beats_per_movement or "auto")
    except ValueError as exc:
        raise BenchmarkInputError(str(exc)) from None
    if given and ("music" not in directions or args.generator == "ground_truth_only"):
        raise BenchmarkInputError(
            "--beats-per-movement: only for dance → music with a model (--direction music)"
        )
    skeleton = "dwm21"
    folder: str | None = None
    if args.generator != "ground_truth_only":
        folder = str(default_model_dir("dance")) if args.generator == "shipped" else args.generator
        if args.generator != "shipped" and not Path(folder).is_dir():
            raise BenchmarkInputError(
                f"--generator {folder}: not shipped, ground_truth_only or a model folder"
            )
        record = model_record(Path(folder))
        skeleton = record.skeleton
        if record.method != "momu" and "music" in directions:
            raise BenchmarkInputError(
                f"--generator {folder}: a {record.method} model generates dance only; use --direction dance"
            )
        if record.task != "music":
            raise BenchmarkInputError(
                f"--generator {folder}: a text→motion model; the benchmark needs a music model"
            )
    return directions, folder, skeleton


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    args = build_parser().parse_args(argv)
    try:
        directions, folder, skeleton = _check(args)
        from momu.following import dataset_node, load_pairs

        node = dataset_node(args.data, args.split, skeleton, args.seconds, args.songs)
        try:
            pairs = load_pairs(node, args.seconds, args.songs, fps=args.fps)
        except (OSError, ValueError, KeyError) as exc:
            raise BenchmarkInputError(f"--data {args.data}: {str(exc).splitlines()[0]}") from None
        if len(pairs) < 2:
            raise BenchmarkInputError(
                f"--data {args.data} --split {args.split}: {len(pairs)} usable songs; at least 2 are needed"
            )
        generators: dict[str, dict[str, Any]] = {d: {} for d in directions}
        if folder is not None:
            from momu.following.adapters import from_model_dir, model_name

            name = (
                f"shipped ({Path(folder).name})" if args.generator == "shipped" else model_name(Path(folder))
            )
            for d in directions:
                beats = args.beats_per_movement if d == "music" else 1
                label = name if d == "dance" or beats == "auto" else f"{name}, beats per movement {beats}"
                generators[d][label] = from_model_dir(folder, d, beats)
        generated: dict[str, dict[str, Any]] = {d: {} for d in directions}
        if args.generated is not None:
            from momu.cli.eval_inputs import EvalInputError
            from momu.following.pairs import load_generated

            if len(directions) > 1:
                raise BenchmarkInputError("--generated: give --direction dance or music (one kind of output)")
            try:
                outputs = load_generated(args.generated, pairs, directions[0], args.fps)
            except (EvalInputError, ValueError) as exc:
                raise BenchmarkInputError(f"--generated {str(exc).splitlines()[0]}") from None
            generated[directions[0]][f"generated:{args.generated.name}"] = outputs
    except (BenchmarkInputError, GenerateInputError) as exc:
        return fail("music_following", exc)  # one line, exit 2; under accelerate launch also its error file
    return _run(args, argv, pairs, generators, generated, node)


def _run(
    args: argparse.Namespace,
    argv: list[str] | None,
    pairs: list[Any],
    generators: dict[str, dict[str, Any]],
    generated: dict[str, dict[str, Any]],
    node: dict[str, Any],
) -> int:

    from momu.engine.provenance import git_commit, package_versions
    from momu.following import run_benchmark, write_results

    start, commit = time.time(), git_commit()  # the code that runs, not what is checked out at the end
    directions = {
        d: run_benchmark(
            pairs,
            gens,
            direction=d,
            generated=generated[d],
            seeds=args.seeds,
            controls=not args.no_controls,
            progress=not args.quiet,
        )
        for d, gens in generators.items()
    }
    data = "synth_dance" if args.data == "synth" else Path(args.data).name
    results = {
        "benchmark": "music_following",
        "data": f"{data} ({args.split} split)" if node["name"] != "pair_folder" else data,
        "settings": {
            "generator": args.generator,
            "split": args.split,
            "songs": len(pairs),
            "seconds": args.seconds,
            "seeds": " ".join(map(str, args.seeds)),
            **({"beats_per_movement": args.beats_per_movement} if generators.get("music") else {}),
        },
        "dataset": node,
        "directions": directions,
        "provenance": {
            "command": [
                "python",
                "recipes/music_following.py",
                *(argv if argv is not None else sys.argv[1:]),
            ],
            "git_commit": commit,
            "versions": package_versions(),
            "wall_time_s": round(time.time() - start, 1),
        },
    }
    js, md = write_results(results, args.out / "music_following")
    for d, res in directions.items():
        log.info("%s: ground truth passes %s", d, ", ".join(res["ground_truth_passes"]) or "none")
    log.info("wrote %s and %s (%.0f s)", js, md, time.time() - start)
    return 0
