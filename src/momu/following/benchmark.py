"""``run_benchmark``: the music-following benchmark of one direction on one set of songs.

For each row — the calibration rows (:mod:`momu.following.calibration`), then each generator — every
input (:mod:`momu.following.inputs`) is answered, every answer analysed once
(:mod:`momu.following.analysis`), the tests (:mod:`momu.following.checks`) give a value per
(song, seed), and :mod:`momu.following.stats` turns each into a mean with its 95 % interval and a
verdict. A generator's verdict on a test is withheld where ground truth does not pass that test on this
data, or a calibration row built to fail it passes (:func:`momu.following.stats.gate`). Beside
following, the dance direction measures motion realism against the real data's 5th-95th percentile.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from momu.following.adapters import DanceGenerator, MusicGenerator
from momu.following.analysis import Analysis, analyse_audio, analyse_motion
from momu.following.calibration import CALIBRATION_ROWS, MUST_FAIL, MUST_PASS, calibration_responder
from momu.following.checks import (
    GENERATOR_ONLY,
    TESTS,
    Inputs,
    bas_own,
    generator_tests,
    pair_tests,
    tempo_partners,
)
from momu.following.controls import control_stats
from momu.following.inputs import FACTORS, Request, make_input, requests
from momu.following.pairs import Pair
from momu.following.realism import REALISM_KEYS, realism_stats
from momu.following.signals import RATE, motion_at_rate
from momu.following.stats import PASSES, Estimate, gate, song_seed_bootstrap, verdict

__all__ = ["run_benchmark", "rejudge", "TEST_RULES", "analyse_inputs", "reference_realism"]

log = logging.getLogger(__name__)

TEST_RULES: dict[str, tuple[str, float]] = {
    "input_sensitivity": ("not_below", 0.5),
    "tempo_following": ("slope", 0.0),
    "tempo_match": ("above", 0.0),
    "beat_phase_bailando": ("above", 0.0),
    "beat_phase_mint": ("above", 0.0),
    "matched_bailando": ("above", 0.0),
    "matched_mint": ("above", 0.0),
}
"""Verdict rule and threshold of each test (:func:`momu.following.stats.verdict`)."""
NEEDS_GENERATOR = "needs a generator"
BONE_CV_SLACK = 0.01
"""Bone-length variation passes up to the real data's 95th percentile or 1 %, whichever is larger (a
rigid real skeleton has 0, and a generator cannot be asked for exactly 0)."""
DETERMINISTIC = ("ground_truth", "shuffled", "static", "half_beat_shift", "input_tempo")

Generator = DanceGenerator | MusicGenerator
Responder = Callable[[Request], "tuple[np.ndarray, float] | None"]


def analyse_inputs(pairs: Sequence[Pair]) -> Inputs:
    """Analyses of the songs' and dances' excerpts, their tempi and tempo partners."""
    songs = [analyse_audio(p.excerpt_audio(), p.sample_rate) for p in pairs]
    dances = [analyse_motion(p.excerpt_motion(), p.fps, p.skeleton) for p in pairs]
    tempo = np.array([s.beat_tempo for s in songs])
    return Inputs(songs, dances, tempo, tempo_partners(tempo))


def reference_realism(pairs: Sequence[Pair]) -> dict[str, dict[str, float]]:
    """The real dances' realism statistics over every ``seconds``-long window of each whole dance:
    5th and 95th percentiles, median and the number of windows."""
    values: dict[str, list[float]] = {k: [] for k in REALISM_KEYS}
    for p in pairs:
        x = motion_at_rate(p.motion, p.fps)
        n = int(round(p.seconds * RATE))
        for a in range(0, max(1, len(x) - n + 1), n):
            for k, v in realism_stats(x[a : a + n], RATE, p.skeleton).items():
                if np.isfinite(v):
                    values[k].append(v)
    return {
        k: {
            "p5": float(np.percentile(v, 5)),
            "p95": float(np.percentile(v, 95)),
            "median": float(np.median(v)),
            "windows": len(v),
        }
        for k, v in values.items()
        if v
    }


def _analyse(direction: str, response: tuple[np.ndarray, float], skeleton: str) -> Analysis:
    out, rate = response
    if direction == "dance":
        return analyse_motion(np.asarray(out), float(rate), skeleton)
    return analyse_audio(np.asarray(out).reshape(-1), int(rate))


def _clean(a: np.ndarray) -> list[list[float | None]]:
    return [[float(x) if np.isfinite(x) else None for x in row] for row in np.asarray(a, dtype=np.float64)]


def _summary(values: np.ndarray) -> dict[str, Any]:
    return {**song_seed_bootstrap(values).as_dict(), "per_song_seed": _clean(values)}


def _row_outputs(
    direction: str,
    respond: Responder,
    reqs: list[Request],
    skeleton: str,
    deterministic: bool,
    bar: Any,
) -> dict[Request, Analysis]:
    outputs: dict[Request, Analysis] = {}
    seen: dict[tuple[int, float, str | None], Analysis] = {}
    for r in reqs:
        key = (r.song, r.factor, r.control)
        if deterministic and key in seen:
            outputs[r] = seen[key]
        else:
            response = respond(r)
            if response is not None:
                outputs[r] = seen[key] = _analyse(direction, response, skeleton)
        if bar is not None:
            bar.update(1)
    return outputs


def _row_result(
    direction: str,
    inputs: Inputs,
    outputs: dict[Request, Analysis],
    seeds: list[int],
    factors: tuple[float, ...],
    full: bool,
) -> dict[str, Any]:
    n = len(inputs.songs)
    values = pair_tests(direction, inputs, outputs, seeds)
    gen = generator_tests(outputs, n, seeds, factors)
    tests: dict[str, Any] = {}
    for t in TESTS:
        if t in GENERATOR_ONLY and not full:
            tests[t] = {"verdict": NEEDS_GENERATOR}
            continue
        tests[t] = _summary(gen[t] if t in GENERATOR_ONLY else values[t])
        if t == "tempo_following":
            tests[t]["share_within_5pct"] = _summary(gen["tempo_following_share"])
        if t == "input_sensitivity":
            tests[t]["seed_distance"] = _summary(gen["seed_distance"])
            tests[t]["song_distance"] = _summary(gen["song_distance"])
    result: dict[str, Any] = {
        "tests": tests,
        "bas": {v: _summary(a) for v, a in bas_own(direction, inputs, outputs, seeds).items()},
    }
    if direction == "dance":
        realism = {}
        for k in REALISM_KEYS:
            a = np.full((n, len(seeds)), np.nan)
            for i in range(n):
                for j, s in enumerate(seeds):
                    o = outputs.get(Request(i, s))
                    if o is not None:
                        a[i, j] = o.realism.get(k, np.nan)  # type: ignore[union-attr]
            if np.isfinite(a).any():
                realism[k] = _summary(a)
        result["realism"] = realism
    controls = control_stats(direction, outputs, inputs.tempo, seeds)
    if controls:
        result["controls"] = {c: {k: _summary(v) for k, v in st.items()} for c, st in controls.items()}
    return result


def _estimate(d: dict[str, Any]) -> Estimate:
    return Estimate(d["estimate"], d["low"], d["high"], d["songs"], d["seeds"])


def _slope_interval(row: dict[str, Any] | None) -> tuple[float, float] | None:
    slope = row["tests"]["tempo_following"] if row else {}
    return (slope["low"], slope["high"]) if "low" in slope else None


def _verdicts(rows: list[dict[str, Any]], reference: dict[str, dict[str, float]]) -> None:
    """Raw verdicts on every row, then the gated verdicts of the generator rows (in place).

    A generator's tempo-following slope is judged against the hull of ground truth's interval and the
    ``input_tempo`` row's: both follow the input exactly, and differ only in how the benchmark's tempo
    estimator reads them (on Dance with Melody an exact follower of the input's tempo misses ground
    truth's interval by 0.0001-0.0002, :mod:`momu.following.calibration`). Calibration rows are judged
    against ground truth's alone.
    """
    by_id = {r["id"]: r for r in rows}
    gt = by_id.get("ground_truth")
    gt_slope = _slope_interval(gt)
    followed = [s for s in (gt_slope, _slope_interval(by_id.get("input_tempo"))) if s is not None]
    reference_slope = (min(s[0] for s in followed), max(s[1] for s in followed)) if followed else None
    for r in rows:
        for t, d in r["tests"].items():
            if "estimate" not in d:
                continue
            rule, threshold = TEST_RULES[t]
            ref = None
            if t == "tempo_following" and r["id"] != "ground_truth":
                ref = gt_slope if r["kind"] == "calibration" else reference_slope
            d["raw_verdict"] = verdict(_estimate(d), rule, threshold, ref)
        for k, d in r.get("realism", {}).items():
            if k in reference:
                d["real_p5"], d["real_p95"] = reference[k]["p5"], reference[k]["p95"]
                low, high = reference[k]["p5"], reference[k]["p95"]
                if k == "bone_length_cv":  # rigid real skeletons (p95 ≈ 0): allow 1 % variation
                    low, high = 0.0, max(high, BONE_CV_SLACK)
                d["verdict"] = verdict(_estimate(d), "within", low, high)
    for r in rows:
        for t, d in r["tests"].items():
            if "raw_verdict" not in d:
                continue
            if r["kind"] == "calibration":
                d["verdict"] = d["raw_verdict"]
                must_fail = t in MUST_FAIL.get(r["id"], ())
                must_pass = r["id"] == "ground_truth" or t in MUST_PASS.get(r["id"], ())
                d["expected"] = "fails" if must_fail else ("passes" if must_pass else None)
                continue
            gt_verdict = gt["tests"][t].get("raw_verdict") if gt else None
            passing = [
                c["id"]
                for c in rows
                if c["kind"] == "calibration"
                and t in MUST_FAIL.get(c["id"], ())
                and c["tests"][t].get("raw_verdict") == PASSES
            ]
            d["verdict"] = gate(d["raw_verdict"], gt_verdict, passing)


def rejudge(results: dict[str, Any]) -> dict[str, Any]:
    """``results`` (one direction's, or ``{"directions": ...}``) with every verdict recomputed from its
    stored estimates and intervals by this version's rules (in place; returned for chaining)."""
    for res in results["directions"].values() if "directions" in results else [results]:
        _verdicts(res["rows"], res.get("reference_realism", {}))
        gt = next((r for r in res["rows"] if r["id"] == "ground_truth"), None)
        res["ground_truth_passes"] = [
            t for t in TESTS if gt and gt["tests"].get(t, {}).get("raw_verdict") == PASSES
        ]
    return results


def run_benchmark(
    pairs: Sequence[Pair],
    generators: Mapping[str, Generator] | None = None,
    *,
    direction: str = "dance",
    seeds: Sequence[int] = (0, 1, 2),
    factors: Sequence[float] = FACTORS,
    calibration: Sequence[str] = CALIBRATION_ROWS,
    controls: bool = True,
    generated: Mapping[str, Sequence[tuple[np.ndarray, float]]] | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """The benchmark of ``direction`` (``"dance"``: music → dance, ``"music"``: dance → music).

    Args:
        pairs: the songs and their real dances (:func:`momu.following.pairs.load_pairs`), at least 2.
        generators: rows to test, by name: :class:`~momu.following.adapters.DanceGenerator` for
            ``"dance"``, :class:`~momu.following.adapters.MusicGenerator` for ``"music"``.
        seeds: generation seeds (the same for every row).
        factors: tempo factors of the stretched inputs.
        calibration: the calibration rows to compute (``ground_truth`` is needed for any verdict).
        controls: also run the control inputs through the generators.
        generated: rows of already generated outputs, by name: one ``(output, rate)`` per pair for its
            excerpt (seed ``seeds[0]``) — the tests that need a generator are reported as such.
        progress: show a progress bar.

    Returns:
        The results (``rows``, ``reference_realism``, ``ground_truth_passes`` and the settings), ready for
        :func:`momu.following.report.write_results`.
    """
    from tqdm.auto import tqdm

    if direction not in ("dance", "music"):
        raise ValueError(f"direction: expected 'dance' or 'music', got {direction!r}")
    if len(pairs) < 2:
        raise ValueError(f"run_benchmark: needs at least 2 songs, got {len(pairs)}")
    seeds, factors = [int(s) for s in seeds], tuple(float(f) for f in factors)
    generators, generated = dict(generators or {}), dict(generated or {})
    start = time.time()
    pairs = list(pairs)
    inputs = analyse_inputs(pairs)
    beats = [s.beats for s in inputs.songs]
    skeleton = pairs[0].skeleton
    plain = requests(direction, len(pairs), seeds, factors, controls=False)
    full = requests(direction, len(pairs), seeds, factors, controls=controls)
    total = len(calibration) * len(plain) + len(generators) * len(full)
    rows: list[dict[str, Any]] = []
    with tqdm(
        total=total, desc=f"music following ({direction})", unit="input", disable=None if progress else True
    ) as bar:
        for row in calibration:
            respond = calibration_responder(row, direction, pairs, beats)
            outputs = _row_outputs(direction, respond, plain, skeleton, row in DETERMINISTIC, bar)
            rows.append(
                {
                    "id": row,
                    "kind": "calibration",
                    **_row_result(direction, inputs, outputs, seeds, factors, True),
                }
            )
        for name, generator in generators.items():
            started = time.time()

            def respond(r: Request, g: Generator = generator) -> tuple[np.ndarray, float]:
                x, rate = make_input(direction, pairs, r, beats)
                out, out_rate = g.generate(x, rate, r.seed)  # type: ignore[arg-type]
                return np.asarray(out), float(out_rate)

            outputs = _row_outputs(direction, respond, full, skeleton, False, bar)
            result = _row_result(direction, inputs, outputs, seeds, factors, True)
            rows.append(
                {"id": name, "kind": "generator", "wall_time_s": round(time.time() - started, 1), **result}
            )
        for name, answers in generated.items():
            if len(answers) != len(pairs):
                raise ValueError(f"generated row {name!r}: {len(answers)} outputs for {len(pairs)} songs")
            outputs = {Request(i, seeds[0]): _analyse(direction, a, skeleton) for i, a in enumerate(answers)}
            rows.append(
                {
                    "id": name,
                    "kind": "generator",
                    **_row_result(direction, inputs, outputs, seeds[:1], factors, False),
                }
            )
    reference = reference_realism(pairs) if direction == "dance" else {}
    _verdicts(rows, reference)
    gt = next((r for r in rows if r["id"] == "ground_truth"), None)
    return {
        "direction": direction,
        "songs": [p.id for p in pairs],
        "song_tempo_bpm": [float(t) for t in inputs.tempo],
        "tempo_partner": [pairs[int(j)].id for j in inputs.partner],
        "seconds": [p.seconds for p in pairs],
        "seeds": seeds,
        "factors": list(factors),
        "rate_hz": RATE,
        "rows": rows,
        "reference_realism": reference,
        "ground_truth_passes": [t for t in TESTS if gt and gt["tests"][t].get("raw_verdict") == PASSES],
        "wall_time_s": round(time.time() - start, 1),
    }
