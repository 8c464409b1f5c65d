"""MoMu-Diffusion Tables 2–6: the paper's numbers, the columns, and the per-subset configs.

See :mod:`momu.methods.momu.tables` for the tables themselves.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from momu.config import ConfigError, apply_overrides, build_component, to_container
from momu.engine.context import RunContext
from momu.engine.table import Column
from momu.methods.momu.recipes import BASE_CONFIG, SHARED_DIR
from momu.methods.momu.recipes import PRESETS as MOMU_PRESETS

log = logging.getLogger(__name__)

TABLES_CONFIG = BASE_CONFIG.parent / "momu_tables.yaml"
"""Subsets, stand-ins and Table 3–4 settings, merged over ``recipes/configs/momu.yaml``."""


BEAT_METRICS: tuple[tuple[str, str, bool], ...] = (
    ("bcs", "BCS", True),
    ("csd", "CSD", False),
    ("bhs", "BHS", True),
    ("hsd", "HSD", False),
    ("f1", "F1", True),
)
"""LORIS beat scores (MoMu App. B.4): key, label, higher is better."""

QUALITY_METRICS: tuple[tuple[str, str, bool], ...] = (
    ("fid", "FID", False),
    ("diversity", "Diversity", True),
    ("mean_kld", "Mean KLD", False),
)
"""Music→motion quality (MoMu Table 6, App. B.5)."""

# ---------------------------------------------------------------------------------------- paper numbers
_B = ("bcs", "csd", "bhs", "hsd", "f1")
_Q = ("fid", "diversity", "mean_kld")


def _cells(groups: Mapping[str, Sequence[float]], keys: Sequence[str] = _B) -> dict[str, float]:
    out: dict[str, float] = {}
    for prefix, values in groups.items():
        if len(values) != len(keys):
            raise ValueError(f"paper cells of {prefix}: {len(values)} values for {len(keys)} columns")
        out.update({f"{prefix}_{k}": float(v) for k, v in zip(keys, values)})
    return out


# Table 3 and Table 4 print the same baseline numbers (the paper's Table 4 block repeats Table 3's
# baseline rows verbatim); they are reported as printed.
_FLOOR_SKATING_BASELINES = {
    "Foley": ((36.0, 36.2, 32.3, 30.7, 34.1), (32.6, 38.0, 28.4, 32.5, 30.4)),
    "CMT": ((46.4, 30.1, 57.4, 29.8, 51.3), (42.3, 32.0, 53.8, 31.7, 47.4)),
    "D2MGAN": ((45.3, 27.7, 58.7, 30.1, 51.1), (41.9, 29.2, 54.7, 32.7, 47.5)),
    "CDCD": ((49.0, 21.1, 61.0, 27.0, 54.3), (45.9, 23.8, 57.5, 29.3, 51.0)),
    "LORIS": ((58.8, 19.4, 67.1, 21.1, 62.7), (54.7, 21.6, 63.8, 24.5, 58.9)),
}

PAPER: dict[str, dict[str, dict[str, float]]] = {
    "momu_table2": {
        "Foley": _cells({"aist": (96.4, 6.9, 41.0, 15.0, 57.5)}),
        "CMT": _cells({"aist": (97.1, 6.4, 46.2, 18.6, 62.6)}),
        "D2MGAN": _cells({"aist": (95.6, 9.4, 88.7, 19.0, 93.1)}),
        "CDCD": _cells({"aist": (96.5, 9.1, 89.3, 18.1, 92.7)}),
        "LORIS": _cells({"aist": (98.6, 6.1, 90.8, 13.9, 94.5)}),
        "Ours": _cells({"aist": (97.5, 5.2, 98.6, 2.8, 98.1)}),
    },
    "momu_table3": {
        **{name: _cells({"fe25": a, "fe50": b}) for name, (a, b) in _FLOOR_SKATING_BASELINES.items()},
        "Ours": _cells({"fe25": (66.6, 14.3, 76.9, 19.1, 71.4), "fe50": (62.7, 24.0, 68.1, 20.2, 65.3)}),
    },
    "momu_table4": {
        **{name: _cells({"fs25": a, "fs50": b}) for name, (a, b) in _FLOOR_SKATING_BASELINES.items()},
        "Ours": _cells({"fs25": (63.5, 16.3, 75.6, 28.8, 69.0), "fs50": (59.9, 22.6, 68.7, 22.2, 64.0)}),
    },
    "momu_table5": {
        "D2M": _cells({"aist": (23.7, 13.8, 42.8, 23.6, 30.5), "bhs": (35.1, 15.9, 57.5, 35.0, 43.6)}),
        "DiffGesture": _cells(
            {"aist": (28.5, 16.7, 40.4, 25.7, 33.4), "bhs": (42.8, 21.3, 61.1, 23.9, 50.3)}
        ),
        "Ours": _cells({"aist": (39.2, 10.2, 56.3, 12.0, 46.2), "bhs": (47.9, 8.4, 78.5, 12.1, 59.5)}),
    },
    "momu_table6": {
        "D2M": _cells({"aist": (17.3, 46.2, 14.5), "bhs": (11.6, 55.9, 7.4)}, _Q),
        "DiffGesture": _cells({"aist": (18.6, 37.1, 12.6), "bhs": (13.8, 38.9, 7.0)}, _Q),
        "Ours": _cells({"aist": (7.3, 52.7, 4.9), "bhs": (6.5, 67.4, 4.2)}, _Q),
    },
}
"""The numbers printed in MoMu Tables 2–6, keyed ``<subset>_<metric>`` (percent for beat scores)."""

SUBSET_LABELS = {
    "aist": "AIST++",
    "bhs": "BHS",
    "fe25": "FE-25s",
    "fe50": "FE-50s",
    "fs25": "FS-25s",
    "fs50": "FS-50s",
}


# ---------------------------------------------------------------------------------------- columns
def beat_columns(prefix: str, label: str = "") -> list[Column]:
    """BCS↑ CSD↓ BHS↑ HSD↓ F1↑ columns keyed ``<prefix>_<metric>``."""
    head = f"{label} " if label else ""
    return [
        Column(f"{prefix}_{k}", f"{head}{lab}{'↑' if hi else '↓'}", hi, reducer="f1" if k == "f1" else "mean")
        for k, lab, hi in BEAT_METRICS
    ]


def onset_column(prefix: str, label: str = "") -> Column:
    """``<prefix>_onset_f1``: the ±50 ms onset F-measure diagnostic (not in the paper)."""
    head = f"{label} " if label else ""
    return Column(f"{prefix}_onset_f1", f"{head}onset F1 ±50ms↑", True)


def quality_columns(prefix: str, label: str = "") -> list[Column]:
    """FID↓ Diversity↑ Mean KLD↓ columns keyed ``<prefix>_<metric>``."""
    head = f"{label} " if label else ""
    return [Column(f"{prefix}_{k}", f"{head}{lab}{'↑' if hi else '↓'}", hi) for k, lab, hi in QUALITY_METRICS]


def beat_percent(prefix: str, scores: Mapping[str, float]) -> dict[str, float]:
    """``beat_scores`` / ``kinematic_beat_scores`` output (fractions) → ``<prefix>_<metric>`` in percent."""
    out = {}
    for key, _, _ in BEAT_METRICS:
        value = next((v for k, v in scores.items() if k == key or k.endswith("." + key)), None)
        if value is None:
            raise KeyError(f"beat scores have no {key!r} (got {', '.join(scores)})")
        out[f"{prefix}_{key}"] = 100.0 * float(value)
    return out


# ---------------------------------------------------------------------------------------- config
def table_base_config(
    momu_yaml: str | Path = BASE_CONFIG,
    tables_yaml: str | Path = TABLES_CONFIG,
    subsets: Sequence[str] | None = None,
) -> dict[str, Any]:
    """``momu.yaml`` (the method) merged with ``momu_tables.yaml``; its ``dataset`` node is dropped.

    Each subset brings its own dataset node; the method, the training settings and the evaluation
    settings are ``momu.yaml``'s, so Tables 2–6 and Table 7 train the same model on the same data.
    ``subsets`` keeps only the table's own subsets (all when ``None``).
    """
    for path in (momu_yaml, tables_yaml):
        if not Path(path).is_file():
            raise ConfigError(f"{path}: config file not found")
    base = OmegaConf.to_container(OmegaConf.merge(OmegaConf.load(momu_yaml), OmegaConf.load(tables_yaml)))
    assert isinstance(base, dict)
    base.pop("dataset", None)
    if subsets is not None:
        defined = base.get("subsets") or {}
        missing = [s for s in subsets if s not in defined]
        if missing:
            raise ConfigError(f"{tables_yaml}: subsets {', '.join(missing)} not defined")
        base["subsets"] = {s: defined[s] for s in subsets}
    return {str(k): v for k, v in base.items()}


def table_presets(subsets: Sequence[str]) -> dict[str, list[str]]:
    """The Table 7 presets (:data:`momu.methods.momu.recipes.PRESETS`) for a table over ``subsets``.

    The method overrides are Table 7's; its ``dataset.*`` overrides are applied to every subset's
    synthetic stand-in. ``smoke`` also shrinks the Table 3–4 encoder and lengths, ``paper`` sets
    the Table 3–4 DiT length to fit 50 s.
    """
    out: dict[str, list[str]] = {}
    for preset, overrides in MOMU_PRESETS.items():
        method = [o for o in overrides if not o.startswith("dataset.")]
        data = [o.split(".", 1)[1] for o in overrides if o.startswith("dataset.")]
        per_subset = [f"subsets.{s}.synth_dataset.{o}" for s in subsets for o in data]
        out[preset] = [*method, *per_subset, *_EXTRA_PRESETS[preset](subsets)]
    return out


def _smoke_extra(subsets: Sequence[str]) -> list[str]:
    extra = [
        "learnable_encoder.dim_feat=16",
        "learnable_encoder.dim_rep=8",
        "learnable_encoder.depth=1",
        "learnable_encoder.num_heads=2",
        "learnable_train.steps=3",
        "learnable_train.batch_size=4",
        "method.evaluation.extractor_epochs=1",
    ]
    lengths = {"25": 2.0, "50": 3.0}
    for s in subsets:
        if s[-2:] in lengths:
            extra.append(f"subsets.{s}.seconds={lengths[s[-2:]]}")
    return extra


PAPER_LENGTHS = ("25", "50")
"""Suffixes of the Table 3–4 length subsets (``fe25`` … ``fs50``): the clip length in seconds."""

_EXTRA_PRESETS: dict[str, Callable[[Sequence[str]], list[str]]] = {
    "smoke": _smoke_extra,
    "cpu": lambda subsets: [],
    # bare names replace the cpu-sized nodes of momu_tables.yaml, then every field is pinned: MotionBERT's
    # DSTformer sizes (MoMu §5.1 "derived from [51]"), the denoisers' App. B.3 optimiser, a DiT
    # length that holds 50 s with concatenated positions (2 x 1562 + 1 = 3125), and Tables 3-4's
    # 25-s and 50-s columns at their own lengths (momu_tables.yaml's 4 s / 8 s are the cpu stand-ins)
    "paper": lambda subsets: [
        "learnable_encoder=learnable_motion",
        "learnable_encoder={dim_feat: 256, dim_rep: 256, depth: 5, num_heads: 8, mlp_ratio: 4.0,"
        " velocity: false, standardize: true}",
        "learnable_train={steps: 400000, batch_size: 16, lr: 1.6e-5, warmup_steps: 10000,"
        " lr_schedule: constant, weight_decay: 0.0}",
        "learnable_frames_per_latent=1",
        "method.music_backbone.max_length=3200",
        *(f"subsets.{s}.seconds={float(s[-2:])}" for s in subsets if s[-2:] in PAPER_LENGTHS),
    ],
}


def subset_config(cfg: DictConfig, subset: str) -> DictConfig:
    """``cfg`` with ``dataset`` set to ``subset``'s node (synthetic or real) and its length applied.

    ``--data DIR`` (``real_data.root`` set) selects ``real_dataset`` (a relative ``root`` is taken
    under ``DIR``), otherwise ``synth_dataset``.
    A subset with ``seconds`` (Tables 3–4) sets the stand-in's clip length, the evaluation length
    and the training window to it (hop: half of it): the paper trains and evaluates each length
    column on clips of that length.
    """
    plain = to_container(cfg)
    subsets = plain.get("subsets") or {}
    if subset not in subsets:
        raise ConfigError(f"subsets.{subset}: not defined; defined subsets: {', '.join(subsets) or 'none'}")
    sub = subsets[subset]
    real_root = (plain.get("real_data") or {}).get("root")
    real = real_root is not None
    node = dict(sub["real_dataset"] if real else sub["synth_dataset"])
    if real and node.get("root") is not None:  # a relative root is a folder under --data DIR
        node["root"] = str(Path(str(real_root)) / str(node["root"]))
    overrides = []
    if real and sub.get("real_joints"):  # the keypoint VAE's input layout of the real data
        joints, dims = (int(x) for x in sub["real_joints"])
        overrides += [f"method.encoder.num_joints={joints}", f"method.encoder.joint_dims={dims}"]
    seconds = sub.get("seconds")
    if seconds is not None:
        s = float(seconds)
        if not real:
            node.update(min_seconds=s, max_seconds=s)
        overrides += [
            f"method.evaluation.seconds={s}",
            f"method.window_seconds={s}",
            f"method.window_hop_seconds={s / 2}",
        ]
    plain["dataset"] = node
    plain.pop("subsets", None)
    # ``cfg`` is validated already; the parts built from the result validate their own nodes
    out = apply_overrides(plain, overrides)
    OmegaConf.set_readonly(out, True)
    return out


def check_subsets(cfg: DictConfig, subsets: Sequence[str], *, need_audio: bool = True) -> None:
    """Fail before any training if a subset is undefined, its real data folder is missing, or
    (``need_audio``) its clips carry no waveform."""
    real = (cfg.get("real_data") or {}).get("root") is not None
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        if not real:
            continue
        root = scfg.dataset.get("root")
        if root is not None and not Path(str(root)).is_dir():
            raise FileNotFoundError(f"subsets.{sid}: dataset folder {root} not found")
        dataset = build_component(scfg.dataset, "datasets")
        if len(dataset) == 0:
            raise ValueError(f"subsets.{sid}: dataset {scfg.dataset.name!r} under {root} has no clips")
        if need_audio and dataset[0].audio is None:
            raise ValueError(
                f"subsets.{sid}: dataset {scfg.dataset.name!r} has no raw audio (BHS Dance ships MFCC "
                "features only); MoMu's MFCC-conditioned variant without BiCoR-VAE (§5.2) is not implemented"
            )


def shared_context(ctx: RunContext) -> RunContext:
    """A context whose stages live in ``<out>/momu_shared`` (shared by Tables 2–6; provenance and
    remembered values shared too)."""
    return RunContext(
        accelerator=ctx.accelerator,
        out_dir=ctx.out_dir.parent / SHARED_DIR,
        resume=ctx.resume,
        trained=ctx.trained,
        timings=ctx.timings,
        derived=ctx.derived,
    )
