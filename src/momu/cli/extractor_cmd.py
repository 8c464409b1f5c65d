"""``momu extractor train|info``: train and inspect the learned-metric feature extractors.

``momu extractor train --kind motion|audio --data synth|DIR --out FILE.safetensors [...]`` trains the
motion style classifier (DSTformer, MoMu App. B.5) or the default audio embedding (log-mel CNN) on the
style labels (``Clip.style``) of a dataset and writes ``FILE.safetensors`` + ``FILE.json``. ``--data synth``
generates ``synth_dance`` in memory; ``--data DIR`` reads a registered dataset (``--dataset``, default
``synth_dance``) from ``DIR``. The trained file is then named in a metric config
(``fid_learned.extractor=FILE.safetensors`` …). ``momu extractor info FILE`` prints its kind, classes,
training summary and sha256.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
from pathlib import Path
from typing import Any

from momu.config import ConfigError

__all__ = ["add_parser", "run_train", "run_info", "load_training_clips"]

logger = logging.getLogger(__name__)


def add_parser(sub: Any) -> None:
    p = sub.add_parser("extractor", help="train / inspect the feature extractors of the learned metrics")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True

    t = actions.add_parser(
        "train",
        help="train a motion or audio style classifier (features for fid_learned, mean_kld, diversity, fad)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    t.add_argument("--kind", required=True, choices=("motion", "audio"), help="which extractor to train")
    t.add_argument("--data", required=True, help="'synth' (generate synth_dance) or a dataset folder")
    t.add_argument("--out", required=True, type=Path, help="output weights, FILE.safetensors (+ FILE.json)")
    t.add_argument(
        "--dataset", default="synth_dance", help="registered dataset reading DIR (default synth_dance)"
    )
    t.add_argument(
        "--split", default="train", help="dataset split to train on (default train; 'all' = every clip)"
    )
    g = t.add_argument_group("synthetic data (--data synth)")
    g.add_argument("--clips", type=int, default=48, help="number of synth clips, all splits (default 48)")
    g.add_argument("--seconds", type=float, default=6.0, help="synth clip duration in seconds (default 6)")
    g.add_argument("--skeleton", default="openpose14", help="synth joint layout (default openpose14)")
    g.add_argument("--fps", type=float, default=None, help="synth motion frame rate (default: skeleton's)")
    g.add_argument("--data-seed", type=int, default=0, help="synth dataset seed (default 0)")
    o = t.add_argument_group("training")
    o.add_argument("--epochs", type=int, default=None, help="epochs (default 20; 100 with --paper)")
    o.add_argument("--batch-size", type=int, default=16)
    o.add_argument(
        "--lr", type=float, default=None, help="Adam learning rate (default 1e-3; 1e-4 with --paper)"
    )
    o.add_argument(
        "--samples-per-clip", type=int, default=8, help="random windows/segments per clip per epoch"
    )
    o.add_argument("--val-fraction", type=float, default=0.2, help="held-out clip fraction for accuracy")
    o.add_argument("--seed", type=int, default=0, help="training seed")
    o.add_argument("--device", default="cpu")
    o.add_argument("--paper", action="store_true", help="MoMu App. B.5 schedule: Adam lr 1e-4, 100 epochs")
    m = t.add_argument_group("motion classifier")
    m.add_argument("--model-fps", type=float, default=15.0, help="classifier frame rate (default 15)")
    m.add_argument("--window", type=int, default=30, help="frames per window at --model-fps (default 30)")
    m.add_argument("--depth", type=int, default=2, help="DSTformer dual-stream layers (default 2)")
    m.add_argument("--dim-feat", type=int, default=32, help="DSTformer width (default 32)")
    m.add_argument("--dim-rep", type=int, default=16, help="DSTformer output width per joint (default 16)")
    t.set_defaults(func=run_train)

    i = actions.add_parser("info", help="print a trained extractor's kind, classes, summary and sha256")
    i.add_argument("path", type=Path, help="FILE.safetensors written by `momu extractor train`")
    i.set_defaults(func=run_info)


def load_training_clips(args: argparse.Namespace) -> list[Any]:
    """The labelled clips ``--data`` names (materialised)."""
    from momu.registry import DATASETS

    split = None if args.split in ("all", "") else args.split
    if args.data == "synth":
        from momu.data.synth import SynthConfig, SynthDance

        cfg = SynthConfig(
            num_clips=args.clips,
            min_seconds=args.seconds,
            max_seconds=args.seconds,
            skeleton=args.skeleton,
            fps=args.fps,
            seed=args.data_seed,
        )
        dataset: Any = SynthDance(cfg, split=split)
    else:
        root = Path(args.data)
        if not root.is_dir():
            raise ValueError(f"--data {root}: not 'synth' and not a folder")
        entry = DATASETS.get(args.dataset)
        fields = {f.name for f in dataclasses.fields(entry.config)} if entry.config else set()
        if "root" not in fields:
            raise ValueError(
                f"--dataset {args.dataset}: this dataset does not read from a folder (no 'root')"
            )
        params: dict[str, Any] = {"root": str(root)}
        if "split" in fields and split is not None:
            params["split"] = split
        if "load_audio" in fields and args.kind == "motion":
            params["load_audio"] = False  # motion classifiers never read the audio
        dataset = DATASETS.build(args.dataset, params)
    clips = [dataset[i] for i in range(len(dataset))]
    if not clips:
        raise ValueError(f"--data {args.data}: no clips in split {args.split!r}")
    return clips


def run_train(args: argparse.Namespace) -> int:
    from momu.encoders.dstformer import DSTformerConfig
    from momu.metrics.extractors import (
        AudioClassifierConfig,
        MotionClassifierConfig,
        TrainConfig,
        train_extractor,
    )

    out: Path = args.out
    if out.suffix != ".safetensors":
        sys.stderr.write(f"momu extractor train: error: --out must end in .safetensors, got {out}\n")
        return 2
    try:
        base = TrainConfig.paper() if args.paper else TrainConfig()
        train = dataclasses.replace(
            base,
            epochs=args.epochs if args.epochs is not None else base.epochs,
            lr=args.lr if args.lr is not None else base.lr,
            batch_size=args.batch_size,
            samples_per_clip=args.samples_per_clip,
            val_fraction=args.val_fraction,
            seed=args.seed,
            device=args.device,
        )
        model_cfg: MotionClassifierConfig | AudioClassifierConfig
        if args.kind == "motion":
            model_cfg = MotionClassifierConfig(
                fps=args.model_fps,
                window=args.window,
                dstformer=DSTformerConfig(depth=args.depth, dim_feat=args.dim_feat, dim_rep=args.dim_rep),
            )
        else:
            model_cfg = AudioClassifierConfig()
        clips = load_training_clips(args)
        extractor, summary = train_extractor(args.kind, clips, out, model_config=model_cfg, train=train)
    except (ValueError, FileNotFoundError, ConfigError) as exc:
        sys.stderr.write(f"momu extractor train: error: {exc}\n")
        return 2
    acc = summary["val_accuracy"]
    sys.stdout.write(
        f"trained {extractor.kind} on {len(summary['train_clips'])} clips "
        f"({', '.join(summary['class_names'])})\n"
        f"final loss {summary['loss_history'][-1]:.4f}; held-out accuracy "
        f"{'n/a' if acc is None else f'{acc:.3f}'} on {len(summary['val_clips'])} clips\n"
        f"wrote {out} (sha256 {extractor.sha256}) and {out.with_suffix('.json')}\n"
    )
    return 0


def run_info(args: argparse.Namespace) -> int:
    from momu.io import read_json
    from momu.metrics.extractors import file_sha256

    path: Path = args.path
    side = path.with_suffix(".json")
    try:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: file not found")
        meta = read_json(side)
    except (OSError, ValueError) as exc:
        sys.stderr.write(f"momu extractor info: error: {exc}\n")
        return 2
    digest = file_sha256(path)
    train = meta.get("train", {}) if isinstance(meta, dict) else {}
    info = {
        "path": str(path),
        "kind": meta.get("kind"),
        "sha256": digest,
        "sha256_matches_json": digest == meta.get("sha256"),
        "classes": train.get("class_names"),
        "val_accuracy": train.get("val_accuracy"),
        "final_loss": (train.get("loss_history") or [None])[-1],
        "config": meta.get("config"),
    }
    sys.stdout.write(json.dumps(info, indent=2) + "\n")
    return 0
