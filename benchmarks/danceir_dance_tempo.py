"""Can a dance tempo estimator read the song's tempo from a real Dance with Melody dance? (issue 32)

The dance → music tempo-match test asks the music written for a dance to match its song's tempo (within 5
% of ×1, ×2, ×½, ×3, ×⅓, :func:`momu.following.tempo.tempo_matches`). A music model can reach that only
through what the dance shows of the beat. For each dance's benchmark excerpt (``--seconds``, default 15,
from 2 s in), this compares with the song's beat-grid tempo
(:func:`momu.following.analysis.analyse_audio`, the benchmark's reference):

* ``danceir`` (PyPI 1.0.0, the issue's suggestion): its multi-anchor estimator
  (``estimate_tempo_from_keypoints``: hands, feet and torso centre of mass, zero-velocity anchors,
  45-140 BPM, 5-s tempogram windows) on the dance projected to 2D as a front camera sees it (COCO-17
  joints from ``dwm21``, image y pointing down), vertical (``danceir_y``) and horizontal (``danceir_x``)
  axes;
* per split, how many dances' own song each estimate matches, beside the share of the split's other
  songs it matches (chance);
* the benchmark's own periodogram of the mean joint speed (20-200 BPM), the same of the ankles' speed
  limited to 60-200 BPM (steps rather than sways), and librosa's autocorrelation tempo with its
  120-BPM prior (``librosa.feature.tempo``) on the joint speed.

danceir is not a momu dependency: install it beside momu to run this (``pip install --no-deps
danceir==1.0.0``). Its tempogram still uses ``np.complex_``, which NumPy 2 removed, so the alias is set
here before it is imported.

    python benchmarks/danceir_dance_tempo.py --data ../shared/data/dance_with_melody \
        --out benchmarks/results/danceir_dance_tempo.json
"""

from __future__ import annotations

import logging
import sys

import librosa
import numpy as np
from study_common import excerpt, study_args, write_study  # benchmarks/study_common.py

from momu.config import build_component
from momu.features.skeletons import get_skeleton
from momu.following.analysis import analyse_audio
from momu.following.pairs import LEAD_S, dataset_node
from momu.following.signals import RATE, joint_speed, motion_at_rate
from momu.following.tempo import periodogram_tempo, tempo_matches

COCO17 = (
    ("head_front",) * 3
    + ("head_back",) * 2
    + tuple(
        f"{side}_{part}"
        for part in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle")
        for side in ("l", "r")
    )
)
"""``dwm21`` joints standing in for COCO-17's (nose and eyes: the front of the head; ears: the back)."""
log = logging.getLogger("danceir_dance_tempo")


def estimates(motion: np.ndarray, fps: float, estimate: object) -> dict[str, float]:
    """Every estimator's tempo (BPM) of ``motion`` ``(T, 21, 3)`` (global positions, Y up)."""
    names = get_skeleton("dwm21").joint_names
    coco = motion[:, [names.index(n) for n in COCO17]]
    image = np.stack([coco[..., 0], -coco[..., 1]], axis=-1)  # a front camera: x right, y down
    out = {}
    for axis in ("y", "x"):
        res = estimate(image, axis=axis, fps=fps, window_length=int(5 * fps), hop_size=int(2.5 * fps))
        out[f"danceir_{axis}"] = float(res["combined_anchors"]["gtempo"])
    x = motion_at_rate(motion, fps)
    speed = joint_speed(x)
    ankles = np.array([i for i, n in enumerate(names) if "ankle" in n])
    out["periodogram"] = periodogram_tempo(speed, RATE)
    out["ankle_periodogram_60_200"] = periodogram_tempo(joint_speed(x, joints=ankles), RATE, (60.0, 200.0))
    out["librosa_tempo"] = float(librosa.feature.tempo(onset_envelope=speed, sr=RATE, hop_length=1)[0])
    return out


def chance(row: dict, group: list[dict], key: str) -> float:
    """Share of the split's other songs whose tempo ``row``'s estimate matches (what chance gives)."""
    return float(
        np.mean([tempo_matches(row[f"{key}_bpm"], o["song_beat_bpm"]) for o in group if o is not row])
    )


def main() -> None:
    args = study_args(__doc__, "danceir_dance_tempo")
    np.complex_ = np.complex128  # type: ignore[attr-defined]  # danceir 1.0.0 uses the NumPy 1 alias
    try:
        from danceir.pipelines.tempo_estimation import estimate_tempo_from_keypoints
    except ImportError:
        sys.exit(
            "danceir_dance_tempo.py: error: danceir is not installed (pip install --no-deps danceir==1.0.0)"
        )
    ds = build_component(dataset_node(args.data, "all", "dwm21", args.seconds, 8), "datasets")
    rows = []
    for i in range(len(ds)):
        clip = ds[i]
        motion, audio = excerpt(clip, args.seconds)
        song = analyse_audio(audio, clip.sample_rate).beat_tempo
        tempi = estimates(motion, clip.fps, estimate_tempo_from_keypoints)
        rows.append(
            {
                "id": clip.id,
                "split": clip.meta.get("split", "all"),
                "song_beat_bpm": round(float(song), 1),
                **{f"{k}_bpm": round(v, 1) for k, v in tempi.items()},
                **{f"{k}_matches": bool(tempo_matches(v, song)) for k, v in tempi.items()},
            }
        )
        log.info("%s", rows[-1])
    keys = [k[: -len("_matches")] for k in rows[0] if k.endswith("_matches")]
    summary = {
        split: {
            k: {
                "own_song": f"{sum(r[f'{k}_matches'] for r in group)} of {len(group)}",
                "other_songs": round(float(np.mean([chance(r, group, k) for r in group])), 2),
            }
            for k in keys
        }
        for split in ("train", "val", "test")
        if (group := [r for r in rows if r["split"] == split])
    }
    write_study(args.out, {"excerpt_s": [LEAD_S, args.seconds], "summary": summary, "dances": rows}, indent=1)
    log.info(
        "song tempo read within 5 %% (×1 ×2 ×½ ×3 ×⅓), own song vs others: %s; wrote %s", summary, args.out
    )


if __name__ == "__main__":
    main()
