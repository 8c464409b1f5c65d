"""The music-following benchmark: does a generator's output follow its input? (docs/following.md)

    from momu.following import run_benchmark, load_pairs, dataset_node, from_model_dir, write_results

    pairs = load_pairs(dataset_node("synth", "val", "dwm21", 10.0, 8), 10.0, 8)
    results = run_benchmark(pairs, {"mine": from_model_dir("runs/momu-0")}, direction="dance")
    write_results(results, "out/music_following")

A generator is anything with ``generate(audio, sample_rate, seed) -> (motion, fps)``
(:class:`DanceGenerator`) or ``generate(motion, fps, seed) -> (audio, sample_rate)``
(:class:`MusicGenerator`).

The names load on first use (PEP 562), so ``recipes/music_following.py`` checks its options before
torch and the metrics are imported (docs/performance.md, "The command's start").
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from momu.following.adapters import DanceGenerator, MusicGenerator, from_model_dir, model_name, shipped
    from momu.following.benchmark import TEST_RULES, run_benchmark
    from momu.following.calibration import CALIBRATION_ROWS, MUST_FAIL
    from momu.following.checks import TESTS
    from momu.following.inputs import FACTORS
    from momu.following.pairs import DWM_SPLIT, Pair, dataset_node, load_pairs
    from momu.following.report import write_results

_HOMES = {
    "CALIBRATION_ROWS": "calibration",
    "DWM_SPLIT": "pairs",
    "DanceGenerator": "adapters",
    "FACTORS": "inputs",
    "MUST_FAIL": "calibration",
    "MusicGenerator": "adapters",
    "Pair": "pairs",
    "TESTS": "checks",
    "TEST_RULES": "benchmark",
    "dataset_node": "pairs",
    "from_model_dir": "adapters",
    "load_pairs": "pairs",
    "model_name": "adapters",
    "run_benchmark": "benchmark",
    "shipped": "adapters",
    "write_results": "report",
}

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


def __getattr__(name: str) -> Any:
    """Import a public name from its module on first use."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'momu.following' has no attribute {name!r}")
    return getattr(import_module(f"momu.following.{home}"), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_HOMES))
