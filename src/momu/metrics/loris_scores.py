"""Beat coverage / hit scores BCS, CSD, BHS, HSD and F1 (LORIS ``beats_scores.py``; METRICS.md §1.8).

MoMu-Diffusion §5 / App. B.4 reports these for motion→music: onsets of the generated and of the
ground-truth music, each reduced to a vector of **one-second bins** (a bin is 1 if any onset falls in
that second), matched bin by bin:

* audio → mono, 22050 Hz (``librosa.load`` default, soxr_hq resampling);
* ``onset_detect(y, sr=22050, wait=1, delta=0.2, pre_avg=3, post_avg=3, pre_max=3, post_max=3,
  units='time')`` — windows in frames of 512/22050 s = 23.2 ms;
* ``n = ceil(len(y)/22050)`` bins, ``bin[int(trunc(t))] = 1``;
* per pair: ``gt ← gt[:len(syn)]`` (a generated vector longer than the ground truth is an error),
  ``Nt = Σgt, Ns = Σsyn, Nm = #{gt = syn = 1}``; ``BCS = Nm/Ns`` (0 if Ns = 0), ``BHS = Nm/Nt``
  (0 if Nt = 0);
* dataset: ``BCS``/``BHS`` = means, ``CSD``/``HSD`` = ``np.std(ddof=1)`` across pairs,
  ``F1 = 2·BCS·BHS/(BCS+BHS)`` of the means. Fractions in [0, 1] (the paper prints ×100).

Variant ``"cdcd"`` (L-YeZhu/CDCD, vtan05/dmd): ``onset_detect(..., pre_avg=1, post_avg=1, post_max=1)``
(pre_max 1), no truncation (equal lengths required), ``BCS = Ns/Nt`` (can exceed 1), ``BHS = Nm/Nt``,
dataset = plain means, no std.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import librosa
import numpy as np

from momu.data.types import Clip
from momu.metrics._audio import prepare_audio
from momu.metrics._checks import EmptyBeatsError, as_times
from momu.metrics._clips import ClipMetric, check_pairs, clip_audio
from momu.metrics.base import MetricResult
from momu.registry import METRICS

__all__ = [
    "LORIS_SR",
    "ONSET_PARAMS",
    "onset_times",
    "second_bins",
    "check_bin_seconds",
    "onset_beat_bins",
    "pair_beat_scores",
    "aggregate_beat_scores",
    "beat_scores",
    "BeatScoresConfig",
    "BeatScoresMetric",
]

logger = logging.getLogger(__name__)

LORIS_SR = 22050
"""Sample rate (Hz) the reference loads audio at (``librosa.load`` default)."""

ONSET_PARAMS: dict[str, dict[str, Any]] = {
    "loris": {"wait": 1, "delta": 0.2, "pre_avg": 3, "post_avg": 3, "pre_max": 3, "post_max": 3},
    "cdcd": {"wait": 1, "delta": 0.2, "pre_avg": 1, "post_avg": 1, "post_max": 1},
}
"""``librosa.onset.onset_detect`` keyword arguments of each variant (windows in 23.2 ms frames)."""

Variant = Literal["loris", "cdcd"]


def _variant(variant: str) -> str:
    if variant not in ONSET_PARAMS:
        raise ValueError(f"variant: expected 'loris' or 'cdcd', got {variant!r}")
    return variant


def _detect(audio: np.ndarray, sr: int, variant: str) -> tuple[np.ndarray, float]:
    y = prepare_audio(audio, sr, LORIS_SR)
    params = ONSET_PARAMS[_variant(variant)]
    times = librosa.onset.onset_detect(y=y, sr=LORIS_SR, units="time", **params)
    return np.asarray(times, dtype=np.float64), len(y) / LORIS_SR


def onset_times(audio: np.ndarray, sr: int, *, variant: Variant = "loris") -> np.ndarray:
    """Onset times in seconds of a waveform, detected exactly as the reference (22050 Hz, hop 512)."""
    return _detect(audio, sr, variant)[0]


def second_bins(times: np.ndarray, duration: float, bin_seconds: float = 1.0) -> np.ndarray:
    """Beat vector: ``ceil(duration / w)`` int bins, ``bin[trunc(t / w)] = 1`` for each time ``t``.

    ``w = bin_seconds`` is 1 s in the reference (one-second bins); a finer ``w`` is momu's option for
    data whose music has an onset in every second (every pair would then match every bin).

    Args:
        times: event times in seconds (>= 0).
        duration: length of the signal in seconds (``len(y)/sr`` in the reference); events at or past
            ``ceil(duration / w) * w`` seconds are an error.
        bin_seconds: bin width ``w`` in seconds (> 0).
    """
    t = as_times(times, "times")
    if not duration >= 0 or not math.isfinite(duration):
        raise ValueError(f"duration: must be a finite number of seconds >= 0, got {duration!r}")
    w = check_bin_seconds(bin_seconds)
    n = int(np.ceil(duration / w - 1e-9)) if w != 1.0 else int(np.ceil(duration))
    bins = np.zeros(n, dtype=np.int64)
    idx = np.trunc(t / w).astype(np.int64)  # t / 1.0 is t exactly: the reference's bins
    if idx.size and idx.max() >= n:
        raise ValueError(f"times: an event at {t.max():.3f} s lies past the signal's {n} bins of {w:g} s")
    bins[idx] = 1
    return bins


def check_bin_seconds(bin_seconds: float) -> float:
    """``bin_seconds`` as a float, or a ValueError naming it when it is not a finite number > 0."""
    w = float(bin_seconds)
    if not (w > 0 and math.isfinite(w)):
        raise ValueError(f"bin_seconds: must be a finite number of seconds > 0, got {bin_seconds!r}")
    return w


def onset_beat_bins(
    audio: np.ndarray, sr: int, *, variant: Variant = "loris", bin_seconds: float = 1.0
) -> np.ndarray:
    """The reference's ``beat_detect``: one-second onset bins of a waveform (``ceil(len(y)/22050)``).

    ``bin_seconds`` other than 1 gives bins of that width (see :func:`second_bins`).
    """
    times, duration = _detect(audio, sr, variant)
    return second_bins(times, duration, bin_seconds)


def pair_beat_scores(
    gt_bins: np.ndarray, syn_bins: np.ndarray, *, variant: Variant = "loris", truncate: str = "reference"
) -> tuple[float, float]:
    """``(cover, hit)`` of one pair of one-second beat vectors.

    ``"loris"``: ``gt ← gt[:len(syn)]``; ``cover = Nm/Ns`` (0 if Ns = 0), ``hit = Nm/Nt`` (0 if Nt = 0).
    ``"cdcd"``: equal lengths required; ``cover = Ns/Nt``, ``hit = Nm/Nt``.

    Args:
        truncate: ``"reference"`` — the variant's own rule (a generated vector longer than the ground
            truth is an error, as the reference's assert); ``"shortest"`` — cut both to the shorter
            (for signals whose lengths differ by rounding, e.g. motion vs music).

    Raises:
        ValueError: lengths that the rule rejects. EmptyBeatsError: ``cdcd`` with ``Nt = 0``.
    """
    gt = np.asarray(gt_bins, dtype=np.int64).reshape(-1)
    syn = np.asarray(syn_bins, dtype=np.int64).reshape(-1)
    if np.any((gt != 0) & (gt != 1)) or np.any((syn != 0) & (syn != 1)):
        raise ValueError("pair_beat_scores: beat vectors must hold only 0 and 1")
    if truncate == "shortest":
        n = min(gt.size, syn.size)
        gt, syn = gt[:n], syn[:n]
    elif truncate != "reference":
        raise ValueError(f"truncate: expected 'reference' or 'shortest', got {truncate!r}")
    if _variant(variant) == "loris":
        gt = gt[: syn.size]
    if gt.size != syn.size:
        raise ValueError(
            f"pair_beat_scores: ground truth has {gt.size} one-second bins but generated has {syn.size}; "
            + (
                "the generated signal is longer than the ground truth"
                if variant == "loris"
                else "cdcd requires equal lengths"
            )
        )
    n_t, n_s = int(gt.sum()), int(syn.sum())
    n_m = int(np.sum((gt == 1) & (syn == 1)))
    if variant == "loris":
        return (n_m / n_s if n_s else 0, n_m / n_t if n_t else 0)
    if n_t == 0:
        raise EmptyBeatsError("pair_beat_scores (cdcd): the ground truth has no beats (CDCD divides by 0)")
    return n_s / n_t, n_m / n_t


def aggregate_beat_scores(
    covers: Sequence[float], hits: Sequence[float], *, variant: Variant = "loris"
) -> dict[str, float]:
    """Dataset BCS/CSD/BHS/HSD/F1 from per-pair ``(cover, hit)`` values.

    BCS/BHS are the means (sequential sums / n as the reference); CSD/HSD ``np.std(ddof=1)``; F1 the
    harmonic mean of the two means. With one pair the sample std is undefined: CSD/HSD are NaN and
    a warning is logged. If BCS = BHS = 0, F1 is 0 (the reference raises ``ZeroDivisionError``).
    ``"cdcd"`` returns only ``bcs``/``bhs`` (no std, no F1 in CDCD).
    """
    if len(covers) != len(hits):
        raise ValueError(f"aggregate_beat_scores: {len(covers)} cover values but {len(hits)} hit values")
    n = len(covers)
    if n == 0:
        raise ValueError("aggregate_beat_scores: no pairs")
    bcs = sum(covers) / n
    bhs = sum(hits) / n
    if _variant(variant) == "cdcd":
        return {"bcs": bcs, "bhs": bhs, "n": float(n)}
    if n < 2:
        logger.warning("beat_scores: one pair only; CSD/HSD (ddof=1) are undefined and reported as NaN")
        csd = hsd = float("nan")
    else:
        csd = float(np.std(np.asarray(covers, dtype=np.float64), ddof=1))
        hsd = float(np.std(np.asarray(hits, dtype=np.float64), ddof=1))
    f1 = 2 * bcs * bhs / (bcs + bhs) if (bcs + bhs) > 0 else 0.0
    return {"bcs": bcs, "csd": csd, "bhs": bhs, "hsd": hsd, "f1": f1, "n": float(n)}


def beat_scores(
    generated: Sequence[np.ndarray],
    reference: Sequence[np.ndarray],
    sr: int | Sequence[int],
    *,
    reference_sr: int | Sequence[int] | None = None,
    variant: Variant = "loris",
    truncate: str = "reference",
    bin_seconds: float = 1.0,
) -> dict[str, float]:
    """BCS, CSD, BHS, HSD and F1 of generated vs ground-truth music (MoMu App. B.4; LORIS).

    Args:
        generated: generated waveforms ``(S,)`` (pairs by position with ``reference``).
        reference: ground-truth waveforms.
        sr: sample rate(s) of ``generated`` in Hz (one for all, or one per waveform).
        reference_sr: sample rate(s) of ``reference`` (default: ``sr``).
        variant: ``"loris"`` (default; MoMu) or ``"cdcd"``.
        truncate: see :func:`pair_beat_scores`.
        bin_seconds: bin width (1 s in the reference; see :func:`second_bins`).

    Returns:
        ``{"bcs", "csd", "bhs", "hsd", "f1", "n"}`` as fractions in [0, 1] (``cdcd``: bcs, bhs, n).
    """
    if len(generated) != len(reference):
        raise ValueError(f"beat_scores: {len(generated)} generated but {len(reference)} reference waveforms")
    gen_sr = _rates(sr, len(generated), "sr")
    ref_sr = gen_sr if reference_sr is None else _rates(reference_sr, len(reference), "reference_sr")
    covers, hits = [], []
    for i, (gen, ref) in enumerate(zip(generated, reference)):
        gt_bins = onset_beat_bins(ref, ref_sr[i], variant=variant, bin_seconds=bin_seconds)
        syn_bins = onset_beat_bins(gen, gen_sr[i], variant=variant, bin_seconds=bin_seconds)
        try:
            cover, hit = pair_beat_scores(gt_bins, syn_bins, variant=variant, truncate=truncate)
        except ValueError as exc:
            raise type(exc)(f"pair {i}: {exc}") from None
        covers.append(cover)
        hits.append(hit)
    return aggregate_beat_scores(covers, hits, variant=variant)


def _rates(sr: int | Sequence[int], n: int, name: str) -> list[int]:
    if isinstance(sr, (int, np.integer)):
        return [int(sr)] * n
    rates = [int(r) for r in sr]
    if len(rates) != n:
        raise ValueError(f"{name}: {len(rates)} sample rates for {n} waveforms")
    return rates


@dataclass
class BeatScoresConfig:
    """Parameters of the registered ``beat_scores`` metric (motion→music, MoMu Tables 2–4).

    Attributes:
        variant: ``"loris"`` (MoMu / LORIS) or ``"cdcd"``.
        truncate: ``"reference"`` (LORIS rule) or ``"shortest"``.
        bin_seconds: bin width in seconds (1 = the reference's one-second bins).
    """

    variant: str = "loris"
    truncate: str = "reference"
    bin_seconds: float = 1.0


class BeatScoresMetric(ClipMetric):
    """Registered ``beat_scores``: generated clips' audio against the reference clips' audio."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        covers, hits = self.pairs(generated, reference)
        scores = aggregate_beat_scores(covers, hits, variant=self.cfg.variant)
        return {f"{self.name}.{k}": v for k, v in scores.items() if k != "n"}

    def pairs(
        self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None
    ) -> tuple[list[float], list[float]]:
        """Per-pair ``(covers, hits)`` (BCS and BHS of each clip; the cell is their aggregate)."""
        cfg: BeatScoresConfig = self.cfg
        gen = self._require(generated)
        ref = check_pairs(gen, reference, self.name)
        variant: Variant = cfg.variant  # type: ignore[assignment]  # checked by build_beat_scores
        covers, hits = [], []
        for g, r in zip(gen, ref):
            gt_bins = onset_beat_bins(*clip_audio(r, self.name), variant=variant, bin_seconds=cfg.bin_seconds)
            syn_bins = onset_beat_bins(
                *clip_audio(g, self.name), variant=variant, bin_seconds=cfg.bin_seconds
            )
            try:
                cover, hit = pair_beat_scores(gt_bins, syn_bins, variant=variant, truncate=cfg.truncate)
            except ValueError as exc:
                raise type(exc)(f"{self.name}: clip {g.id!r}: {exc}") from None
            covers.append(cover)
            hits.append(hit)
        return covers, hits


@METRICS.register("beat_scores", config=BeatScoresConfig)
def build_beat_scores(cfg: BeatScoresConfig) -> BeatScoresMetric:
    """``beat_scores``: BCS/CSD/BHS/HSD/F1 (METRICS.md §1.8, MoMu App. B.4)."""
    _variant(cfg.variant)
    check_bin_seconds(cfg.bin_seconds)
    return BeatScoresMetric(cfg, name="beat_scores", needs_reference=True, spec="METRICS.md §1.8; MoMu B.4")
