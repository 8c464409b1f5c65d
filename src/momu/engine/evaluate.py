"""Evaluation work split across processes and gathered without duplicated tail samples."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from accelerate import Accelerator
from torch.utils.data import DataLoader
from tqdm.auto import tqdm

__all__ = ["map_gathered"]

R = TypeVar("R")


def _identity(batch: list[int]) -> list[int]:
    return batch


def map_gathered(
    accelerator: Accelerator,
    indices: Sequence[int],
    fn: Callable[[list[int]], list[R]],
    *,
    batch_size: int = 8,
    desc: str = "evaluate",
) -> list[R]:
    """Apply ``fn`` to batches of ``indices`` on every process and gather the results in order.

    Each process handles its shard of ``indices``; accelerate pads the last round of batches
    with repeated items so every process takes part in each gather, and
    ``gather_for_metrics`` drops those repeats, so every index is returned exactly once, in the
    order given.
    """
    positions: Any = list(range(len(indices)))  # a list is a valid map-style dataset
    loader = accelerator.prepare_data_loader(
        DataLoader(positions, batch_size=batch_size, shuffle=False, collate_fn=_identity)
    )
    gathered: list[tuple[int, R]] = []
    bar = tqdm(total=len(loader), desc=desc, disable=not accelerator.is_local_main_process, leave=False)
    for batch in loader:
        mine = [int(i) for i in batch]
        results = fn([indices[i] for i in mine])
        if len(results) != len(mine):
            raise ValueError(f"{desc}: fn returned {len(results)} results for {len(mine)} items")
        gathered.extend(accelerator.gather_for_metrics(list(zip(mine, results)), use_gather_object=True))
        bar.update(1)
    bar.close()
    by_position: dict[int, Any] = dict(gathered)
    missing = [i for i in range(len(indices)) if i not in by_position]
    if missing:
        raise RuntimeError(f"{desc}: results missing for positions {missing[:5]}")
    return [by_position[i] for i in range(len(indices))]
