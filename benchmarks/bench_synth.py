"""Benchmark: generate and write ``synth_dance`` (issue 3 target: 256 clips x 10 s in < 60 s on 2 cores).

Usage::

    python benchmarks/bench_synth.py [--clips 256] [--seconds 10] [--skeleton smpl24] [--out DIR]

Prints the wall time of in-memory generation and of ``write_dataset`` (generation + wav/npy/manifest
writing), and checks that writing the same configuration twice gives byte-identical files.
"""

from __future__ import annotations

import argparse
import hashlib
import tempfile
import time
from pathlib import Path

from momu.data.synth import STYLE_NAMES, SynthConfig, generate_clip, write_dataset
from momu.features.skeletons import SKELETON_NAMES


def _digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(folder)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clips", type=int, default=256)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--skeleton", default="smpl24", choices=SKELETON_NAMES)
    parser.add_argument("--out", type=Path, default=None, help="write here (default: a temporary folder)")
    args = parser.parse_args()
    cfg = SynthConfig(
        num_clips=args.clips,
        min_seconds=args.seconds,
        max_seconds=args.seconds,
        skeleton=args.skeleton,
        styles=list(STYLE_NAMES),
    )

    t0 = time.perf_counter()
    frames = sum(generate_clip(cfg, i).num_frames for i in range(cfg.num_clips))
    gen = time.perf_counter() - t0
    print(
        f"generate in memory: {cfg.num_clips} clips x {args.seconds:g} s ({cfg.skeleton}, {frames} frames): "
        f"{gen:.2f} s ({1000 * gen / max(cfg.num_clips, 1):.1f} ms/clip)"
    )

    with tempfile.TemporaryDirectory() as tmp:
        first = args.out if args.out is not None else Path(tmp) / "a"
        t0 = time.perf_counter()
        write_dataset(first, cfg)
        wrote = time.perf_counter() - t0
        size = sum(p.stat().st_size for p in first.rglob("*") if p.is_file())
        print(f"write_dataset: {wrote:.2f} s, {size / 2**20:.1f} MiB")
        second = Path(tmp) / "b"
        write_dataset(second, cfg)
        print("byte-identical second write:", _digest(first) == _digest(second))


if __name__ == "__main__":
    main()
