"""The music-following benchmark: does a generator's output follow its input? (docs/following.md)

    from momu.following import run_benchmark, load_pairs, dataset_node, from_model_dir, write_results

    pairs = load_pairs(dataset_node("synth", "val", "dwm21", 10.0, 8), 10.0, 8)
    results = run_benchmark(pairs, {"mine": from_model_dir("runs/momu-0")}, direction="dance")
    write_results(results, "out/music_following")

A generator is anything with ``generate(audio, sample_rate, seed) -> (motion, fps)``
(:class:`DanceGenerator`) or ``generate(motion, fps, seed) -> (audio, sample_rate)``
(:class:`MusicGenerator`).
"""

from momu.following.adapters import DanceGenerator, MusicGenerator, from_model_dir, model_name, shipped
from momu.following.benchmark import TEST_RULES, run_benchmark
from momu.following.calibration import CALIBRATION_ROWS, MUST_FAIL
from momu.following.checks import TESTS
from momu.following.inputs import FACTORS
from momu.following.pairs import DWM_SPLIT, Pair, dataset_node, load_pairs
from momu.following.report import write_results

__all__ = [
    "CALIBRATION_ROWS",
    "DWM_SPLIT",
    "DanceGenerator",
    "FACTORS",
    "MUST_FAIL",
    "MusicGenerator",
    "Pair",
    "TESTS",
    "TEST_RULES",
    "dataset_node",
    "from_model_dir",
    "load_pairs",
    "model_name",
    "run_benchmark",
    "shipped",
    "write_results",
]
