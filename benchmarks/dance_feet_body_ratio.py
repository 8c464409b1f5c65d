"""Can a dance's style multiple be read from the motion alone? The feet's period against the body's,
and the body's own (issue 32, the dance → music direction's tempo match).

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

The ratio alone cannot tell a waltz danced once per bar from dancers who move on every beat with quick
feet (``synth_dance``'s waltzers read 3-4.6). Their bodies move at different rates: a bar, 21-38 times
a minute on Dance with Melody, against a beat, 50 or more on synth_dance. So the same readings (the
body's tempo beside each ratio) are taken on ``synth_dance`` excerpts as the benchmark cuts them
(``--synth-songs`` of its train split, 10 s, and its val songs as the synth_dance reproduction's
``--songs 8`` reads them), and
:data:`~momu.features.ballroom_metre.BAR_BPM` (``auto``'s threshold) is the geometric mean of the
fastest *train* waltz bar and the slowest *train* synth_dance body whose feet read as a waltz's, over
all stretches. Written: each split's readings that ``auto`` gets wrong (a Dance with Melody waltz not
read as 3 beats per movement, any other dance not read as 1).
"""

from __future__ import annotations

import logging

import numpy as np
from dance_tempo_vs_song import style_multiple  # benchmarks/dance_tempo_vs_song.py
from study_common import excerpt, study_args, write_study  # benchmarks/study_common.py

from momu.config import build_component
from momu.features.ballroom_metre import WALTZ_RATIO, auto_beats, movement_tempi
from momu.following.pairs import DWM_SPLIT, dataset_node, load_pairs
from momu.following.signals import time_scale_motion

STRETCHES = (0.8, 0.9, 1.0, 1.1, 1.25)
SYNTH_SECONDS = 10.0
"""The synth_dance reproduction's excerpt (``reproductions/music_following_synth``)."""
SYNTH_VAL_SONGS = 8
log = logging.getLogger("dance_feet_body_ratio")


def readings(motion: np.ndarray, fps: float, skeleton: str) -> dict[str, list[float]]:
    """Body tempo (per minute) and feet/body ratio of ``motion`` at each of :data:`STRETCHES`."""
    tempi = [movement_tempi(time_scale_motion(motion, fps, f), fps, skeleton) for f in STRETCHES]
    return {
        "ratios": [round(feet / body, 3) for body, feet in tempi],
        "body_bpm": [round(body, 1) for body, _ in tempi],
        "auto": [auto_beats(body, feet) for body, feet in tempi],
    }


def synth_rows(split: str, songs: int) -> list[dict]:
    """:func:`readings` of the first ``songs`` synth_dance excerpts of ``split`` (the benchmark's cut)."""
    node = dataset_node("synth", split, "dwm21", SYNTH_SECONDS, songs)
    rows = []
    for pair in load_pairs(node, SYNTH_SECONDS, songs):
        rows.append(
            {"id": pair.id, "split": f"synth_{split}", **readings(pair.excerpt_motion(), pair.fps, "dwm21")}
        )
        log.info("%s", rows[-1])
    return rows


def main() -> None:
    args = study_args(__doc__, "dance_feet_body_ratio", extra={"--synth-songs": 24})
    node = {"name": "dance_with_melody", "root": args.data, "sample_rate": 16000, "split": "all", **DWM_SPLIT}
    ds = build_component(node, "datasets")
    rows = []
    for i in range(len(ds)):
        clip = ds[i]
        motion, _ = excerpt(clip, args.seconds)
        rows.append(
            {
                "id": clip.id,
                "split": clip.meta.get("split", "all"),
                "style_multiple": style_multiple(clip.id),
                **readings(motion, clip.fps, "dwm21"),
            }
        )
        log.info("%s", rows[-1])
    synth = synth_rows("train", args.synth_songs) + synth_rows("val", SYNTH_VAL_SONGS)
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
    bar = max(b for r in train if r["style_multiple"] == 3 for b in r["body_bpm"])
    beat = min(
        b
        for r in synth
        if r["split"] == "synth_train"
        for b, x in zip(r["body_bpm"], r["ratios"], strict=True)
        if x > WALTZ_RATIO
    )
    auto_wrong: dict[str, str] = {}
    for split in ("train", "val", "test", "synth_train", "synth_val"):
        group = [r for r in rows + synth if r["split"] == split]
        want = [3 if r.get("style_multiple") == 3 else 1 for r in group]
        bad = sum(n != w for r, w in zip(group, want, strict=True) for n in r["auto"])
        auto_wrong[split] = f"{bad} of {len(group) * len(STRETCHES)}"
    summary = {
        "train_threshold": round(threshold, 3),
        "train_groups": [low, high],
        "wrong_side": wrong,
        "bar_bpm": round(float(np.sqrt(bar * beat)), 1),
        "bar_bpm_groups": [bar, beat],
        "auto_wrong": auto_wrong,
    }
    log.info("%s", summary)
    write_study(
        args.out,
        {
            "excerpt_s": args.seconds,
            "synth_excerpt_s": SYNTH_SECONDS,
            "stretches": list(STRETCHES),
            "summary": summary,
            "dances": rows,
            "synth_dances": synth,
        },
    )


if __name__ == "__main__":
    main()
