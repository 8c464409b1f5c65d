"""Procedural music on a beat grid: kick/snare transients and plucks on beats, a chord pad per bar.

Every percussive or tonal attack sits exactly on a beat of the grid (kick- and snare-like
transients following the style's per-bar pattern, tonal plucks for styles without drums), the
harmonic layer changes chord at every downbeat, and light white noise is added. Nothing sounds
between beats, so onset detection (librosa, MoMu §B.2 / HarmoGAN §III-B) recovers the grid.
*Breaks* (one or more bars of which only the first downbeat sounds, then the held chord) leave seconds
without onsets, as real music has; without them every one-second bin of the LORIS/MoMu beat
scores (BCS/BHS) would hold an onset and those scores could not tell pairs apart.
"""

from __future__ import annotations

import numpy as np

from momu.data.synth.styles import Style

__all__ = ["beat_grid", "render_music", "midi_to_hz", "PROGRESSIONS"]

# Chord progressions as (scale degree in semitones from the key, minor?) per bar.
PROGRESSIONS: tuple[tuple[tuple[int, bool], ...], ...] = (
    ((0, False), (7, False), (9, True), (5, False)),  # I V vi IV
    ((9, True), (5, False), (0, False), (7, False)),  # vi IV I V
    ((0, False), (5, False), (7, False), (5, False)),  # I IV V IV
    ((0, True), (8, False), (3, False), (10, False)),  # i VI III VII
)


def midi_to_hz(note: np.ndarray | float) -> np.ndarray:
    """Equal-tempered frequency (Hz) of MIDI note numbers (A4 = 69 = 440 Hz)."""
    return 440.0 * 2.0 ** ((np.asarray(note, dtype=np.float64) - 69.0) / 12.0)


def beat_grid(
    first_beat: float, period: float, duration: float, beats_per_bar: int, first_index: int
) -> dict:
    """Beat times of a constant-tempo grid covering ``[0, duration)`` seconds.

    ``first_beat`` is the first beat at or after 0 s (seconds), ``period`` the beat period
    (seconds), ``first_index`` the position of that first beat in its bar (0 = downbeat).
    Returns ``{"beats": (N,), "downbeats": (M,), "bar_starts": (B,)}`` in seconds, where
    ``bar_starts`` also includes the (possibly negative) start of the bar containing 0 s, and
    ``"beat_bar"``: ``(N,)`` the index into ``bar_starts`` of each beat's bar.
    """
    n = int(np.floor((duration - first_beat) / period)) + 1 if first_beat < duration else 0
    k = np.arange(n)
    beats = first_beat + k * period
    down = beats[(k + first_index) % beats_per_bar == 0]
    bar0 = first_beat - first_index * period
    if bar0 > 0:
        bar0 -= beats_per_bar * period
    num_bars = int(np.ceil((duration - bar0) / (beats_per_bar * period)))
    bars = bar0 + np.arange(num_bars) * beats_per_bar * period
    first_bar = 1 if first_beat - first_index * period > 0 else 0
    beat_bar = first_bar + (k + first_index) // beats_per_bar
    return {"beats": beats, "downbeats": down, "bar_starts": bars, "beat_bar": beat_bar}


def _kick(sr: int, rng: np.random.Generator) -> np.ndarray:
    t = np.arange(int(0.35 * sr)) / sr
    freq = 45.0 + 110.0 * np.exp(-t / 0.025)
    body = np.sin(2 * np.pi * np.cumsum(freq) / sr) * np.exp(-t / 0.13)
    click = 0.4 * rng.standard_normal(t.size) * np.exp(-t / 0.004)
    return body + click


def _snare(sr: int, rng: np.random.Generator) -> np.ndarray:
    t = np.arange(int(0.25 * sr)) / sr
    high = min(6000.0, 0.45 * sr)
    from scipy.signal import butter, sosfilt  # here: scipy.signal takes 0.8 s to import (`momu --help`)

    sos = butter(2, [1000.0, high], btype="bandpass", fs=sr, output="sos")
    noise = sosfilt(sos, rng.standard_normal(t.size)) * np.exp(-t / 0.07)
    tone = 0.5 * np.sin(2 * np.pi * 185.0 * t) * np.exp(-t / 0.06)
    return 1.6 * noise + tone


def _pluck(freq: float, sr: int, table: np.ndarray) -> np.ndarray:
    t = np.arange(int(0.6 * sr)) / sr
    return _oscillator(table, freq, t) * np.exp(-t / 0.18) * np.minimum(t / 0.002, 1.0)


_TABLE_SIZE = 4096


def _wavetable(brightness: float, num_harmonics: int) -> np.ndarray:
    """One period of a harmonic tone (partial ``h`` has amplitude ``brightness**(h-1) / h``)."""
    phase = np.arange(_TABLE_SIZE) / _TABLE_SIZE
    h = np.arange(1, num_harmonics + 1)[:, None]
    return ((brightness ** (h - 1) / h) * np.sin(2 * np.pi * h * phase)).sum(0)


def _oscillator(table: np.ndarray, freq: float, times: np.ndarray) -> np.ndarray:
    """Wavetable oscillator: ``table`` read at ``freq`` Hz at absolute ``times`` (seconds, >= 0)."""
    idx = (times * (freq * _TABLE_SIZE)).astype(np.int64) & (_TABLE_SIZE - 1)  # table size: a power of 2
    return table[idx]


def _add(out: np.ndarray, sound: np.ndarray, start: int, gain: float) -> None:
    if gain == 0.0 or start >= out.size:
        return
    end = min(out.size, start + sound.size)
    out[start:end] += gain * sound[: end - start]


def render_music(
    style: Style,
    grid: dict[str, np.ndarray],
    first_index: int,
    num_samples: int,
    sample_rate: int,
    rng: np.random.Generator,
    *,
    sounded: np.ndarray | None = None,
    hits: np.ndarray | None = None,
    held_bars: np.ndarray | None = None,
    noise: float = 0.005,
) -> np.ndarray:
    """Render ``num_samples`` of mono audio in [-1, 1] (float32) for a :func:`beat_grid`.

    Args:
        style: the style's drum pattern, plucks, pad timbre and register.
        grid: the output of :func:`beat_grid`; ``first_index`` is the bar position of its first beat.
        num_samples: output length in samples at ``sample_rate`` Hz.
        rng: the clip's generator (key, chords and noise are drawn from it).
        sounded: ``(N,)`` bool, beats that play the style's pattern (default: all).
        hits: ``(N,)`` bool, beats that sound although not ``sounded``: the downbeat that opens a
            break (played like any downbeat, then silence but for the held chord).
        held_bars: ``(B,)`` bool, bars that sustain the previous bar's chord without a new attack.
        noise: standard deviation of the added white noise, relative to a peak of 1.
    """
    sr = sample_rate
    bpb = style.beats_per_bar
    beats, bars = grid["beats"], grid["bar_starts"]
    sounded = np.ones(beats.size, bool) if sounded is None else np.asarray(sounded, bool)
    hits = np.zeros(beats.size, bool) if hits is None else np.asarray(hits, bool)
    held = np.zeros(bars.size, bool) if held_bars is None else np.asarray(held_bars, bool)
    key = int(rng.integers(0, 12))
    prog = PROGRESSIONS[int(rng.integers(len(PROGRESSIONS)))]
    kick, snare = _kick(sr, rng), _snare(sr, rng)
    pluck_table = _wavetable(0.6, 5)
    drums = np.zeros(num_samples)
    tonal = np.zeros(num_samples)
    bar_len = bpb * (beats[1] - beats[0]) if beats.size > 1 else 1.0

    # The chord of every bar: the progression, except held bars keep the previous bar's chord.
    chords: list[tuple[int, bool]] = []
    for b in range(bars.size):
        chords.append(chords[-1] if held[b] and chords else prog[b % len(prog)])

    for i, t in enumerate(beats):
        pos = (i + first_index) % bpb
        start = int(round(t * sr))
        degree, minor = chords[int(grid["beat_bar"][i])]
        if not (sounded[i] or hits[i]):
            continue
        _add(drums, kick, start, style.kick[pos])
        _add(drums, snare, start, 0.8 * style.snare[pos])
        if style.pluck[pos] > 0:
            tone = (0, 3 if minor else 4, 7)[i % 3]
            note = style.octave + 12 + key + degree + tone
            _add(tonal, _pluck(float(midi_to_hz(note)), sr, pluck_table), start, style.pluck[pos])

    # Harmonic pad: root, third, fifth + bass; a new attack on every downbeat except held bars.
    pad = np.zeros(num_samples)
    table = _wavetable(style.brightness, 4)
    b = 0
    while b < bars.size:
        span = 1
        while b + span < bars.size and held[b + span]:
            span += 1
        start_t, length = bars[b], span * bar_len
        s0, s1 = max(0, int(round(start_t * sr))), min(num_samples, int(round((start_t + length) * sr)))
        if s1 > s0:
            degree, minor = chords[b]
            notes = style.octave + key + degree + np.array([0, 3 if minor else 4, 7])
            t_abs = np.arange(s0, s1) / sr
            t_loc = t_abs - start_t
            wave = 1.5 * _oscillator(table, float(midi_to_hz(notes[0])), t_abs)  # bass
            for note in notes:
                wave += _oscillator(table, float(midi_to_hz(note + 12)), t_abs)
            env = np.minimum(t_loc / 0.03, 1.0) * (0.45 + 0.55 * np.exp(-t_loc / 0.6))
            env *= np.clip((length - t_loc) / 0.02, 0.0, 1.0)
            pad[s0:s1] += wave * env
        b += span

    mix = drums + 0.5 * tonal + 0.08 * pad
    peak = float(np.max(np.abs(mix))) if mix.size else 0.0
    if peak > 0:
        mix *= 0.85 / peak
    mix += noise * rng.standard_normal(num_samples)
    return np.clip(mix, -1.0, 1.0).astype(np.float32)
