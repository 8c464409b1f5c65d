"""HarmoGAN's Ballroom test music (§V-A): the paper's 7 columns, 10 % of each, 6-s clips.

"It contains 698 background music clips ... involving 7 types: cha-cha, jive, quickstep, rumba, samba,
tango, and waltz ... we randomly select 10 % of audio sequences from each dance category, which are cut
into 6-second clips." The Ballroom dataset's folders are ChaChaCha (111), Jive (60), Quickstep (82),
Rumba-American (7), Rumba-International (51), Rumba-Misc (40), Samba (86), Tango (86), VienneseWaltz
(65) and Waltz (110): 698 tracks in 10 folders. momu's map to the paper's 7 columns (:data:`FOLDER_COLUMNS`):
the three Rumba folders are rumba, and **VienneseWaltz is waltz** — the only reading under which "698
clips" and "7 types" both hold. The selection draws ``ceil(fraction · n)`` tracks per column with a
fixed seed (the same test set for every training seed); each track is cut into consecutive clips of
``clip_seconds`` (a shorter tail is dropped).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from momu.data.types import Clip

__all__ = ["COLUMNS", "FOLDER_COLUMNS", "ballroom_column", "select_tracks", "ballroom_test_clips"]

COLUMNS: tuple[str, ...] = ("cha-cha", "jive", "quickstep", "rumba", "samba", "tango", "waltz")
"""The paper's Table I / II columns, in print order."""

FOLDER_COLUMNS: dict[str, str] = {
    "ChaChaCha": "cha-cha",
    "Jive": "jive",
    "Quickstep": "quickstep",
    "Rumba-American": "rumba",
    "Rumba-International": "rumba",
    "Rumba-Misc": "rumba",
    "Samba": "samba",
    "Tango": "tango",
    "VienneseWaltz": "waltz",
    "Waltz": "waltz",
}


def ballroom_column(folder: str) -> str:
    """The paper's column of a Ballroom genre folder (``Rumba-*`` → rumba; VienneseWaltz → waltz).

    Raises:
        ValueError: a folder outside the Ballroom layout.
    """
    if folder in FOLDER_COLUMNS:
        return FOLDER_COLUMNS[folder]
    if folder.startswith("Rumba"):
        return "rumba"
    raise ValueError(
        f"ballroom: genre folder {folder!r} has no Table I column; known: {', '.join(FOLDER_COLUMNS)}"
    )


def select_tracks(ids: list[str], fraction: float, seed: int) -> list[int]:
    """Indices of ``ceil(fraction · n)`` tracks per column (ids are ``<folder>/<name>``), seeded."""
    if not 0.0 < fraction <= 1.0:
        raise ValueError(f"ballroom.fraction must be in (0, 1], got {fraction}")
    by_column: dict[str, list[int]] = {}
    for i, item in enumerate(ids):
        by_column.setdefault(ballroom_column(item.split("/")[0]), []).append(i)
    rng = np.random.default_rng(seed)
    chosen: list[int] = []
    for column in COLUMNS:
        members = by_column.get(column, [])
        if members:
            k = math.ceil(fraction * len(members))
            chosen += sorted(int(members[j]) for j in rng.permutation(len(members))[:k])
    return chosen


def ballroom_test_clips(dataset: Any, fraction: float, clip_seconds: float, seed: int) -> list[Clip]:
    """The selected tracks of a ``ballroom`` dataset cut into ``clip_seconds`` clips, ``style`` = column.

    Raises:
        ValueError: the dataset has no audio, or no track is long enough for one clip.
    """
    clips: list[Clip] = []
    for index in select_tracks(list(dataset.ids), fraction, seed):
        track: Clip = dataset[index]
        if track.audio is None or not track.sample_rate:
            raise ValueError(f"ballroom: track {track.id!r} has no audio (load_audio must be true)")
        width = int(round(clip_seconds * track.sample_rate))
        for k in range(len(track.audio) // width):
            clips.append(
                dataclasses.replace(
                    track,
                    id=f"{track.id}@{k * clip_seconds:g}s",
                    audio=track.audio[k * width : (k + 1) * width],
                    style=ballroom_column(track.id.split("/")[0]),
                    meta={**track.meta, "folder": track.id.split("/")[0], "offset_seconds": k * clip_seconds},
                )
            )
    if not clips:
        raise ValueError(f"ballroom: no selected track is {clip_seconds} s long")
    return clips
