"""HarmoGAN's table and figure recipes: base config, presets, columns, rows, table specs.

``recipes/harmogan_table1.py`` … ``harmogan_fig12.py`` are thin scripts over the ``*_spec`` functions
here and :func:`run_harmogan` (the shared table runner plus pairwise comparisons of our rows and a bar
plot).

Presets (``recipes/configs/harmogan.yaml`` is the ``cpu`` preset):

* ``smoke`` — every row end-to-end in seconds (tiny networks, one epoch per stage, 3-s clips; each
  dance cut to 20 s with real data). The numbers mean nothing.
* ``cpu`` — the YAML as is: the real 8 dances with ``--data`` (else the synthetic stand-in), 15 fps,
  2-s meter units, a 64-wide generator, 60 pretraining epochs (the paper's decay factors every 15)
  and the paper's first 15 adversarial epochs (lr 1e-4, 5e-5, 1e-5), held-out 6-s windows.
* ``paper`` — ``recipes/configs/harmogan_paper.yaml`` replaces every node (§V-B's schedules in full,
  momu's documented sizes); nothing is inherited from the cpu YAML.

Every table and figure prints the calibration rows (issue 15): ground truth (calibration), and as rows
with verdicts against ground truth and shuffled pairs on the same clips: shuffled ground truth, audio
shifted by half a beat, a static pose with 0.1 mm noise, and ground truth sped up ×1.25.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from momu.engine.table import Column, PaperRow, Row, TableSpec, parse_table_args, run_table
from momu.engine.table_report import pairwise_lines
from momu.io import atomic_write_text, write_json
from momu.methods.harmogan.ballroom import COLUMNS as GENRES
from momu.methods.harmogan.evaluate import CALIBRATION_ROWS
from momu.methods.harmogan.tables import (
    calibrate_fig9,
    calibrate_fig11,
    calibrate_fig12,
    calibrate_table1,
    calibrate_table2,
    check_genre_columns,
    evaluate_fig9,
    evaluate_fig11,
    evaluate_fig12,
    evaluate_table1,
    evaluate_table2,
)

__all__ = [
    "BASE_CONFIG",
    "PAPER_CONFIG",
    "PRESETS",
    "node_overrides",
    "table1_spec",
    "table2_spec",
    "fig9_spec",
    "fig11_spec",
    "fig12_spec",
    "run_harmogan",
]

_CONFIGS = Path(__file__).resolve().parents[4] / "recipes" / "configs"
BASE_CONFIG = _CONFIGS / "harmogan.yaml"
PAPER_CONFIG = _CONFIGS / "harmogan_paper.yaml"


def node_overrides(path: str | Path) -> list[str]:
    """Overrides that replace every top-level node of a config with ``path``'s (its ``paper`` preset).

    A node holding a ``name`` replaces the node it overrides whole (``momu.config.apply_overrides``); the
    other nodes are mappings whose every key ``path`` pins, so nothing of the base config survives
    (``tests/unit/test_harmogan_recipes.py`` checks the resolved preset against ``path`` loaded alone).
    """
    tree = OmegaConf.to_container(OmegaConf.load(Path(path)), resolve=False)
    assert isinstance(tree, dict)
    return [f"{key!s}={json.dumps(value)}" for key, value in tree.items()]


_TINY = {
    "method.generator_encoder": "{hidden: 16, noise_dim: 4}",
    "method.cross_modal_discriminator_encoder": "{hidden: 16, blocks: 3}",
    "method.spatiotemporal_discriminator_encoder": "{hidden: 16, spatial_blocks: 1}",
}

PRESETS: dict[str, list[str]] = {
    "smoke": [
        *(f"{k}={v}" for k, v in _TINY.items()),
        "dance.real_dataset.window_seconds=20.0",
        "dance.synth_dataset.num_clips=4",
        "dance.synth_dataset.min_seconds=12.0",
        "dance.synth_dataset.max_seconds=12.0",
        "method.test_fraction=0.3",
        "method.meter.unit_seconds=1.0",
        "method.pretrain={epochs: 1, decay_every: 0}",
        "method.adversarial={epochs: 1, decay_every: 0}",
        "method.evaluation.clip_seconds=3.0",
        "ballroom.fraction=0.5",
    ],
    "cpu": [],
    "paper": node_overrides(PAPER_CONFIG),
}

_CALIBRATION = tuple(
    Row(f"cal-{kind.replace('_', '-')}", name, (f"calibration_row={kind}",))
    for kind, name in CALIBRATION_ROWS.items()
)

_TABLE1 = {
    "Lee et al. [28]": (0.3509, 0.3359, 0.2773, 0.2862, 0.2805, 0.2657, 0.2703, 0.2953),
    "Ren et al. [18]": (0.2759, 0.3321, 0.1625, 0.2154, 0.2761, 0.2671, 0.3122, 0.2630),
    "HarmoGAN w/o L_harmo": (0.1536, 0.2115, 0.2150, 0.1679, 0.2495, 0.1929, 0.2377, 0.2040),
    "HarmoGAN": (0.4097, 0.3995, 0.3199, 0.3529, 0.3468, 0.2948, 0.3455, 0.3527),
}
_TABLE2 = {
    "Lee et al. [28]": (58.89, 59.92, 53.03, 65.06, 64.92, 58.46, 54.30, 59.23),
    "Ren et al. [18]": (28.13, 51.03, 33.33, 41.53, 49.07, 42.84, 52.59, 42.65),
    "HarmoGAN w/o L_harmo": (14.25, 17.45, 18.18, 20.91, 29.12, 21.48, 25.53, 20.99),
    "HarmoGAN": (74.60, 75.70, 71.21, 77.01, 83.69, 74.98, 72.89, 75.73),
}
_WITHOUT_HARMO = ("method.weights.harmo=0.0",)
_GAN_ONLY = ("method.weights.harmo=0.0", "method.weights.feat=0.0")

_METRIC_NOTES = (
    "What the harmony score can and cannot show (momu's analysis, docs/papers/harmogan.md): maxima AND "
    "minima of the velocity sum are visual beats (about two per music beat) and T_delay = 0.25 s covers "
    "most phases, and the visual mask is relative to the clip's own variation, so the calibration rows "
    "(shuffled, half-beat shift, static pose + 0.1 mm noise, ×1.25) score close to ground truth: h and the "
    "hit rate measure how densely a motion has salient extrema, not whether they fall on the beat.",
    "h depends on the clip length (per-clip saliency normalisation): every cell is on 6-s clips, the "
    "paper's Ballroom clip length.",
)


def _paper(prefix: str, values: Sequence[float]) -> dict[str, float]:
    return {f"{prefix}_{g}": v for g, v in zip((*GENRES, "average"), values)}


def _genre_spec(
    name: str,
    title: str,
    prefix: str,
    label: str,
    paper: Mapping[str, Sequence[float]],
    evaluate: Any,
    calibrate: Any,
    base: str | Path,
) -> TableSpec:
    columns = [Column(f"{prefix}_{g}", f"{label} {g}↑", True) for g in (*GENRES, "average")]
    return TableSpec(
        name=name,
        title=title,
        base_config=base,
        presets=PRESETS,
        columns=columns,
        rows=[
            Row("harmogan", "HarmoGAN", (), _paper(prefix, paper["HarmoGAN"])),
            Row(
                "wo-harmo",
                "HarmoGAN w/o L_harmo",
                _WITHOUT_HARMO,
                _paper(prefix, paper["HarmoGAN w/o L_harmo"]),
            ),
            *_CALIBRATION,
        ],
        baselines=[PaperRow(n, _paper(prefix, paper[n])) for n in ("Lee et al. [28]", "Ren et al. [18]")],
        evaluate=evaluate,
        calibrate=calibrate,
        check=check_genre_columns,
        data_key="dance",
        notes=(
            "Columns: without ballroom.root, the Dance with Melody stand-in — held-out 6-s windows of its "
            "cha-cha, rumba, tango and waltz dances (jive, quickstep, samba stay empty); the average is the "
            "unweighted mean of the genre columns present (the paper's average is over its 7 Ballroom "
            "columns). With ballroom.root=DIR: the paper's protocol (10 % of each category, 6-s clips; "
            "Rumba-* → rumba, VienneseWaltz → waltz); the calibration rows other than the static pose need "
            "ground-truth motion and stay on the Dance with Melody windows.",
            "Model rows generate from each clip's music starting from its first ground-truth pose (one "
            "initial pose, recurrent over meter units); *other condition* = the same model and noise given "
            "another clip's music, scored against this clip's music.",
            "Lee et al. and Ren et al. are the paper's numbers (external code, not re-run).",
            *_METRIC_NOTES,
        ),
    )


def table1_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """HarmoGAN Table I: harmony score h for 7 types of dance music (Ballroom, 6-s clips)."""
    return _genre_spec(
        "harmogan_table1",
        "HarmoGAN Table I: harmony score h per dance genre",
        "h",
        "h",
        _TABLE1,
        evaluate_table1,
        calibrate_table1,
        base_config,
    )


def table2_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """HarmoGAN Table II: hit rate (%) for 7 types of dance music."""
    return _genre_spec(
        "harmogan_table2",
        "HarmoGAN Table II: hit rate (%) per dance genre",
        "hit_rate",
        "hit rate %",
        _TABLE2,
        evaluate_table2,
        calibrate_table2,
        base_config,
    )


def fig12_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """HarmoGAN Fig. 12: h and hit rate on the Dance test set (no values in the paper)."""
    return TableSpec(
        name="harmogan_fig12",
        title="HarmoGAN Fig. 12: harmony score and hit rate on the Dance data (held-out windows)",
        base_config=base_config,
        presets=PRESETS,
        columns=[Column("h", "h↑", True), Column("hit_rate", "hit rate %↑", True)],
        rows=[
            Row("harmogan", "HarmoGAN"),
            Row("wo-harmo", "HarmoGAN w/o L_harmo", _WITHOUT_HARMO),
            *_CALIBRATION,
        ],
        evaluate=evaluate_fig12,
        calibrate=calibrate_fig12,
        data_key="dance",
        notes=(
            "The paper's Fig. 12 has bars only: HarmoGAN 'significantly outperforms its variant in both "
            "harmony score and hit rate, achieving results that are comparable to human ground truth'. "
            "The pairwise section compares our rows directly.",
            *_METRIC_NOTES,
        ),
    )


def fig9_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """HarmoGAN Fig. 9: motion quality of three GAN variants against ground truth (no values in the paper)."""
    return TableSpec(
        name="harmogan_fig9",
        title="HarmoGAN Fig. 9: motion quality of the GAN variants (lower is better)",
        base_config=base_config,
        presets=PRESETS,
        columns=[
            Column("mse", "MSE (m²)↓", False),
            Column("cosine", "cosine distance↓", False),
            Column("fid", "pose FD↓", False),
            Column("bone_error", "bone-length error %↓", False),
            Column("foot_error", "foot-height error (cm)↓", False),
        ],
        rows=[
            Row("gan", "L_gan only (no L_feat, no L_harmo)", _GAN_ONLY),
            Row("gan-feat", "+ L_feat (= w/o L_harmo)", _WITHOUT_HARMO),
            Row("gan-feat-harmo", "+ L_harmo (HarmoGAN)"),
            *_CALIBRATION,
        ],
        evaluate=evaluate_fig9,
        calibrate=calibrate_fig9,
        data_key="dance",
        notes=(
            "The paper plots MSE, cosine distance, LPIPS and FID (bars, no values): L_gan alone is better on "
            "MSE, cosine and FID but fails on LPIPS; + L_feat helps LPIPS and worsens the rest; + L_harmo is "
            "the best trade-off. LPIPS needs pretrained image networks (unavailable offline): not computed.",
            "Every variant keeps λ_kl L_kl + λ_mse L_mse; L_feat is momu's kinematic stand-in for the VGG "
            "feature loss (velocities and accelerations), not VGG.",
            "pose FD: Fréchet distance of the per-frame root-centred poses (63-d) of the generated vs the "
            "ground-truth held-out windows (a stand-in for FID on rendered frames); its *ground truth* row, "
            "and the reference every row is compared with, is the training frames vs the held-out frames. "
            "The shuffled, half-beat and ×1.25 rows pool the held-out frames themselves: their pose FD is 0 "
            "up to rounding, the same for every seed, and gets no verdict.",
            "bone-length error: mean over bones of |mean length / the training data's mean − 1| per clip; "
            "foot-height error: |median lowest heel/toe height relative to the root − the ground-truth "
            "clip's| (`foot_height` itself is in results.json). The shuffled row shows the data's own "
            "spread: another real clip's motion, judged against this clip.",
        ),
    )


def fig11_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """HarmoGAN Fig. 11, metric side: how often h ranks ground truth above its perturbation."""
    kinds = {
        "chunks": ("permuted 1-s chunks", ["chunks"]),
        "slow": ("slowed ×0.8", ["slow"]),
        "fast": ("sped up ×1.25", ["fast"]),
        "pooled": (
            "chunks, slow and fast pooled (the paper's 'permuting or warping')",
            ["chunks", "slow", "fast"],
        ),
        "shuffled": ("motion of another clip (shuffled)", ["shuffled"]),
        "half-beat": ("audio shifted by half a beat", ["half_beat"]),
        "static": ("static mean pose + 0.1 mm noise", ["static"]),
    }
    rows = [
        Row(
            rid,
            name,
            (f"fig11_perturbations={json.dumps(k)}",),
            {"agreement_h": 81.5} if rid == "pooled" else {},
        )
        for rid, (name, k) in kinds.items()
    ]
    return TableSpec(
        name="harmogan_fig11",
        title="HarmoGAN Fig. 11 (metric side): h ranks ground truth above a perturbed copy",
        base_config=base_config,
        presets=PRESETS,
        columns=[
            Column("agreement_h", "GT ranked higher by h %↑", True),
            Column("agreement_hit_rate", "GT ranked higher by hit rate %↑", True),
            Column("h", "h of the perturbed copy", True),
        ],
        rows=rows,
        evaluate=evaluate_fig11,
        calibrate=calibrate_fig11,
        data_key="dance",
        notes=(
            "The paper's 81.5 % is the agreement of h with 12 viewers on 20 pairs (ground truth vs permuted "
            "or "
            "warped copies); momu has no viewers, so this is the metric side only: the share of all 6-s "
            "windows of the dances where h (or the hit rate) scores the ground truth above its perturbed "
            "copy (ties ½). Viewers presumably prefer ground truth in all of them.",
            *_METRIC_NOTES,
        ),
    )


def run_harmogan(spec: TableSpec, argv: Sequence[str] | None = None) -> int:
    """:func:`momu.engine.table.run_table`, then the pairwise comparisons of our rows (appended to
    ``results.md``, ``pairwise.json``) and a bar plot (``bars.png``)."""
    status = run_table(spec, argv)
    if status != 0:
        return status
    out = parse_table_args(spec, argv).out / spec.name
    results = out / "results.json"
    if not results.is_file():  # not the main process
        return status
    result = json.loads(results.read_text())
    lines, pairs = pairwise_lines(result)
    write_json(out / "pairwise.json", pairs)
    md = (out / "results.md").read_text()
    atomic_write_text(out / "results.md", md.rstrip("\n") + "\n" + "\n".join(lines) + "\n")
    from momu.methods.harmogan.plot import bar_plot

    bar_plot(result, out / "bars.png")
    return status
