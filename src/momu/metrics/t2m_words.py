"""T2M's caption input: GloVe word vectors and part-of-speech one-hots (Guo et al., CVPR 2022).

T2M's text encoder reads each caption as HumanML3D's tokens (``texts/<id>.txt`` lines
``caption#word/POS word/POS ...#start#end``; ``Clip.meta["text_segments"][i]["tokens"]`` of the
``humanml3d`` loader), wrapped as ``sos/OTHER … eos/OTHER`` and cut to 20 words (T2M's
``max_text_len``). Each token gives

* its word's 300-d vector from the GloVe subset T2M ships (``glove/our_vab_data.npy`` rows,
  ``our_vab_words.pkl`` the words, ``our_vab_idx.pkl`` word → row); a word outside it takes
  ``unk``'s vector and the POS ``OTHER``;
* a 15-way one-hot of its POS (:data:`POS_ENUMERATOR`), where a word of T2M's hand-made lists
  (:data:`VIP_WORDS`: directions, body parts, objects, actions, manners) takes that list's tag
  instead — the first list containing it, in T2M's order.

The two ``.pkl`` files are read with :mod:`momu.data.safe_pickle` (plain containers only).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momu.data.files import DataFileError, load_npy, read_pickle

__all__ = ["POS_ENUMERATOR", "VIP_WORDS", "MAX_TEXT_LEN", "WordVectorizer", "caption_arrays"]

POS_ENUMERATOR = {
    "VERB": 0, "NOUN": 1, "DET": 2, "ADP": 3, "NUM": 4, "AUX": 5, "PRON": 6, "ADJ": 7, "ADV": 8,
    "Loc_VIP": 9, "Body_VIP": 10, "Obj_VIP": 11, "Act_VIP": 12, "Desc_VIP": 13, "OTHER": 14,
}  # fmt: skip
"""T2M's POS classes (``utils/word_vectorizer.py``)."""

VIP_WORDS: dict[str, tuple[str, ...]] = {
    "Loc_VIP": ("left", "right", "clockwise", "counterclockwise", "anticlockwise", "forward", "back",
                "backward", "up", "down", "straight", "curve"),
    "Body_VIP": ("arm", "chin", "foot", "feet", "face", "hand", "mouth", "leg", "waist", "eye", "knee",
                 "shoulder", "thigh"),
    "Obj_VIP": ("stair", "dumbbell", "chair", "window", "floor", "car", "ball", "handrail", "baseball",
                "basketball"),
    "Act_VIP": ("walk", "run", "swing", "pick", "bring", "kick", "put", "squat", "throw", "hop", "dance",
                "jump", "turn", "stumble", "stop", "sit", "lift", "lower", "raise", "wash", "stand",
                "kneel", "stroll", "rub", "bend", "balance", "flap", "jog", "shuffle", "lean", "rotate",
                "spin", "spread", "climb"),
    "Desc_VIP": ("slowly", "carefully", "fast", "careful", "slow", "quickly", "happy", "angry", "sad",
                 "happily", "angrily", "sadly"),
}  # fmt: skip
"""T2M's word lists whose words take a list tag as their POS."""

MAX_TEXT_LEN = 20
"""Words kept per caption (T2M's ``max_text_len``; ``sos``/``eos`` come on top)."""

_PREFIX = "our_vab"


@dataclass(frozen=True)
class WordVectorizer:
    """Word vectors and POS one-hots of T2M's GloVe subset (module docstring).

    Attributes:
        vectors: ``(N, 300)`` word vectors.
        index: word → row of ``vectors``.
    """

    vectors: np.ndarray
    index: dict[str, int]

    @classmethod
    def load(cls, glove_dir: str | Path) -> WordVectorizer:
        """Read ``our_vab_data.npy``, ``our_vab_words.pkl`` and ``our_vab_idx.pkl`` from ``glove_dir``.

        Raises:
            DataFileError: a missing or malformed file (the message names it), or no ``unk`` word.
        """
        folder = Path(glove_dir).expanduser()
        data = folder / f"{_PREFIX}_data.npy"
        vectors = load_npy(data)
        if vectors.ndim != 2 or not np.issubdtype(vectors.dtype, np.floating):
            raise DataFileError(
                data, f"expected (words, 300) float vectors, got {vectors.dtype} {vectors.shape}"
            )
        words_path, idx_path = folder / f"{_PREFIX}_words.pkl", folder / f"{_PREFIX}_idx.pkl"
        words, idx = read_pickle(words_path, 256 << 20), read_pickle(idx_path, 256 << 20)
        if not isinstance(words, (list, tuple)) or not all(isinstance(w, str) for w in words):
            raise DataFileError(words_path, "expected a pickled list of words")
        if not isinstance(idx, dict):
            raise DataFileError(idx_path, "expected a pickled dict word -> row")
        index: dict[str, int] = {}
        for w in words:
            row = idx.get(w)
            if not isinstance(row, (int, np.integer)) or not 0 <= int(row) < len(vectors):
                raise DataFileError(idx_path, f"word {w!r}: row {row!r} is not a row of {data.name}")
            index[w] = int(row)
        if "unk" not in index:
            raise DataFileError(words_path, "no 'unk' word (T2M's vector for unknown words)")
        return cls(vectors.astype(np.float32), index)

    @property
    def dim(self) -> int:
        return int(self.vectors.shape[1])

    def __call__(self, token: str) -> tuple[np.ndarray, np.ndarray]:
        """``(word vector, POS one-hot)`` of one ``word/POS`` token."""
        word, _, pos = token.rpartition("/")
        if not word:
            word, pos = pos, "OTHER"
        one_hot = np.zeros(len(POS_ENUMERATOR), dtype=np.float32)
        row = self.index.get(word)
        if row is None:
            one_hot[POS_ENUMERATOR["OTHER"]] = 1
            return self.vectors[self.index["unk"]], one_hot
        tag = next((key for key, group in VIP_WORDS.items() if word in group), pos)
        one_hot[POS_ENUMERATOR.get(tag, POS_ENUMERATOR["OTHER"])] = 1
        return self.vectors[row], one_hot


def caption_arrays(words: WordVectorizer, tokens: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """``(L, 300)`` word vectors and ``(L, 15)`` POS one-hots of one caption (``sos``/``eos`` added,
    at most :data:`MAX_TEXT_LEN` words), ``L`` its length for the encoder."""
    body = list(tokens)[:MAX_TEXT_LEN]
    pairs = [words(t) for t in ["sos/OTHER", *body, "eos/OTHER"]]
    return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])
