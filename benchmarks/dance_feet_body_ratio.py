"""Can a dance's style multiple be read from the motion alone? The feet's period against the body's
(issue 32, the dance → music direction's tempo match).

    python benchmarks/dance_feet_body_ratio.py [--data ../shared/data/dance_with_melody] [--seconds 15]
        [--out benchmarks/results/dance_feet_body_ratio.json]

Given the style's multiple of the dancer's movement period (3 for a waltz's bar, 2 otherwise), the
shipped music passes tempo match on the validation songs (``benchmarks/results/music_beats_per_movement``);
a threshold on the movement rate itself picks the multiple on unstretched dances but not on stretched
ones. This reads a time-scale-free cue instead (:func:`momu.features.ballroom_metre.feet_body_ratio`):
the dominant tempo of the feet's kinematic onsets (ankles, heels, toes; periodogram 20-400 BPM) over
the whole body's (θ_a's reading: 20-200 BPM), on each dance's excerpt (2 s in, ``--seconds``) played
×0.8, ×0.9, ×1, ×1.1 and ×1.25 (:func:`momu.following.signals.time_scale_motion`). Both periods scale
with a stretch, so their ratio should not move. Written per dance: its style's multiple and the five
ratios; and the threshold between the *train* split's two groups (the geometric mean of the largest
non-waltz ratio and the smallest waltz ratio at ×1, the excerpts' own speed) with how many readings of
each split fall on the wrong side of it.

The cue was noticed while looking at all 23 dances (this session's exploration, not a held-out design):
treat its val and test counts as descriptive, not as a validation.
"""

from __future__ import annotations

import logging

import numpy as np
from dance_tempo_vs_song import style_multiple  # benchmarks/dance_tempo_vs_song.py
from study_common import excerpt, study_args, write_study  # benchmarks/study_common.py

from momu.config import build_component
from momu.features.ballroom_metre import feet_body_ratio
from momu.following.pairs import DWM_SPLIT
from momu.following.signals import time_scale_motion

STRETCHES = (0.8, 0.9, 1.0, 1.1, 1.25)
log = logging.getLogger("dance_feet_body_ratio")


def main() -> None:
    args = study_args(__doc__, "dance_feet_body_ratio")
    node = {"name": "dance_with_melody", "root": args.data, "sample_rate": 16000, "split": "all", **DWM_SPLIT}
    ds = build_component(node, "datasets")
    rows = []
    for i in range(len(ds)):
        clip = ds[i]
        motion, _ = excerpt(clip, args.seconds)
        ratios = [
            feet_body_ratio(time_scale_motion(motion, clip.fps, f), clip.fps, "dwm21") for f in STRETCHES
        ]
        rows.append(
            {
                "id": clip.id,
                "split": clip.meta.get("split", "all"),
                "style_multiple": style_multiple(clip.id),
                "ratios": [round(r, 3) for r in ratios],
            }
        )
        log.info("%s", rows[-1])
    own = STRETCHES.index(1.0)
    train = [r for r in rows if r["split"] == "train"]
    low = max(r["ratios"][own] for r in train if r["style_multiple"] == 2)
    high = min(r["ratios"][own] for r in train if r["style_multiple"] == 3)
    threshold = float(np.sqrt(low * high)) if high > low else float("nan")
    wrong: dict[str, str] = {}
    for split in ("train", "val", "test"):
        group = [r for r in rows if r["split"] == split]
        bad = sum((x > threshold) != (r["style_multiple"] == 3) for r in group for x in r["ratios"])
        wrong[split] = f"{bad} of {len(group) * len(STRETCHES)}"
    summary = {"train_threshold": round(threshold, 3), "train_groups": [low, high], "wrong_side": wrong}
    log.info("%s", summary)
    write_study(
        args.out,
        {"excerpt_s": args.seconds, "stretches": list(STRETCHES), "summary": summary, "dances": rows},
    )


if __name__ == "__main__":
    main()
