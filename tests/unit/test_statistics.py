"""Intervals, paired comparisons and verdicts of the table runner (momu.engine.statistics / table_results)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from momu.engine.scores import ROW, Scores
from momu.engine.statistics import (
    Interval,
    paired_bootstrap,
    paired_seed_interval,
    reduce_components,
    t_interval,
    verdict,
)
from momu.engine.table import Column
from momu.engine.table_results import compare_row, orderings, summarise_seeds

T_975_2 = 4.302652729911275  # Student t quantile 0.975 with 2 degrees of freedom (printed tables: 4.303)


def test_t_interval_of_known_seed_values() -> None:
    interval = t_interval([1.0, 2.0, 3.0])  # mean 2, s = 1, n = 3
    assert interval.estimate == 2.0 and interval.n == 3
    assert interval.half_width == pytest.approx(T_975_2 / math.sqrt(3.0))
    assert (interval.low, interval.high) == pytest.approx((2.0 - 2.4841, 2.0 + 2.4841), abs=1e-4)


def test_one_seed_has_no_interval_and_no_verdict() -> None:
    interval = t_interval([5.0])
    assert (interval.low, interval.high, interval.n) == (5.0, 5.0, 1)
    assert verdict(paired_seed_interval([5.0], [1.0]), True) == "cannot tell"


def test_a_row_equal_to_shuffled_cannot_be_told_apart() -> None:
    rng = np.random.default_rng(0)
    clips = rng.uniform(0, 100, size=(3, 40, 2))
    interval = paired_bootstrap(clips, clips.copy(), reducer="f1")
    assert interval.estimate == 0.0 and interval.low == 0.0 and interval.high == 0.0
    assert verdict(interval, True) == "cannot tell"  # a zero-width interval has nothing to exclude 0 with


def test_a_constant_paired_difference_has_a_zero_width_interval_and_no_verdict() -> None:
    base = np.random.default_rng(1).normal(size=(2, 30, 1))
    interval = paired_bootstrap(base + 0.5, base)
    assert interval.estimate == pytest.approx(0.5)
    assert interval.low == pytest.approx(0.5) and interval.high == pytest.approx(0.5)
    assert interval.degenerate and interval.clips == 30
    assert verdict(interval, True) == "cannot tell" and verdict(interval, False) == "cannot tell"


def test_bootstrap_is_deterministic_under_its_seed() -> None:
    rng = np.random.default_rng(2)
    a, b = rng.normal(1.0, 1.0, size=(3, 25, 1)), rng.normal(0.0, 1.0, size=(3, 25, 1))
    first, again = paired_bootstrap(a, b, seed=7), paired_bootstrap(a, b, seed=7)
    assert first == again
    assert paired_bootstrap(a, b, seed=8) != first


def test_bootstrap_interval_matches_the_normal_approximation_on_many_clips() -> None:
    rng = np.random.default_rng(3)
    d = rng.normal(0.3, 1.0, size=400)
    interval = paired_bootstrap(d[:, None], np.zeros((400, 1)), seed=0)
    se = d.std(ddof=1) / math.sqrt(d.size)
    assert interval.estimate == pytest.approx(d.mean())
    assert interval.half_width == pytest.approx(1.96 * se, rel=0.12)


def test_f1_reducer_is_the_f1_of_the_mean_components() -> None:
    comp = np.array([[[80.0, 40.0], [60.0, 20.0]]])  # mean BCS 70, mean BHS 30
    assert reduce_components(comp, "f1")[0] == pytest.approx(2 * 70 * 30 / 100)
    interval = paired_bootstrap(comp, np.zeros_like(comp), reducer="f1")
    assert interval.estimate == pytest.approx(42.0)


def test_a_seed_independent_calibration_pairs_with_every_seed() -> None:
    row = np.stack([np.full((10, 1), 2.0), np.full((10, 1), 4.0)])  # two seeds
    calibration = np.ones((10, 1))  # ground truth: the same for every seed
    interval = paired_bootstrap(row, calibration)
    assert interval.estimate == pytest.approx(2.0) and interval.n == 20


def test_lower_is_better_verdicts() -> None:
    better = Interval(-3.0, -4.0, -2.0, 30, "x")
    assert verdict(better, higher_is_better=False) == "better"
    assert verdict(Interval(1.0, -1.0, 3.0, 30, "x"), higher_is_better=False) == "not distinguishable"


def test_paired_seed_interval_is_a_t_interval_of_the_differences() -> None:
    interval = paired_seed_interval([11.0, 12.0, 13.0], [10.0, 10.0, 10.0])
    assert interval.estimate == 2.0
    assert interval.half_width == pytest.approx(T_975_2 / math.sqrt(3.0))


def _scores(seed_shift: float, n: int = 20) -> Scores:
    rng = np.random.default_rng(int(seed_shift * 10))
    row = rng.uniform(50, 70, size=(n, 2))
    shuffled = row - 15.0 + rng.normal(0, 1, size=(n, 2))
    s = Scores(metrics={"f1": float(reduce_components(row[None], "f1")[0]), "fid": 10.0 + seed_shift})
    s.add_clips("f1", ROW, row)
    s.add_clips("f1", "shuffled", shuffled)
    s.add_clips("f1", "other condition", row)  # ignores its condition
    s.add_seed_value("fid", "ground truth", 5.0)
    return s


def test_compare_row_gives_per_clip_and_seed_level_verdicts() -> None:
    columns = [Column("f1", "F1↑", True, reducer="f1"), Column("fid", "FID↓", False)]
    summary = summarise_seeds([_scores(0.0), _scores(1.0), _scores(2.0)])
    assert np.shape(summary["per_clip"]["f1"][ROW]) == (3, 20, 2)
    comparisons = compare_row(summary, columns)
    assert comparisons["f1"]["shuffled"]["verdict"] == "better"
    assert comparisons["f1"]["shuffled"]["seeds_agreeing"] == 3
    assert comparisons["f1"]["other condition"]["verdict"] == "cannot tell"  # identical: no spread
    fid = comparisons["fid"]["ground truth"]  # 10, 11, 12 vs a floor of 5: +6 ± t·1/√3
    assert fid["estimate"] == pytest.approx(6.0) and fid["verdict"] == "worse"
    assert summary["interval"]["fid"] == pytest.approx(T_975_2 / math.sqrt(3.0))


def test_orderings_count_only_distinguishable_pairs() -> None:
    columns = [Column("x", "X↑", True)]
    rows = []
    rng = np.random.default_rng(5)
    for rid, level, paper in (("#1", 10.0, 1.0), ("#2", 10.0, 2.0), ("#3", 20.0, 3.0)):
        seeds = []
        for _ in range(3):
            s = Scores(metrics={"x": level})
            s.add_clips("x", ROW, level + rng.normal(0, 1, size=(12, 1)))
            seeds.append(s)
        rows.append({"id": rid, "paper": {"x": paper}, **summarise_seeds(seeds)})
    out = orderings(rows, columns)["x"]
    # #1 vs #2 tie (not distinguishable); #3 above both, as in the paper
    assert (out["total"], out["distinguishable"], out["agree"]) == (3, 2, 2)
    pair = next(p for p in out["pairs"] if p["rows"] == ["#1", "#3"])
    assert pair["outcome"] == "second higher" and pair["seeds_agreeing"] == 3 and len(pair["per_seed"]) == 3


def test_scores_round_trip_json_and_reject_unknown_variants() -> None:
    s = _scores(0.5)
    s.artifacts["model"] = "models/x"
    back = Scores.from_json(s.to_json())
    assert back.metrics == s.metrics and back.artifacts == {"model": "models/x"}
    np.testing.assert_array_equal(back.clips["f1"][ROW], s.clips["f1"][ROW])
    with pytest.raises(ValueError, match="unknown comparison variant 'shufled'"):
        s.add_clips("f1", "shufled", np.zeros((2, 1)))


def _diversity(cell: float, gt: float, shuffled: float) -> Scores:
    s = Scores(metrics={"div": cell})
    s.add_seed_value("div", "ground truth", gt)
    s.add_seed_value("div", "shuffled", shuffled)
    return s


def test_closer_to_reference_columns_compare_distances() -> None:
    """MoFusion Table 2's "Diversity →": a cell is better the closer it is to ground truth's."""
    col = Column("div", "Diversity→", False, closer_to="ground truth")
    # below ground truth by ~1, a far-off comparison (shuffled) ~4 away: closer, so better
    near = summarise_seeds(
        [_diversity(8.9, 10.0, 6.0), _diversity(9.1, 10.1, 6.1), _diversity(9.0, 9.9, 5.9)]
    )
    out = compare_row(near, [col])["div"]
    assert (
        out["ground truth"]["estimate"] == pytest.approx(-1.0) and out["ground truth"]["verdict"] == "worse"
    )
    assert out["shuffled"]["estimate"] == pytest.approx(1.0 - 4.0) and out["shuffled"]["verdict"] == "better"
    # a cell above the reference by as much as the other is below: |+2| vs |−2|, not distinguishable
    far = summarise_seeds(
        [_diversity(12.0, 10.0, 8.0), _diversity(12.1, 10.1, 8.1), _diversity(11.9, 9.9, 7.85)]
    )
    rec = compare_row(far, [col])["div"]["shuffled"]
    assert rec["verdict"] == "not distinguishable"
    # no higher-is-better reading: a cell far above the reference is worse than one just below it
    high = summarise_seeds(
        [_diversity(20.0, 10.0, 9.0), _diversity(21.0, 10.1, 9.1), _diversity(20.5, 9.9, 8.9)]
    )
    assert compare_row(high, [col])["div"]["shuffled"]["verdict"] == "worse"
    # at the reference within noise: not distinguishable from it
    same = summarise_seeds(
        [_diversity(10.2, 10.0, 5.0), _diversity(9.8, 10.0, 5.0), _diversity(10.0, 10.0, 5.0)]
    )
    assert compare_row(same, [col])["div"]["ground truth"]["verdict"] == "not distinguishable"
    rows = [{"id": r, "paper": {"div": p}, **near} for r, p in (("#1", 8.0), ("#2", 9.0))]
    assert orderings(rows, [col]) == {}  # no ordering without the paper's reference per pair


def test_closer_to_reference_direction_is_printed() -> None:
    from momu.engine.table_report import _direction

    assert _direction({"higher_is_better": False, "closer_to": "ground truth"}) == "closer to ground truth"
    assert _direction({"higher_is_better": True}) == "higher"
