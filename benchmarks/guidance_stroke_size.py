"""Does guidance make the dance's strokes wider than its training data's? (issue 32, foot speed)

    python benchmarks/guidance_stroke_size.py [--model DIR] [--scales 8 1] [--songs 4] \
        [--data ../shared/data/dance_with_melody] [--out FILE.json]

For the shipped dance model (or ``--model DIR``), each motion-sampler guidance scale in ``--scales``
(everything else as the folder has it) and generation seed 0: the dance for the first ``--songs``
15-s excerpts of (a) ``synth_dance`` validation songs as the shipped model is trained on
(``recipes/pretrain.py``'s ``SYNTH_OVERRIDES``) and (b) the real Dance with Melody validation songs
(the project's agreed split). Foot speed, joint speed and root travel
(:func:`momu.following.realism.realism_stats`, at the benchmark's 100 Hz) of each generated dance and
of each song's own dance, averaged over the songs. Writes the averages per scale and source.
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import OmegaConf

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "recipes"))

log = logging.getLogger("guidance_stroke_size")
KEYS = ("foot_speed", "joint_speed", "root_travel_m_per_min")


def _synth_node() -> dict[str, Any]:
    """``synth_dance`` val songs as the shipped model is trained on (``pretrain.SYNTH_OVERRIDES``)."""
    from pretrain import SYNTH_OVERRIDES

    from momu.config import apply_overrides

    base = {"dataset": {"name": "synth_dance", "num_clips": 64, "split": "val", "seed": 0}}
    base["dataset"].update({"min_seconds": 18.0, "max_seconds": 18.0})
    tree = apply_overrides(base, SYNTH_OVERRIDES)
    return dict(OmegaConf.to_container(tree.dataset))  # type: ignore[arg-type]


def _stats(motion: np.ndarray, fps: float, skeleton: str) -> dict[str, float]:
    from momu.following.realism import realism_stats
    from momu.following.signals import RATE, motion_at_rate

    stats = realism_stats(motion_at_rate(motion, fps), RATE, skeleton)
    return {k: stats[k] for k in KEYS}


def _mean(rows: list[dict[str, float]]) -> dict[str, float]:
    return {k: round(float(np.mean([r[k] for r in rows])), 3) for k in KEYS}


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", type=Path, default=None, help="model folder (default: the shipped one)")
    p.add_argument("--scales", type=float, nargs="+", default=[8.0, 1.0])
    p.add_argument("--songs", type=int, default=4)
    p.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "dance_with_melody"))
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "guidance_stroke_size.json")
    args = p.parse_args()
    from momu.cli.generate_io import default_model_dir
    from momu.following.adapters import from_model_dir
    from momu.following.pairs import dataset_node, load_pairs

    model = args.model or default_model_dir("dance")
    sources = {
        "synth_dance val": load_pairs(_synth_node(), 15.0, args.songs),
        "Dance with Melody val": load_pairs(
            dataset_node(args.data, "val", "dwm21", 15.0, 8), 15.0, args.songs
        ),
    }
    shown = model.resolve().relative_to(ROOT) if model.resolve().is_relative_to(ROOT) else model
    result: dict[str, Any] = {"model": str(shown), "songs": args.songs, "seed": 0, "rows": []}
    for name, pairs in sources.items():
        data = _mean([_stats(p.excerpt_motion(), p.fps, p.skeleton) for p in pairs])
        result["rows"].append({"source": name, "dances": "data", "songs": [p.id for p in pairs], **data})
    for scale in args.scales:
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp) / model.name
            shutil.copytree(model, folder)
            meta = json.loads((folder / "momu.json").read_text())
            meta["config"]["motion_sampler"]["guidance_scale"] = scale
            (folder / "momu.json").write_text(json.dumps(meta, indent=2) + "\n")
            generator = from_model_dir(folder, "dance")
            for name, pairs in sources.items():
                rows = []
                for pair in pairs:
                    motion, fps = generator.generate(pair.excerpt_audio(), pair.sample_rate, 0)  # type: ignore[call-arg, arg-type]
                    rows.append(_stats(np.asarray(motion), fps, pair.skeleton))
                row = {"source": name, "dances": f"generated, guidance scale {scale:g}", **_mean(rows)}
                log.info("%s", row)
                result["rows"].append(row)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    log.info("wrote %s", args.out)


if __name__ == "__main__":
    main()
