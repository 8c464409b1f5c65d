"""Mel → linear magnitude inversion of the ``griffin_lim`` vocoder: ``librosa`` vs ``multiplicative``.

Both solve ``min ‖M x − p‖², x ≥ 0`` per frame. For the first 12 ``synth_dance`` train clips (8 s,
MoMu's mel) this prints, per method: CPU seconds of the inversion alone and of the whole vocoder
(inversion + 16 Griffin-Lim iterations, ``GriffinLimVocoder.synthesize`` as momu runs it), the
relative residual ``‖M x − p‖ / ‖p‖``, the onset F1 (±50 ms, LORIS's onset detector) of the vocoded
audio against the original (the music F1 columns see onsets only), and whether the magnitudes are
bit for bit those of ``librosa.util.nnls``. The first row times ``librosa.util.nnls`` itself
(its vocoder column is momu's vocoder, the same for both ``librosa`` rows).

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_mel_inversion.py

Result (2026-12-03, one thread, CPU seconds for 12 clips):

    librosa.util.nnls    inversion 12.24 s                    residual 0.0433  onset F1 1.000
    momu nnls (librosa)  inversion  0.26 s  vocoder 2.09 s    residual 0.0433  onset F1 1.000  same bits
    multiplicative, 10   inversion  0.87 s  vocoder 3.33 s    residual 0.0190  onset F1 1.000
    multiplicative, 50   inversion  3.90 s  vocoder 6.14 s    residual 0.0055  onset F1 1.000

``librosa.util.nnls`` spends almost all of its time in SciPy's per-variable bound handling, which
:mod:`momu.vocoders.nnls` skips (47x less CPU, the same array). Before it (2026-12-02) the
multiplicative inversion was the fast one: 3.2 s against 27.7 s for the whole 12-clip loop.
"""

from __future__ import annotations

import time

import librosa
import numpy as np
import torch

from momu.data.synth import SynthConfig, SynthDance
from momu.features.audio import MoMuMelConfig, mel_filterbank, mel_to_power, momu_mel
from momu.metrics.loris_scores import onset_times
from momu.vocoders.griffin_lim import GriffinLimConfig, GriffinLimVocoder


def onset_f1(a: np.ndarray, b: np.ndarray, sr: int, tol: float = 0.05) -> float:
    """F1 of ``a``'s onsets against ``b``'s within ±``tol`` seconds."""
    oa, ob = onset_times(a, sr), onset_times(b, sr)
    if not len(oa) or not len(ob):
        return 0.0
    precision = float(np.mean([np.min(np.abs(ob - t)) <= tol for t in oa]))
    recall = float(np.mean([np.min(np.abs(oa - t)) <= tol for t in ob]))
    return 2 * precision * recall / max(precision + recall, 1e-9)


def main() -> None:
    torch.set_num_threads(1)
    mel_cfg = MoMuMelConfig()
    ds = SynthDance(
        SynthConfig(num_clips=60, skeleton="openpose14", min_seconds=8, max_seconds=8), split="train"
    )
    clips = [ds[i] for i in range(12)]
    basis = mel_filterbank(mel_cfg)
    logmels = [np.asarray(momu_mel(np.asarray(clip.audio), clip.sample_rate)) for clip in clips]
    powers = [mel_to_power(logmel, mel_cfg) for logmel in logmels]
    reference = [librosa.util.nnls(basis.astype(p.dtype), p) for p in powers]
    settings = {
        "librosa.util.nnls": ("librosa", {}),
        "momu nnls (librosa)": ("librosa", {}),
        "multiplicative, 10": ("multiplicative", {"inversion_iters": 10}),
        "multiplicative, 50": ("multiplicative", {"inversion_iters": 50}),
    }
    for name, (method, extra) in settings.items():
        voc = GriffinLimVocoder(GriffinLimConfig(mel=mel_cfg, n_iter=16, mel_inversion=method, **extra))
        start = time.process_time()
        if name == "librosa.util.nnls":
            mags = [librosa.util.nnls(basis.astype(p.dtype), p) ** (1.0 / mel_cfg.power) for p in powers]
        else:
            mags = [voc.magnitude(p) for p in powers]
        inversion = time.process_time() - start
        start = time.process_time()
        wavs = [voc.synthesize(logmel) for logmel in logmels]
        vocoding = time.process_time() - start
        residuals = [
            np.linalg.norm(basis @ m**mel_cfg.power - p) / np.linalg.norm(p) for m, p in zip(mags, powers)
        ]
        f1s = [onset_f1(w, np.asarray(c.audio), c.sample_rate) for w, c in zip(wavs, clips)]
        same = all(np.array_equal(m, r ** (1.0 / mel_cfg.power)) for m, r in zip(mags, reference))
        print(
            f"{name:20s} inversion {inversion:6.2f} s  vocoder {vocoding:6.2f} s  residual "
            f"{np.mean(residuals):.4f}  onset F1 {np.mean(f1s):.3f}  same as librosa: {same}"
        )


if __name__ == "__main__":
    main()
