"""Calibration rows: responses built from the real data whose answer is known, scored by the same code.

Each row answers a :class:`~momu.following.inputs.Request` for song ``i`` at tempo factor ``f`` (controls
get no answer: the real data has none):

* ``ground_truth`` — song ``i``'s real partner (its dance, or for dance → music its song), played ``f``
  times faster like the input: the ideal response. Every test must pass it, or gives no verdict.
* ``shuffled`` — the real partner of song ``i + n/2 (mod n)``, not stretched: real, but of another song.
* ``static`` — dance: one pose held (the first frame of the first dance); music: a steady 220 Hz tone.
* ``jitter`` — ground truth with independent noise: Gaussian :data:`JITTER_M` on every joint coordinate
  and frame (dance), or white noise at the music's own RMS (music, 0 dB SNR); a new draw per seed.
* ``half_beat_shift`` — ground truth delayed by half a beat of song ``i`` against its input (dance:
  the dance's window starts half a beat earlier; music: the song's window does).
* ``input_tempo`` — the input's tempo and nothing else, as the benchmark reads it: dance → music, a
  click on every beat of a grid at the input dance's tempo (:func:`~momu.following.tempo.periodogram_tempo`
  of its joint speed, the estimator every output is scored with); music → dance, dance ``i``'s first
  pose moving up on one beat and down on the next of the input song's beat grid (its joint speed
  peaks once per beat, so its tempo reads as the song's). A response that follows the input's
  tempo exactly: built to pass tempo following (:data:`MUST_PASS`). Its tempo match shows what
  following the input's tempo alone can score there — for dance → music, whether the dances carry
  their songs' tempi at all: ground truth's music is the song itself, so it passes tempo match by
  identity, not by reading the dance.

:data:`MUST_FAIL` says which tests a row is built to fail; one that passes such a test shows the test
cannot see what it claims on this data, and the generator gets no verdict on it. :data:`MUST_PASS` says
which tests a row other than ``ground_truth`` (which must pass every test) is built to pass; the report
names any it does not. A generator's tempo-following slope is judged against ground truth's interval and
``input_tempo``'s together (:func:`momu.following.benchmark.rejudge`): both follow the input exactly.
"""

from __future__ import annotations

from collections.abc import Callable

import librosa
import numpy as np

from momu.following.inputs import Request, bobbing_pose
from momu.following.pairs import Pair
from momu.following.signals import RATE, joint_speed, motion_at_rate, time_scale_motion, time_stretch_audio
from momu.following.tempo import beat_tempo, periodogram_tempo

__all__ = ["CALIBRATION_ROWS", "MUST_FAIL", "MUST_PASS", "JITTER_M", "calibration_responder"]

CALIBRATION_ROWS = ("ground_truth", "shuffled", "static", "jitter", "half_beat_shift", "input_tempo")
JITTER_M = 0.02
"""Jitter of the ``jitter`` dance row (m per coordinate and frame at the data's rate)."""
PHASE_TESTS = ("beat_phase_bailando", "beat_phase_mint")
MATCH_TESTS = ("matched_bailando", "matched_mint")
TEMPO_TESTS = ("tempo_following", "tempo_match")
MUST_FAIL: dict[str, tuple[str, ...]] = {
    "shuffled": (*TEMPO_TESTS, *PHASE_TESTS, *MATCH_TESTS),
    "static": ("input_sensitivity", *TEMPO_TESTS, *PHASE_TESTS, *MATCH_TESTS),
    "jitter": (),
    "half_beat_shift": PHASE_TESTS,
    "input_tempo": (),
}
"""The tests each calibration row must not pass (a row is not expected to fail the tests not listed:
a shuffled dance is still sensitive to its input, a delayed one keeps the tempo). ``jitter`` keeps the
real dance's rhythm under its noise, so the following tests may pass it; it is built to fail realism
(joint and foot speed, bone-length variation: :mod:`momu.following.realism`)."""
MUST_PASS: dict[str, tuple[str, ...]] = {"input_tempo": ("input_sensitivity", "tempo_following")}
"""The tests a calibration row other than ``ground_truth`` is built to pass."""

Response = tuple[np.ndarray, float] | None


def _half_beat(beats: np.ndarray) -> float:
    return 0.5 * float(np.median(np.diff(beats))) if len(beats) > 1 else 0.25


def _clicks_at(bpm: float, seconds: float, sample_rate: int) -> np.ndarray:
    """A click on every beat at ``bpm`` from 0 s for ``seconds`` (silence when ``bpm`` is not finite)."""
    n = int(round(seconds * sample_rate))
    if not np.isfinite(bpm) or bpm <= 0:
        return np.zeros(n, dtype=np.float32)
    times = np.arange(0.0, seconds, 60.0 / bpm)
    return librosa.clicks(times=times, sr=sample_rate, length=n).astype(np.float32)


def calibration_responder(
    row: str, direction: str, pairs: list[Pair], beats: list[np.ndarray]
) -> Callable[[Request], Response]:
    """The response function of calibration ``row`` (:data:`CALIBRATION_ROWS`) in ``direction``."""
    n = len(pairs)
    if row not in CALIBRATION_ROWS:
        raise ValueError(f"calibration row {row!r}: expected one of {CALIBRATION_ROWS}")

    def dance(request: Request) -> Response:
        i, f = request.song, request.factor
        p = pairs[i]
        if row == "ground_truth":
            return time_scale_motion(p.excerpt_motion(), p.fps, f), p.fps
        if row == "shuffled":
            q = pairs[(i + n // 2) % n]
            return q.excerpt_motion()[: int(round(p.seconds / f * q.fps))], q.fps
        if row == "static":
            first = pairs[0]
            frames = int(round(p.seconds / f * first.fps))
            return np.repeat(first.excerpt_motion()[:1], frames, axis=0), first.fps
        if row == "jitter":
            x = time_scale_motion(p.excerpt_motion(), p.fps, f)
            rng = np.random.default_rng([request.seed, i, int(round(f * 1000))])
            return x + JITTER_M * rng.standard_normal(x.shape), p.fps
        if row == "input_tempo":
            frames = int(round(p.seconds / f * p.fps))
            half_tempo = beat_tempo(beats[i]) * f / 2.0  # up on one beat, down on the next
            return bobbing_pose(p.excerpt_motion()[:1], frames, p.fps, half_tempo), p.fps
        shifted = p.excerpt_motion(offset=-_half_beat(beats[i]))
        return time_scale_motion(shifted, p.fps, f), p.fps

    def music(request: Request) -> Response:
        i, f = request.song, request.factor
        p = pairs[i]
        if row == "ground_truth":
            return time_stretch_audio(p.excerpt_audio(), f), p.sample_rate
        if row == "shuffled":
            q = pairs[(i + n // 2) % n]
            return q.excerpt_audio()[: int(round(p.seconds / f * q.sample_rate))], q.sample_rate
        if row == "static":
            t = np.arange(int(round(p.seconds / f * p.sample_rate))) / p.sample_rate
            return (0.3 * np.sin(2 * np.pi * 220.0 * t)).astype(np.float32), p.sample_rate
        if row == "jitter":
            y = time_stretch_audio(p.excerpt_audio(), f)
            rng = np.random.default_rng([request.seed, i, int(round(f * 1000))])
            rms = float(np.sqrt(np.mean(np.square(y)))) if y.size else 0.0
            return (y + rms * rng.standard_normal(y.shape)).astype(np.float32), p.sample_rate
        if row == "input_tempo":
            x = time_scale_motion(p.excerpt_motion(), p.fps, f)
            return _clicks_at(
                periodogram_tempo(joint_speed(motion_at_rate(x, p.fps)), RATE), len(x) / p.fps, p.sample_rate
            ), p.sample_rate
        shifted = p.excerpt_audio(offset=-_half_beat(beats[i]))
        return time_stretch_audio(shifted, f), p.sample_rate

    def respond(request: Request) -> Response:
        if request.control is not None:
            return None
        return dance(request) if direction == "dance" else music(request)

    return respond
