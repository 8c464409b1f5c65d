"""run_benchmark on constructed generators whose answer is known, and the recipe end to end (tiny)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from momu.following import DanceGenerator, dataset_node, load_pairs, run_benchmark
from momu.following.analysis import analyse_audio, analyse_motion
from momu.following.benchmark import analyse_inputs, rejudge
from momu.following.calibration import calibration_responder
from momu.following.inputs import Request, make_input
from momu.following.signals import song_beats
from momu.following.tempo import beat_tempo


@pytest.fixture(scope="module")
def pairs() -> list:
    return load_pairs(dataset_node("synth", "val", "dwm21", 6.0, 3), 6.0, 3)


class Bobbing:
    """Follows the music: a pose bobbing once per beat of the song it hears (beats tracked by librosa),
    plus a seed-dependent sway (so seeds differ)."""

    def __init__(self, pose: np.ndarray) -> None:
        self.pose = pose

    def generate(self, audio: np.ndarray, sample_rate: int, seed: int) -> tuple[np.ndarray, float]:
        fps = 25.0
        t = np.arange(int(len(audio) / sample_rate * fps)) / fps
        beats = song_beats(audio, sample_rate)
        period = float(np.median(np.diff(beats))) if len(beats) > 1 else 0.5
        phase = (t - (beats[0] if len(beats) else 0.0)) / period
        motion = np.repeat(self.pose[None], len(t), axis=0).copy()
        motion[..., 1] += 0.1 * np.cos(np.pi * phase)[:, None]  # extremes (speed 0) on the beats
        motion[..., 0] += 0.05 * np.sin(2 * np.pi * 0.1 * t + seed)[:, None]
        return motion, fps


class Frozen:
    """Ignores the music: the same pose whatever it hears."""

    def __init__(self, pose: np.ndarray) -> None:
        self.pose = pose

    def generate(self, audio: np.ndarray, sample_rate: int, seed: int) -> tuple[np.ndarray, float]:
        frames = int(len(audio) / sample_rate * 25.0)
        return np.repeat(self.pose[None], frames, axis=0), 25.0


def test_a_dance_on_the_beat_follows_and_a_frozen_one_does_not(pairs: list) -> None:
    pose = pairs[0].excerpt_motion()[0]
    assert isinstance(Bobbing(pose), DanceGenerator)
    gens = {"bobbing": Bobbing(pose), "frozen": Frozen(pose)}
    calibration = ("ground_truth", "static", "half_beat_shift")
    res = run_benchmark(pairs, gens, seeds=[0, 1], calibration=calibration, controls=False, progress=False)
    rows = {r["id"]: r for r in res["rows"]}
    assert "tempo_following" in res["ground_truth_passes"]
    bob, frozen = rows["bobbing"]["tests"], rows["frozen"]["tests"]
    assert bob["tempo_following"]["raw_verdict"] == "passes"
    assert bob["tempo_following"]["estimate"] > 0.8
    assert frozen["tempo_following"]["verdict"] == "fails"
    assert frozen["input_sensitivity"]["verdict"] == "fails"
    # the spread the index compares: the frozen pose never varies, the bobbing one sways with the seed
    assert frozen["input_sensitivity"]["seed_distance"]["estimate"] == 0.0
    assert bob["input_sensitivity"]["seed_distance"]["estimate"] > 0.0
    assert bob["beat_phase_bailando"]["estimate"] > 0.2
    assert frozen["beat_phase_bailando"]["estimate"] == 0.0
    assert rows["half_beat_shift"]["tests"]["beat_phase_bailando"]["raw_verdict"] == "fails"
    assert rows["static"]["realism"]["joint_speed"]["verdict"] == "fails"


@pytest.mark.parametrize("direction", ["dance", "music"])
def test_the_input_tempo_row_follows_the_input_tempo_and_nothing_else(pairs: list, direction: str) -> None:
    res = run_benchmark(
        pairs, direction=direction, seeds=[0, 1], calibration=("ground_truth", "input_tempo"), progress=False
    )
    row = next(r for r in res["rows"] if r["id"] == "input_tempo")
    assert row["tests"]["tempo_following"]["raw_verdict"] == "passes"
    assert row["tests"]["tempo_following"]["expected"] == "passes"
    assert row["tests"]["input_sensitivity"]["raw_verdict"] == "passes"
    assert row["tests"]["input_sensitivity"]["seed_distance"]["estimate"] == 0.0  # a function of the input
    beats = [song.beats for song in analyse_inputs(pairs).songs]
    request = Request(0, seed=0, factor=1.25)
    out, rate = calibration_responder("input_tempo", direction, pairs, beats)(request)
    x, x_rate = make_input(direction, pairs, request, beats)
    if direction == "music":  # clicks at the tempo the benchmark reads from the input dance
        assert analyse_audio(out, int(rate)).tempo == pytest.approx(analyse_motion(x, x_rate).tempo, rel=0.03)
    else:  # up on one beat, down on the next: the joint speed peaks once per beat
        assert analyse_motion(out, rate).tempo == pytest.approx(beat_tempo(beats[0]) * 1.25, rel=0.03)


def test_the_recipe_end_to_end_with_ground_truth_only(tmp_path: Path) -> None:
    from momu.following.run import main

    argv = [
        "--generator",
        "ground_truth_only",
        "--direction",
        "both",
        "--songs",
        "2",
        "--seconds",
        "5",
        "--seeds",
        "0",
        "--out",
        str(tmp_path),
        "--quiet",
    ]
    assert main(argv) == 0
    out = tmp_path / "music_following"
    res = json.loads((out / "results.json").read_text())
    assert set(res["directions"]) == {"dance", "music"}
    assert res["directions"]["dance"]["rows"][0]["id"] == "ground_truth"
    assert res["provenance"]["command"][1] == "recipes/music_following.py"
    assert "Ground truth passes" in (out / "results.md").read_text()


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--songs", "1"], "--songs"),
        (["--seconds", "1"], "--seconds"),
        (["--data", "/nonexistent/folder"], "--data"),
        (["--generator", "/nonexistent/model"], "--generator"),
        (["--seeds", "0", "0"], "--seeds"),
        (["--beats-per-movement", "0"], "--beats-per-movement: must be 1 to 8, ballroom or auto"),
        (["--beats-per-movement", "ballroom"], "--beats-per-movement: only for dance → music with a model"),
    ],
)
def test_bad_options_one_line_exit_2(tmp_path: Path, argv: list[str], needle: str) -> None:
    import contextlib
    import io

    from momu.following.run import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["--generator", "ground_truth_only", *argv, "--out", str(tmp_path / "o")])
    assert code == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and needle in lines[0]
    assert not (tmp_path / "o").exists()


def test_bad_options_answer_before_torch_loads(tmp_path: Path) -> None:
    """The recipe checks its options before importing torch or the metrics (5.5 s → 0.5 s on 2 cores)."""
    import subprocess
    import sys

    heavy = ("torch", "diffusers", "librosa", "momu.metrics")
    code = (
        "import sys\n"
        "from momu.following.run import main\n"
        "code = main(['--data', 'absent_folder', '--out', 'o'])\n"
        f"print(code, [m for m in {heavy!r} if m in sys.modules])\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert proc.stdout.split() == ["2", "[]"], proc.stdout + proc.stderr
    assert "absent_folder" in proc.stderr and not (tmp_path / "o").exists()


def test_a_folder_of_generated_dances_is_scored_like_its_ground_truth(tmp_path: Path) -> None:
    """Real dances saved as 'generated' outputs (whole songs, momu eval's layout) score exactly as the
    ground-truth row; the tests that need a generator say so."""
    from momu.following.run import main

    gen = tmp_path / "gen"
    gen.mkdir()
    for p in load_pairs(dataset_node("synth", "val", "dwm21", 5.0, 2), 5.0, 2):
        np.save(gen / f"{p.id}.npy", p.motion.astype(np.float32))
        (gen / f"{p.id}.json").write_text(json.dumps({"fps": p.fps, "skeleton": p.skeleton}))
    argv = ["--generator", "ground_truth_only", "--generated", str(gen), "--songs", "2", "--seconds", "5",
            "--seeds", "0", "--no-controls", "--out", str(tmp_path), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    rows = {r["id"]: r for r in json.loads((tmp_path / "music_following" / "results.json").read_text())
            ["directions"]["dance"]["rows"]}  # fmt: skip
    g, gt = rows["generated:gen"]["tests"], rows["ground_truth"]["tests"]
    assert g["beat_phase_bailando"]["estimate"] == pytest.approx(gt["beat_phase_bailando"]["estimate"])
    assert g["input_sensitivity"]["verdict"] == g["tempo_following"]["verdict"] == "needs a generator"


def _slope_rows(**slopes: tuple[float, float, float]) -> dict:
    rows = []
    for name, (est, low, high) in slopes.items():
        kind = "generator" if name.startswith("gen") else "calibration"
        cell = {"estimate": est, "low": low, "high": high, "songs": 6, "seeds": 3}
        rows.append({"id": name, "kind": kind, "tests": {"tempo_following": cell}})
    return {"rows": rows}


def test_an_exact_follower_of_the_input_tempo_widens_what_counts_as_following() -> None:
    # Dance with Melody val, dance → music: the real songs follow their stretch at 0.9986 [0.9976,
    # 0.9996], clicks at the input dance's tempo at 1.009 [1.0002, 1.026]; a generator at 1.016
    # [1.0001, 1.037] follows as well as the clicks do
    res = rejudge(
        _slope_rows(
            ground_truth=(0.9986, 0.9976, 0.9996),
            input_tempo=(1.009, 1.0002, 1.026),
            gen_follows=(1.016, 1.0001, 1.037),
            gen_half=(0.6, 0.3, 0.95),
        )
    )
    verdicts = {r["id"]: r["tests"]["tempo_following"]["verdict"] for r in res["rows"]}
    assert verdicts["gen_follows"] == "passes"
    assert verdicts["gen_half"] == "fails"  # disjoint from both exact followers
    assert verdicts["input_tempo"] == "fails"  # a calibration row is judged against ground truth alone
    # without the input_tempo row (results written before it existed) ground truth alone decides
    old = rejudge(_slope_rows(ground_truth=(0.9986, 0.9976, 0.9996), gen_follows=(1.016, 1.0001, 1.037)))
    assert old["rows"][1]["tests"]["tempo_following"]["verdict"] == "fails"


def test_every_public_name_of_the_benchmark_resolves() -> None:
    """``momu.following`` loads its names lazily; each one in ``__all__`` still imports."""
    import momu.following as following

    assert all(getattr(following, name) is not None for name in following.__all__)
    assert set(following.__all__) <= set(dir(following))
    with pytest.raises(AttributeError, match="no_such_name"):
        following.no_such_name  # noqa: B018


def test_a_data_folder_is_recorded_by_its_absolute_path(tmp_path: Path, monkeypatch) -> None:
    """Runs on one folder, named relatively or absolutely, share one group in the collected table."""
    (tmp_path / "dwm" / "DANCE_C_1").mkdir(parents=True)
    (tmp_path / "pairs").mkdir()
    monkeypatch.chdir(tmp_path)
    relative = dataset_node("dwm", "val", "dwm21", 10.0, 2)
    assert relative["name"] == "dance_with_melody"
    assert relative == dataset_node(str(tmp_path / "dwm"), "val", "dwm21", 10.0, 2)
    assert dataset_node("pairs", "val", "dwm21", 10.0, 2)["root"] == str(tmp_path / "pairs")
