"""Music-following benchmark: does a generator's dance follow its song (and its music its dance)?

    python recipes/music_following.py --generator shipped --direction both --data synth --seeds 0 1 2
    python recipes/music_following.py --generator DIR --data ../shared/data/dance_with_melody --split val

Tests, calibration rows, statistics and verdicts: docs/following.md (:mod:`momu.following`); options:
``--help``. Writes ``<out>/music_following/results.json`` and ``results.md``; several runs collect into
one "which models follow" table with ``python -m momu.following.table RESULTS.json ... --out DIR``.
"""

from __future__ import annotations

import sys

from momu.following.run import main

if __name__ == "__main__":
    sys.exit(main())
