"""The accelerate training/evaluation engine shared by every method and recipe."""

from momu.engine.accelerate_setup import TRACKERS, RunConfig, finish_accelerator, make_accelerator
from momu.engine.evaluate import map_gathered
from momu.engine.trainer import Preempted, TrainConfig, steps_per_epoch, train_stage

__all__ = [
    "TRACKERS",
    "Preempted",
    "RunConfig",
    "finish_accelerator",
    "TrainConfig",
    "make_accelerator",
    "map_gathered",
    "steps_per_epoch",
    "train_stage",
]
