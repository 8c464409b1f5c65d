"""Built-in metrics; importing this package registers them in momu.registry.METRICS.

Public functions on plain arrays (units, frame rates and axes in each docstring; the specification is
METRICS.md): music and motion beats, BAS, D2M beat coverage/hit, LORIS beat scores, MoMu's kinematic
beat scores, EDGE's PFC, HarmoGAN's harmony score and hit rate.
"""

from momu.metrics import (
    motion_metrics,  # noqa: F401  (registers fid_k, fid_g, div_k, div_g, multimodality)
    text_motion,  # noqa: F401  (registers r_precision, mm_dist, text_diversity, text_multimodality)
)
from momu.metrics._checks import EmptyBeatsError
from momu.metrics.beat_align import bas, bas_dataset, beat_align_score
from momu.metrics.beat_coverage import beat_coverage_dataset, beat_coverage_scores, select_aligned
from momu.metrics.beats import (
    aistpp_tempo,
    motion_beats,
    motion_envelope,
    music_beat_onehot,
    music_beats,
    music_onset_envelope,
)
from momu.metrics.diversity import average_pairwise_distance, diversity, multimodality
from momu.metrics.foot_contact import pfc, pfc_sequence
from momu.metrics.frechet import fid, frechet_distance
from momu.metrics.geometric import geometric_features
from momu.metrics.harmony import HarmonyResult, harmony_from_beats, harmony_score, hit_rate
from momu.metrics.kinematic_beats import kinematic_beat_frames, kinematic_beat_scores
from momu.metrics.kinetic import kinetic_features
from momu.metrics.learned import inter_diversity, intra_diversity, mean_kl_divergence  # + fid_learned, fad
from momu.metrics.loris_scores import beat_scores, onset_beat_bins, pair_beat_scores

__all__ = [
    "average_pairwise_distance",
    "diversity",
    "fid",
    "frechet_distance",
    "geometric_features",
    "kinetic_features",
    "multimodality",
    "EmptyBeatsError",
    "HarmonyResult",
    "aistpp_tempo",
    "bas",
    "bas_dataset",
    "beat_align_score",
    "beat_coverage_dataset",
    "beat_coverage_scores",
    "beat_scores",
    "harmony_from_beats",
    "harmony_score",
    "hit_rate",
    "kinematic_beat_frames",
    "kinematic_beat_scores",
    "motion_beats",
    "motion_envelope",
    "music_beat_onehot",
    "music_beats",
    "music_onset_envelope",
    "onset_beat_bins",
    "pair_beat_scores",
    "pfc",
    "pfc_sequence",
    "select_aligned",
    "inter_diversity",
    "intra_diversity",
    "mean_kl_divergence",
]
